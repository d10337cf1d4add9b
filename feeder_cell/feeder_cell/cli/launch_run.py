"""One run of a launch plan's nodes: start them, bring them up, run until the end, stop every one."""

from __future__ import annotations

import time
from typing import Any, Callable

from feeder_cell.cli.launch_bring_up import bring_up, wait_until_in_graph
from feeder_cell.cli.launch_plan import LaunchPlan, extra_parameters, host_groups
from feeder_cell.cli.launch_recording import discover_matched, drain, open_recording
from feeder_cell.cli.launch_report import RunOutcome, launch_result
from feeder_cell.launcher import NodeProcess, NodeSpec, start_host, start_node

RECORDER_DISCOVERY_PERIOD_S = 0.5  # wall s between the recorder's looks for new topics, off the clock


def run_scene(plan: LaunchPlan, node: Any, executor: Any, keep_going: Callable[[], bool]) -> dict[str, Any]:
    """Run the plan's nodes on ``node`` and return the launch's result.

    Whatever ends the run (its duration, a node's end, a stop signal, an error at any step), every
    process started is stopped and the bag is closed before this returns or raises.
    """
    run = LaunchRun(plan, node, executor, keep_going)
    try:
        run.start()
        run.bring_up()
        run.run_loop()
    finally:
        outcome = run.stop()
    return launch_result(plan, outcome)


class LaunchRun:
    """The processes of one launch and what watches them (the recorder, in lockstep its observer)."""

    def __init__(self, plan: LaunchPlan, node: Any, executor: Any, keep_going: Callable[[], bool]) -> None:
        from feeder_cell.lockstep_observer import CellTime

        self.plan = plan
        self.node = node
        self.executor = executor
        self.keep_going = keep_going
        self.processes: list[NodeProcess] = []
        self.ended_scene = False  # a node's end ended the scene (a controller done with its cycles)
        self.cell_time = CellTime(node) if plan.sim_time else None
        self.recorder, self.observer = open_recording(node, plan)
        self.states: dict[str, str] = {}

    def start(self) -> None:
        """Start every node of the plan, in its order: a host's nodes together, where its first one is."""
        plan = self.plan
        groups = host_groups(plan.specs, plan.participants, plan.args)
        host_of = {id(member): name for name, members in groups.items() for member in members}
        for spec in plan.specs:
            if not self.keep_going():
                break  # interrupted during start-up: end what was started, no traceback
            host = host_of.get(id(spec))
            if host is not None:
                members = groups[host]
                if spec is members[0]:
                    with_extra = [(m, self._extra(m)) for m in members]
                    self.processes += start_host(host, with_extra, plan.log_dir)
                continue
            self.processes.append(start_node(spec, plan.log_dir, extra_parameters=self._extra(spec)))
        self.processes.sort(key=lambda p: plan.specs.index(p.spec))  # the scene's order: the bring-up's

    def _extra(self, spec: NodeSpec) -> dict[str, Any]:
        return extra_parameters(spec, self.plan.specs, self.plan.participants, self.plan.args)

    def bring_up(self) -> None:
        """Wait until every node is in the graph, start the recording, bring the managed nodes up."""
        wait_until_in_graph(self.node, self.executor, self.processes, self.keep_going)
        if self.observer is not None and self.keep_going():
            # Subscribed to every topic the scene's nodes made at start-up before the clock's join
            # completes (it waits for the recorder): the recording starts at the start time.
            self.observer.start(
                self.executor,
                self.keep_going,
                [(p.spec.node_name, p.spec.namespace) for p in self.processes],
                participants=tuple(s.fully_qualified_name for s in self.plan.participants),
            )
        if self.keep_going():
            # Recording starts before the bring-up, which takes a while: a controller in the scene
            # is working already.
            discover = None
            if self.recorder and self.observer is None:

                def discover() -> None:
                    discover_matched(self.recorder, self.node, self.executor, self.keep_going)

            self.states = bring_up(self.node, self.executor, self.processes, discover, self.keep_going)

    def run_loop(self) -> None:
        """Spin until the duration is up, a stop signal, or a node's end ends the scene."""
        duration = self.plan.args.duration
        started = time.monotonic()
        next_discovery = 0.0
        while self.keep_going() and (duration is None or time.monotonic() - started < duration):
            if self.recorder and self.observer is None and time.monotonic() >= next_discovery:
                self.recorder.discover()
                next_discovery = time.monotonic() + RECORDER_DISCOVERY_PERIOD_S
            if any(not p.alive() and not self._dropped_by_clock(p) for p in self.processes):
                # A node that ends mid-run ends the scene: on_exit shutdown (a controller done with
                # its cycles) by design, any other as a failure; exit codes are reported below. In
                # lockstep a device that dies is the clock's to drop (--on-lockstep-timeout).
                self.ended_scene = True
                break
            observer = self.observer
            self.executor.spin_once(timeout_sec=0.001 if observer and observer.holding() else 0.05)
            if observer is not None:
                observer.after_spin(self.executor)

    def _dropped_by_clock(self, process: NodeProcess) -> bool:
        """Whether a dead node leaves the scene running: a lockstep participant, which the clock drops.

        Not a node whose on_exit ends the scene (the controller done with its cycles).
        """
        plan = self.plan
        return plan.sim_time and process.spec in plan.participants and process.spec.on_exit != "shutdown"

    def stop(self) -> RunOutcome:
        """Close the recording, then stop every process started; return how each ended."""
        if self.recorder is not None and self.keep_going() and self.ended_scene:
            drain(self.executor)
        if self.observer is not None:
            self.observer.leave()
        stats = self.recorder.close() if self.recorder else {}
        processes = self.processes
        cpu = {p.spec.fully_qualified_name: p.cpu_seconds() for p in processes}
        # Alive or not before any is stopped: a host's nodes share one process, and when a hosted
        # node's own work ended it (the controller done with its cycles), that node ended the scene
        # and the others were stopped with it, as they would have been in processes of their own.
        ended_by = {name for p in processes for name in p.ended_by()}
        alive_before = [
            p.alive() or (bool(ended_by) and p.host != "" and p.spec.fully_qualified_name not in ended_by)
            for p in processes
        ]
        codes = [(p, alive, p.stop()) for p, alive in zip(processes, alive_before, strict=True)]
        bag_stats = stats if self.recorder else None
        return RunOutcome(self.states, codes, cpu, self.cell_time, bag_stats)
