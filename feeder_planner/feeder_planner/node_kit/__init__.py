"""The node kit: what every feeder node shares, so that nodes never reach into each other.

Parameters (declared with descriptions, validated once), the service guard, ``run_node``, the QoS
profiles and the conversions between messages and the mechanics. This subpackage and the node modules
are the only parts of ``feeder_planner`` that import rclpy.
"""

from feeder_planner.node_kit.msg_geometry import from_vec, planar_pose, point, vec, yaw_quaternion
from feeder_planner.node_kit.parameters import (
    Check,
    ParameterSpec,
    check_value,
    declare_parameters,
    finite,
    in_range,
    integer,
    integer_at_least,
    negative,
    non_empty_string,
    non_negative,
    one_of,
    positive,
)
from feeder_planner.node_kit.qos import EVENT_DEPTH, LATCHED, LATCHED_EVENTS, STREAM_DEPTH
from feeder_planner.node_kit.runner import run_node
from feeder_planner.node_kit.services import ServiceResponse, service_guard

__all__ = [
    "Check",
    "ParameterSpec",
    "check_value",
    "declare_parameters",
    "finite",
    "in_range",
    "integer",
    "integer_at_least",
    "negative",
    "non_empty_string",
    "non_negative",
    "one_of",
    "positive",
    "LATCHED",
    "LATCHED_EVENTS",
    "STREAM_DEPTH",
    "EVENT_DEPTH",
    "run_node",
    "ServiceResponse",
    "service_guard",
    "from_vec",
    "planar_pose",
    "point",
    "vec",
    "yaw_quaternion",
]
