"""The cell loop's drivers: each device's station (``feeder_sim.<device>.station``) under the kit's rules.

Each driver holds the same station the device node holds and calls it as the node does: its tick, its
goal's start and decision, its faults; what the node publishes it does not. What the kit does around the
station is ``kit.StationDriver``. The DeviceStatus fault codes are the message's (the loop imports no ROS
message; tests/experiment/test_loop_drivers.py checks they agree).
"""

from __future__ import annotations

from typing import Any

from feeder_cell.experiment.kit import StationDriver
from feeder_device.declarations import ActiveFault
from feeder_planner.errors import FeederError
from feeder_planner.mems import ProgramStep
from feeder_sim.fixture import plan_goal
from feeder_sim.fixture.follow import goal_waypoints
from feeder_sim.fixture.parameters import FixtureParameters
from feeder_sim.fixture.path_goal import PathGoal, PathOutcome
from feeder_sim.fixture.station import FixtureStation
from feeder_sim.mems.parameters import MemsParameters
from feeder_sim.mems.program_goal import ProgramGoal
from feeder_sim.mems.settling import check_timeout, settling_criterion
from feeder_sim.mems.station import MemsStation
from feeder_sim.throwing.feeding import FeedGoal, check_feed_goal
from feeder_sim.throwing.outcome import ThrowOutcome
from feeder_sim.throwing.parameters import ArmParameters
from feeder_sim.throwing.station import ArmStation

__all__ = ["ArmDriver", "MemsDriver", "FixtureDriver", "fault_specs_of"]

FAULT_TIME_STEP = 3  # a warning; the loop had 203, which no message defines (test_loop_drivers found it)
FAULT_MOTOR, FAULT_PART_LOST = 101, 102
FAULT_POWER_LOSS = 201
FAULT_AXIS_STALL, FAULT_RATE_LIMIT = 301, 302


class ArmDriver(StationDriver):
    """The throwing arm's station (``feeder_sim.throwing.station``) under the kit's rules, no streams."""

    name = "throwing_arm"

    def __init__(self, p: ArmParameters, origin_ns: int) -> None:
        super().__init__(origin_ns)
        self.p = p
        self.rate = float(p.sensor_rate)
        self.station: ArmStation[None] = ArmStation(p, self)
        self.station.simulated = origin_ns
        self.arm, self.cycle = self.station.arm, self.station.cycle
        self.goal: FeedGoal[None] | None = None

    def busy(self) -> bool:
        """Return whether the model is busy without a goal (the node's ``busy`` less the kit's part)."""
        return self.cycle.busy

    def tick(self, now_ns: int) -> None:
        """Tick the station at ``now_ns`` (the node's tick without the streams)."""
        # An ended goal takes nothing a tick tells (FeedGoal): no need to ask whether it ended.
        self.station.tick(now_ns, self.elapsed_ns(now_ns), self.goal, self.ready())

    # ArmEvents: nothing to publish; a lost part is held as the kit's raise_model_fault holds it.
    def landed(self, now_ns: int, outcome: ThrowOutcome) -> None:
        """Take a landing: nothing to publish, no event for the goal's report."""
        return None

    def thrown(self, now_ns: int, outcome: ThrowOutcome) -> None:
        """Take a throw: nothing to publish or count."""
        return None

    def part_lost(self, now_ns: int, outcome: ThrowOutcome, text: str) -> None:
        """Hold FAULT_PART_LOST as the kit's ``raise_model_fault`` does."""
        self.model_fault = (FAULT_PART_LOST, text)

    def goal_done(self) -> bool:
        """Return whether there is no goal or it has ended."""
        return self.goal is None or self.goal.done

    def advance_goal(self, now_ns: int) -> None:
        """Close the tick at ``now_ns`` for the goal: the station's decision."""
        assert self.goal is not None
        self.station.advance_goal(self.goal, now_ns, self.stopping_fault())

    def send_feed(self, max_throws: int, timeout: float) -> None:
        """Accept a ``~/feed_part`` goal (checked now); it starts after the next tick."""
        request = check_feed_goal(max_throws, timeout)

        def start(now_ns: int) -> None:
            self.goal = self.station.feed_goal(request, now_ns)

        self.pending_goal = start

    def place(self, edge: int, radius: float) -> None:
        """~/place_part: accepted when ready or in FAULT from a part lost only (arm_parts.py)."""
        fault = self.stopping_fault()
        lost_only = ArmStation.lost_only(fault, self.faults, FAULT_PART_LOST)
        if not (lost_only and not self.stopped) and not self.ready():
            raise FeederError(f"place_part refused: {self.name} is in FAULT: {fault[1] if fault else ''}")
        self.station.place(edge, radius)
        self.faults.pop("part_lost", None)
        self.model_fault = None

    def apply_fault(self, fault: ActiveFault) -> None:
        """Put an injected fault into the station's model (the node's ``apply_fault``)."""
        self.station.apply_fault(fault)

    def clear_fault(self, name: str) -> None:
        """Take an injected fault out of the station's model (the node's ``clear_fault``)."""
        self.cycle.faults.clear(name)
        self._require_part_again()

    def reset_device(self) -> None:
        """Do the device's own part of ``~/reset`` (the node's ``reset_device``)."""
        self.cycle.cancel_commands()
        self._require_part_again()

    def _require_part_again(self) -> None:
        lost = self.station.lost_part_text()
        if lost is not None and self.model_fault is None:
            self.model_fault = (FAULT_PART_LOST, lost)


