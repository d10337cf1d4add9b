"""The squeeze gripper device's parameters, ROS-free: one declaration for the node, the scene and the docs.

Each entry is a ``ParameterSpec`` (type by its default, meaning, check, read-only or runtime). The node
declares them to rclpy with the display parameters of the node kit; the launcher's scene validation and
the docs' parameter table read them from here without ROS. ``configure_gripper`` builds the model from
validated values, every problem naming its parameter (a failed lifecycle configure says which).
"""

from __future__ import annotations

from dataclasses import dataclass

from feeder_device.parameters import DeviceParameters
from feeder_planner.errors import InputError
from feeder_planner.parameter_specs import (
    finite,
    in_range,
    non_empty_string,
    non_negative,
    one_of,
    param,
    positive,
)
from feeder_planner.parts import Part, load_part
from feeder_planner.squeeze.tolerances import MAX_FRICTION
from feeder_sim.squeeze.dynamic import DynamicSettings
from feeder_sim.squeeze.gripper import FIDELITIES, SqueezeGripper
from feeder_sim.squeeze.tolerances import MAX_JAW_SPEED, MAX_TURN_SPEED

__all__ = ["BASE_FRAME", "GripperParameters", "configure_gripper"]

BASE_FRAME = "squeeze_gripper"


# Read-only, and why: the part and the fidelity define the model configure builds; open_width is checked
# against the part there; the start orientation only means something at configure; publish_rate is the
# timer and the rate status measures against; frame_id stamps every stream. The runtime ones (friction,
# jaw_speed, turn_speed, dynamic_step) apply from the next squeeze.
@dataclass(frozen=True)
class GripperParameters(DeviceParameters):
    """The squeeze gripper's parameters (the device kit's come with ``DeviceParameters``)."""

    part_file: str = param(
        "", "part file (YAML, contract section 2); required", non_empty_string("a part file"), read_only=True
    )
    fidelity: str = param(
        "ideal",
        "ideal (Goldberg's frictionless quasi-static squeeze) or dynamic (pymunk: friction, jaw speed)",
        one_of(FIDELITIES),
        read_only=True,
    )
    friction: float = param(
        0.0,
        f"Coulomb friction between jaws and part, in [0, {MAX_FRICTION:g}] (the dynamic fidelity's; the "
        "ideal one is frictionless); applied from the next squeeze",
        in_range(0.0, MAX_FRICTION),
    )
    jaw_speed: float = param(
        0.05,
        f"closing speed of the jaws (m/s, in (0, {MAX_JAW_SPEED:g}]); applied from the next squeeze",
        in_range(0.0, MAX_JAW_SPEED, include_low=False, unit="m/s"),
    )
    turn_speed: float = param(
        3.0,
        f"turning speed of the gripper (rad/s, in (0, {MAX_TURN_SPEED:g}]); applied from the next squeeze",
        in_range(0.0, MAX_TURN_SPEED, include_low=False, unit="rad/s"),
    )
    open_width: float = param(
        0.0, "jaw opening (m); 0: 1.2 x the part's largest width", non_negative, read_only=True
    )
    dynamic_step: float = param(
        5e-4, "pymunk step (s) of the dynamic fidelity; applied from the next squeeze", positive
    )
    place_part: bool = param(True, "place the part between the jaws at configure", read_only=True)
    initial_orientation: float = param(
        0.0, "orientation of the part placed at configure (rad, world frame)", finite, read_only=True
    )
    publish_rate: float = param(
        50.0,
        "rate of the state, joint state and part pose streams (Hz of the node clock): the main stream",
        positive,
        read_only=True,
    )
    frame_id: str = param(
        "",
        f"frame of the part pose and markers (the gripper's base, jaws in its plane); empty: {BASE_FRAME} "
        "under the node's namespace",
        read_only=True,
    )


def configure_gripper(p: GripperParameters) -> tuple[SqueezeGripper, Part]:
    """Load the part and build the gripper from validated parameter values ``p`` (errors name them)."""
    try:
        part = load_part(p.part_file)
    except InputError as error:
        raise InputError("parameter part_file", str(error)) from None
    try:
        gripper = SqueezeGripper(
            part.outer,
            fidelity=p.fidelity,
            friction=p.friction,
            jaw_speed=p.jaw_speed,
            turn_speed=p.turn_speed,
            open_width=p.open_width,
            dynamic=DynamicSettings(step=p.dynamic_step),
            seed=p.fault_seed,
        )
    except InputError as error:
        field = "part_file" if error.field == "vertices" else error.field
        raise InputError(f"parameter {field}", error.problem) from None
    if p.place_part:
        gripper.place(p.initial_orientation)
    return gripper, part
