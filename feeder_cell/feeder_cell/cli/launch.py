"""``feeder launch``: run the nodes of a scene file together, optionally recording a bag, end them by pid."""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Callable

from feeder_cell.cli.bag import _summary as bag_summary
from feeder_cell.cli.common import add_json_flag, emit, finite_float, output_directory
from feeder_cell.launcher import (
    NO_HOST,
    NodeProcess,
    NodeSpec,
    ParameterScalar,
    hostable,
    joins_lockstep,
    load_scene,
    start_host,
    start_node,
    with_overrides,
)
from feeder_cell.lifecycle_client import LifecycleClient, LifecycleError, LifecycleInterruptedError
from feeder_cell.node_modules import node_class
from feeder_cell.ros_session import with_node
from feeder_planner.errors import FeederError, InputError

STARTUP_TIMEOUT_S = 30.0
# Primary lifecycle states in the order `feeder launch` walks them (anything else is a transition state).
RANK = {"unconfigured": 0, "inactive": 1, "active": 2}

# The cell clock `--real-time-factor` starts, in lockstep; every node of the scene then runs on sim time.
CLOCK_NODE = NodeSpec("feeder_cell", "cell_clock")
# ... and beside it the simulation_interfaces node, which drives the cell through the clock and devices.
SIMULATION_NODE = NodeSpec("feeder_cell", "cell_simulation")
# Simulation-node parameter listing each device kind's nodes, by the executable that simulates it.
DEVICE_LISTS = {
    "mems_field_array": "mems_field_arrays",
    "throwing_arm": "throwing_arms",
    "assembly_fixture": "assembly_fixtures",
}
LAUNCH_NODE = "feeder_launch"
DEFAULT_QUANTUM = 0.1  # s of cell time per lockstep advance (the clock's own default)


# /clock updates per wall second of a free-running cell clock (tests start one directly): a device can
# tick at most once per clock update, so at factor F the clock must update at least F x the fastest
# device rate (the arm's 100 Hz sensor) per wall second, with a margin of two against aliasing.
CLOCK_UPDATES_PER_CLOCK_SECOND = 200.0
MAX_CLOCK_RATE = 2000.0


def clock_rate(factor: float) -> float:
    """Return the /clock rate (Hz, wall) of a free-running cell clock at real-time factor ``factor``."""
    return min(MAX_CLOCK_RATE, max(CLOCK_UPDATES_PER_CLOCK_SECOND, CLOCK_UPDATES_PER_CLOCK_SECOND * factor))


