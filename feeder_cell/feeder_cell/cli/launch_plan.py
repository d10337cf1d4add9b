"""What ``feeder launch`` runs, decided before anything starts: the checked arguments and every node.

On the cell clock the plan adds the clock and cell_simulation in front of the scene's nodes, and
decides which nodes share a cell host and what each node's parameters gain.
"""

from __future__ import annotations

import argparse
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from feeder_cell.cli.common import output_directory
from feeder_cell.launcher import (
    NO_HOST,
    NodeSpec,
    ParameterScalar,
    Scene,
    hostable,
    joins_lockstep,
    load_scene,
    with_overrides,
)
from feeder_planner.errors import InputError

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
HOST_NAME = "cell_host"


@dataclass(frozen=True)
class LaunchPlan:
    """A launch's checked arguments and its nodes, in start order (on the cell clock: clock first)."""

    args: argparse.Namespace
    scene: Scene
    log_dir: Path
    sim_time: bool
    specs: list[NodeSpec]
    participants: list[NodeSpec]  # the scene's lockstep participants


def plan_launch(args: argparse.Namespace) -> LaunchPlan:
    """Load the scene, check the arguments (in this order: a user sees the first mistake), list the nodes."""
    scene = with_overrides(load_scene(args.scene), args.set) if args.set else load_scene(args.scene)
    _check_arguments(args)
    log_dir = Path(args.log_dir) if args.log_dir else Path(tempfile.mkdtemp(prefix=f"feeder-{scene.name}-"))
    sim_time = args.real_time_factor is not None
    specs = list(scene.nodes)
    participants = [s for s in specs if joins_lockstep(s.package, s.executable)]
    if sim_time:
        specs.insert(0, _clock_spec(args, participants))
        specs.insert(1, simulation_spec(specs[1:], args.quantum))
    return LaunchPlan(args, scene, log_dir, sim_time, specs, participants)


def _check_arguments(args: argparse.Namespace) -> None:
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


def _clock_spec(args: argparse.Namespace, participants: list[NodeSpec]) -> NodeSpec:
    """Return the lockstep cell clock: each quantum it waits for every participant (and the recorder)."""
    expect: list[ParameterScalar] = [s.fully_qualified_name for s in participants]
    if args.record:
        expect.append(f"/{LAUNCH_NODE}")
    return NodeSpec(
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
