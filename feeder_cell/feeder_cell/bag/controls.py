"""The pause controls a recorder and a player both serve, as rosbag2 names and shapes them.

``~/pause``, ``~/resume``, ``~/toggle_paused`` and ``~/is_paused`` (feeder_msgs types with the names and
fields of rosbag2_interfaces), each with the kit's deep request queue: a script that steps or toggles in a
burst must not lose requests.
"""

from __future__ import annotations

from typing import Callable, TypeVar

from rclpy.node import Node
from rclpy.service import Service

from feeder_planner.node_kit.qos import request_qos

__all__ = ["serve_pause_controls"]

# A service response message: a callback fills in and returns the one it is handed.
Response = TypeVar("Response")


def serve_pause_controls(
    node: Node,
    pause: Callable[[], object],
    resume: Callable[[], object],
    toggle: Callable[[], object],
    paused: Callable[[], bool],
) -> list[Service]:
    """Serve the four pause services on ``node``; return the services (the caller keeps them alive).

    Parameters
    ----------
    node
        The recorder's or player's node: the services are private names of it.
    pause, resume, toggle
        What each request does (their return values are ignored).
    paused
        Whether the recorder or player is paused now, for ``~/is_paused``.
    """
    from feeder_msgs.srv import IsPaused, Pause, Resume, TogglePaused

    def doing(action: Callable[[], object]) -> Callable[[object, Response], Response]:
        def callback(_request: object, response: Response) -> Response:
            action()
            return response

        return callback

    def is_paused(_request: IsPaused.Request, response: IsPaused.Response) -> IsPaused.Response:
        response.paused = paused()
        return response

    qos = request_qos()
    return [
        node.create_service(Pause, "~/pause", doing(pause), qos_profile=qos),
        node.create_service(Resume, "~/resume", doing(resume), qos_profile=qos),
        node.create_service(TogglePaused, "~/toggle_paused", doing(toggle), qos_profile=qos),
        node.create_service(IsPaused, "~/is_paused", is_paused, qos_profile=qos),
    ]
