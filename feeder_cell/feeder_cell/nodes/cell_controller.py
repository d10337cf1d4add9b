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
The work is in ``feeder_cell.controller_ros``: the bounded waits and calls (``link``), the file parameters
(``inputs``), the fault processes (``faults``), the bring-up, the stations' steps (``stations``,
``squeeze``); this module wires them, runs the cycle, and reports.
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

import sys
import threading
import time

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.clock import Clock, ClockType
from rclpy.duration import Duration
from rclpy.executors import ExternalShutdownException, ShutdownException, SingleThreadedExecutor
from rclpy.impl.implementation_singleton import rclpy_implementation
from rclpy.node import Node
from rclpy.task import Future
from std_srvs.srv import Trigger

from feeder_cell.controller import CellMachine, Outcome, State, Transition
from feeder_cell.controller.fault_schedule import REPAIR_EARLY_S
from feeder_cell.controller.parameters import PARAMETERS
from feeder_cell.controller.reporting import cell_status, diagnostic_entry
from feeder_cell.controller_ros import inputs
from feeder_cell.controller_ros.bring_up import BringUp
from feeder_cell.controller_ros.faults import FaultInjector
from feeder_cell.controller_ros.link import POLL_S, DeviceLink, ShutdownError
from feeder_cell.controller_ros.squeeze import SqueezeStation
from feeder_cell.controller_ros.stations import Stations
from feeder_msgs.msg import CellStatus
from feeder_planner.errors import InputError
from feeder_planner.node_kit import LATCHED, declare_parameters
from feeder_planner.node_kit.lockstep import Participant
from feeder_planner.node_kit.runner import StopRequest, build_node, profiled

__all__ = ["PARAMETERS", "CellController", "main"]

NODE_NAME = "cell_controller"
HEARTBEAT_RATE = 1.0  # Hz (steady clock) of ~/status and /diagnostics besides every transition
EXIT_FINISHED, EXIT_STOPPED = 0, 1  # a bad parameter exits 2 (node_kit.runner.build_node)
EXIT_SHUT_DOWN = 0  # Ctrl-C or SIGTERM: a clean end for a ROS node, whatever state the cell was in
# Before a controller done with its cycles ends, every subscriber must have its last status: the process
# (or the host) ends right after, and a sample still queued in DDS then never arrives. A launch recording
# the squeeze cell lost the FINISHED status so (2 of 5 runs under load). Bounded (wall s): a subscriber
# that never acknowledges does not hold the end.
STATUS_DELIVERY_S = 2.0