def real_time_factor(text: str) -> float:
    """Argparse type of --real-time-factor: a finite number > 0, or ``max`` (0: as fast as it can)."""
    if text.strip().lower() == "max":
        return 0.0
    value = finite_float(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be > 0 or max, got {text!r}")
    return value


HOST_NAME = "cell_host"


def _hosted_by_default(spec: NodeSpec, participants: list[NodeSpec], controller: bool) -> bool:
    """Whether a lockstep launch puts ``spec`` in the cell host: the clock, cell_simulation, the devices.

    A lockstep participant that is not a device (the reference controller: it decides on a thread of its
    own) stays a process of its own and takes part over DDS, as a user's node does, unless ``controller``.
    """
    return (
        spec.executable in (CLOCK_NODE.executable, SIMULATION_NODE.executable)
        or (spec in participants and spec.executable in DEVICE_LISTS)
        or (controller and spec.package == "feeder_cell" and spec.executable == "cell_controller")
    )


def host_groups(
    specs: list[NodeSpec], participants: list[NodeSpec], args: argparse.Namespace
) -> dict[str, list[NodeSpec]]:
    """Return the launch's hosts and their nodes, in scene order: what each scene node's ``host`` asks.

    ``host: NAME`` puts a node in that host, ``host: none`` in a process of its own; without it, on the
    cell clock, the clock, cell_simulation and the devices share ``cell_host``. ``--one-process-per-node``
    overrides every one. A node a host cannot take (no ``NODE`` in its module, or a second node of one
    executable) runs alone when the launch chose; a scene that asked for it is refused, naming the node.
    """
    if args.one_process_per_node:
        return {}
    sim_time = args.real_time_factor is not None
    asked: dict[str, list[NodeSpec]] = {}
    for spec in specs:
        if spec.host == NO_HOST:
            continue
        if spec.host:
            name = spec.host
        elif sim_time and _hosted_by_default(spec, participants, args.host_controller):
            name = HOST_NAME
        else:
            continue
        asked.setdefault(name, []).append(spec)
    groups = {}
    for name, members in asked.items():
        taken = hostable(members)
        for spec in members:
            if spec.host and spec not in taken:
                raise InputError(
                    f"node {spec.fully_qualified_name}: host",
                    f"{spec.package}/{spec.executable} cannot run in host {name} (its module offers no NODE, "
                    "or the host has a node of that executable already)",
                )
        groups[name] = taken
    return groups


def extra_parameters(
    spec: NodeSpec, specs: list[NodeSpec], participants: list[NodeSpec], args: argparse.Namespace
) -> dict[str, Any]:
    """Return what the launch adds to a node's parameters (on the cell clock: sim time, pace, lockstep)."""
    if args.real_time_factor is None or spec is specs[0]:
        return {}
    # Every node follows /clock, and every device learns the factor it must keep up with (an undeclared
    # parameter is ignored by the nodes without one).
    extra: dict[str, Any] = {"use_sim_time": True, "real_time_factor": args.real_time_factor}
    if spec in participants:
        extra["lockstep"] = True
    return extra


def simulation_spec(specs: list[NodeSpec], quantum: float) -> NodeSpec:
    """Return the simulation node of a scene: its devices by kind, the directories of its part files."""
    parameters: dict[str, Any] = {name: [""] for name in DEVICE_LISTS.values()}
    directories: list[str] = []
    for spec in specs:
        if spec.package == "feeder_sim" and spec.executable in DEVICE_LISTS:
            listed = parameters[DEVICE_LISTS[spec.executable]]
            parameters[DEVICE_LISTS[spec.executable]] = [*(n for n in listed if n), spec.fully_qualified_name]
        for key, value in spec.parameters.items():
            files = value if isinstance(value, list) else [value]
            if key in ("part_file", "part_files"):
                directories += [str(Path(str(f)).parent) for f in files if isinstance(f, str) and f]
    parameters["part_directories"] = sorted(set(directories)) or [""]
    parameters["quantum"] = quantum
    parameters["clock_node"] = CLOCK_NODE.fully_qualified_name
    return NodeSpec(SIMULATION_NODE.package, SIMULATION_NODE.executable, parameters)


def _graph_names(node: Any) -> set[str]:
    return {f"{ns.rstrip('/')}/{name}" for name, ns in node.get_node_names_and_namespaces()}


def _process_name(process: NodeProcess, processes: list[NodeProcess]) -> str:
    """Name a process as a user knows it: its node's executable, or the cell host with all its nodes."""
    if not process.host:
        return f"{process.package}/{process.executable}"
    nodes = [p.spec.fully_qualified_name for p in processes if p.host == process.host]
    return f"cell host {process.host} (pid {process.pid}; nodes {', '.join(nodes)})"


def _wait_until_in_graph(
    node: Any, executor: Any, processes: list[NodeProcess], keep_going: Callable[[], bool]
) -> None:
    deadline = time.monotonic() + STARTUP_TIMEOUT_S
    wanted = {p.spec.fully_qualified_name for p in processes}
    while keep_going():
        executor.spin_once(timeout_sec=0.1)
        dead = [p for p in processes if not p.alive()]
        if dead:
            p = dead[0]
            raise FeederError(
                f"{_process_name(p, processes)} exited with code {p.process.returncode} at start-up; "
                f"last log line: {(p.output().strip().splitlines() or ['(none)'])[-1]}"
            )
        missing = sorted(wanted - _graph_names(node))
        if not missing:
            return
        if time.monotonic() > deadline:
            raise FeederError(f"nodes not in the graph after {STARTUP_TIMEOUT_S:.0f} s: {', '.join(missing)}")


def _configuration_error(node: Any, executor: Any, target: str) -> str:
    """Return the fault text a device published on its latched status (why configure failed), if any."""
    from feeder_msgs.msg import DeviceStatus
    from feeder_planner.node_kit import LATCHED

    seen: list[DeviceStatus] = []
    subscription = node.create_subscription(DeviceStatus, f"{target}/status", seen.append, LATCHED)
    deadline = time.monotonic() + 2.0
    while not seen and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.05)
    node.destroy_subscription(subscription)
    return seen[-1].fault_text if seen else ""


