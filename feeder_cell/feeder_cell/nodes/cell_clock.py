"""ROS 2 node: the cell's one clock source, /clock at a real-time factor, free-running or in lockstep.

`feeder launch SCENE --real-time-factor F` starts it in lockstep and sets ``use_sim_time`` on every node,
so every device simulates, times and stamps on this one timeline. Two modes:

- **Lockstep** (``lockstep: true``): cell time advances by ``quantum`` only when every participant has
  finished the present quantum (``feeder_planner.node_kit.lockstep`` is the protocol, ``lockstep_barrier``
  the rules). ``real_time_factor`` is then an upper bound on the pace, 0 runs as fast as the participants
  allow, and the same seed gives the same run at any pace on any host. A participant that does not
  answer within ``lockstep_timeout`` is dropped with an ERROR in /diagnostics naming it (the cell goes on,
  or holds with ``on_lockstep_timeout: stop``).
- **Free-running** (``lockstep: false``): /clock follows the wall clock times the factor at
  ``publish_rate``; a device that cannot keep up falls behind and says so.

Both serve ``~/pause``, ``~/resume`` (std_srvs/Trigger), ``~/step`` (feeder_msgs/StepClock) and
``~/is_paused`` (feeder_msgs/IsPaused): a test can hold the whole cell still and advance it by exact
amounts (in lockstep a step is whole quanta, answered once the cell has reached it; the simulation node
``cell_simulation`` drives the cell through these same services), and ``~/rewind`` (std_srvs/Trigger):
a paused clock back to its start time, which only tick participants (devices) follow (a ResetSimulation
of time). The clock itself runs on the wall (steady) clock.
"""

from __future__ import annotations

import time
from typing import Callable, cast

from diagnostic_msgs.msg import DiagnosticArray
from rcl_interfaces.msg import SetParametersResult
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.clock import Clock as RclClock
from rclpy.clock import ClockType
from rclpy.parameter import Parameter
from rclpy.publisher import Publisher
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.task import Future
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Header
from std_srvs.srv import Trigger

from feeder_cell.clock_diagnostics import lockstep_diagnostics
from feeder_cell.clock_parameters import NANOSECONDS, PARAMETERS, ClockParameters, nanoseconds_of, to_time
from feeder_cell.clock_services import ClockServices
from feeder_cell.host.hub import ClockHub
from feeder_cell.lockstep_barrier import Barrier, Dropped
from feeder_msgs.srv import IsPaused, StepClock
from feeder_planner.errors import InputError
from feeder_planner.node_kit import check_value, declare_parameters, run_node
from feeder_planner.node_kit.lockstep import ANNOUNCE_TOPIC, ANSWER_TOPIC, LEAVE_SEC, LOCKSTEP_QOS, ROLES
from feeder_planner.parameter_specs import from_values

__all__ = ["ClockParameters", "PARAMETERS", "CellClock", "main"]


# rclpy's time source subscribes to /clock best effort with depth 1; a reliable publisher matches it.
CLOCK_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)

# A phase announcement not answered within this many wall seconds is published again: a best-effort
# /clock reader (rclpy's time source) may have missed it. Participants ignore a time they have seen.
REANNOUNCE_S = 1.0
JOIN_REANNOUNCE_S = 0.2
DIAGNOSTICS_PERIOD_S = 1.0
HOUSEKEEPING_PERIOD_S = 0.1


