"""The ROS-free cell loop: the cell scene's devices, goal machines and controller machine on one clock.

One process, no rclpy, no DDS: the same models (``feeder_sim.throwing``, ``feeder_sim.mems``,
``feeder_sim.fixture``), the same goal machines (``FeedGoal``, ``ProgramGoal``, ``PathGoal``) and the same
controller machine (``CellMachine`` with its two tables) as the ROS cell, driven the way the cell clock's
lockstep drives them (docs/cell.md, docs/devices.md "Who drives the tick"):

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
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

import numpy as np

from feeder_cell.controller import CellMachine, Outcome, State
from feeder_cell.controller.fault_schedule import REPAIR_EARLY_S, FaultSchedule
from feeder_cell.controller.parameters import PARAMETERS as CONTROLLER_PARAMETERS
from feeder_cell.experiment.arrivals import ArrivalStream
from feeder_cell.experiment.faults_process import FaultEvent, FaultSpec
from feeder_device.declarations import ActiveFault
from feeder_planner.assembly import prepare
from feeder_planner.assembly.parameters import load_assembly_parameter
from feeder_planner.errors import FeederError, InputError
from feeder_planner.fields_io import load_yaml_mapping
from feeder_planner.mems import ProgramStep, field_from_mapping, program_from_mapping
from feeder_planner.parameter_specs import check_value, from_values, specs_of
from feeder_sim.fixture import Table, certify, plan_goal
from feeder_sim.fixture.follow import goal_waypoints
from feeder_sim.fixture.interlock import certifier
from feeder_sim.fixture.parameters import FixtureParameters, max_advance_per_tick, table_limits
from feeder_sim.fixture.path_goal import PathGoal, PathOutcome
from feeder_sim.mems.configure import configure_scene
from feeder_sim.mems.parameters import NANOSECONDS, MemsParameters, max_steps_per_tick
from feeder_sim.mems.program_goal import ProgramGoal
from feeder_sim.mems.settling import check_timeout, holding_start, settling_criterion
from feeder_sim.throwing import MAX_TICK_PERIODS, ArmFaults
from feeder_sim.throwing.cycle import ThrowCycle, ns
from feeder_sim.throwing.feeding import FeedGoal, check_feed_goal, rest_window_ns
from feeder_sim.throwing.parameters import ArmParameters, configure_arm

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

QUANTUM = 0.1  # s: the cell clock's lockstep quantum (feeder launch --quantum default)
DEVICE_STATES = ("RUNNING", "IDLE", "FAULT")
# The DeviceStatus fault codes the loop needs (feeder_msgs/msg/DeviceStatus.msg; the loop imports no ROS
# message): tests/experiment/test_loop.py checks they agree with the message's constants.
FAULT_MOTOR, FAULT_PART_LOST = 101, 102
FAULT_POWER_LOSS = 201
FAULT_AXIS_STALL, FAULT_RATE_LIMIT = 301, 302
FAULT_TIME_STEP = 203
# The controller's parameters: the node's own specs (feeder_cell.controller.parameters), defaults and checks.
CONTROLLER_SPECS = {spec.name: spec for spec in CONTROLLER_PARAMETERS}
# What the ROS side adds to every node (use_sim_time) and to the devices (the markers' parameters,
# node_kit.viz): accepted and not used.
ROS_ONLY = frozenset({"use_sim_time", "marker_rate", "cell_pose", "cell_frame"})


def controller_parameters(values: dict[str, Any]) -> dict[str, Any]:
    """Return the controller's parameters: its defaults overridden by ``values``, checked as the node does.

    A name it does not have, or a bad value, is an InputError naming ``cell_controller.parameters.NAME``.
    """
    merged = {name: spec.default for name, spec in CONTROLLER_SPECS.items()}
    for name, value in values.items():
        where = f"cell_controller.parameters.{name}"
        if name in ROS_ONLY:
            continue
        spec = CONTROLLER_SPECS.get(name)
        if spec is None:
            raise InputError(where, "is not a parameter of cell_controller")
        default = spec.default
        # rclpy refuses a value of another type than the declared one; say so here as one line.
        if isinstance(default, bool) != isinstance(value, bool) or (
            isinstance(default, (int, float)) and not isinstance(value, (int, float))
        ):
            raise InputError(where, f"must be like {default!r}, got {value!r}")
        if isinstance(default, int) and not isinstance(default, bool) and not isinstance(value, int):
            raise InputError(where, f"must be an integer, got {value!r}")
        if isinstance(default, str) and not isinstance(value, str):
            raise InputError(where, f"must be a string, got {value!r}")
        try:
            check_value(spec, value)
        except InputError as error:
            raise InputError(where, error.problem) from None
        merged[name] = value
    if merged.get("orienter", "mems") != "mems":
        # The squeeze gripper as the orienting station has no model in the loop yet.
        raise InputError(
            "cell_controller.parameters.orienter",
            f"the cell loop runs the MEMS array's ORIENT only, got {merged['orienter']!r}",
        )
    return merged


def _device_parameters(cls: type, values: dict[str, Any], node: str) -> Any:
    """Return a device's typed parameters, each checked as the node's configure checks it."""
    specs = {spec.name: spec for spec in specs_of(cls)}
    merged = {name: spec.default for name, spec in specs.items()}
    for name, value in values.items():
        if name not in specs and name not in ROS_ONLY:
            raise InputError(f"{node}.parameters.{name}", f"is not a parameter of {node}")
        if name in specs:
            merged[name] = value
    merged["lockstep"], merged["real_time_factor"] = True, 0.0
    for name, spec in specs.items():
        try:
            check_value(spec, merged[name])
        except InputError as error:
            raise InputError(
                f"{node}.{error.field.replace('parameter ', 'parameters.')}", error.problem
            ) from None
    return from_values(cls, merged)


@dataclass
class CycleRecord:
    """One finished cycle: its cell time (s), the throws its feeds used, parts good and rejected, faults."""

    cycle: int
    time: float
    throws: int
    presented: int
    rejected: int
    faults_seen: int
    faults_handled: int
    complete: bool = True  # False: the cell stopped in this cycle (time: until the stop)
    end: float = 0.0  # s from the first cycle's start to this cycle's end
    # Cumulative since the first cycle's start, at this cycle's end: quanta per device and state, and
    # quanta the cell was down (a device in FAULT, or the controller in RECOVER).
    device_quanta: dict[str, dict[str, int]] = field(default_factory=dict)
    down_quanta: int = 0


@dataclass
class LoopResult:
    """What one replication did: its cycles, how it ended, each device's time per state, the failures."""

    cycles: list[CycleRecord]
    end_state: str
    stop_reason: str
    cell_time: float  # s from the first cycle's start to the end
    device_time: dict[str, dict[str, float]]  # device -> state -> s
    failures: list[FaultEvent]  # injected
    transitions: list[tuple[float, str, str, str]] = field(default_factory=list)  # (t, from, outcome, to)