class MemsDriver(StationDriver):
    """The MEMS array's station (``feeder_sim.mems.station``) under the kit's rules, no streams."""

    name = "mems_field_array"

    def __init__(self, p: MemsParameters, origin_ns: int) -> None:
        super().__init__(origin_ns)
        self.p = p
        self.rate = float(p.publish_rate)
        self.station = MemsStation(p)
        self.scene, self.parts = self.station.scene, self.station.parts
        self.goal: ProgramGoal | None = None

    def busy(self) -> bool:
        """Return whether the model is busy without a goal (the node's ``busy`` less the kit's part)."""
        return self.station.moving()

    def tick(self, now_ns: int) -> None:
        """Tick the station at ``now_ns`` (the node's tick without the streams)."""
        self.station.tick(self.elapsed_ns(now_ns))

    def goal_done(self) -> bool:
        """Return whether there is no goal or it has ended."""
        return self.goal is None or self.goal.done

    def stiff_warning(self) -> tuple[int, str] | None:
        """Return (FAULT_TIME_STEP, why) while the step is too stiff, else None."""
        why = self.station.stiffness()
        return (FAULT_TIME_STEP, why) if why else None

    def advance_goal(self, now_ns: int) -> None:
        """Close the tick at ``now_ns`` for the goal: the station's decision."""
        assert self.goal is not None
        self.station.advance_goal(
            self.goal, now_ns, self.stopping_fault(), self.stopped, self.stiff_warning()
        )

    def send_program(
        self, program: tuple[ProgramStep, ...], timeout: float, tolerance: float, dwell: float
    ) -> None:
        """Accept a ``~/run_program`` goal (checked now); it installs its program after the next tick."""
        criterion = settling_criterion(tolerance, dwell)
        timeout = check_timeout(timeout)

        def start(now_ns: int) -> None:
            self.goal = self.station.start_program(program, criterion, timeout, now_ns)

        self.pending_goal = start

    def place_reset(self) -> None:
        """``~/place_parts`` reset: the parts as configured (refused unless ready)."""
        if not self.ready():
            raise FeederError(f"place_parts refused: {self.name} is not ready")
        self.parts.reset()

    def place(self, poses: tuple[tuple[float, float, float], ...]) -> None:
        """``~/place_parts``: the parts at ``poses`` (x, y, theta), at rest (refused unless ready)."""
        if not self.ready():
            raise FeederError(f"place_parts refused: {self.name} is not ready")
        columns = ([p[0] for p in poses], [p[1] for p in poses], [p[2] for p in poses])
        self.station.place(list(self.parts.names), *columns)

    def apply_fault(self, fault: ActiveFault) -> None:
        """Put an injected fault into the station's model (the node's ``apply_fault``)."""
        self.station.apply_fault(fault)

    def clear_fault(self, name: str) -> None:
        """Take an injected fault out of the station's model (the node's ``clear_fault``)."""
        self.station.clear_fault(name)

    def reset_device(self) -> None:
        """Do the device's own part of ``~/reset`` (the node's ``reset_device``)."""
        self.station.reset()