class CellController(Node):
    """Bring the cell up, run production cycles, handle faults by the machine's policy, report."""

    def __init__(self, stop: StopRequest | None = None) -> None:
        super().__init__(NODE_NAME)
        self.p = declare_parameters(self, PARAMETERS)
        if self.p["policy"] != "sequential":
            raise InputError("parameter policy", f"{self.p['policy']} runs in the ROS-free loop only, so far")
        for name in ("fixture_route", "fixture_home"):
            self.p[name] = [float(v) for v in self.p[name]]
        # The orienting station ORIENT commands: the MEMS array ("mems") or the squeeze gripper ("squeeze").
        self.orienter: str = self.p["orienter"]
        squeezing = self.orienter == "squeeze"
        program = inputs.field_program(self.p)
        squeeze_part = inputs.squeeze_part(self.p) if squeezing else None
        arrivals = inputs.arrival_stream(self.p, self.orienter)
        self.faults = inputs.fault_schedule(self.p)
        self.machine = CellMachine(
            cycles=self.p["cycles"], max_retries=self.p["max_retries"], orienter=self.orienter
        )
        self.devices = {
            self.orienter: self.p["squeeze_device" if squeezing else "mems_device"],
            "arm": self.p["arm_device"],
            "fixture": self.p["fixture_device"],
        }
        # Every client is made once, here: a server must discover a client before it can answer it. The
        # orienting station's clients are made for the station the cell has. The MEMS cell's entities are
        # made in the order they always were: while an injection was sent without waiting, the executor's
        # order of ready entities decided which quantum it landed in (tests/experiment/
        # test_loop_equivalence_ros measured a 0.1 s shorter cycle with the order changed). Injections
        # are now answered before the cycle goes on (faults.py); the order is kept all the same, since
        # nothing has measured that it no longer matters. So: the
        # devices' status and /diagnostics, the stations' subscriptions and clients, the injections, the
        # lifecycle clients, the squeeze gripper's, the publishers and the heartbeat, the lockstep.
        self.link = DeviceLink(self, self.p, self.devices, stop, lambda: self.injector.inject_due())
        self.stations = Stations(self, self.link, self.machine, program, arrivals)
        self.injector = FaultInjector(self, self.link, self.faults, self.machine)
        self.bring_up = BringUp(self, self.link)
        self.squeezer = (
            SqueezeStation(self, self.link, self.machine, squeeze_part) if squeeze_part is not None else None
        )
        self.status_pub = self.create_publisher(CellStatus, "~/status", LATCHED)
        self.diagnostics_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(1.0 / HEARTBEAT_RATE, self._heartbeat, clock=steady)
        self.last: Transition | None = None
        self.step_times: dict[str, float] = {}  # s of node clock per state in this cycle
        # Lockstep: the link's waits let the clock go; the first announcement publishes the first status.
        self.lockstep = Participant(self, "react", hold=True) if self.p["lockstep"] else None
        self.link.lockstep = self.lockstep
        if self.lockstep is not None:
            self.lockstep.on_first = self.publish_status
        self.last_status: CellStatus | None = None
        self.publish_status()

    # --- the cycle ------------------------------------------------------------------------------
    def hosted_work(self, stop: StopRequest) -> int:
        """Run the cycles and end as ``exit_when_done`` says; return the exit code.

        On the thread ``main`` keeps for it, or the cell host's (``feeder_cell.host``): there the controller
        reacts by direct calls to the hosted clock (its participant joins the clock's hub), its requests to
        the devices still go through their services.
        """
        self.link.stop_request = stop
        code = self.run()
        if self.lockstep is not None:
            self.lockstep.leave()  # the clock goes on without a controller that has stopped deciding
        if self.p["exit_when_done"]:
            if not self.link.stopping():  # after Ctrl-C the node ends at once
                self.status_pub.wait_for_all_acked(Duration(seconds=STATUS_DELIVERY_S))
        else:
            while not self.link.stopping():  # keep serving the latched status until Ctrl-C
                time.sleep(POLL_S)
            code = EXIT_SHUT_DOWN
        return code

    def run(self) -> int:
        """Run the machine to its end; return the exit code (0 FINISHED or shut down, 1 STOPPED)."""
        stations = self.stations
        work = {
            State.BRING_UP: self.bring_up.run,
            State.ORIENT: self.squeezer.orient if self.squeezer is not None else stations.orient,
            State.INFEED: stations.infeed,
            State.FEED: stations.feed,
            State.TILT: lambda: stations.tilt_route("fixture_route"),
            State.PLAN_TILT: lambda: stations.plan_to_end_of("fixture_route"),
            State.TILT_SAFE: lambda: stations.tilt(stations.safe),
            State.RETURN: lambda: stations.tilt_route("fixture_home"),
            State.PLAN_RETURN: lambda: stations.plan_to_end_of("fixture_home"),
            State.RETURN_SAFE: lambda: stations.tilt(stations.safe),
            State.RECOVER: self.recover,
        }
        try:
            if not self.link.join_clock():
                self.on_transition(self.machine.stop("the lockstep cell clock never settled a time"))
                return EXIT_STOPPED
            while not self.machine.finished:
                self.link.check_stop()
                self.injector.inject_due()
                state, started = self.machine.state, self.link.now()
                outcome = work[state]()
                self.step_times[state.value] = (
                    self.step_times.get(state.value, 0.0) + self.link.now() - started
                )
                self.on_transition(self.machine.advance(outcome, self.link.now()))
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
            squeezes = f", {self.squeezer.squeezes} squeezes" if self.squeezer is not None else ""
            log.info(
                f"cycle {self.machine.cycle - (t.target is State.ORIENT)}: {m.last_cycle_time:.2f} s "
                f"({steps}), {self.stations.throws} throws{squeezes}; {m.cycles_completed} cycles, "
                f"{m.parts_presented} parts, "
                f"{m.parts_per_minute(self.link.now()):.2f} parts/min, faults seen {m.faults_seen} handled "
                f"{m.faults_handled}, reroutes {m.reroutes}"
            )
            self.stations.throws, self.step_times = 0, {}
            if self.squeezer is not None:
                self.squeezer.squeezes = 0
        elif t.policy is not None and t.target is not State.STOPPED:
            log.warning(f"{t.source.value}: {t.outcome.label()} -> {t.policy.value}: {t.note}")
        elif t.target is State.STOPPED:
            log.error(f"cell STOPPED: {self.machine.stop_reason}")
        elif t.note:
            log.info(f"{t.source.value} -> {t.target.value}: {t.note}")
        if t.target is State.FINISHED:
            log.info(f"cell FINISHED: {m.cycles_completed} cycles, {m.parts_presented} parts")
        self.publish_status()

    def recover(self) -> Outcome:
        """~/reset the device that failed (the arm, the gripper: then a fresh part); wait until ready."""
        key = self.machine.device
        if key == "planner":
            return Outcome("DONE")  # the planner holds no state to reset
        end = self.faults.under_repair_until(self.devices[key].rsplit("/", 1)[-1])
        if end > self.link.now():
            # A failure of the device's fault process lasts until its repair: the cell waits for it.
            self.get_logger().info(
                f"RECOVER: {self.devices[key]} is under repair until +{end - self.faults.origin:.3f} s"
            )
            self.link.wait(Future(), end - self.link.now() - REPAIR_EARLY_S)
        response = self.link.call(key, self.stations.resets[key], Trigger.Request())
        if isinstance(response, Outcome):
            return response
        if not response.success:
            return Outcome("ERROR", 0, f"{self.devices[key]}/reset: {response.message}")
        if key == "arm":
            placed = self.stations.infeed()
            if placed.event != "DONE":
                return placed
        if key == "squeeze" and self.squeezer is not None:
            # A dropped part keeps the gripper in FAULT after the reset until a part is placed again, which
            # it takes only once the jaws the reset opens are open.
            problem = self.squeezer.wait_jaws_open() or self.squeezer.place()
            if problem is not None:
                return problem
        return self.link.ready(key)

    # --- status -----------------------------------------------------------------------------------
    def status_msg(self) -> CellStatus:
        """Return the controller's status now."""
        return cell_status(self.machine, self.last, self.get_clock().now().to_msg(), self.link.now())

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
        if self.lockstep is not None:
            self.lockstep.delivered(self.status_pub)  # in the quantum it was decided in, for every reader
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