# --- the devices ------------------------------------------------------------------------------------------
class _Device:
    """What the kit does for every device: the tick grid, elapsed time, faults, stop, goal start."""

    name = ""
    rate = 20.0

    def __init__(self, origin_ns: int) -> None:
        self.origin_ns = origin_ns
        self.index = 0
        self.last_advance_ns = origin_ns
        self.faults: dict[str, ActiveFault] = {}
        self.model_fault: tuple[int, str] | None = None
        self.stopped = False
        self.pending_goal: Any = None  # accepted, starts after the next tick
        self.goal: Any = None

    def elapsed_ns(self, now_ns: int) -> int:
        elapsed = max(0, now_ns - self.last_advance_ns)
        self.last_advance_ns = now_ns
        return elapsed

    def stopping_fault(self) -> tuple[int, str] | None:
        if self.model_fault is not None:
            return self.model_fault
        for fault in self.faults.values():
            if fault.spec.stops_device:
                return fault.spec.code, f"injected fault {fault.label}: {fault.spec.description}"
        return None

    def ready(self) -> bool:
        return self.stopping_fault() is None and not self.stopped

    def state(self) -> str:
        if self.stopping_fault() is not None:
            return "FAULT"
        return "RUNNING" if self.goal is not None or self.busy() else "IDLE"

    def busy(self) -> bool:
        return False

    def advance(self, now_ns: int) -> None:
        """Tick every instant of the grid up to ``now_ns``; then start an accepted goal (at ``now_ns``)."""
        while (instant := self.origin_ns + round((self.index + 1) * 1e9 / self.rate)) <= now_ns:
            self.index += 1
            self.tick(instant)
            if self.goal is not None and not self.goal_done():
                self.advance_goal(instant)
        if self.pending_goal is not None:
            start, self.pending_goal = self.pending_goal, None
            start(now_ns)

    def goal_done(self) -> bool:
        raise NotImplementedError

    def advance_goal(self, now_ns: int) -> None:
        raise NotImplementedError

    def tick(self, now_ns: int) -> None:
        raise NotImplementedError

    def inject(self, spec: FaultSpec, clear: bool, seed: int, faults: Any) -> None:
        """~/inject_fault with ``spec``'s fault, value and state (or its clear), as the kit does."""
        if clear:
            if spec.fault in self.faults:
                self.clear_fault(spec.fault)
                del self.faults[spec.fault]
            return
        fault = ActiveFault(faults[spec.fault], float(spec.value), bool(spec.state), (), 0.0, seed)
        self.apply_fault(fault)
        self.faults[spec.fault] = fault

    def reset(self) -> None:
        """~/reset: every fault cleared, stop ended, the device's own reset."""
        for name in list(self.faults):
            self.clear_fault(name)
        self.faults.clear()
        self.model_fault = None
        self.stopped = False
        self.reset_device()

    def apply_fault(self, fault: ActiveFault) -> None:
        raise NotImplementedError

    def clear_fault(self, name: str) -> None:
        raise NotImplementedError

    def reset_device(self) -> None:
        """Nothing beyond the kit's reset."""


