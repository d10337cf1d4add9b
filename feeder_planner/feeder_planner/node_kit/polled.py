"""A subscription the executor never wakes for: its messages are taken when the node needs them.

A node that only needs the latest sample of a stream when a request comes (the simulation node's entity
states: the arm publishes its part's pose 100 times a cell second) would otherwise be woken, and its wait set
rebuilt, for every sample: at a cell clock many times real time that was most of what it cost. The
subscription here is matched and queues in DDS as any other (its QoS bounds the queue: the latest ``depth``
samples), but it belongs to a callback group no executor may run, so it is never in a wait set; ``take``
runs its callback on every queued message, oldest first, when the node asks.
"""

from __future__ import annotations

from typing import Any, Callable

from rclpy.callback_groups import CallbackGroup
from rclpy.node import Node
from rclpy.qos import QoSProfile

__all__ = ["PolledSubscription"]


class _NeverExecuted(CallbackGroup):
    """A callback group whose entities no executor waits for or runs."""

    def can_execute(self, entity: Any) -> bool:
        return False

    def beginning_execution(self, entity: Any) -> bool:
        return False


class PolledSubscription:
    """A subscription taken on demand (``take``), never by the executor."""

    def __init__(
        self, node: Node, msg_type: Any, topic: str, on_message: Callable[[Any], None], qos: QoSProfile
    ) -> None:
        self.on_message = on_message
        self.subscription = node.create_subscription(
            msg_type, topic, on_message, qos, callback_group=_NeverExecuted()
        )

    def take(self) -> int:
        """Run the callback on every message queued since the last take, in order; return how many."""
        sub = self.subscription
        taken = 0
        with sub.handle:
            while (message_and_info := sub.handle.take_message(sub.msg_type, sub.raw)) is not None:
                self.on_message(message_and_info[0])
                taken += 1
        return taken