class CellClock(ClockServices):
    """Publishes /clock; serves ~/pause, ~/resume (std_srvs/Trigger) and ~/step (feeder_msgs/StepClock)."""

    def __init__(self) -> None:
        super().__init__("cell_clock")
        self.p = from_values(ClockParameters, declare_parameters(self, PARAMETERS))
        if not self.p.lockstep and self.p.real_time_factor == 0:
            raise InputError("parameter real_time_factor", "0 (as fast as possible) needs lockstep: true")
        start = self.p.start_time or time.time()
        # Integer nanoseconds: a long run at a high factor must not drift by float rounding.
        self.now_ns = int(round(start * NANOSECONDS))
        self.start_ns = self.now_ns  # where ~/rewind sets cell time back to
        self.factor = float(self.p.real_time_factor)
        self.paused = bool(self.p.start_paused)
        self.last_wall = time.monotonic()
        self.pub = self.create_publisher(Clock, "/clock", CLOCK_QOS)
        # The /clock callbacks of the nodes in the cell host with this clock (feeder_cell.host): by call.
        self.hosted_readers: list[Callable[[Clock], None]] = []
        self.create_service(Trigger, "~/pause", self.on_pause)
        self.create_service(Trigger, "~/resume", self.on_resume)
        # Its own reentrant group: in lockstep a step waits for the answers of the quanta it runs, which the
        # default (exclusive) group would hold back until the step's callback had returned.
        self.create_service(StepClock, "~/step", self.on_step, callback_group=ReentrantCallbackGroup())
        self.create_service(IsPaused, "~/is_paused", self.on_is_paused)
        self.create_service(Trigger, "~/rewind", self.on_rewind, callback_group=ReentrantCallbackGroup())
        self.add_on_set_parameters_callback(self.on_parameters)
        steady = RclClock(clock_type=ClockType.STEADY_TIME)
        self.barrier: Barrier | None = None
        if self.p.lockstep:
            self._start_lockstep(steady)
        else:
            self.create_timer(1.0 / self.p.publish_rate, self.tick, clock=steady)
        self.publish()
        mode = f"lockstep, quantum {self.p.quantum:g} s" if self.p.lockstep else "free-running"
        pace = "max" if self.factor == 0 else f"{self.factor:g}"
        paused = " (paused)" if self.paused else ""
        self.get_logger().info(f"/clock at real-time factor {pace}, {mode}{paused}")

    def publish(self) -> None:
        """Publish the present simulated time (and hand it to the time sources of the nodes it hosts)."""
        msg = Clock(clock=to_time(self.now_ns))
        self.pub.publish(msg)
        for reader in self.hosted_readers:
            reader(msg)

    # --- free-running -------------------------------------------------------------------------------
    def tick(self) -> None:
        """Advance by the wall time since the last tick times the factor (nothing while paused)."""
        wall = time.monotonic()
        elapsed, self.last_wall = wall - self.last_wall, wall
        if not self.paused:
            self.now_ns += int(round(elapsed * self.factor * NANOSECONDS))
        self.publish()

    # --- lockstep -----------------------------------------------------------------------------------
    def _start_lockstep(self, steady: RclClock) -> None:
        self.barrier = Barrier(
            self.now_ns,
            int(round(self.p.quantum * NANOSECONDS)),
            [name for name in self.p.lockstep_expect if name],
            self.p.lockstep_timeout,
            self.p.join_timeout,
            phase_started=time.monotonic(),
        )
        self.stopped = ""  # why the clock holds for good (on_lockstep_timeout: stop)
        self.steps_left = 0
        self.step_waiters: list[Future] = []
        self.join_waiters: list[Future] = []  # a rewind, answered once every tick member is at the start
        # Wall time the next quantum may start at F: kept on a grid of q/F from the last on-time start, so
        # the timer's lateness does not add up (after a slow quantum the grid starts again from now).
        self.next_due = 0.0
        self.announced_wall = time.monotonic()
        self.quanta = 0
        # The participants built in this process (the cell host) join here, not over DDS.
        self.hub = ClockHub(self, self.barrier, self._pump)
        self.announcers: dict[str, Publisher] = {
            role: self.create_publisher(Header, ANNOUNCE_TOPIC[role], LOCKSTEP_QOS) for role in ROLES
        }
        self.clock_wall = 0.0  # wall time /clock was last published
        self.held_published_ns = -1  # the held time last published on /clock
        # A quantum completes inside an answer's callback; the next one starts from this guard, so the
        # executor takes the answers, services and timers waiting in between (one quantum per turn).
        self.next_quantum = self.create_guard_condition(self._pump)
        for role in ROLES:
            self.create_subscription(
                Header, ANSWER_TOPIC[role], lambda msg, role=role: self._on_answer(role, msg), LOCKSTEP_QOS
            )
        self.diagnostics_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self.diagnostics_wall = 0.0
        # Timeouts, re-announcements and diagnostics need no finer grain than this.
        self.create_timer(HOUSEKEEPING_PERIOD_S, self._on_lockstep_timer, clock=steady)
        # The pace: a one-shot wake at the next quantum's due time (_wait_for_pace). It was a 2 ms poll,
        # and each of its 500 wakes a second rebuilt the executor's wait set: 69 % of a core for the cell
        # host of one arm at factor 4, most of it spent waiting, which a loaded machine then took from the
        # quanta (a CI run's arm reached 2.6 of 4).
        self.pace_timer = self.create_timer(1.0, self._on_pace, clock=steady, autostart=False)

    def _on_answer(self, role: str, msg: Header) -> None:
        barrier = cast(Barrier, self.barrier)
        leave = msg.stamp.sec == LEAVE_SEC
        # The answer names the node without the leading slash (a frame id has none); the barrier knows it
        # by its fully qualified name.
        name = "/" + msg.frame_id.lstrip("/")
        barrier.answer(role, name, -1 if leave else nanoseconds_of(msg.stamp), leave)
        self._pump()

    def _on_lockstep_timer(self) -> None:
        barrier = cast(Barrier, self.barrier)
        wall = time.monotonic()
        late = barrier.overdue(wall)
        if late:
            self._report_dropped(late)
        elif not barrier.complete() and wall - self.announced_wall > (
            JOIN_REANNOUNCE_S if barrier.phase == "join" else REANNOUNCE_S
        ):
            # Joining, the tick participants hear the start time again (they join by answering it).
            self._announce("tick" if barrier.phase == "join" else barrier.phase)
        if wall - self.diagnostics_wall >= DIAGNOSTICS_PERIOD_S:
            self._publish_diagnostics()
        self._pump()

    def _report_dropped(self, late: list[Dropped]) -> None:
        for dropped in late:
            self.get_logger().error(f"lockstep: {dropped.describe()}")
        if self.p.on_lockstep_timeout == "stop":
            self.stopped = f"held after a lockstep timeout: {late[0].describe()}"
        self._publish_diagnostics()

    def _announce(self, role: str) -> None:
        self.announced_wall = time.monotonic()
        self.announcers[role].publish(Header(stamp=to_time(self.now_ns)))
        self.hub.arrive(role, self.now_ns)
        if role == "tick" and self.announced_wall - self.clock_wall >= 1.0 / self.p.clock_rate:
            self.clock_wall = self.announced_wall
            self.publish()

    def _pump(self) -> None:
        """Run the phases as far as the answers allow: announce each phase once the previous is complete."""
        barrier = cast(Barrier, self.barrier)
        while barrier.complete() and not self.stopped:
            wall = time.monotonic()
            if barrier.phase == "join":
                self._wake(self.join_waiters)
            if barrier.phase in ("join", "done"):
                if self.paused and self.steps_left == 0:
                    self._publish_held()
                    return
                if barrier.phase == "done" and self.factor > 0 and wall < self.next_due:
                    self._wait_for_pace(self.next_due - wall)
                    return
                if self.paused and barrier.phase == "done":
                    self.steps_left -= 1
                if self.factor > 0:
                    period = self.p.quantum / self.factor
                    late = wall - self.next_due > period
                    self.next_due = (wall if late else self.next_due) + period
            role = barrier.next_phase(wall)
            self.now_ns = barrier.now_ns
            if role == "done":
                self.quanta += 1
                if self.steps_left == 0:
                    self._wake_steps()
                self.next_quantum.trigger()
                return
            self._announce(role)

    def _wait_for_pace(self, seconds: float) -> None:
        """Pump again ``seconds`` from now (rcl_timer_reset restarts a cancelled timer's full period)."""
        self.pace_timer.timer_period_ns = max(1, int(seconds * NANOSECONDS))
        self.pace_timer.reset()

    def _on_pace(self) -> None:
        self.pace_timer.cancel()
        self._pump()

    def _publish_held(self) -> None:
        """Held, say where: /clock is throttled to clock_rate, and the last quantum may not have gone out."""
        if self.held_published_ns != self.now_ns:
            self.held_published_ns = self.now_ns
            self.publish()

    def _wake_steps(self) -> None:
        self._wake(self.step_waiters)

    @staticmethod
    def _wake(waiters: list[Future]) -> None:
        taken = list(waiters)
        waiters.clear()
        for waiter in taken:
            if not waiter.done():
                waiter.set_result(True)

    def _publish_diagnostics(self) -> None:
        self.diagnostics_wall = time.monotonic()
        self.diagnostics_pub.publish(
            lockstep_diagnostics(
                cast(Barrier, self.barrier),
                name=self.get_fully_qualified_name(),
                now_ns=self.now_ns,
                quantum=self.p.quantum,
                factor=self.factor,
                quanta=self.quanta,
                paused=self.paused,
                stopped=self.stopped,
            )
        )

    def on_parameters(self, changes: list[Parameter]) -> SetParametersResult:
        """Apply a new real-time factor at once (the clock continues from where it is)."""
        for change in changes:
            if change.name == "real_time_factor":
                try:
                    check_value(PARAMETERS[0], change.value)
                    if self.barrier is None and change.value == 0:
                        raise InputError("parameter real_time_factor", "0 needs lockstep: true")
                except InputError as error:
                    return SetParametersResult(successful=False, reason=str(error))
                if self.barrier is None:
                    self.tick()
                self.factor = float(change.value)
        return SetParametersResult(successful=True)


NODE = CellClock  # what the cell host builds (feeder_cell.host)


def main(args: list[str] | None = None) -> None:
    """Run the cell clock node."""
    run_node(CellClock, "cell_clock", args)


if __name__ == "__main__":
    main()