class _Arm(_Device):
    name = "throwing_arm"

    def __init__(self, p: ArmParameters, origin_ns: int) -> None:
        super().__init__(origin_ns)
        self.p = p
        self.rate = float(p.sensor_rate)
        self.arm = configure_arm(p)
        self.cycle = ThrowCycle(self.arm, ArmFaults(self.arm))
        self.cycle.running = bool(p.autostart)
        self.simulated = origin_ns
        self.throws = 0
        self.goal: FeedGoal[None] | None = None
        self._rest_key: tuple[Any, ...] | None = None
        self._rest_bit = False

    def busy(self) -> bool:
        return self.cycle.busy

    def ground_truth(self) -> tuple[int, float]:
        return self.arm.ground_truth()

    def tick(self, now_ns: int) -> None:
        """Take the node's tick (nodes/throwing_arm.py) without the streams."""
        cycle, p = self.cycle, self.p
        self.simulated += min(self.elapsed_ns(now_ns), ns(MAX_TICK_PERIODS / p.sensor_rate))
        t = self.simulated
        in_flight = cycle.motion is not None
        shown = cycle.show(t, ns(p.period * p.motion_fraction))
        feed = self.goal if self.goal is not None and not self.goal.done else None
        if shown.landed is not None:
            if feed is not None:
                feed.landed(now_ns, *self.ground_truth(), None)
        elif not in_flight:
            wants = feed is not None and feed.wants_throw(now_ns)
            if cycle.throw_due(t, ns(p.period), wants, self.ready()):
                outcome = cycle.throw(t)
                self.throws += 1
                if feed is not None:
                    feed.throw_started()
                if outcome.kind == "fault":
                    self.model_fault = (FAULT_PART_LOST, f"throw {self.throws}: {outcome.fault}")
        pose = None if cycle.motion is None else shown.pose
        delivered = cycle.faults.sensor(self._reading(pose))
        if pose is None and feed is not None:
            feed.sample(delivered)

    def _reading(self, pose: tuple[float, float, float] | None) -> bool:
        """Return the true sensor bit; at rest from a cache (the same bit while the part lies still).

        At rest the bit depends only on the part, its edge and R and the sensor's place: the node computes
        it again every tick (100 Hz), a quarter of the loop's time; the faults still see every sample.
        """
        p, arm = self.p, self.arm
        if pose is not None:
            return arm.sensor(p.sensor_radius, p.sensing_height, pose)
        key = (id(arm.part), arm.on_arm, arm.edge, arm.radius, p.sensor_radius, p.sensing_height)
        if self._rest_key != key:
            self._rest_key, self._rest_bit = key, arm.sensor(p.sensor_radius, p.sensing_height)
        return self._rest_bit

    def goal_done(self) -> bool:
        return self.goal is None or self.goal.done

    def advance_goal(self, now_ns: int) -> None:
        assert self.goal is not None
        self.goal.tick(now_ns, self.stopping_fault(), self.cycle.motion is not None)

    def send_feed(self, max_throws: int, timeout: float) -> None:
        request = check_feed_goal(max_throws, timeout)
        window = rest_window_ns(self.p.period, self.p.motion_fraction, self.p.sensor_rate)

        def start(now_ns: int) -> None:
            self.goal = FeedGoal(request, now_ns, window, *self.ground_truth())

        self.pending_goal = start

    def place(self, edge: int, radius: float) -> None:
        """~/place_part: accepted when ready or in FAULT from a part lost only (arm_parts.py)."""
        others = [f for f in self.faults.values() if f.spec.stops_device and f.spec.name != "part_lost"]
        fault = self.stopping_fault()
        lost_only = fault is not None and fault[0] == FAULT_PART_LOST and not others
        if not (lost_only and not self.stopped) and not self.ready():
            raise FeederError(f"place_part refused: {self.name} is in FAULT: {fault[1] if fault else ''}")
        self.cycle.place(edge, radius, self.p.arm_length)
        self.faults.pop("part_lost", None)
        self.model_fault = None

    def apply_fault(self, fault: ActiveFault) -> None:
        self.cycle.faults.inject(fault.spec.name, fault.value, fault.state, fault.indices, fault.seed)
        if fault.spec.stops_device:
            self.cycle.cancel_commands()
        if fault.spec.name == "part_lost":
            self.cycle.motion = None

    def clear_fault(self, name: str) -> None:
        self.cycle.faults.clear(name)
        self._require_part_again()

    def reset_device(self) -> None:
        self.cycle.cancel_commands()
        self._require_part_again()

    def _require_part_again(self) -> None:
        if self.arm.faulted and self.model_fault is None:
            self.model_fault = (FAULT_PART_LOST, f"{self.arm.faulted} (~/place_part puts it back)")


