"""The ROS-free cell loop: the cell scene's devices, goal machines and controller machine on one clock.

One process, no rclpy, no DDS: the same stations as the device nodes (``feeder_sim.<device>.station``:
each device's tick, goal machine and faults, run here by ``drivers.py`` under the kit's rules of
``kit.py``) and the same controller machine (``CellMachine`` with its two tables) as the ROS cell, driven
the way the cell clock's lockstep drives them (docs/cell.md, docs/devices.md "The station" and "Who
drives the tick"). This module is the clock and the machine's run; the work of each state is
``work.py``, the scene's checks ``cell_scene.py``, what it returns ``results.py``:

- cell time advances by the quantum (0.1 s); in each quantum every device ticks every instant of its
  rate's grid (arm 100 Hz, array and fixture 20 Hz), each tick followed by its goal's decision;
- the controller decides at the quantum's end (the react phase). A service call costs no cell time (the
  controller holds the clock while it is answered). A goal sent at T starts after the device's first tick
  after acceptance, i.e. once the ticks of (T, T + q] are done, with its start time T + q; its first
  decision is at the first tick after that; its result is seen at the end of the quantum whose tick ended it;
- a fault process's failure is injected at the first react time at or after it (``fault_origin`` +
  start), its repair cleared at the first react time at or after its end; RECOVER waits until the first
  react time after the repair before it resets.

What the loop returns per cycle: cell time, throws, presented and rejected parts, faults seen and handled;
per replication each device's cell time RUNNING, IDLE and FAULT (one quantum at a time, as the device's
state is at the quantum's end). A part is rejected when the sensor said PRESENTED but the true reading at
rest is false (a stuck or lying sensor: the part is not on the goal edge). A feed that ends in
MAX_THROWS, TIMEOUT or a lost part is no reject by itself: the fault policy resets the arm and places the
same cycle's part again (as the ROS controller does). A cell that stops (a motor fault, a power loss, a
spent retry budget) ends the replication; the cycle it stopped in is recorded incomplete, its time lost.
tests/experiment/test_loop_equivalence_ros.py compares the loop with the ROS lockstep run of the same
scene and seed.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Callable

import numpy as np

from feeder_cell.controller import CellMachine, Outcome, State
from feeder_cell.controller.fault_schedule import FaultSchedule
from feeder_cell.experiment.arrivals import ArrivalStream
from feeder_cell.experiment.cell_scene import (
    DEVICES,
    check_scene,
    controller_parameters,
    device_parameters,
    read_scene,
)
from feeder_cell.experiment.drivers import ArmDriver, FixtureDriver, MemsDriver, fault_specs_of
from feeder_cell.experiment.faults_process import FaultEvent, FaultSpec
from feeder_cell.experiment.kit import StationDriver
from feeder_cell.experiment.results import DEVICE_STATES, QUANTUM, CycleRecord, LoopResult
from feeder_cell.experiment.work import CellWork
from feeder_planner.errors import FeederError
from feeder_planner.fields_io import load_yaml_mapping
from feeder_planner.mems import ProgramStep, field_from_mapping, program_from_mapping
from feeder_sim.fixture.parameters import FixtureParameters
from feeder_sim.mems.parameters import NANOSECONDS, MemsParameters
from feeder_sim.throwing.parameters import ArmParameters

if TYPE_CHECKING:
    from feeder_cell.launcher import Scene

__all__ = [
    "QUANTUM",
    "DEVICE_STATES",
    "CycleRecord",
    "LoopResult",
    "CellLoop",
    "controller_parameters",
    "read_scene",
    "check_scene",
    "scene_loop",
]


class CellLoop(CellWork):
    """One replication of the cell: build the devices from the scene's parameters, run the machine.

    Parameters
    ----------
    devices
        Node name -> parameters of the three devices (``mems_field_array``, ``throwing_arm``,
        ``assembly_fixture``), as the scene gives them (paths resolved).
    controller
        The controller's parameters (``controller_parameters``).
    arrivals, faults, seed, replication
        The scene's random inputs and the replication whose streams they draw (None, () for none).
    start_time
        Cell time (s) of the first cycle's start (the ROS run's first settled time: only the absolute
        stamps depend on it).
    """

    def __init__(
        self,
        devices: dict[str, dict[str, Any]],
        controller: dict[str, Any],
        arrivals: ArrivalStream | None = None,
        faults: tuple[FaultSpec, ...] = (),
        seed: int = 0,
        replication: int = 0,
        start_time: float = 0.0,
    ) -> None:
        self.c = controller_parameters(controller)
        self.q = int(round(QUANTUM * NANOSECONDS))
        self.now = int(round(start_time * NANOSECONDS))
        origin = self.now
        self.arm = ArmDriver(
            device_parameters(ArmParameters, devices.get("throwing_arm", {}), "throwing_arm"), origin
        )
        self.mems = MemsDriver(
            device_parameters(MemsParameters, devices.get("mems_field_array", {}), "mems_field_array"),
            origin,
        )
        self.fixture = FixtureDriver(
            device_parameters(FixtureParameters, devices.get("assembly_fixture", {}), "assembly_fixture"),
            origin,
        )
        self.by_key: dict[str, StationDriver] = {"mems": self.mems, "arm": self.arm, "fixture": self.fixture}
        self.by_name: dict[str, StationDriver] = {d.name: d for d in self.by_key.values()}
        self.machine = CellMachine(
            cycles=int(self.c["cycles"]), max_retries=int(self.c["max_retries"]), policy=str(self.c["policy"])
        )
        self.program = self._program()
        self.arrivals = arrivals
        self.seed, self.replication = seed, replication
        # The node names the controller drives (its *_device parameters), as the fault processes name them.
        self.node_of = {key: str(self.c[f"{key}_device"]).rsplit("/", 1)[-1] for key in self.by_key}
        self.by_node = {self.node_of[key]: device for key, device in self.by_key.items()}
        self.schedule = FaultSchedule(faults, seed, replication)
        self.failures: list[FaultEvent] = []
        self.fault_tables = {
            s.device: fault_specs_of(self.by_node[s.device].name) for s in faults if s.device in self.by_node
        }
        # Quanta per device and state (counted, not summed: no rounding drift over thousands of cycles).
        self.device_quanta = {d.name: dict.fromkeys(DEVICE_STATES, 0) for d in self.by_key.values()}
        self.down_quanta = 0
        self.stood = np.array(self.c["fixture_home"][-3:], float)
        self.cycle_throws = 0
        self.cycle_presented = 0
        self.cycle_rejected = 0
        self.ahead_started = False
        self.ahead_outcome: Outcome | None = None
        self.batches: list[int] = []
        self.cycles: list[CycleRecord] = []
        self.transitions: list[tuple[float, str, str, str]] = []
        self._seen_at_cycle_start = (0, 0)
        self.first_start = math.nan

    def _program(self) -> tuple[ProgramStep, ...]:
        path = self.c["orient_program_file"]
        if not path:
            # The node's one combined field (FieldSpec defaults: centre 0, strength 1), forever.
            mapping = {"type": "combined", "delta": float(self.c["orient_delta"]), "center": [0.0, 0.0]}
            return (ProgramStep(field_from_mapping({**mapping, "strength": 1.0}, "program"), math.inf),)
        return tuple(program_from_mapping(load_yaml_mapping(path), "program"))

    # --- time ---------------------------------------------------------------------------------------------
    def t(self) -> float:
        """Cell time now (s)."""
        return self.now / NANOSECONDS

    def _quantum(self) -> None:
        """One quantum: every device ticks up to the next react time; the state shares; due faults."""
        self.now += self.q
        for device in (self.mems, self.arm, self.fixture):  # the cell host's order; they do not interact
            device.advance(self.now)
        down = self.machine.state is State.RECOVER
        for each in self.by_key.values():
            state = each.state()
            self.device_quanta[each.name][state] += 1
            down = down or state == "FAULT"
        self.down_quanta += down
        self.see_ahead()
        self._inject_due()

    def _wait(self, done: Callable[[], bool], timeout: float) -> bool:
        """Let quanta pass until ``done()`` at a react time, or the step's bound (cell time) passed."""
        deadline = self.now + timeout * NANOSECONDS
        while not done():
            if self.now > deadline:
                return False
            self._quantum()
        return True

    # --- faults ---------------------------------------------------------------------------------------------
    def _inject_due(self) -> None:
        """Apply what the fault schedule says is due now (the ROS controller's ``_inject_due``)."""
        if self.machine.state is State.BRING_UP:
            return
        for action in self.schedule.due(self.t()):
            if not action.clear:
                self.failures.append(action.event)
            device = self.by_node.get(action.spec.device)
            if device is None:
                continue  # no such device in the cell: the ROS controller finds no service either
            try:
                device.inject(action.spec, action.clear, 0, self.fault_tables[action.spec.device])
            except FeederError:
                pass  # the device refused (the ROS controller logs it): the failure has no effect

    # --- the machine ----------------------------------------------------------------------------------------
    def run(self, until: Callable[[list[CycleRecord]], bool] | None = None) -> LoopResult:
        """Run the machine to its end, or (``until``) to the first cycle end at which ``until(cycles)``.

        With ``until`` the machine runs whatever its ``cycles`` (the end state is then HORIZON).
        """
        if until is not None:
            self.machine.cycles = 0
        work = {
            State.BRING_UP: lambda: Outcome("DONE"),
            State.ORIENT: self.orient,
            State.INFEED: self.infeed,
            State.FEED: self.feed,
            State.TILT: lambda: self.tilt(self._route(self.c["fixture_route"])),
            State.TILT_SAFE: lambda: self.tilt(self.safe),
            State.RETURN: lambda: self.tilt(self._route(self.c["fixture_home"])),
            State.RETURN_SAFE: lambda: self.tilt(self.safe),
            State.PLAN_TILT: lambda: self.plan(self._route(self.c["fixture_route"])[-1]),
            State.PLAN_RETURN: lambda: self.plan(self._route(self.c["fixture_home"])[-1]),
            State.RECOVER: self.recover,
        }
        self.safe: list[tuple[float, float, float]] = []
        while not self.machine.finished:
            self._inject_due()
            state = self.machine.state
            outcome = work[state]()
            transition = self.machine.advance(outcome, self.t())
            self.transitions.append((self.t(), state.value, outcome.label(), transition.target.value))
            if transition.ahead is State.ORIENT and not self.ahead_started:
                self.orient_ahead()
            if state is State.BRING_UP:
                self.first_start = self.t()
            if state in (State.RETURN, State.RETURN_SAFE) and transition.policy is None:
                self._end_cycle()
                if until is not None and until(self.cycles):
                    break
        m = self.machine
        if m.state is State.STOPPED and m.cycle > len(self.cycles):
            # The cycle the cell stopped in: its time counts (lost), its part is neither good nor a reject.
            self._end_cycle(complete=False)
        return LoopResult(
            self.cycles,
            m.state.value if m.finished else "HORIZON",
            m.stop_reason,
            self.t() - (self.first_start if math.isfinite(self.first_start) else self.t()),
            {d: {k: n * QUANTUM for k, n in counts.items()} for d, counts in self.device_quanta.items()},
            self.failures,
            self.transitions,
        )

    def _end_cycle(self, complete: bool = True) -> None:
        m = self.machine.metrics
        seen0, handled0 = self._seen_at_cycle_start
        self.cycles.append(
            CycleRecord(
                len(self.cycles) + 1,
                m.last_cycle_time if complete else self.t() - self.machine.cycle_start,
                self.cycle_throws,
                self.cycle_presented,
                self.cycle_rejected,
                m.faults_seen - seen0,
                m.faults_handled - handled0,
                complete,
                self.t() - self.first_start,
                {d: dict(counts) for d, counts in self.device_quanta.items()},
                self.down_quanta,
            )
        )
        self._seen_at_cycle_start = (m.faults_seen, m.faults_handled)
        self.cycle_throws = self.cycle_presented = self.cycle_rejected = 0


def scene_loop(
    scene: Scene,
    replication: int = 0,
    overrides: dict[str, dict[str, Any]] | None = None,
    start_time: float = 0.0,
) -> CellLoop:
    """Return the loop of one replication of ``scene``, parameters overridden per executable."""
    overrides = overrides or {}
    parameters: dict[str, dict[str, Any]] = {}
    for node in scene.nodes:
        parameters[node.executable] = {**node.parameters, **overrides.get(node.executable, {})}
    arrivals = ArrivalStream(scene.arrivals, scene.seed, replication) if scene.arrivals is not None else None
    faults = tuple(scene.faults or ())  # by node name, as the controller's *_device parameters name them
    return CellLoop(
        {k: v for k, v in parameters.items() if k in DEVICES},
        parameters.get("cell_controller", {}),
        arrivals,
        faults,
        scene.seed,
        replication,
        start_time,
    )
