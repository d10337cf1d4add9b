"""node_kit.action_client.ActionClient: a goal sent off the executor thread is never lost (ros2/rclpy#1123).

The race needs the server's answer to be executed between rclpy sending the request and recording it. A
forwarding wrapper of the client's handle holds that window open (it sleeps after the send), so the answer
always arrives inside it: rclpy's own client then loses the goal, ours answers it.
"""

from __future__ import annotations

import time
from typing import Any

import pytest

WINDOW_S = 0.5  # the held-open window between sending a goal request and recording it
ANSWER_TIMEOUT_S = 2.0


class _SlowSend:
    """The client's rcl handle, sleeping after each goal request is sent (before rclpy records it)."""

    def __init__(self, handle: Any) -> None:
        self._handle = handle

    def send_goal_request(self, request: Any) -> Any:
        sequence = self._handle.send_goal_request(request)
        time.sleep(WINDOW_S)
        return sequence

    def __getattr__(self, name: str) -> Any:
        return getattr(self._handle, name)

    def __enter__(self) -> Any:
        return self._handle.__enter__()

    def __exit__(self, *exc: Any) -> Any:
        return self._handle.__exit__(*exc)


def _goal_answered(client_class: type, ros_client: Any, name: str) -> bool:
    """Send one goal from this (non-executor) thread through a held-open window: is it answered?"""
    from feeder_msgs.action import FeedPart

    client = client_class(ros_client, FeedPart, name)
    try:
        assert client.wait_for_server(timeout_sec=10.0), f"action server {name} not found"
        client._client_handle = _SlowSend(client._client_handle)
        future = client.send_goal_async(FeedPart.Goal())
        deadline = time.monotonic() + ANSWER_TIMEOUT_S
        while not future.done() and time.monotonic() < deadline:
            time.sleep(0.01)
        return future.done()
    finally:
        client.destroy()


@pytest.fixture(scope="module")
def feed_part_server(ros_client: Any) -> Any:
    """A FeedPart action server on the test's client node that rejects every goal at once."""
    from rclpy.action import ActionServer, GoalResponse

    from feeder_msgs.action import FeedPart

    server = ActionServer(
        ros_client,
        FeedPart,
        "race_test/feed_part",
        execute_callback=lambda handle: FeedPart.Result(),
        goal_callback=lambda goal: GoalResponse.REJECT,
    )
    yield "race_test/feed_part"
    server.destroy()


@pytest.mark.ros
def test_a_goal_answered_inside_the_registration_window_reaches_our_client(
    ros_client: Any, feed_part_server: str
) -> None:
    from rclpy.action import ActionClient as RclpyActionClient

    from feeder_planner.node_kit.action_client import ActionClient

    # The window is real: rclpy's client drops the answer (if this starts passing, rclpy has the fix).
    assert not _goal_answered(RclpyActionClient, ros_client, feed_part_server)
    assert _goal_answered(ActionClient, ros_client, feed_part_server)