class _Mems(_Device):
    name = "mems_field_array"

    def __init__(self, p: MemsParameters, origin_ns: int) -> None:
        super().__init__(origin_ns)
        self.p = p
        self.rate = float(p.publish_rate)
        configured = configure_scene(p)
        self.scene, self.parts = configured.scene, configured.parts()
        self.step_ns = int(round(p.time_step * NANOSECONDS))
        self.owed_ns = 0
        self.goal: ProgramGoal | None = None

    def busy(self) -> bool:
        scene = self.scene
        if not scene.switched_on or scene.faults.power_loss:
            return False
        return not scene.on_last_step() or not all(scene.settled())

    def tick(self, now_ns: int) -> None:
        self.owed_ns += self.elapsed_ns(now_ns)
        steps, self.owed_ns = divmod(self.owed_ns, self.step_ns)
        steps = min(steps, max_steps_per_tick(self.p, self.step_ns))
        dt = float(self.p.time_step)
        for _ in range(steps):
            self.scene.step(dt)

    def goal_done(self) -> bool:
        return self.goal is None or self.goal.done

    def stiff_warning(self) -> tuple[int, str] | None:
        why = self.scene.stiffness_warning(float(self.p.time_step))
        return (FAULT_TIME_STEP, why) if why else None

    def advance_goal(self, now_ns: int) -> None:
        assert self.goal is not None
        self.goal.advance(now_ns, self.stopping_fault(), self.stopped, self.stiff_warning())

    def send_program(
        self, program: tuple[ProgramStep, ...], timeout: float, tolerance: float, dwell: float
    ) -> None:
        criterion = settling_criterion(tolerance, dwell)
        timeout = check_timeout(timeout)

        def start(now_ns: int) -> None:
            self.scene.set_program(program)
            names = self.parts.names
            self.goal = ProgramGoal(self.scene, names, criterion, timeout, now_ns, holding_start(program))

        self.pending_goal = start

    def place_reset(self) -> None:
        if not self.ready():
            raise FeederError(f"place_parts refused: {self.name} is not ready")
        self.parts.reset()

    def place(self, poses: tuple[tuple[float, float, float], ...]) -> None:
        from feeder_sim.mems.placing import place_parts, placement_reach

        if not self.ready():
            raise FeederError(f"place_parts refused: {self.name} is not ready")
        reach = placement_reach(self.p.array_size, float(self.p.pitch))
        names = list(self.parts.names)
        columns = ([p[0] for p in poses], [p[1] for p in poses], [p[2] for p in poses])
        place_parts(self.scene, names, (names, *columns), reach)

    def apply_fault(self, fault: ActiveFault) -> None:
        self.scene.inject_fault(
            fault.spec.name,
            value=fault.value,
            indices=fault.indices,
            angle=fault.angle,
            seed=fault.seed,
            cells=self.p.array_size,
        )

    def clear_fault(self, name: str) -> None:
        self.scene.set_faults(self.scene.faults.without(name))

    def reset_device(self) -> None:
        self.scene.switched_on = True
        self.scene.set_program(self.scene.program)


