"""The cell host's executor: rclpy's single-threaded one, without the QoS event handlers in its wait set.

rclpy gives every publisher and subscription a default event handler (a log line when a peer's QoS is
incompatible), each a waitable its executor adds to the wait set, counts and asks "ready?" on every wait.
In the host, with every hosted node's publishers and subscriptions in one wait set, those were about 30 of
its 100 entities and, by a py-spy profile of the cell scene at max, a good part of the 29 % of the host's
time spent building and reading wait sets. The hosted nodes use no QoS event callbacks of their own, so
the host waits without them. What is lost is that log line for a hosted node (the same node run alone, or
with ``--one-process-per-node``, still logs it); a DDS peer sees no difference.
"""

from __future__ import annotations

from typing import Any

from rclpy.event_handler import EventHandler
from rclpy.executors import SingleThreadedExecutor

__all__ = ["HostExecutor"]


class HostExecutor(SingleThreadedExecutor):
    """A single-threaded executor that never waits for QoS events."""

    def can_execute(self, entity: Any) -> bool:
        """Whether ``entity`` is waited for and run: everything rclpy's executor runs but QoS events."""
        return not isinstance(entity, EventHandler) and super().can_execute(entity)