# Before a node's first transition the recorder's new readers must have matched their writers: a
# transition event (volatile) published before the match is lost. The most it waits (wall s), and the
# settle after the readers' side matched, for the writers' side (as the lockstep observer's).
RECORDER_MATCH_TIMEOUT_S = 2.0
RECORDER_MATCH_SETTLE_S = 0.2
# A node that ends the scene (the controller done with its cycles) published its last status just before
# it exited: the launch sees the exit while those messages may still be on their way to the recorder (a
# CI run under load lost the squeeze cell's FINISHED status so). Before the bag is closed the launch
# spins this long (wall s). Not "until quiet": the devices' markers, statuses and /diagnostics beat on
# the wall clock, so a cell never falls quiet. In lockstep the clock is held meanwhile (the recorder does
# not answer the quantum), so little newer than the end comes in.
RECORDER_DRAIN_S = 0.5


def _drain(executor: Any) -> None:
    """Spin for RECORDER_DRAIN_S: the recorder takes in what an ended node sent just before it exited."""
    end = time.monotonic() + RECORDER_DRAIN_S
    while time.monotonic() < end:
        executor.spin_once(timeout_sec=0.02)


def _discover_matched(recorder: Any, node: Any, executor: Any, keep_going: Callable[[], bool]) -> None:
    """Subscribe the recorder to the topics there are now and wait until its new readers have matched."""
    if not recorder.discover():
        return
    deadline = time.monotonic() + RECORDER_MATCH_TIMEOUT_S
    while keep_going() and time.monotonic() < deadline:
        subscriptions = recorder.subscriptions()
        if all(s.get_publisher_count() >= node.count_publishers(n) for n, s in subscriptions.items()):
            settled = time.monotonic() + RECORDER_MATCH_SETTLE_S
            while keep_going() and time.monotonic() < settled:
                executor.spin_once(timeout_sec=0.02)
            return
        executor.spin_once(timeout_sec=0.02)


def _while_alive(process: NodeProcess, keep_going: Callable[[], bool]) -> Callable[[], bool]:
    return lambda: keep_going() and process.alive()


def is_managed_node(spec: NodeSpec) -> bool | None:
    """Whether the node is a lifecycle node, from the class its module offers (``NODE``); None: unknown.

    Asking the graph instead means waiting for lifecycle services that an unmanaged node never offers: two
    seconds for each planner of a scene, while a recording launch holds the cell clock for the bring-up.
    """
    from rclpy.lifecycle import LifecycleNode

    offered = node_class(spec.package, spec.executable)
    return None if offered is None else issubclass(offered, LifecycleNode)


def bring_up(
    node: Any,
    executor: Any,
    processes: list[NodeProcess],
    between: Callable[[], object] | None = None,
    keep_going: Callable[[], bool] = lambda: True,
) -> dict[str, str]:
    """Bring every managed node to its scene's lifecycle target, in scene order; return the states.

    A node without lifecycle services is left as it is ("unmanaged"), and so is one already at or past
    its target, or in a transition (another client of the scene is moving it). A refused transition
    stops the launch with the node's own reason. A stop signal (``keep_going`` false) ends the bring-up
    at once, and a node whose process has ended is left ("exited") at once too, never waited for: the
    launch's loop decides what its death means (in lockstep the clock drops it and the cell goes on).
    """
    states: dict[str, str] = {}
    for process in processes:
        if not keep_going():
            break
        if between is not None:
            between()  # e.g. the recorder's discovery: the scene is running while it is brought up
        target = process.spec.fully_qualified_name
        if is_managed_node(process.spec) is False:
            states[target] = "unmanaged"  # known from its class: no wait for services that never come
            continue
        client = LifecycleClient(node, executor, target, keep_going=_while_alive(process, keep_going))
        try:
            if not client.is_managed():
                states[target] = "unmanaged"
                continue
            state = client.get_state()
            if RANK.get(state, len(RANK)) >= RANK[process.spec.lifecycle]:
                # Forward only: a node already at or past its target (a controller of the scene brought
                # it up, or is doing so now) is left to it, never taken back.
                states[target] = state
                continue
            states[target] = client.bring_to(process.spec.lifecycle)
        except LifecycleInterruptedError:
            if not keep_going():
                break
            states[target] = "exited"
        except LifecycleError as error:
            reason = _configuration_error(node, executor, target)
            raise FeederError(f"{error}{': ' + reason if reason else ''}") from None
        finally:
            client.close()
    return states


