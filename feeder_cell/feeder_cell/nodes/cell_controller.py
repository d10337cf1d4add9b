"""ROS 2 node: the reference cell controller, the example a user copies to drive the feeder cell.

Written only against standard ROS 2 client interfaces: the devices' lifecycle services, their action
servers (``~/run_program`` or ``~/run_plan``, ``~/feed_part``, ``~/follow_path``), their services
(``~/place_parts``, ``~/place_part``, ``~/reset``), their latched ``~/status`` and ``/diagnostics``, the
region planner's ``~/safe_path`` and, orienting on the squeeze gripper (``orienter: squeeze``), the squeeze
planner's ``~/plan``. It imports no device or planner node: swap the simulators for hardware with the same
interfaces and it runs unchanged. Device names are relative, so the controller moves with its namespace
(started in ``/cell`` it drives ``/cell/throwing_arm``...).

The cycle and the fault policy are the ROS-free ``feeder_cell.controller.CellMachine`` (two tables you
can read in one screen); this node performs the work of each state and hands the machine the outcome.
Every wait is bounded twice: on the node clock (``step_timeout``, so a bound scales with the cell clock's
real-time factor) and on the wall clock (``wall_timeout``, so a held ``/clock`` cannot hang it).

Threads: rclpy spins on a background thread (answers, results, status messages); the cycle runs as a
plain loop in the main thread and waits on futures. That keeps the cycle readable top to bottom.

Stopping: SIGINT and SIGTERM only complete a stop request (``node_kit.runner.StopRequest``, as for every
other node); the context stays valid, so no call in flight fails under the main thread. Every wait looks at
the request (``stopping``) and ends the cycle with ShutdownError; the clean-up then publishes the last
status, leaves the lockstep and destroys the node on the main thread alone. Exit 0, whichever phase the
signal came in (construction, bring-up, a cycle, the clean-up).

Lockstep (``lockstep: true``, which ``feeder launch --real-time-factor`` sets): the controller is a react
participant of the cell clock (``feeder_planner.node_kit.lockstep``). Its cycle starts at the first
``/lockstep/settled`` time and holds the clock while it works; a wait for a result lets the clock go
one quantum at a time and looks again once every device has ticked it. Service calls and goal
acceptances are answered within the quantum. So every decision happens at a defined cell time.
"""

from __future__ import annotations

import math
import sys
import threading
import time
from typing import Any, Callable

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Vector3
from rclpy.clock import Clock, ClockType
from rclpy.executors import ExternalShutdownException, ShutdownException, SingleThreadedExecutor
from rclpy.impl.implementation_singleton import rclpy_implementation
from rclpy.node import Node
from rclpy.task import Future
from std_srvs.srv import Trigger

from feeder_cell.controller import CellMachine, Outcome, State, Transition
from feeder_cell.controller.fault_schedule import REPAIR_EARLY_S, FaultAction, FaultSchedule
from feeder_cell.controller.parameters import PARAMETERS
from feeder_cell.controller.reporting import cell_status, diagnostic_entry
from feeder_cell.experiment.arrivals import ArrivalStream, scene_arrivals, scene_seed
from feeder_cell.experiment.faults_process import scene_faults
from feeder_cell.lifecycle_client import LifecycleClient, LifecycleError, LifecycleInterruptedError
from feeder_msgs.action import FeedPart, FollowPath, RunPlan, RunProgram
from feeder_msgs.msg import CellStatus, DeviceStatus, FieldProgram, FieldSpec, MemsParts, SqueezeState
from feeder_msgs.msg import Part as PartMsg
from feeder_msgs.srv import (
    ArmPlacePart,
    InjectFault,
    MemsPlaceParts,
    SqueezePlacePart,
    SqueezePlanCompute,
    StablePath,
)
from feeder_planner.errors import FeederError, InputError
from feeder_planner.fields_io import load_yaml_mapping
from feeder_planner.mems import program_from_mapping
from feeder_planner.node_kit import (
    LATCHED,
    STREAM_DEPTH,
    declare_parameters,
)
from feeder_planner.node_kit.action_client import ActionClient
from feeder_planner.node_kit.lockstep import Participant
from feeder_planner.node_kit.msg_fields import fill_field_spec
from feeder_planner.node_kit.msg_parts import part_from_msg, part_to_msg
from feeder_planner.node_kit.runner import StopRequest, build_node, profiled
from feeder_planner.parts import load_part
from feeder_planner.throwing.geometry import arm_part

__all__ = ["PARAMETERS", "CellController", "main"]

NODE_NAME = "cell_controller"
HEARTBEAT_RATE = 1.0  # Hz (steady clock) of ~/status and /diagnostics besides every transition
POLL_S = 0.02  # wall seconds between looks at a pending future

PLAN_CALLS = 3  # a fresh server may drop its first reply: the plan request is idempotent, sent again
# A transition refused while another client moves the same device is looked at again after a moment.
BRING_UP_ATTEMPTS, BRING_UP_SETTLE_S = 3, 0.5
EXIT_FINISHED, EXIT_STOPPED = 0, 1  # a bad parameter exits 2 (node_kit.runner.build_node)
EXIT_SHUT_DOWN = 0  # Ctrl-C or SIGTERM: a clean end for a ROS node, whatever state the cell was in