class _Fixture(_Device):
    name = "assembly_fixture"

    def __init__(self, p: FixtureParameters, origin_ns: int) -> None:
        super().__init__(origin_ns)
        self.p = p
        self.rate = float(p.publish_rate)
        self.limits = table_limits(p)
        assembly = load_assembly_parameter(p.assembly_file)
        self.prepared = prepare(assembly, p.mu if p.override_mu else None, p.facets)
        self.table = Table(np.array([p.initial_tilt_x, p.initial_tilt_y], float), self.limits)
        self.stalls = 0
        self.goal: PathGoal | None = None
        self.early: PathOutcome | None = None

    def busy(self) -> bool:
        return self.table.moving

    def _advance_to(self, now_ns: int) -> None:
        elapsed = min(self.elapsed_ns(now_ns) / NANOSECONDS, max_advance_per_tick(self.p))
        stall = self.table.advance(elapsed)
        if stall is not None:
            self.stalls += 1
            self.model_fault = (FAULT_AXIS_STALL, stall.describe())

    def tick(self, now_ns: int) -> None:
        self._advance_to(now_ns)

    def goal_done(self) -> bool:
        return self.goal is None or self.goal.done

    def advance_goal(self, now_ns: int) -> None:
        assert self.goal is not None
        every = max(1, math.ceil(float(self.p.publish_rate) / float(self.p.feedback_rate) - 1e-9))
        try:
            self.goal.advance(self.stopping_fault(), self.stopped, self.stalls, every, True)
        except FeederError as error:
            self.goal.table.halt()
            self.goal.end("FAULT", f"not certified: {error}; the table halted")

    def send_path(self, gravity: list[tuple[float, float, float]]) -> None:
        waypoints = goal_waypoints(gravity, [], self.limits)
        plan_goal(self.table, waypoints, self.p.path_step)  # the goal-time check (raises naming the field)

        def start(now_ns: int) -> None:
            self.goal, self.early = None, None
            if not self.ready():
                self.early = PathOutcome("FAULT", f"not started: {self.name} is not ready")
                return
            self._advance_to(now_ns)
            planned = plan_goal(self.table, waypoints, self.p.path_step)
            verdict = certify(self.prepared, planned.samples)
            if not verdict.stable and self.p.interlock:
                self.early = PathOutcome("REFUSED", f"refused by the interlock: {verdict.problem()}")
                return
            warning = "" if verdict.stable else f"interlock off, moving anyway: {verdict.problem()}"
            certified = certifier(self.prepared, planned.samples, verdict)
            self.goal = PathGoal(
                self.table, planned, verdict, waypoints, warning, self.stalls, certified, FAULT_AXIS_STALL
            )
            self.table.start(planned.path)

        self.pending_goal = start

    def apply_fault(self, fault: ActiveFault) -> None:
        self.table.faults.inject(
            fault.spec.name,
            self.limits,
            value=fault.value,
            indices=fault.indices,
            angle=fault.angle,
            seed=fault.seed,
        )

    def clear_fault(self, name: str) -> None:
        self.table.faults.clear(name)
        if name == "axis_stall" and self.model_fault is not None and self.model_fault[0] == FAULT_AXIS_STALL:
            self.model_fault = None

    def reset_device(self) -> None:
        """Nothing beyond the kit's reset (the node's reset_device is the kit's default)."""


