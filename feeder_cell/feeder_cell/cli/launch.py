"""``feeder launch``: run the nodes of a scene file together, optionally recording a bag, end them by pid.

The steps, each in a module of its own: launch_plan checks the arguments and lists the nodes,
launch_run starts them, brings them up (launch_bring_up), records (launch_recording), runs and stops
them, and launch_report builds the result and the exit code.
"""

from __future__ import annotations

import argparse
from typing import Any, Callable

from feeder_cell.cli.common import add_json_flag, emit, finite_float
from feeder_cell.cli.launch_plan import CLOCK_NODE, LAUNCH_NODE, SIMULATION_NODE, host_groups, plan_launch
from feeder_cell.cli.launch_report import exit_code, summary
from feeder_cell.cli.launch_run import run_scene
from feeder_cell.ros_session import with_node

__all__ = ["CLOCK_NODE", "SIMULATION_NODE", "clock_rate", "host_groups", "real_time_factor", "register"]

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


def _launch(args: argparse.Namespace) -> int:
    plan = plan_launch(args)

    def work(node: Any, executor: Any, keep_going: Callable[[], bool]) -> dict[str, Any]:
        return run_scene(plan, node, executor, keep_going)

    result = with_node(LAUNCH_NODE, work, use_sim_time=plan.sim_time)
    emit(args, result, summary)
    return exit_code(result["nodes"])


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
    _add_cell_clock_flags(parser)
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="NODE.PARAM=VALUE",
        help="set a node's parameter for this run, over the scene file's (NODE: its name, e.g. "
        "cell_controller.cycles=1; VALUE: YAML); checked against the node's declarations; repeatable",
    )
    _add_process_flags(parser)
    parser.add_argument("--log-dir", help="where node logs go (default: a new temporary folder)")
    add_json_flag(parser)
    parser.set_defaults(handler=_launch)


def _add_cell_clock_flags(parser: argparse.ArgumentParser) -> None:
    """Add the flags of the lockstep cell clock: its pace, quantum, start time and timeouts."""
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


def _add_process_flags(parser: argparse.ArgumentParser) -> None:
    """Add the flags that decide which nodes share the cell host's process."""
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