class ShutdownError(FeederError):
    """The node is shutting down (Ctrl-C): the cycle ends where it is."""


class CellController(Node):
    """Bring the cell up, run production cycles, handle faults by the machine's policy, report."""

    def __init__(self, stop: StopRequest | None = None) -> None:
        super().__init__(NODE_NAME)
        self.stop_request = stop
        self.p = declare_parameters(self, PARAMETERS)
        if self.p["policy"] != "sequential":
            raise InputError("parameter policy", f"{self.p['policy']} runs in the ROS-free loop only, so far")
        for name in ("fixture_route", "fixture_home"):
            self.p[name] = [float(v) for v in self.p[name]]
        # The orienting station ORIENT commands: the MEMS array ("mems") or the squeeze gripper ("squeeze").
        self.orienter: str = self.p["orienter"]
        squeezing = self.orienter == "squeeze"
        self.program = self._program()
        self.squeeze_part = self._squeeze_part() if squeezing else None
        self.arrivals = self._arrivals()
        self.faults = self._fault_schedule()
        self.machine = CellMachine(
            cycles=self.p["cycles"], max_retries=self.p["max_retries"], orienter=self.orienter
        )
        self.devices = {
            self.orienter: self.p["squeeze_device" if squeezing else "mems_device"],
            "arm": self.p["arm_device"],
            "fixture": self.p["fixture_device"],
        }
        planner = self.p["region_planner"]
        # Latest status per device (latched: the current one arrives at once) and diagnostics values.
        self.status: dict[str, DeviceStatus] = {}
        self.diagnostics: dict[str, dict[str, str]] = {}
        for key, name in self.devices.items():
            self.create_subscription(DeviceStatus, f"{name}/status", self._status_callback(key), LATCHED)
        self.create_subscription(DiagnosticArray, "/diagnostics", self._on_diagnostics, 10)
        # What the arrivals need of the devices: the names of the array's parts, the arm's part.
        self.mems_names: list[str] | None = None
        self.arm_part: PartMsg | None = None
        if self.arrivals is not None:
            if not squeezing:
                self.create_subscription(
                    MemsParts, f"{self.devices['mems']}/parts", self._on_mems_parts, LATCHED
                )
            self.create_subscription(PartMsg, f"{self.devices['arm']}/part", self._on_arm_part, LATCHED)
        # Every client is made once, here: a server must discover a client before it can answer it. The
        # orienting station's clients are made for the station the cell has. The MEMS cell's entities are
        # made in the order they always were: a fault process's injection is sent without waiting, and
        # the executor's order of ready entities decides which quantum it lands in (tests/experiment/
        # test_loop_equivalence_ros measured a 0.1 s shorter cycle with the order changed).
        station = self.devices[self.orienter]
        self.run_program = None if squeezing else ActionClient(self, RunProgram, f"{station}/run_program")
        self.feed_part = ActionClient(self, FeedPart, f"{self.devices['arm']}/feed_part")
        self.follow_path = ActionClient(self, FollowPath, f"{self.devices['fixture']}/follow_path")
        self.place_parts = None if squeezing else self.create_client(MemsPlaceParts, f"{station}/place_parts")
        self.place_part = self.create_client(ArmPlacePart, f"{self.devices['arm']}/place_part")
        self.resets = {k: self.create_client(Trigger, f"{n}/reset") for k, n in self.devices.items()}
        self.safe_path = self.create_client(StablePath, f"{planner}/safe_path")
        # Fault processes: each device's failures are injected through its ~/inject_fault.
        self.injections = {
            s.device: self.create_client(InjectFault, f"{s.device}/inject_fault") for s in self.faults.specs
        }
        self.lifecycle = {
            k: LifecycleClient(self, None, n, keep_going=lambda: not self.stopping())
            for k, n in self.devices.items()
        }
        # The squeeze gripper and its planner (orienter: squeeze).
        self.run_plan = ActionClient(self, RunPlan, f"{station}/run_plan") if squeezing else None
        self.squeeze_place = (
            self.create_client(SqueezePlacePart, f"{station}/place_part") if squeezing else None
        )
        self.squeeze_planner = (
            self.create_client(SqueezePlanCompute, f"{self.p['squeeze_planner']}/plan") if squeezing else None
        )
        self.plan_angles: list[float] | None = None  # the squeeze planner's plan, asked for once
        self.plan_answer: SqueezePlanCompute.Response | None = None
        # After a reset the gripper opens its jaws before it takes a part: RECOVER waits for a ~/state
        # stamped after the reset that says IDLE, (after ns, completed by it).
        self.jaws_open: tuple[int, Future] | None = None
        if squeezing:
            self.create_subscription(SqueezeState, f"{station}/state", self._on_squeeze_state, STREAM_DEPTH)
        self.status_pub = self.create_publisher(CellStatus, "~/status", LATCHED)
        self.diagnostics_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(1.0 / HEARTBEAT_RATE, self._heartbeat, clock=steady)
        self.last: Transition | None = None
        self.stood = Vector3()  # where the fixture stands (gravity), from its last follow_path result
        self.safe: list[Vector3] = []  # the planner's last path
        self.throws = 0  # throws the feeds of this cycle used
        self.squeezes = 0  # squeezes the gripper's plans of this cycle completed
        self.step_times: dict[str, float] = {}  # s of node clock per state in this cycle
        # Lockstep: the cell time whose decisions are being made (the last /lockstep/settled taken in).
        self.lockstep = Participant(self, "react", hold=True) if self.p["lockstep"] else None
        if self.lockstep is not None:
            self.lockstep.on_first = self.publish_status
        self.settled_ns = -1
        self.last_status: CellStatus | None = None
        self.publish_status()

    # --- the cycle ------------------------------------------------------------------------------
    def hosted_work(self, stop: StopRequest) -> int:
        """Run the cycles and end as ``exit_when_done`` says; return the exit code.

        On the thread ``main`` keeps for it, or the cell host's (``feeder_cell.host``): there the controller
        reacts by direct calls to the hosted clock (its participant joins the clock's hub), its requests to
        the devices still go through their services.
        """
        self.stop_request = stop
        code = self.run()
        if self.lockstep is not None:
            self.lockstep.leave()  # the clock goes on without a controller that has stopped deciding
        if not self.p["exit_when_done"]:
            while not self.stopping():  # keep serving the latched status until Ctrl-C
                time.sleep(POLL_S)
            code = EXIT_SHUT_DOWN
        return code

    def run(self) -> int:
        """Run the machine to its end; return the exit code (0 FINISHED or shut down, 1 STOPPED)."""
        work = {
            State.BRING_UP: self.bring_up,
            State.ORIENT: self.squeeze if self.orienter == "squeeze" else self.orient,
            State.INFEED: self.infeed,
            State.FEED: self.feed,
            State.TILT: lambda: self.tilt(self._route(self.p["fixture_route"])),
            State.PLAN_TILT: lambda: self.plan(self._route(self.p["fixture_route"])[-1]),
            State.TILT_SAFE: lambda: self.tilt(self.safe),
            State.RETURN: lambda: self.tilt(self._route(self.p["fixture_home"])),
            State.PLAN_RETURN: lambda: self.plan(self._route(self.p["fixture_home"])[-1]),
            State.RETURN_SAFE: lambda: self.tilt(self.safe),
            State.RECOVER: self.recover,
        }
        try:
            if self.lockstep is not None:
                self.settled_ns = self.lockstep.wait_announcement(-1, self.p["wall_timeout"], self.stopping)
                self._check_stop()
                if self.settled_ns < 0:
                    self.on_transition(self.machine.stop("the lockstep cell clock never settled a time"))
                    return EXIT_STOPPED
            while not self.machine.finished:
                self._check_stop()
                self._inject_due()
                state, started = self.machine.state, self.now()
                outcome = work[state]()
                self.step_times[state.value] = self.step_times.get(state.value, 0.0) + self.now() - started
                self.on_transition(self.machine.advance(outcome, self.now()))
        except ShutdownError:
            # A requested shutdown (Ctrl-C, SIGTERM) is a clean end for a ROS node: exit 0, as every
            # other node does; 1 is kept for a cell that stopped on its own (a fault, a spent budget).
            self.on_transition(self.machine.stop("the controller was shut down"))
            return EXIT_SHUT_DOWN
        return EXIT_FINISHED if self.machine.state is State.FINISHED else EXIT_STOPPED

    def on_transition(self, t: Transition) -> None:
        """Log the transition (a cycle in one line), publish the status."""
        self.last = t
        log = self.get_logger()
        m = self.machine.metrics
        if t.source in (State.RETURN, State.RETURN_SAFE) and t.policy is None:
            steps = " ".join(f"{k.lower()} {v:.1f}" for k, v in self.step_times.items() if k != "BRING_UP")
            squeezes = f", {self.squeezes} squeezes" if self.orienter == "squeeze" else ""
            log.info(
                f"cycle {self.machine.cycle - (t.target is State.ORIENT)}: {m.last_cycle_time:.2f} s "
                f"({steps}), {self.throws} throws{squeezes}; {m.cycles_completed} cycles, "
                f"{m.parts_presented} parts, "
                f"{m.parts_per_minute(self.now()):.2f} parts/min, faults seen {m.faults_seen} handled "
                f"{m.faults_handled}, reroutes {m.reroutes}"
            )
            self.throws, self.squeezes, self.step_times = 0, 0, {}
        elif t.policy is not None and t.target is not State.STOPPED:
            log.warning(f"{t.source.value}: {t.outcome.label()} -> {t.policy.value}: {t.note}")
        elif t.target is State.STOPPED:
            log.error(f"cell STOPPED: {self.machine.stop_reason}")
        elif t.note:
            log.info(f"{t.source.value} -> {t.target.value}: {t.note}")
        if t.target is State.FINISHED:
            log.info(f"cell FINISHED: {m.cycles_completed} cycles, {m.parts_presented} parts")
        self.publish_status()

    # --- the work of each state -------------------------------------------------------------------
    def bring_up(self) -> Outcome:
        """Configure and activate each device (one already active is left so); wait until it is ready."""
        if not self.p["bring_up"]:
            return self._all_ready()
        for key, client in self.lifecycle.items():
            for attempt in range(BRING_UP_ATTEMPTS):
                try:
                    client.bring_to("active")
                    break
                except LifecycleInterruptedError:
                    raise ShutdownError("shutdown") from None
                except LifecycleError as error:
                    # Someone else (a launcher, an operator) may be moving the same device: look again.
                    if attempt + 1 < BRING_UP_ATTEMPTS and self._moved_elsewhere(client):
                        continue
                    status = self.status.get(key)
                    why = status.fault_text if status is not None and status.fault_text else ""
                    message = f"{error}{': ' + why if why else ''}"
                    return Outcome("ERROR", DeviceStatus.FAULT_CONFIGURATION, message)
        return self._all_ready()

    def _moved_elsewhere(self, client: LifecycleClient) -> bool:
        """Return whether a refused transition was a race (the device moved on), not a failed configure."""
        self._sleep(BRING_UP_SETTLE_S)
        try:
            return client.get_state() in ("inactive", "active")
        except LifecycleInterruptedError:
            raise ShutdownError("shutdown") from None
        except LifecycleError:
            return False

    def orient(self) -> Outcome:
        """Place a new batch on the MEMS array and run the field program until every part has settled."""
        assert self.place_parts is not None and self.run_program is not None  # made for orienter mems
        if self.p["new_batch"] and self.machine.attempts == 0:  # a retry goes on from where they are
            response = self.call("mems", self.place_parts, MemsPlaceParts.Request(reset=True))
            if isinstance(response, Outcome):
                return response
        if (
            self.arrivals is not None
            and self.arrivals.arrivals.mems is not None
            and self.machine.attempts == 0
        ):
            placed = self._place_arrivals()
            if placed is not None:
                return placed
        goal = RunProgram.Goal(
            program=self.program,
            timeout=self.p["orient_timeout"],
            tolerance=self.p["orient_tolerance"],
            dwell=self.p["orient_dwell"],
        )
        result = self.action("mems", self.run_program, "run_program", goal, self.p["orient_timeout"])
        return (
            result
            if isinstance(result, Outcome)
            else Outcome(result.outcome_name, result.fault_code, result.message)
        )

    def squeeze(self) -> Outcome:
        """Orient on the squeeze gripper: a new part between its jaws, then the squeeze planner's plan.

        The plan is asked for once (it orients every initial orientation, Goldberg 1993, so every cycle
        runs the same one). A retry runs the plan again on the part where it lies (after a dropped part,
        RECOVER has placed a new one).
        """
        if self.plan_angles is None:
            planned = self._squeeze_plan()
            if planned is not None:
                return planned
        if self.machine.attempts == 0:
            placed = self._squeeze_place()
            if placed is not None:
                return placed
        assert self.run_plan is not None and self.plan_angles is not None
        goal = RunPlan.Goal(angles=self.plan_angles, timeout=self.p["squeeze_timeout"])
        result = self.action("squeeze", self.run_plan, "run_plan", goal, self.p["squeeze_timeout"])
        if isinstance(result, Outcome):
            return result
        self.squeezes += result.squeezes
        message = f"{result.squeezes} squeezes; {result.message}"
        if result.outcome_name == "DONE" and self.plan_answer is not None:
            # Ground truth (the gripper reports it for logging): how far the plan left the part from its
            # final orientation, modulo the symmetry period.
            error = math.remainder(
                result.part_orientation - self.plan_answer.final_orientation,
                self.plan_answer.symmetry_period,
            )
            widths = ", ".join(f"{w:.6g}" for w in result.jaw_widths)
            message = (
                f"{result.squeezes} squeezes, jaw widths [{widths}] m, part at "
                f"{result.part_orientation:.6f} rad ({error:+.2e} rad from the plan's final orientation)"
            )
            self.get_logger().info(f"cycle {self.machine.cycle}: ORIENT on the squeeze gripper: {message}")
        return Outcome(result.outcome_name, result.fault_code, message)

    def _squeeze_plan(self) -> Outcome | None:
        """Ask the squeeze planner for the plan of the gripper's part; an Outcome if there is none."""
        assert self.squeeze_planner is not None and self.squeeze_part is not None
        request = SqueezePlanCompute.Request(
            part=self.squeeze_part, first_angle=self.p["squeeze_first_angle"]
        )
        response: Any = Outcome("NO_ANSWER", 0, "no call made")
        for _ in range(PLAN_CALLS):
            response = self.call("squeeze_planner", self.squeeze_planner, request)
            if not (isinstance(response, Outcome) and response.event == "NO_ANSWER"):
                break
        if isinstance(response, Outcome):
            return response
        self.plan_answer = response
        self.plan_angles = [float(a) for a in response.angles]
        angles = ", ".join(f"{a:.6f}" for a in self.plan_angles)
        self.get_logger().info(
            f"squeeze plan from {self.squeeze_planner.srv_name}: {len(self.plan_angles)} squeezes at "
            f"[{angles}] rad, final orientation {response.final_orientation:.6f} rad modulo "
            f"{response.symmetry_period:.6f}, margin {response.margin:.6f} rad"
        )
        return None

    def _squeeze_place(self) -> Outcome | None:
        """Put a new part between the gripper's open jaws; an Outcome if that failed."""
        assert self.squeeze_place is not None
        request = SqueezePlacePart.Request(
            orientation=self.p["squeeze_orientation"], random=self.p["squeeze_random"]
        )
        response = self.call("squeeze", self.squeeze_place, request)
        if isinstance(response, Outcome):
            return response
        self.get_logger().info(
            f"cycle {self.machine.cycle}: a part arrives in the squeeze gripper at "
            f"{response.orientation:.6f} rad"
        )
        return None

    def _wait_jaws_open(self) -> Outcome | None:
        """Wait (``squeeze_timeout`` of node clock) for a gripper ~/state after now saying IDLE."""
        future: Future = Future()
        self.jaws_open = (self.get_clock().now().nanoseconds, future)
        if self.wait(future, self.p["squeeze_timeout"]):
            return None
        return Outcome(
            "NO_ANSWER",
            0,
            f"{self.devices['squeeze']}/state did not say IDLE (the jaws open) within "
            f"{self.p['squeeze_timeout']:g} s of the reset",
        )

    def _on_squeeze_state(self, msg: SqueezeState) -> None:
        pending = self.jaws_open
        stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        if pending is not None and msg.phase == "IDLE" and stamp > pending[0] and not pending[1].done():
            pending[1].set_result(True)

    def infeed(self) -> Outcome:
        """Put a new part on the arm at the infeed pose (the presented one was taken).

        With arrivals, the cycle's drawn edge and radius (the same part again after a reset: the draw is
        the cycle's, whatever the retries).
        """
        request = ArmPlacePart.Request(edge=self.p["infeed_edge"], radius=self.p["infeed_radius"])
        if self.arrivals is not None and self.arrivals.arrivals.arm is not None:
            if self.arrivals.drop is None:
                problem = self._arm_drop()
                if problem is not None:
                    return problem
            arrival = self.arrivals.arm(self.machine.cycle)
            request = ArmPlacePart.Request(edge=arrival.edge, radius=arrival.radius)
            self.get_logger().info(
                f"cycle {self.machine.cycle}: part arrives on edge {arrival.edge} at R {arrival.radius:.6g} m"
            )
        response = self.call("arm", self.place_part, request)
        return response if isinstance(response, Outcome) else Outcome("DONE")

    def _place_arrivals(self) -> Outcome | None:
        """Place every part on the array at this cycle's drawn pose; an Outcome if that failed."""
        assert self.arrivals is not None and self.place_parts is not None
        if not self._wait_until(lambda: self.mems_names is not None) or not self.mems_names:
            return Outcome("ERROR", 0, f"arrivals: no part names from {self.devices['mems']}/parts")
        names = list(self.mems_names)
        poses = self.arrivals.mems(self.machine.cycle, len(names))
        request = MemsPlaceParts.Request(
            reset=False,
            names=names,
            x=[p[0] for p in poses],
            y=[p[1] for p in poses],
            theta=[p[2] for p in poses],
        )
        response = self.call("mems", self.place_parts, request)
        if isinstance(response, Outcome):
            return response
        placed = ", ".join(
            f"{n} ({x:.6g}, {y:.6g}, {t:.6g})" for n, (x, y, t) in zip(names, poses, strict=True)
        )
        self.get_logger().info(f"cycle {self.machine.cycle}: parts placed on the array at {placed}")
        return None

    def _arm_drop(self) -> Outcome | None:
        """Compute the arm part's drop distribution from its ~/part; an Outcome if it cannot be had."""
        assert self.arrivals is not None
        if not self._wait_until(lambda: self.arm_part is not None) or self.arm_part is None:
            return Outcome("ERROR", 0, f"arrivals: no part from {self.devices['arm']}/part")
        try:
            drop = self.arrivals.set_part(arm_part(part_from_msg(self.arm_part, "part")))
        except FeederError as error:
            return Outcome("ERROR", 0, f"arrivals: the arm part's drop distribution: {error}")
        shares = ", ".join(f"{p:.4f}" for p in drop.probabilities)
        self.get_logger().info(
            f"arrivals: {drop.fidelity} drop distribution of the arm part by edge: {shares}"
        )
        return None

    def feed(self) -> Outcome:
        """Throw until the arm's sensor says the part is presented (or max throws, timeout, a fault)."""
        goal = FeedPart.Goal(max_throws=self.p["feed_max_throws"], timeout=self.p["feed_timeout"])
        result = self.action("arm", self.feed_part, "feed_part", goal, self.p["feed_timeout"])
        if isinstance(result, Outcome):
            return result
        self.throws += result.throws
        return Outcome(result.outcome_name, result.fault_code, f"{result.throws} throws; {result.message}")

    def tilt(self, waypoints: list[Vector3]) -> Outcome:
        """Follow gravity waypoints; a refusal names the first unstable sample and its bodies."""
        goal = FollowPath.Goal(gravity_waypoints=waypoints)
        result = self.action("fixture", self.follow_path, "follow_path", goal, 0.0)
        if isinstance(result, Outcome):
            return result
        self.stood = result.gravity
        message = result.message
        if result.outcome_name == "REFUSED":
            bodies = ", ".join(result.unbalanced_bodies) or "none named"
            message = f"sample {result.first_unstable_sample} unstable ({bodies}); {result.message}"
        return Outcome(result.outcome_name, result.fault_code, message)

    def plan(self, goal: Vector3) -> Outcome:
        """Ask the region planner for a certified path from where the fixture stands to ``goal``."""
        request = StablePath.Request(start=self.stood, goal=goal, step=self.p["path_step"])
        response = self.call("planner", self.safe_path, request)
        if isinstance(response, Outcome):
            return Outcome("NO_PATH", 0, response.message) if response.event == "ERROR" else response
        self.safe = list(response.path[1:]) or [goal]
        return Outcome(
            "PLANNED", 0, f"{len(response.path)} samples, min margin {response.min_margin:.3f} rad"
        )

    def recover(self) -> Outcome:
        """~/reset the device that failed (the arm, the gripper: then a fresh part); wait until ready."""
        key = self.machine.device
        if key == "planner":
            return Outcome("DONE")  # the planner holds no state to reset
        end = self.faults.under_repair_until(self.devices[key].rsplit("/", 1)[-1])
        if end > self.now():
            # A failure of the device's fault process lasts until its repair: the cell waits for it.
            self.get_logger().info(
                f"RECOVER: {self.devices[key]} is under repair until +{end - self.faults.origin:.3f} s"
            )
            self.wait(Future(), end - self.now() - REPAIR_EARLY_S)
        response = self.call(key, self.resets[key], Trigger.Request())
        if isinstance(response, Outcome):
            return response
        if not response.success:
            return Outcome("ERROR", 0, f"{self.devices[key]}/reset: {response.message}")
        if key == "arm":
            placed = self.infeed()
            if placed.event != "DONE":
                return placed
        if key == "squeeze":
            # A dropped part keeps the gripper in FAULT after the reset until a part is placed again, which
            # it takes only once the jaws the reset opens are open.
            problem = self._wait_jaws_open() or self._squeeze_place()
            if problem is not None:
                return problem
        return self._ready(key)

    # --- bounded waits ------------------------------------------------------------------------------
    def now(self) -> float:
        """Node-clock seconds (the cell clock under use_sim_time)."""
        return self.get_clock().now().nanoseconds * 1e-9

    def stopping(self) -> bool:
        """Whether a stop was requested (a signal), or the context ended under the node."""
        requested = self.stop_request is not None and self.stop_request.requested
        return requested or not rclpy.ok(context=self.context)

    def _check_stop(self) -> None:
        if self.stopping():
            raise ShutdownError("shutdown")

    def _sleep(self, seconds: float) -> None:
        """Sleep ``seconds`` of wall time, looking at the stop request every POLL_S."""
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self._check_stop()
            time.sleep(min(POLL_S, max(deadline - time.monotonic(), 0.0)))

    def _wait_until(self, ready: Callable[[], bool]) -> bool:
        """Wait (``answer_timeout`` wall s) until ``ready()``, looking at the stop request every POLL_S.

        Not rclpy's wait_for_service / wait_for_server: they look only at the context, which a stop
        request leaves valid, so Ctrl-C would wait out the whole timeout.
        """
        deadline = time.monotonic() + self.p["answer_timeout"]
        while not ready():
            self._check_stop()
            if time.monotonic() > deadline:
                return ready()
            time.sleep(POLL_S)
        return True

    def wait(self, future: Any, sim_timeout: float) -> bool:
        """Wait for a future: at most ``sim_timeout`` s of node clock and ``wall_timeout`` s of wall clock.

        In lockstep the clock moves only while this waits: one quantum at a time, the future looked at
        after each (every device has ticked it by then, so the answer is seen at a defined cell time).
        """
        sim_deadline = self.now() + sim_timeout
        wall_deadline = time.monotonic() + self.p["wall_timeout"]
        while not future.done():
            self._check_stop()
            if time.monotonic() > wall_deadline or self.now() > sim_deadline:
                return False
            if self.lockstep is None:
                time.sleep(POLL_S)
                self._inject_due()
                continue
            self.lockstep.release(self.settled_ns)
            settled = self.lockstep.wait_announcement(
                self.settled_ns, wall_deadline - time.monotonic(), self.stopping
            )
            self._check_stop()
            if settled < 0:
                return False
            self.settled_ns = settled
            self._inject_due()
        return True

    def wait_wall(self, future: Any) -> bool:
        """Wait for a server's answer: at most ``answer_timeout`` wall s (in lockstep, within the quantum)."""
        done = threading.Event()
        future.add_done_callback(lambda _: done.set())
        deadline = time.monotonic() + self.p["answer_timeout"]
        while not done.wait(POLL_S):
            self._check_stop()
            if time.monotonic() > deadline:
                return future.done()
        return True

    def call(self, key: str, client: Any, request: Any) -> Any:
        """Call a device service; an answer with ok false or none in time becomes an Outcome."""
        if not self._wait_until(client.service_is_ready):
            return Outcome("NO_ANSWER", 0, f"service {client.srv_name} not available")
        future = client.call_async(request)
        if not self.wait_wall(future):
            return Outcome(
                "NO_ANSWER", 0, f"{client.srv_name} did not answer in {self.p['answer_timeout']:g} s"
            )
        response = future.result()
        if getattr(response, "ok", True):
            return response
        return self._refusal(key, f"{client.srv_name}: {response.error}")

    def action(self, key: str, client: ActionClient, action: str, goal: Any, goal_timeout: float) -> Any:
        """Send a goal and wait for its result (bounded); a rejection or no result becomes an Outcome."""
        name = f"{self.devices[key]}/{action}"
        if not self._wait_until(client.server_is_ready):
            return Outcome("NO_ANSWER", 0, f"action {name} not available")
        sent = client.send_goal_async(goal)
        if not self.wait_wall(sent):
            return Outcome("NO_ANSWER", 0, f"{name}: goal not answered in {self.p['answer_timeout']:g} s")
        handle = sent.result()
        if not handle.accepted:
            why = self.diagnostics.get(self._qualified(self.devices[key]), {}).get("last_goal_rejection", "")
            return self._refusal(key, f"{name}: goal rejected{': ' + why if why else ''}")
        result = handle.get_result_async()
        if not self.wait(result, goal_timeout + self.p["step_timeout"]):
            handle.cancel_goal_async()  # not waited on: the step has failed either way
            return Outcome("NO_ANSWER", 0, f"{name}: no result within the step's bound; goal canceled")
        return result.result().result

    def _refusal(self, key: str, message: str) -> Outcome:
        """Return a refusal as FAULT with the device's code when its status says FAULT, else as ERROR."""
        status = self.status.get(key)
        if status is not None and status.state == DeviceStatus.FAULT:
            return Outcome("FAULT", status.fault_code, f"{status.fault_text} ({message})")
        return Outcome("ERROR", 0, message)

    def _ready(self, key: str) -> Outcome:
        """Wait (answer_timeout, wall) until the device's status says ready; else say its state."""
        if self._wait_until(lambda: (s := self.status.get(key)) is not None and s.ready):
            return Outcome("DONE")
        status = self.status.get(key)
        if status is None:
            return Outcome("NO_ANSWER", 0, f"no status from {self.devices[key]}")
        if status.state == DeviceStatus.FAULT:
            return Outcome("FAULT", status.fault_code, f"{self.devices[key]}: {status.fault_text}")
        return Outcome(
            "ERROR", status.fault_code, f"{self.devices[key]} is {status.state_name}: {status.fault_text}"
        )

    def _all_ready(self) -> Outcome:
        for key in self.devices:
            outcome = self._ready(key)
            if outcome.event != "DONE":
                return outcome
        # Under use_sim_time the node clock reads 0 until the first /clock: cycle times start after.
        if not self._wait_until(lambda: self.now() > 0.0):
            return Outcome("NO_ANSWER", 0, "no /clock (use_sim_time is set)")
        return Outcome("DONE")

    # --- inputs and outputs ---------------------------------------------------------------------------
    def _program(self) -> FieldProgram:
        """Return the program ORIENT runs: the file's, or one combined field (orient_delta) forever."""
        program = FieldProgram(name="cell_controller")
        path = self.p["orient_program_file"]
        if not path:
            program.steps = [FieldSpec(type="combined", delta=self.p["orient_delta"], strength=1.0)]
            return program
        try:
            steps = program_from_mapping(load_yaml_mapping(path), "program")
        except InputError as error:
            raise InputError("parameter orient_program_file", str(error)) from None
        program.steps = [fill_field_spec(FieldSpec(), step) for step in steps]
        return program

    def _squeeze_part(self) -> PartMsg:
        """Return the part ``squeeze_part_file`` names, for the squeeze planner's ~/plan."""
        path = self.p["squeeze_part_file"]
        if not path:
            raise InputError(
                "parameter squeeze_part_file", "is required with orienter squeeze (the gripper's part_file)"
            )
        try:
            load_part(path)  # checked here: a bad part is named at start, not at the first cycle
            return part_to_msg(load_yaml_mapping(path))
        except InputError as error:
            raise InputError("parameter squeeze_part_file", str(error)) from None

    def _arrivals(self) -> ArrivalStream | None:
        """Return the arrivals ``arrivals_file`` names (its arrivals: section and seed), or None."""
        path = self.p["arrivals_file"]
        if not path:
            return None
        try:
            document = load_yaml_mapping(path)
            arrivals = scene_arrivals(document)
            if arrivals is None:
                raise InputError("arrivals", "is missing: the file has no arrivals: section")
            seed = scene_seed(document)
        except InputError as error:
            raise InputError("parameter arrivals_file", str(error)) from None
        if arrivals.mems is not None and self.orienter != "mems":
            raise InputError(
                "parameter arrivals_file",
                f"arrivals.mems places parts on the MEMS array, but the orienter is {self.orienter}",
            )
        return ArrivalStream(arrivals, seed, self.p["replication"])

    def _fault_schedule(self) -> FaultSchedule:
        """Return the fault processes ``faults_file`` names (its faults: section and seed); none if empty."""
        path = self.p["faults_file"]
        if not path:
            return FaultSchedule(())
        try:
            document = load_yaml_mapping(path)
            specs = scene_faults(document)
            if specs is None:
                raise InputError("faults", "is missing: the file has no faults: section")
            seed = scene_seed(document)
        except InputError as error:
            raise InputError("parameter faults_file", str(error)) from None
        return FaultSchedule(specs, seed, self.p["replication"])

    def _inject_due(self) -> None:
        """Inject every failure whose time has come, and clear every one whose repair time has come.

        Each request is answered before the controller goes on (``_send_fault``); its effect shows in the
        step's outcome, which the fault policy handles. A clear at the repair time ends a fault the device
        keeps until then (a stuck sensor); one the controller's ~/reset already cleared answers that it is
        not active, which is fine.
        """
        if self.machine.state is State.BRING_UP:
            return
        for action in self.faults.due(self.now()):
            self._send_fault(action)

    def _send_fault(self, action: FaultAction) -> None:
        """Send ~/inject_fault (or its clear), log it, and wait for the answer; a refusal is logged."""
        spec, event, clear = action.spec, action.event, action.clear
        client = self.injections[spec.device]
        request = InjectFault.Request(fault=spec.fault, clear=clear, value=spec.value, state=spec.state)
        what = "repaired (cleared)" if clear else "injected"
        at = self.now() - self.faults.origin
        self.get_logger().info(
            f"fault process: {spec.fault} {what} in {spec.device} at +{at:.3f} s "
            f"(failure +{event.start:.3f} s to +{event.end:.3f} s)"
        )
        if not client.service_is_ready():
            self.get_logger().warning(f"fault process: {client.srv_name} is not available")
            return

        # Waited for: in lockstep the controller holds the clock meanwhile, so the device takes the fault
        # in at the cell time it is due, before its next tick (as the ROS-free loop applies it). Sent and
        # left, it landed in that quantum or the next as the device's executor happened to order its
        # callbacks: the fresh-clone CI run's loop-equivalence and squeeze-cell runs differed so.
        future = client.call_async(request)
        if not self.wait_wall(future):
            self.get_logger().warning(
                f"fault process: {client.srv_name} did not answer in {self.p['answer_timeout']:g} s"
            )
            return
        response = future.result()
        if response is not None and not response.ok and not clear:
            self.get_logger().warning(f"fault process: {client.srv_name}: {response.error}")

    def _on_mems_parts(self, msg: MemsParts) -> None:
        self.mems_names = [part.name for part in msg.parts]

    def _on_arm_part(self, msg: PartMsg) -> None:
        self.arm_part = msg

    @staticmethod
    def _route(flat: list[float]) -> list[Vector3]:
        return [Vector3(x=flat[i], y=flat[i + 1], z=flat[i + 2]) for i in range(0, len(flat), 3)]

    def _qualified(self, name: str) -> str:
        namespace = self.get_namespace().rstrip("/")
        return name if name.startswith("/") else f"{namespace}/{name}"

    def _status_callback(self, key: str) -> Callable[[DeviceStatus], None]:
        def on_status(msg: DeviceStatus) -> None:
            self.status[key] = msg

        return on_status

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        for status in msg.status:
            self.diagnostics[status.name] = {kv.key: kv.value for kv in status.values}

    def status_msg(self) -> CellStatus:
        """Return the controller's status now."""
        return cell_status(self.machine, self.last, self.get_clock().now().to_msg(), self.now())

    def _heartbeat(self) -> None:
        """Publish the status again (in lockstep the last one as it was: the cycle's thread makes news)."""
        if self.lockstep is None:
            self.publish_status()
        elif self.last_status is not None:
            self.status_pub.publish(self.last_status)
            self._publish_diagnostics(self.last_status)

    def publish_status(self) -> None:
        """Publish ~/status (latched) and the controller's /diagnostics entry.

        In lockstep not before the first announcement, which sets the node clock that stamps it.
        """
        if self.lockstep is not None and self.lockstep.announced_ns < 0:
            return
        msg = self.status_msg()
        self.last_status = msg
        self.status_pub.publish(msg)
        self._publish_diagnostics(msg)

    def _publish_diagnostics(self, msg: CellStatus) -> None:
        """Publish the controller's /diagnostics entry for the status ``msg``."""
        entry = diagnostic_entry(msg, self.get_fully_qualified_name(), f"sim:{self.get_name()}")
        self.diagnostics_pub.publish(DiagnosticArray(header=msg.header, status=[entry]))


