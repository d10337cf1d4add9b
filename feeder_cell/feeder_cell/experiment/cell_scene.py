"""The cell loop's scene: the nodes it runs, their parameters checked as the nodes check them.

The loop runs a cell scene's three devices and the reference controller (``feeder_cell/scenes/cell.yaml``)
without their node modules (no rclpy): each device's parameters are its station's dataclass
(``feeder_sim.<device>.parameters``), the controller's its node's specs (``feeder_cell.controller.
parameters``), each checked here as the node checks it, one line naming the field.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from feeder_cell.controller.parameters import PARAMETERS as CONTROLLER_PARAMETERS
from feeder_cell.experiment.drivers import fault_specs_of
from feeder_planner.errors import InputError
from feeder_planner.fields_io import load_yaml_mapping
from feeder_planner.parameter_specs import check_value, from_values, specs_of
from feeder_sim.fixture.parameters import FixtureParameters
from feeder_sim.mems.parameters import MemsParameters
from feeder_sim.throwing.parameters import ArmParameters

if TYPE_CHECKING:
    from feeder_cell.launcher import Scene

__all__ = [
    "CONTROLLER_SPECS",
    "DEVICES",
    "PARAMETER_CLASSES",
    "controller_parameters",
    "device_parameters",
    "read_scene",
    "check_scene",
]

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


def device_parameters(cls: type, values: dict[str, Any], node: str) -> Any:
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
            device_parameters(PARAMETER_CLASSES[node.executable], node.parameters, node.executable)
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
        known = fault_specs_of(executable)
        if spec.fault not in known:
            raise InputError(
                f"faults.{spec.device}.fault",
                f"unknown fault {spec.fault!r}; {executable} knows {', '.join(sorted(known))}",
            )
    return scene
