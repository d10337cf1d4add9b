"""The ``ros2msg`` schema of a topic's type, as rosbag2 writes it into MCAP (and Foxglove reads it).

The definition text is the bag writer's (``feeder_cell.bag.types``): the type's .msg text, then every
nested type after a separator line and ``MSG: pkg/Name``. So a live channel and a recorded one of the
same topic carry the same schema.
"""

from __future__ import annotations

from feeder_cell.bag import types

__all__ = ["SCHEMA_ALIASES", "schema_of", "service_schemas"]

# Types advertised under another name with the same fields and bytes: our stand-in for tf2_msgs (see
# feeder_planner.node_kit.tf) is the standard TFMessage to Foxglove, whose 3D panel then uses the frames.
SCHEMA_ALIASES = {"feeder_msgs/msg/TFMessage": "tf2_msgs/msg/TFMessage"}


def schema_of(type_name: str) -> tuple[str, str] | None:
    """Return (schema name, ros2msg definition text) of a ROS type, or None when it cannot be described."""
    name = SCHEMA_ALIASES.get(type_name, type_name)
    source = name if types.is_known(name) else type_name
    try:
        return name, types.connection_definition(source)[0]  # also service event and action feedback types
    except Exception:  # noqa: BLE001 -- rosbags raises several unrelated errors for a type it cannot describe
        return None


def service_schemas(service_type: str) -> tuple[str, str] | None:
    """Return the ros2msg definitions of a service type's request and response, or None.

    A ``pkg/srv/Name`` service is described as the ROS foxglove_bridge describes it: its two halves
    ``pkg/srv/Name_Request`` and ``pkg/srv/Name_Response``, each a message definition with its nested types.
    """
    request = schema_of(f"{service_type}_Request")
    response = schema_of(f"{service_type}_Response")
    if request is None or response is None:
        return None
    return request[1], response[1]
