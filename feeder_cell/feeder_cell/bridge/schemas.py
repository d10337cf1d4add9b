"""The ``ros2msg`` schema of a topic's type, as rosbag2 writes it into MCAP (and Foxglove reads it).

The definition text is the bag writer's (``feeder_cell.bag.types``): the type's .msg text, then every
nested type after a separator line and ``MSG: pkg/Name``. So a live channel and a recorded one of the
same topic carry the same schema.
"""

from __future__ import annotations

from feeder_cell.bag import types

__all__ = ["schema_of", "service_schemas"]


def schema_of(type_name: str) -> tuple[str, str] | None:
    """Return (schema name, ros2msg definition text) of a ROS type, or None when it cannot be described."""
    try:
        return type_name, types.connection_definition(type_name)[
            0
        ]  # also service event and action feedback types
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