NODE = CellController  # what the cell host builds (feeder_cell.host); it runs hosted_work on a thread


def main(args: list[str] | None = None) -> None:
    """Run the controller: spin on a thread, run the cycles here; exit 0 FINISHED or shut down, 1 STOPPED."""
    dump_profile = profiled(NODE_NAME)
    stop = StopRequest()
    node = build_node(lambda: CellController(stop), NODE_NAME, args, stop)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    # Completed by the clean-up: the spinning thread serves answers until then (a stop request leaves the
    # context valid), and no polling spin (rclpy 7.1 leaks a timer per spin_once with a timeout).
    spun_out: Future = Future()

    def spin() -> None:
        try:
            if node.lockstep is not None:
                node.lockstep.spin(executor, stopped=spun_out.done)
            else:
                executor.spin_until_future_complete(spun_out)
        except (ExternalShutdownException, ShutdownException):
            pass

    spinner = threading.Thread(target=spin, name="rclpy", daemon=True)
    spinner.start()
    code = EXIT_STOPPED
    try:
        code = node.hosted_work(stop)
    finally:
        stop.ignore_from_now()
        if rclpy.ok(context=node.context):
            try:
                node.publish_status()
                if node.lockstep is not None:
                    node.lockstep.leave()
            except rclpy_implementation.RCLError:
                pass  # the context ended under the node (an external shutdown): nothing to tell
        # The spinning thread must be gone before the node is destroyed and the process exits.
        spun_out.set_result(True)
        executor.shutdown(timeout_sec=2.0)
        spinner.join(timeout=5.0)
        node.destroy_node()
        rclpy.try_shutdown()
        dump_profile()
    sys.exit(code)


if __name__ == "__main__":
    main()
