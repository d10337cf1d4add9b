"""rclpy's ActionClient without its registration race (ros2/rclpy#1123), for clients off the executor.

``rclpy.action.ActionClient.send_goal_async`` sends the request first and only then records its sequence
number. When an executor spins on another thread (the cell controller's cycle runs on its main thread, as do
the tests' clients), the server's answer can be taken and executed in between: rclpy logs "Ignoring
unexpected goal response. There may be more than one action server" and the goal's future never completes
(seen once in CI: the controller's feed_part goal "not answered in 20 s"). Result and cancel requests have
the same gap. Here a request is sent and recorded under one lock, and ``execute`` takes that lock before it
looks a response up, so it waits for a registration in flight. The fix proposed upstream (ros2/rclpy#1308)
locks the same way; Jazzy's rclpy does not have it.
"""

from __future__ import annotations

import threading
from typing import Any

from rclpy.action import ActionClient as _RclpyActionClient

__all__ = ["ActionClient"]


class ActionClient(_RclpyActionClient):
    """``rclpy.action.ActionClient`` whose requests are recorded before their responses are looked up."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._registration = threading.Lock()

    def send_goal_async(self, *args: Any, **kwargs: Any) -> Any:
        """Send a goal and record it under the lock (see the module docstring)."""
        with self._registration:
            return super().send_goal_async(*args, **kwargs)

    def _get_result_async(self, *args: Any, **kwargs: Any) -> Any:
        """Request a result and record it under the lock."""
        with self._registration:
            return super()._get_result_async(*args, **kwargs)

    def _cancel_goal_async(self, *args: Any, **kwargs: Any) -> Any:
        """Request a cancel and record it under the lock."""
        with self._registration:
            return super()._cancel_goal_async(*args, **kwargs)

    async def execute(self, taken_data: Any) -> None:
        """Wait for a registration in flight, then dispatch the responses as rclpy does.

        The lock is released before dispatching: a done callback that sends a new goal must not deadlock.
        """
        with self._registration:
            pass
        await super().execute(taken_data)