# --- the loop ---------------------------------------------------------------------------------------------
def _fault_specs_of(device: str) -> Any:
    """Return the device's FaultSpecs by name (the kit's, with the codes the node hands in)."""
    if device == "throwing_arm":
        from feeder_sim.throwing.fault_specs import fault_specs as arm_specs

        return arm_specs({"motor_fault": FAULT_MOTOR, "part_lost": FAULT_PART_LOST})
    if device == "mems_field_array":
        from feeder_sim.mems.fault_specs import fault_specs as mems_specs

        return mems_specs({"power_loss": FAULT_POWER_LOSS})
    from feeder_sim.fixture.fault_specs import fault_specs as fixture_specs

    return fixture_specs({"axis_stall": FAULT_AXIS_STALL, "rate_limit": FAULT_RATE_LIMIT})


class CellLoop:
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
        self.arm = _Arm(
            _device_parameters(ArmParameters, devices.get("throwing_arm", {}), "throwing_arm"), origin
        )
        self.mems = _Mems(
            _device_parameters(MemsParameters, devices.get("mems_field_array", {}), "mems_field_array"),
            origin,
        )
        self.fixture = _Fixture(
            _device_parameters(FixtureParameters, devices.get("assembly_fixture", {}), "assembly_fixture"),
            origin,
        )
        self.by_key: dict[str, _Device] = {"mems": self.mems, "arm": self.arm, "fixture": self.fixture}
        self.by_name: dict[str, _Device] = {d.name: d for d in self.by_key.values()}
        self.machine = CellMachine(cycles=int(self.c["cycles"]), max_retries=int(self.c["max_retries"]))
        self.program = self._program()
        self.arrivals = arrivals
        self.seed, self.replication = seed, replication
        # The node names the controller drives (its *_device parameters), as the fault processes name them.
        self.node_of = {key: str(self.c[f"{key}_device"]).rsplit("/", 1)[-1] for key in self.by_key}
        self.by_node = {self.node_of[key]: device for key, device in self.by_key.items()}
        self.schedule = FaultSchedule(faults, seed, replication)
        self.failures: list[FaultEvent] = []
        self.fault_tables = {
            s.device: _fault_specs_of(self.by_node[s.device].name) for s in faults if s.device in self.by_node
        }
        # Quanta per device and state (counted, not summed: no rounding drift over thousands of cycles).
        self.device_quanta = {d.name: dict.fromkeys(DEVICE_STATES, 0) for d in self.by_key.values()}
        self.down_quanta = 0
        self.stood = np.array(self.c["fixture_home"][-3:], float)
        self.cycle_throws = 0
        self.cycle_presented = 0
        self.cycle_rejected = 0
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
        self._inject_due()

    def _wait(self, done: Any, timeout: float) -> bool:
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

    # --- the work of each state -----------------------------------------------------------------------------
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

    @staticmethod
    def _route(flat: list[float]) -> list[tuple[float, float, float]]:
        return [(float(flat[i]), float(flat[i + 1]), float(flat[i + 2])) for i in range(0, len(flat), 3)]

    def orient(self) -> Outcome:
        """Place a new batch (drawn poses with arrivals) and run the program until every part settled."""
        mems = self.mems
        try:
            if self.c["new_batch"] and self.machine.attempts == 0:
                mems.place_reset()
            arrivals = self.arrivals
            if arrivals is not None and arrivals.arrivals.mems is not None and self.machine.attempts == 0:
                mems.place(arrivals.mems(self.machine.cycle, len(mems.parts.names)))
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
        bound = float(self.c["orient_timeout"]) + float(self.c["step_timeout"])
        if not self._wait(lambda: mems.goal is not None and mems.goal.done, bound):
            return Outcome("NO_ANSWER", 0, "run_program: no result within the step's bound")
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
        device: _Device = self.by_key[key]
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
    def _refusal(device: _Device, message: str) -> Outcome:
        fault = device.stopping_fault()
        if fault is not None:
            return Outcome("FAULT", fault[0], f"{fault[1]} ({message})")
        return Outcome("ERROR", 0, message)


