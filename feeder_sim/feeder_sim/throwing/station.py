"""The throwing arm's station: what one tick does to the model and what a feed goal starts, free of ROS.

One definition of the arm's behaviour per tick, run by both drivers (docs/devices.md, "The station"):
the throwing_arm node (an adapter: the device kit owns the loop, the node publishes what the station
reports) and the ROS-free cell loop (``feeder_cell.experiment``), which ticks the same station on the
same grid. The ros2_control shape: the framework owns the loop, the component implements one step.

One tick at ``now_ns`` (the order the feed goal's decisions depend on):

1. the simulated time advances by the elapsed node-clock time, at most ``MAX_TICK_PERIODS`` sensor
   periods (a driver that cannot keep up lags visibly, never silently);
2. the throw being shown advances; a throw that comes to rest is reported (``ArmEvents.landed``) and
   the feed goal takes its landing (Lynch, Northrop and Pan, section V: the goal judges the bit at rest);
3. else, with no throw in flight, a throw due (commands or the goal's ask, the period, a ready device)
   is thrown (``ArmEvents.thrown``); a throw that faults loses the part (``ArmEvents.part_lost``);
4. the one-bit sensor is read (at rest, or for the pose in flight) and the faults deliver it; a sample
   at rest goes to the feed goal.

The driver then closes the tick with the goal's decision (``advance_goal``).
"""

from __future__ import annotations

from typing import Generic, Mapping, NamedTuple, Protocol, TypeVar

from feeder_device.declarations import ActiveFault
from feeder_planner.throwing import ArmPart
from feeder_sim.throwing.arm import ThrowingArm
from feeder_sim.throwing.cycle import Pose, Shown, ThrowCycle, ns
from feeder_sim.throwing.faults import ArmFaults
from feeder_sim.throwing.feeding import FeedGoal, FeedRequest, rest_window_ns
from feeder_sim.throwing.outcome import ThrowOutcome
from feeder_sim.throwing.parameters import ArmParameters, configure_arm
from feeder_sim.throwing.tolerances import MAX_TICK_PERIODS

__all__ = ["ArmEvents", "ArmTick", "ArmStation"]

Event = TypeVar("Event")
Event_co = TypeVar("Event_co", covariant=True)


class ArmEvents(Protocol[Event_co]):
    """What a driver does when the arm's tick reports something (the node publishes and counts)."""

    def landed(self, now_ns: int, outcome: ThrowOutcome) -> Event_co | None:
        """Take a throw that came to rest; return what the feed goal reports with it (a ThrowEvent)."""
        ...

    def thrown(self, now_ns: int, outcome: ThrowOutcome) -> None:
        """Take a throw that started (or faulted at once: ``part_lost`` follows)."""
        ...

    def part_lost(self, now_ns: int, outcome: ThrowOutcome, text: str) -> None:
        """Take a throw that faulted: the part is lost; hold FAULT_PART_LOST with ``text``."""
        ...


class ArmTick(NamedTuple):
    """What one tick showed: the pose and joint, and the sensor bit delivered (None: dropped)."""

    shown: Shown
    delivered: bool | None
    in_flight: bool