def _launch(args: argparse.Namespace) -> int:
    scene = with_overrides(load_scene(args.scene), args.set) if args.set else load_scene(args.scene)
    if args.duration is not None and args.duration <= 0:
        raise InputError("--duration", f"must be > 0 seconds, got {args.duration}")
    if not (args.quantum > 0):
        raise InputError("--quantum", f"must be > 0 seconds, got {args.quantum}")
    if args.start_time < 0:
        raise InputError("--start-time", f"must be >= 0 seconds, got {args.start_time}")
    if not (args.lockstep_timeout > 0):
        raise InputError("--lockstep-timeout", f"must be > 0 seconds, got {args.lockstep_timeout}")
    if args.record:
        output_directory(args.record, "--record", must_be_new=True)
    if args.log_dir:
        output_directory(args.log_dir, "--log-dir")
    log_dir = Path(args.log_dir) if args.log_dir else Path(tempfile.mkdtemp(prefix=f"feeder-{scene.name}-"))
    sim_time = args.real_time_factor is not None
    specs = list(scene.nodes)
    participants = [s for s in specs if joins_lockstep(s.package, s.executable)]
    if sim_time:
        expect: list[ParameterScalar] = [s.fully_qualified_name for s in participants]
        if args.record:
            expect.append(f"/{LAUNCH_NODE}")
        clock = NodeSpec(
            CLOCK_NODE.package,
            CLOCK_NODE.executable,
            {
                "real_time_factor": args.real_time_factor,
                "lockstep": True,
                "quantum": args.quantum,
                "lockstep_expect": expect or [""],
                "start_time": args.start_time,
                "lockstep_timeout": args.lockstep_timeout,
                "on_lockstep_timeout": args.on_lockstep_timeout,
            },
        )
        specs.insert(0, clock)
        specs.insert(1, simulation_spec(specs[1:], args.quantum))

    def work(node: Any, executor: Any, keep_going: Callable[[], bool]) -> dict[str, Any]:
        from feeder_cell.bag.recorder import Recorder
        from feeder_cell.lockstep_observer import CellTime, RecordingObserver

        processes: list[NodeProcess] = []
        ended_scene = False  # a node's end ended the scene (a controller done with its cycles)
        cell_time = CellTime(node) if sim_time else None
        recorder = None
        observer = None
        if args.record and sim_time:
            # Recording in lockstep, the recorder holds each quantum until it has taken in all of it,
            # and logs each message at the cell time of its quantum.
            observer = RecordingObserver(node, int(round(args.quantum * 1e9)))
            recorder = Recorder(node, Path(args.record), clock=observer.log_time_ns, wait_for_clock=True)
            observer.recorder = recorder
        elif args.record:
            recorder = Recorder(node, Path(args.record))
        states: dict[str, str] = {}
        try:
            groups = host_groups(specs, participants, args)
            host_of = {id(member): name for name, members in groups.items() for member in members}
            for spec in specs:
                if not keep_going():
                    break  # interrupted during start-up: end what was started, no traceback
                host = host_of.get(id(spec))
                if host is not None:
                    members = groups[host]
                    if spec is members[0]:
                        with_extra = [(m, extra_parameters(m, specs, participants, args)) for m in members]
                        processes += start_host(host, with_extra, log_dir)
                    continue
                extra = extra_parameters(spec, specs, participants, args)
                processes.append(start_node(spec, log_dir, extra_parameters=extra))
            processes.sort(key=lambda p: specs.index(p.spec))  # the scene's order: the bring-up's
            _wait_until_in_graph(node, executor, processes, keep_going)
            if observer is not None and keep_going():
                # Subscribed to every topic the scene's nodes made at start-up before the clock's join
                # completes (it waits for the recorder): the recording starts at the start time.
                observer.start(
                    executor,
                    keep_going,
                    [(p.spec.node_name, p.spec.namespace) for p in processes],
                    participants=tuple(s.fully_qualified_name for s in participants),
                )
            if keep_going():
                # Recording starts before the bring-up, which takes a while: a controller in the scene
                # is working already.
                discover = None
                if recorder and observer is None:

                    def discover() -> None:
                        _discover_matched(recorder, node, executor, keep_going)

                states = bring_up(node, executor, processes, discover, keep_going)
            started = time.monotonic()
            next_discovery = 0.0
            while keep_going() and (args.duration is None or time.monotonic() - started < args.duration):
                if recorder and observer is None and time.monotonic() >= next_discovery:
                    recorder.discover()
                    next_discovery = time.monotonic() + 0.5
                if any(not p.alive() and not _dropped_by_clock(p, sim_time, participants) for p in processes):
                    # A node that ends mid-run ends the scene: on_exit shutdown (a controller done with
                    # its cycles) by design, any other as a failure; exit codes are reported below. In
                    # lockstep a device that dies is the clock's to drop (--on-lockstep-timeout).
                    ended_scene = True
                    break
                executor.spin_once(timeout_sec=0.001 if observer and observer.holding() else 0.05)
                if observer is not None:
                    observer.after_spin(executor)
        finally:
            if recorder is not None and keep_going() and ended_scene:
                _drain(executor)
            if observer is not None:
                observer.leave()
            stats = recorder.close() if recorder else {}
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
        result: dict[str, Any] = {
            "scene": scene.name,
            "log_dir": str(log_dir),
            "real_time_factor": "max" if args.real_time_factor == 0 else args.real_time_factor,
            "nodes": [
                {
                    "package": p.package,
                    "executable": p.executable,
                    "name": p.spec.fully_qualified_name,
                    "pid": p.pid,
                    "host": p.host,
                    "lifecycle": states.get(p.spec.fully_qualified_name, "unmanaged"),
                    "on_exit": p.spec.on_exit,
                    "ended_scene": not alive and p.spec.on_exit == "shutdown",
                    "died_early": not alive and p.spec.on_exit != "shutdown",
                    "exit_code": code,
                    "cpu_s": cpu.get(p.spec.fully_qualified_name),
                }
                for p, alive, code in codes
            ],
        }
        hosts = host_reports(codes)
        if hosts:
            result["hosts"] = hosts
            for report in hosts:
                if report["died_early"]:
                    # One line for the host, not one death per node: they are one process.
                    print(
                        f"feeder launch: cell host {report['name']} (pid {report['pid']}) ended with exit "
                        f"code {report['exit_code']}, and with it its nodes {', '.join(report['nodes'])}",
                        file=sys.stderr,
                    )
        if cell_time is not None:
            result["cell_time"] = cell_time.summary()
        if recorder:
            result["bag"] = {
                "path": str(Path(args.record).resolve()),
                "topics": {n: {"type": s.type_name, "count": s.count} for n, s in sorted(stats.items())},
            }
        return result

    result = with_node(LAUNCH_NODE, work, use_sim_time=sim_time)
    emit(args, result, _summary)
    return exit_code(result["nodes"])