DEVICES = ("mems_field_array", "throwing_arm", "assembly_fixture")
PARAMETER_CLASSES: dict[str, type] = {
    "mems_field_array": MemsParameters,
    "throwing_arm": ArmParameters,
    "assembly_fixture": FixtureParameters,
}


def read_scene(path: str | Path) -> Scene:
    """Read and check a cell scene for the loop (no node module imported: no rclpy); errors name the field."""
    from feeder_cell.launcher import scene_from_mapping

    try:
        return check_scene(scene_from_mapping(load_yaml_mapping(path), Path(path).resolve().parent))
    except InputError as error:
        raise error.with_source(str(path)) from None


def check_scene(scene: Scene) -> Scene:
    """Check a parsed scene for the loop; return it.

    The scene must hold the three devices and the reference controller (by executable, as
    ``feeder_cell/scenes/cell.yaml``); other nodes (the planners) are what the loop computes itself. Each
    device's and the controller's parameters are checked as their nodes check them (not through the
    launcher's check, which imports the node modules and with them rclpy). A ``faults:`` entry must name
    one of the three devices and a fault it knows.
    """
    for node in scene.nodes:
        if node.executable in DEVICES:
            _device_parameters(PARAMETER_CLASSES[node.executable], node.parameters, node.executable)
        elif node.executable == "cell_controller":
            controller_parameters(node.parameters)
    executables = {n.executable for n in scene.nodes}
    for needed in (*DEVICES, "cell_controller"):
        if needed not in executables:
            have = ", ".join(sorted(executables))
            raise InputError("nodes", f"the cell loop needs a {needed} node; the scene has {have}")
    by_name = {n.node_name: n.executable for n in scene.nodes}
    for spec in scene.faults or ():
        executable = by_name.get(spec.device, "")
        if executable not in DEVICES:
            devices = ", ".join(DEVICES)
            raise InputError(f"faults.{spec.device}", f"is not a device of the cell loop ({devices})")
        known = _fault_specs_of(executable)
        if spec.fault not in known:
            raise InputError(
                f"faults.{spec.device}.fault",
                f"unknown fault {spec.fault!r}; {executable} knows {', '.join(sorted(known))}",
            )
    return scene


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
