"""Throwing test fixtures: listeners that live for the whole session.

The test client's executor spins on its own thread; destroying a subscription from the test thread races
with it (the executor enters a waitable whose QoS event handler then raises InvalidHandle in
``add_to_wait_set``), the harness's spin thread ends silently, and every later test of the session times
out. So the throwing tests never destroy a subscription: ``listen`` gives one subscription per topic for
the whole session, and waits read its buffer (the same remedy as the MEMS tests'; see the report on
``ros_harness.collect``, which still destroys its subscription).
"""

from __future__ import annotations

import threading
import time
from typing import Any, Callable

import pytest


class Listener:
    """One subscription of the test client for the whole session, with every message it received."""

    def __init__(self, client: Any, msg_type: Any, topic: str, qos: Any) -> None:
        self.topic = topic
        self.messages: list[Any] = []
        self.arrived = threading.Condition()
        client.create_subscription(msg_type, topic, self._on_message, qos)

    def _on_message(self, msg: Any) -> None:
        with self.arrived:
            self.messages.append(msg)
            self.arrived.notify_all()

    def count(self) -> int:
        """Return how many messages arrived so far (a mark for ``since``)."""
        with self.arrived:
            return len(self.messages)

    def since(self, mark: int) -> list[Any]:
        """Return the messages that arrived after ``mark``."""
        with self.arrived:
            return self.messages[mark:]

    def wait(
        self, accept: Callable[[Any], bool] = lambda m: True, timeout: float = 30.0, current: bool = False
    ) -> Any:
        """Return the first message from now on that ``accept`` takes; ``current``: the latest counts too."""
        deadline = time.monotonic() + timeout
        with self.arrived:
            index = max(0, len(self.messages) - 1) if current else len(self.messages)
            while True:
                while index < len(self.messages):
                    msg = self.messages[index]
                    index += 1
                    if accept(msg):
                        return msg
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    last = self.messages[-1] if self.messages else None
                    raise AssertionError(
                        f"no accepted message on {self.topic} within {timeout} s; last: {last}"
                    )
                self.arrived.wait(remaining)


@pytest.fixture(scope="session")
def listen(ros_client: Any) -> Callable[..., Listener]:
    """Return the session's listener of a topic (created at first use, never destroyed)."""
    from feeder_planner.node_kit import LATCHED

    listeners: dict[tuple[Any, str, bool], Listener] = {}

    def get(msg_type: Any, topic: str, latched: bool = False) -> Listener:
        key = (msg_type, topic, latched)
        if key not in listeners:
            listeners[key] = Listener(ros_client, msg_type, topic, LATCHED if latched else 200)
        return listeners[key]

    return get
