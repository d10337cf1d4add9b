"""The work of each state of the controller machine in the ROS-free cell loop: one station step each.

The reference controller's work per state (``feeder_cell.controller``: ORIENT runs the array's program
goal, INFEED places the part on the arm, FEED runs the arm's feed goal, TILT and RETURN the fixture's
follow-path goal, PLAN_* the region planner's safe path, RECOVER a repair and a reset), done by direct
calls on the drivers (``drivers.py``) instead of services and actions. A service call costs no cell time;
a goal's result is seen at the end of the quantum whose tick ended it (``CellLoop._wait``). What each
returns is the controller's ``Outcome``, which the machine's tables take.
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np

from feeder_cell.controller import CellMachine, Outcome
from feeder_cell.controller.fault_schedule import REPAIR_EARLY_S, FaultSchedule
from feeder_cell.experiment.arrivals import ArrivalStream
from feeder_cell.experiment.drivers import ArmDriver, FixtureDriver, MemsDriver
from feeder_cell.experiment.kit import StationDriver
from feeder_planner.errors import FeederError
from feeder_planner.mems import ProgramStep

__all__ = ["CellWork"]


class CellWork:
    """The work of each state on the loop's drivers; the loop (``CellLoop``) owns clock and machine."""

    c: dict[str, Any]
    mems: MemsDriver
    arm: ArmDriver
    fixture: FixtureDriver
    by_key: dict[str, StationDriver]
    node_of: dict[str, str]
    machine: CellMachine
    schedule: FaultSchedule
    arrivals: ArrivalStream | None
    program: tuple[ProgramStep, ...]
    stood: np.ndarray
    safe: list[tuple[float, float, float]]
    cycle_throws: int
    cycle_presented: int
    cycle_rejected: int
    ahead_started: bool  # an ORIENT started ahead (policy pipelined) whose outcome ORIENT has not taken
    ahead_outcome: Outcome | None  # its outcome, once its goal has ended (or it was refused)
    batches: list[int]  # the cycles whose batch was placed on the array, in order

    def t(self) -> float:
        """Cell time now (s)."""
        raise NotImplementedError

    def _wait(self, done: Callable[[], bool], timeout: float) -> bool:
        """Let quanta pass until ``done()`` at a react time, or ``timeout`` s of cell time passed."""
        raise NotImplementedError

    @staticmethod
    def _route(flat: list[float]) -> list[tuple[float, float, float]]:
        return [(float(flat[i]), float(flat[i + 1]), float(flat[i + 2])) for i in range(0, len(flat), 3)]

    def orient(self) -> Outcome:
        """Place a new batch (drawn poses with arrivals) and run the program until every part settled.

        Under ``policy: pipelined`` the cycle's ORIENT may have started ahead (``orient_ahead``) during the
        last cycle: then it takes that goal's outcome, waiting for it if it has not ended.
        """
        if self.ahead_started:
            bound = float(self.c["orient_timeout"]) + float(self.c["step_timeout"])
            seen = self._wait(lambda: self.ahead_outcome is not None, bound)
            self.ahead_started = False
            if not seen:
                return Outcome("NO_ANSWER", 0, "run_program: no result within the step's bound")
            outcome, self.ahead_outcome = self.ahead_outcome, None
            assert outcome is not None
            return outcome
        refused = self._send_orient(self.machine.cycle, self.machine.attempts == 0)
        if refused is not None:
            return refused
        mems = self.mems
        bound = float(self.c["orient_timeout"]) + float(self.c["step_timeout"])
        if not self._wait(lambda: mems.goal is not None and mems.goal.done, bound):
            return Outcome("NO_ANSWER", 0, "run_program: no result within the step's bound")
        return self._orient_outcome()

    def orient_ahead(self) -> None:
        """Start the next cycle's ORIENT in the background (``AHEAD``); its outcome waits for that ORIENT."""
        self.ahead_started = True
        self.ahead_outcome = self._send_orient(self.machine.cycle + 1, True)

    def see_ahead(self) -> None:
        """At a react time: take the outcome of an ORIENT started ahead once its goal has ended."""
        goal = self.mems.goal
        if self.ahead_started and self.ahead_outcome is None and goal is not None and goal.done:
            self.ahead_outcome = self._orient_outcome()

    def _send_orient(self, cycle: int, new: bool) -> Outcome | None:
        """Place ``cycle``'s batch when ``new`` and send the program; the refusal's outcome, or None."""
        mems = self.mems
        try:
            if self.c["new_batch"] and new:
                mems.place_reset()
            arrivals = self.arrivals
            if arrivals is not None and arrivals.arrivals.mems is not None and new:
                mems.place(arrivals.mems(cycle, len(mems.parts.names)))
            if new:
                self.batches.append(cycle)
            if not mems.ready():
                raise FeederError("run_program goal refused: the array is not ready")
            mems.send_program(
                self.program,
                float(self.c["orient_timeout"]),
                float(self.c["orient_tolerance"]),
                float(self.c["orient_dwell"]),
            )
        except FeederError as error:
            return self._refusal(mems, str(error))
        return None

    def _orient_outcome(self) -> Outcome:
        mems = self.mems
        assert mems.goal is not None and mems.goal.outcome is not None
        outcome = mems.goal.outcome
        mems.goal = None
        return Outcome(outcome.name, outcome.fault[0], outcome.message)

    def infeed(self) -> Outcome:
        """Put the cycle's part on the arm (its drawn edge and R with arrivals)."""
        edge, radius = int(self.c["infeed_edge"]), float(self.c["infeed_radius"])
        arrivals = self.arrivals
        if arrivals is not None and arrivals.arrivals.arm is not None:
            if arrivals.drop is None:
                try:
                    arrivals.set_part(self.arm.arm.part)
                except FeederError as error:
                    return Outcome("ERROR", 0, f"arrivals: the arm part's drop distribution: {error}")
            arrival = arrivals.arm(self.machine.cycle)
            edge, radius = arrival.edge, arrival.radius
        try:
            self.arm.place(edge, radius)
        except FeederError as error:
            return self._refusal(self.arm, str(error))
        return Outcome("DONE")

    def feed(self) -> Outcome:
        """Throw until the sensor reads true at rest; count the part good or rejected."""
        arm = self.arm
        if not arm.ready() or arm.cycle.busy:
            return self._refusal(arm, "feed_part: goal rejected")
        try:
            arm.send_feed(int(self.c["feed_max_throws"]), float(self.c["feed_timeout"]))
        except FeederError as error:
            return self._refusal(arm, str(error))
        bound = float(self.c["feed_timeout"]) + float(self.c["step_timeout"])
        if not self._wait(lambda: arm.goal is not None and arm.goal.done, bound):
            return Outcome("NO_ANSWER", 0, "feed_part: no result within the step's bound")
        assert arm.goal is not None and arm.goal.outcome is not None
        result = arm.goal.outcome
        arm.goal = None
        self.cycle_throws += result.throws
        if result.name == "PRESENTED":
            truly = arm.arm.sensor(arm.p.sensor_radius, arm.p.sensing_height)
            if truly:
                self.cycle_presented += 1
            else:
                self.cycle_rejected += 1
        return Outcome(result.name, result.fault_code, f"{result.throws} throws; {result.message}")

    def tilt(self, waypoints: list[tuple[float, float, float]]) -> Outcome:
        """Follow gravity waypoints with the fixture (REFUSED by its interlock, REACHED, STALLED...)."""
        fixture = self.fixture
        if not fixture.ready():
            return self._refusal(fixture, "follow_path: goal rejected")
        try:
            fixture.send_path(waypoints)
        except FeederError as error:
            return self._refusal(fixture, str(error))

        def done() -> bool:
            return fixture.early is not None or (fixture.goal is not None and fixture.goal.done)

        if not self._wait(done, float(self.c["step_timeout"])):
            return Outcome("NO_ANSWER", 0, "follow_path: no result within the step's bound")
        outcome = fixture.early if fixture.early is not None else fixture.goal.outcome  # type: ignore[union-attr]
        assert outcome is not None
        fixture.goal, fixture.early = None, None
        self.stood = fixture.table.gravity()
        return Outcome(outcome.name, outcome.fault_code, outcome.message)

    def plan(self, goal: tuple[float, float, float]) -> Outcome:
        """Plan a certified path from where the fixture stands (the region planner's ~/safe_path)."""
        from feeder_planner.assembly.path import DEFAULT_PATH_STEP, safe_path

        prepared = self.fixture.prepared
        step = float(self.c["path_step"]) or DEFAULT_PATH_STEP
        try:
            path = safe_path(prepared.region, prepared.checker, self.stood, np.array(goal), step)
        except FeederError as error:
            return Outcome("NO_PATH", 0, str(error))
        samples = [(float(g[0]), float(g[1]), float(g[2])) for g in path[1:]]
        self.safe = samples or [goal]
        return Outcome("PLANNED", 0, f"{len(path)} samples")

    def recover(self) -> Outcome:
        """Wait out a failure's repair, reset the device (the arm: a fresh part), check it is ready."""
        key = self.machine.device
        if key == "planner":
            return Outcome("DONE")
        device: StationDriver = self.by_key[key]
        end = self.schedule.under_repair_until(self.node_of[key])
        if end > self.t():
            self._wait(lambda: False, end - self.t() - REPAIR_EARLY_S)
        device.reset()
        if key == "arm":
            placed = self.infeed()
            if placed.event != "DONE":
                return placed
        if not device.ready():
            fault = device.stopping_fault()
            if fault is not None:
                return Outcome("FAULT", fault[0], f"{device.name}: {fault[1]}")
            return Outcome("ERROR", 0, f"{device.name} is not ready")
        return Outcome("DONE")

    @staticmethod
    def _refusal(device: StationDriver, message: str) -> Outcome:
        fault = device.stopping_fault()
        if fault is not None:
            return Outcome("FAULT", fault[0], f"{fault[1]} ({message})")
        return Outcome("ERROR", 0, message)