class FixtureDriver(StationDriver):
    """The fixture's station (``feeder_sim.fixture.station``) under the kit's rules, no streams."""

    name = "assembly_fixture"

    def __init__(self, p: FixtureParameters, origin_ns: int) -> None:
        super().__init__(origin_ns)
        self.p = p
        self.rate = float(p.publish_rate)
        self.station = FixtureStation(p, FAULT_AXIS_STALL)
        self.limits, self.prepared, self.table = (
            self.station.limits,
            self.station.prepared,
            self.station.table,
        )
        self.goal: PathGoal | None = None
        self.early: PathOutcome | None = None

    def busy(self) -> bool:
        """Return whether the model is busy without a goal (the node's ``busy`` less the kit's part)."""
        return self.table.moving

    def _advance_to(self, now_ns: int) -> None:
        stall = self.station.advance(self.elapsed_ns(now_ns)).stall
        if stall is not None:
            self.model_fault = (FAULT_AXIS_STALL, stall.describe())

    def tick(self, now_ns: int) -> None:
        """Tick the station at ``now_ns`` (the node's tick without the streams)."""
        self._advance_to(now_ns)

    def goal_done(self) -> bool:
        """Return whether there is no goal or it has ended."""
        return self.goal is None or self.goal.done

    def advance_goal(self, now_ns: int) -> None:
        """Close the tick at ``now_ns`` for the goal: the station's decision."""
        assert self.goal is not None
        self.station.advance_goal(self.goal, self.stopping_fault(), self.stopped)

    def send_path(self, gravity: list[tuple[float, float, float]]) -> None:
        """Accept a ``~/follow_path`` goal (checked now); it plans and certifies after the next tick."""
        waypoints = goal_waypoints(gravity, [], self.limits)
        plan_goal(self.table, waypoints, self.p.path_step)  # the goal-time check (raises naming the field)

        def start(now_ns: int) -> None:
            self.goal, self.early = None, None
            if not self.ready():
                self.early = PathOutcome("FAULT", f"not started: {self.name} is not ready")
                return
            self._advance_to(now_ns)
            started = self.station.follow(waypoints, plan_goal(self.table, waypoints, self.p.path_step))
            self.goal, self.early = started.goal, started.early

        self.pending_goal = start

    def apply_fault(self, fault: ActiveFault) -> None:
        """Put an injected fault into the station's model (the node's ``apply_fault``)."""
        self.station.apply_fault(fault)

    def clear_fault(self, name: str) -> None:
        """Take an injected fault out of the station's model (the node's ``clear_fault``)."""
        if self.station.clear_fault(name, self.model_fault):
            self.model_fault = None

    def reset_device(self) -> None:
        """Nothing beyond the kit's reset (the node's reset_device is the kit's default)."""


def fault_specs_of(device: str) -> Any:
    """Return the device's FaultSpecs by name (the kit's, with the codes the node hands in)."""
    if device == "throwing_arm":
        from feeder_sim.throwing.fault_specs import fault_specs as arm_specs

        return arm_specs({"motor_fault": FAULT_MOTOR, "part_lost": FAULT_PART_LOST})
    if device == "mems_field_array":
        from feeder_sim.mems.fault_specs import fault_specs as mems_specs

        return mems_specs({"power_loss": FAULT_POWER_LOSS})
    from feeder_sim.fixture.fault_specs import fault_specs as fixture_specs

    return fixture_specs({"axis_stall": FAULT_AXIS_STALL, "rate_limit": FAULT_RATE_LIMIT})