def host_reports(codes: list[tuple[NodeProcess, bool, int | None]]) -> list[dict[str, Any]]:
    """Return one report per cell host: its pid, nodes, exit code, and whether it died before the end."""
    hosts: dict[str, dict[str, Any]] = {}
    for process, alive, code in codes:
        if not process.host:
            continue
        host = hosts.setdefault(
            process.host,
            {"name": process.host, "pid": process.pid, "nodes": [], "exit_code": code, "died_early": False},
        )
        host["nodes"].append(process.spec.fully_qualified_name)
        host["died_early"] = host["died_early"] or (not alive and process.spec.on_exit != "shutdown")
    return list(hosts.values())


def _dropped_by_clock(process: NodeProcess, sim_time: bool, participants: list[NodeSpec]) -> bool:
    """Whether a dead node leaves the scene running: a lockstep participant, which the clock drops.

    Not a node whose on_exit ends the scene (the controller done with its cycles).
    """
    return sim_time and process.spec in participants and process.spec.on_exit != "shutdown"


def exit_code(nodes: list[dict[str, Any]]) -> int:
    """Return the launch's exit code: the code of an on_exit node that ended the scene, else 1 if any died.

    A node ended by a signal (negative code) gives 1; a node that died early makes a 0 a 1.
    """
    failed = 1 if any(n["died_early"] for n in nodes) else 0
    for node in nodes:
        if node["ended_scene"]:
            code = node["exit_code"]
            return (code if isinstance(code, int) and code >= 0 else 1) or failed
    return failed