class ArmStation(Generic[Event]):
    """The arm, its faults and the throw cycle, with the tick and the feed goal's start.

    Parameters
    ----------
    p
        The device's parameters (a driver that changes one at runtime sets ``p`` again).
    events
        What the driver does on a landing, a throw and a lost part.
    """

    def __init__(self, p: ArmParameters, events: ArmEvents[Event]) -> None:
        self.p = p  # the durations below follow it
        self.events = events
        self.arm: ThrowingArm = configure_arm(p)
        self.cycle = ThrowCycle(self.arm, ArmFaults(self.arm))
        self.cycle.running = bool(p.autostart)
        # The model's time in integer ns (no rounding drift at epoch magnitudes): set by the driver at the
        # first activation, then advanced per tick by the elapsed node-clock time, capped.
        self.simulated = 0
        self.throws = 0
        self._rest: tuple[ArmPart | None, tuple[object, ...], bool] | None = None

    @property
    def p(self) -> ArmParameters:
        """The device's parameters."""
        return self._p

    @p.setter
    def p(self, p: ArmParameters) -> None:
        # The tick's durations in ns, converted once per change (a tick at 100 Hz is the loop's hot path).
        self._p = p
        self._cap_ns = ns(MAX_TICK_PERIODS / p.sensor_rate)
        self._window_ns = ns(p.period * p.motion_fraction)
        self._period_ns = ns(p.period)

    # --- one tick ----------------------------------------------------------------------------------
    def tick(self, now_ns: int, elapsed_ns: int, feed: FeedGoal[Event] | None, ready: bool) -> ArmTick:
        """Advance the model by ``elapsed_ns`` (capped), land or throw, read the sensor (module doc).

        ``feed`` is the executing feed goal (None: none); ``ready`` whether the device may throw.
        """
        cycle = self.cycle
        self.simulated += min(elapsed_ns, self._cap_ns)
        t = self.simulated
        in_flight = cycle.motion is not None
        shown = cycle.show(t, self._window_ns)
        if shown.landed is not None:
            event = self.events.landed(now_ns, shown.landed)
            if feed is not None:
                feed.landed(now_ns, *self.arm.ground_truth(), event)
        elif not in_flight:
            wants = feed is not None and feed.wants_throw(now_ns)
            if cycle.throw_due(t, self._period_ns, wants, ready):
                self._throw(now_ns, t, feed)
        pose = None if cycle.motion is None else shown.pose
        delivered = cycle.faults.sensor(self.reading(pose))
        if pose is None and feed is not None:
            feed.sample(delivered)  # the bit as delivered decides, faults and all
        return ArmTick(shown, delivered, cycle.motion is not None)

    def _throw(self, now_ns: int, t: int, feed: FeedGoal[Event] | None) -> None:
        outcome = self.cycle.throw(t)
        self.throws += 1
        if feed is not None:
            feed.throw_started()
        self.events.thrown(now_ns, outcome)
        if outcome.kind == "fault":
            text = f"throw {self.throws}: {outcome.fault} (~/place_part puts it back)"
            self.events.part_lost(now_ns, outcome, text)

    def reading(self, pose: Pose | None = None) -> bool:
        """Return the true sensor bit: for the pose in flight, or at rest (cached while the part lies still).

        At rest the bit depends only on the part, its edge and R and the sensor's place; computed again
        every tick (100 Hz) it was a quarter of the cell loop's time. The faults still see every sample.
        """
        p, arm = self.p, self.arm
        if pose is not None:
            return arm.sensor(p.sensor_radius, p.sensing_height, pose)
        key = (arm.on_arm, arm.edge, arm.radius, p.sensor_radius, p.sensing_height)
        rest = self._rest
        if rest is None or rest[0] is not arm.part or rest[1] != key:
            rest = self._rest = (arm.part, key, arm.sensor(p.sensor_radius, p.sensing_height))
        return rest[2]

    def advance_goal(self, feed: FeedGoal[Event], now_ns: int, fault: tuple[int, str] | None) -> None:
        """Close the tick for the feed goal: judge the bit, end it, or ask for a throw (``FeedGoal.tick``).

        ``fault`` is (code, text) of the fault that stops the device, or None.
        """
        feed.tick(now_ns, fault, self.cycle.motion is not None)

    def stop(self, now_ns: int, feed: FeedGoal[Event] | None) -> None:
        """Cancel the queue and the running cycle; a throw being shown lands at once (it was thrown)."""
        cycle = self.cycle
        cycle.cancel_commands()
        if cycle.motion is not None:
            outcome, cycle.motion = cycle.motion.outcome, None
            event = self.events.landed(now_ns, outcome)
            if feed is not None:
                feed.landed(now_ns, *self.arm.ground_truth(), event)

    # --- the feed goal and the faults --------------------------------------------------------------
    def feed_goal(self, request: FeedRequest, start_ns: int) -> FeedGoal[Event]:
        """Return the feed goal of a checked request, started at ``start_ns`` from the arm's ground truth."""
        p = self.p
        window = rest_window_ns(p.period, p.motion_fraction, p.sensor_rate)
        return FeedGoal(request, start_ns, window, *self.arm.ground_truth())

    def apply_fault(self, fault: ActiveFault) -> None:
        """Put an injected fault into effect (checked by the model); a stopping one halts the throws.

        A part lost falls off with the throw in the air: no landing is shown.
        """
        cycle = self.cycle
        cycle.faults.inject(fault.spec.name, fault.value, fault.state, fault.indices, fault.seed)
        if fault.spec.stops_device:
            cycle.cancel_commands()
        if fault.spec.name == "part_lost":
            cycle.motion = None

    def place(self, edge: int, radius: float) -> None:
        """Put the part at rest at (edge, R), ending any throw being shown (``~/place_part``)."""
        self.cycle.place(edge, radius, self.p.arm_length)

    @staticmethod
    def lost_only(fault: tuple[int, str] | None, faults: Mapping[str, ActiveFault], lost_code: int) -> bool:
        """Return whether the device is in FAULT only because its part is lost (placing a part ends it).

        ``fault`` is the stopping fault, ``faults`` the injected ones, ``lost_code`` FAULT_PART_LOST.
        """
        others = any(f.spec.stops_device and f.spec.name != "part_lost" for f in faults.values())
        return fault is not None and fault[0] == lost_code and not others

    def lost_part_text(self) -> str | None:
        """Return why the arm cannot throw until a part is placed again (a part lost), else None."""
        if self.arm.faulted:
            return f"{self.arm.faulted} (~/place_part puts it back)"
        return None
