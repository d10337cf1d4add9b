"""The recorder's raw readers: one per topic, with a profile that matches the topic's publishers.

A topic is subscribed only once it has a publisher (a subscriber alone makes a topic name visible, with
no QoS to learn from), with the publishers' reliability and durability, and re-checked on every
discovery: a newly appeared latched or best-effort publisher makes the recorder subscribe again with a
profile that matches it. The replacement reader's transient-local history repeats samples the reader it
replaced may have received live: ``Repeats`` knows a sample by its writer's timestamp and sequence number
and drops the repeats. Separate from the recorder because it is about matching publishers, not about
where messages go.

Locking: ``TopicReaders.offers`` is written and ``Repeats`` is used under the recorder's lock (as when
they were the recorder's own); the readers dict is the discovery's and close's (one thread at a time).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Any, Callable

from rclpy.node import Node
from rclpy.qos import QoSProfile

from feeder_cell.bag.qos import matching_qos, offered_qos
from feeder_cell.bag.types import message_class

__all__ = ["SUBSCRIPTION_DEPTH", "Offer", "Repeats", "TopicReaders"]

# Subscription depth: a backlog larger than this between two executor turns (a slow disk, a loaded
# machine) would be dropped by DDS; only a backlog costs its memory.
SUBSCRIPTION_DEPTH = 1000


@dataclass(frozen=True)
class Offer:
    """What a topic's publishers offer, as far as a subscription must match it."""

    reliable: bool  # every publisher reliable (one best-effort publisher needs a best-effort reader)
    latched: bool  # any publisher transient-local (its stored samples are wanted)


class TopicReaders:
    """The raw subscriptions by topic, each made (and made again) to match what its publishers offer."""

    def __init__(self, node: Node, qos_overrides: dict[str, QoSProfile]) -> None:
        self.node = node
        self.qos_overrides = qos_overrides
        self.offers: dict[str, Offer] = {}  # what each reader was made for (under the recorder's lock)
        self.readers: dict[str, Any] = {}

    def offer(self, name: str) -> Offer | None:
        """Return what a subscription must match now, or None while the topic has no publisher."""
        publishers = self.node.get_publishers_info_by_topic(name)
        if not publishers:
            return None
        offer = Offer(*offered_qos(publishers))
        previous = self.offers.get(name)
        if previous is not None:
            # Never step back: a latched publisher that went away leaves its samples recorded, and a
            # best-effort reader still matches reliable publishers. Only widening needs a new reader.
            offer = Offer(previous.reliable and offer.reliable, previous.latched or offer.latched)
        return offer

    def qos(self, name: str, offer: Offer) -> QoSProfile:
        """Return the profile a reader of ``name`` takes: its override, else one matching ``offer``."""
        return self.qos_overrides.get(name) or matching_qos(offer.reliable, offer.latched, SUBSCRIPTION_DEPTH)

    def replace(
        self, name: str, type_name: str, qos: QoSProfile, callback: Callable[[bytes, dict[str, int]], None]
    ) -> None:
        """Make the topic's reader with ``qos``, in place of the one it had (an overridden one stays)."""
        old = self.readers.pop(name, None)
        if old is not None and name in self.qos_overrides:
            self.readers[name] = old  # an overridden profile does not follow the publishers
            return
        if old is not None:
            # Replaced before the new reader exists: a gap of a few milliseconds for volatile samples;
            # a latched publisher's samples come again from its history (repeats are dropped by key).
            self.node.destroy_subscription(old)
        self.readers[name] = self.node.create_subscription(
            message_class(type_name), name, callback, qos, raw=True
        )

    def close(self) -> None:
        """Destroy every reader."""
        for subscription in self.readers.values():
            self.node.destroy_subscription(subscription)
        self.readers.clear()


class Repeats:
    """Per topic the keys of the last SUBSCRIPTION_DEPTH samples written (oldest first, and as a set)."""

    def __init__(self) -> None:
        self._seen: dict[str, tuple[deque[tuple[int, int]], set[tuple[int, int]]]] = {}

    def seen(self, topic: str, key: tuple[int, int]) -> bool:
        """Return whether the sample ``key`` was written already; else remember it (the lock held)."""
        seen = self._seen.setdefault(topic, (deque(maxlen=SUBSCRIPTION_DEPTH), set()))
        recent, keys = seen
        if key in keys:
            return True
        if len(recent) == recent.maxlen:
            keys.discard(recent[0])
        recent.append(key)
        keys.add(key)
        return False