def _summary(result: dict[str, Any]) -> str:
    lines = [f"scene {result['scene']}: logs in {result['log_dir']}"]
    if "cell_time" in result:
        t = result["cell_time"]
        lines.append(
            f"  cell clock: {t['cell_s']:.3f} s of cell time in {t['wall_s']:.3f} s of wall time after the "
            f"first quantum: real-time factor {t['achieved_real_time_factor']:.3g} "
            f"(asked {result['real_time_factor']})"
        )
    for n in result["nodes"]:
        state = "DIED EARLY" if n["died_early"] else "ended the scene" if n["ended_scene"] else "stopped"
        lines.append(
            f"  {n['name']} ({n['package']}/{n['executable']}) pid {n['pid']}: {n['lifecycle']}, "
            f"then {state}, exit code {n['exit_code']}"
            + (f", {n['cpu_s']:.1f} s of CPU" if n.get("cpu_s") is not None else "")
        )
    if "bag" in result:
        lines.append(bag_summary(result["bag"]))
    return "\n".join(lines)


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add this module's subcommands to the ``feeder`` parser."""
    parser = subparsers.add_parser(
        "launch",
        help="run the nodes of a scene file together (optionally recording a bag)",
        description="Start every node a scene file names (YAML: name, nodes: [{package, executable, name, "
        "namespace, remappings, parameters, lifecycle, on_exit}]; parameters ending in _file/_files are "
        "paths relative to the scene file), wait until all are in the ROS graph, bring each managed node to "
        "its lifecycle target (active by default; inactive or unconfigured on request), run for --duration "
        "seconds, until Ctrl-C or until a node with on_exit: shutdown exits (the launch then exits with that "
        "node's exit code), then end each by pid (SIGINT, then SIGKILL). A scene runs only the models it "
        "names.",
    )
    parser.add_argument("scene", help="scene file, e.g. feeder_cell/scenes/demo.yaml")
    parser.add_argument("--duration", type=finite_float, help="seconds to run (default: until Ctrl-C)")
    parser.add_argument("--record", help="record every topic into this new bag directory (rosbag2, MCAP)")
    parser.add_argument(
        "--real-time-factor",
        type=real_time_factor,
        metavar="F",
        help="run one cell clock in lockstep (docs/cell.md) and set use_sim_time on every node: cell time "
        "advances by --quantum once every device, the controller and the recorder are done with the "
        "present quantum, at most F simulated seconds per wall second (F > 0), or as fast as they allow "
        "(max); without it every node runs on wall time",
    )
    parser.add_argument(
        "--quantum",
        type=finite_float,
        default=DEFAULT_QUANTUM,
        metavar="S",
        help=f"cell seconds per lockstep advance (default {DEFAULT_QUANTUM:g})",
    )
    parser.add_argument(
        "--start-time",
        type=finite_float,
        default=0.0,
        metavar="S",
        help="cell time at start, s since the epoch (default 0: the wall time at start); a fixed start "
        "makes two runs' stamps comparable",
    )
    parser.add_argument(
        "--lockstep-timeout",
        type=finite_float,
        default=30.0,
        metavar="S",
        help="wall seconds a lockstep participant may take to answer before it is dropped (default 30)",
    )
    parser.add_argument(
        "--on-lockstep-timeout",
        choices=("drop", "stop"),
        default="drop",
        help="drop: the cell goes on without the participant (an ERROR in /diagnostics names it); "
        "stop: the clock holds where it is (default drop)",
    )
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="NODE.PARAM=VALUE",
        help="set a node's parameter for this run, over the scene file's (NODE: its name, e.g. "
        "cell_controller.cycles=1; VALUE: YAML); checked against the node's declarations; repeatable",
    )
    parser.add_argument(
        "--host-controller",
        action="store_true",
        help="on the cell clock, run the scene's reference controller in the cell host too (it then reacts "
        "by direct calls; default: a process of its own, over DDS)",
    )
    parser.add_argument(
        "--one-process-per-node",
        action="store_true",
        help="on the cell clock, run every node in a process of its own (default: the clock, "
        "cell_simulation and the devices share one cell host process, lockstep among them by direct "
        "calls; docs/cell.md)",
    )
    parser.add_argument("--log-dir", help="where node logs go (default: a new temporary folder)")
    add_json_flag(parser)
    parser.set_defaults(handler=_launch)
