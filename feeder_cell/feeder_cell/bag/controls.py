"""The pause controls a recorder and a player both serve, as rosbag2 names and shapes them.

``~/pause``, ``~/resume``, ``~/toggle_paused`` and ``~/is_paused`` (feeder_msgs types with the names and
fields of rosbag2_interfaces), each with the kit's deep request queue: a script that steps or toggles in a
burst must not lose requests.
"""

from __future__ import annotations

from typing import Any, Callable

from rclpy.node import Node

from feeder_planner.node_kit.qos import request_qos

__all__ = ["serve_pause_controls"]


def serve_pause_controls(
    node: Node,
    pause: Callable[[], Any],
    resume: Callable[[], Any],
    toggle: Callable[[], Any],
    paused: Callable[[], bool],
) -> list[Any]:
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

    def doing(action: Callable[[], Any]) -> Callable[[Any, Any], Any]:
        def callback(_request: Any, response: Any) -> Any:
            action()
            return response

        return callback

    def is_paused(_request: Any, response: Any) -> Any:
        response.paused = paused()
        return response

    qos = request_qos()
    return [
        node.create_service(Pause, "~/pause", doing(pause), qos_profile=qos),
        node.create_service(Resume, "~/resume", doing(resume), qos_profile=qos),
        node.create_service(TogglePaused, "~/toggle_paused", doing(toggle), qos_profile=qos),
        node.create_service(IsPaused, "~/is_paused", is_paused, qos_profile=qos),
    ]
