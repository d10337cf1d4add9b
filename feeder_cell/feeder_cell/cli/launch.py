"""``feeder launch``: run the nodes of a scene file together, optionally recording a bag, end them by pid."""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path
from typing import Any

from feeder_cell.cli.bag import _summary as bag_summary
from feeder_cell.cli.bag import _with_node
from feeder_cell.cli.common import add_json_flag, emit, finite_float
from feeder_cell.launcher import NodeProcess, load_scene, start_node
from feeder_planner.errors import FeederError, InputError

STARTUP_TIMEOUT_S = 30.0


def _wait_until_in_graph(node: Any, executor: Any, processes: list[NodeProcess]) -> None:
    deadline = time.monotonic() + STARTUP_TIMEOUT_S
    names = {p.spec.name or p.spec.executable: p for p in processes}
    while True:
        executor.spin_once(timeout_sec=0.1)
        dead = [p for p in processes if not p.alive()]
        if dead:
            p = dead[0]
            raise FeederError(
                f"{p.package}/{p.executable} exited with code {p.process.returncode} at start-up; "
                f"last log line: {(p.output().strip().splitlines() or ['(none)'])[-1]}"
            )
        missing = sorted(set(names) - set(node.get_node_names()))
        if not missing:
            return
        if time.monotonic() > deadline:
            raise FeederError(f"nodes not in the graph after {STARTUP_TIMEOUT_S:.0f} s: {', '.join(missing)}")


def _launch(args: argparse.Namespace) -> int:
    scene = load_scene(args.scene)
    if args.duration is not None and args.duration <= 0:
        raise InputError("--duration", f"must be > 0 seconds, got {args.duration}")
    log_dir = Path(args.log_dir) if args.log_dir else Path(tempfile.mkdtemp(prefix=f"feeder-{scene.name}-"))

    def work(node: Any, executor: Any, keep_going: Any) -> dict[str, Any]:
        from feeder_cell.bag.recorder import Recorder

        processes: list[NodeProcess] = []
        recorder = Recorder(node, Path(args.record)) if args.record else None
        try:
            for spec in scene.nodes:
                processes.append(start_node(spec, log_dir))
            _wait_until_in_graph(node, executor, processes)
            started = time.monotonic()
            next_discovery = 0.0
            while keep_going() and (args.duration is None or time.monotonic() - started < args.duration):
                if recorder and time.monotonic() >= next_discovery:
                    recorder.discover()
                    next_discovery = time.monotonic() + 0.5
                if any(not p.alive() for p in processes):
                    break  # a node that dies mid-run ends the scene; its exit code is reported below
                executor.spin_once(timeout_sec=0.05)
        finally:
            stats = recorder.close() if recorder else {}
            codes = [(p, p.alive(), p.stop()) for p in processes]
        result: dict[str, Any] = {
            "scene": scene.name,
            "log_dir": str(log_dir),
            "nodes": [
                {
                    "package": p.package,
                    "executable": p.executable,
                    "pid": p.pid,
                    "died_early": not alive,
                    "exit_code": code,
                }
                for p, alive, code in codes
            ],
        }
        if recorder:
            result["bag"] = {
                "path": str(Path(args.record).resolve()),
                "topics": {n: {"type": s.type_name, "count": s.count} for n, s in sorted(stats.items())},
            }
        return result

    result = _with_node("feeder_launch", work)
    emit(args, result, _summary)
    return 1 if any(n["died_early"] for n in result["nodes"]) else 0


def _summary(result: dict[str, Any]) -> str:
    lines = [f"scene {result['scene']}: logs in {result['log_dir']}"]
    for n in result["nodes"]:
        state = "DIED EARLY" if n["died_early"] else "stopped"
        lines.append(
            f"  {n['package']}/{n['executable']} pid {n['pid']}: {state}, exit code {n['exit_code']}"
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
        "parameters}]; parameters ending in _file/_files are paths relative to the scene file), "
        "wait until all are in the ROS graph, run for --duration seconds or until Ctrl-C, then end "
        "each by pid (SIGINT, then SIGKILL). A scene runs only the models it names.",
    )
    parser.add_argument("scene", help="scene file, e.g. feeder_cell/scenes/demo.yaml")
    parser.add_argument("--duration", type=finite_float, help="seconds to run (default: until Ctrl-C)")
    parser.add_argument("--record", help="record every topic into this new bag directory (rosbag2, MCAP)")
    parser.add_argument("--log-dir", help="where node logs go (default: a new temporary folder)")
    add_json_flag(parser)
    parser.set_defaults(handler=_launch)
