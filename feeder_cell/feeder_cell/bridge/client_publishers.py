"""Client publishing (clientPublish): a publisher per client channel, and the client's messages on it.

A client channel (its topic already on the allow-list, ``bridge.client_ops``) gets a publisher if its
topic is a valid name and its schema a ROS message type the bridge has and the topic carries; otherwise
the client is told why, in one line. A message goes out only if it is CDR of that type; the first ones
on a new publisher wait (at most ``MATCH_WAIT``) until DDS has matched the topic's subscribers, in order.
Runs on the ROS thread only (work queue and the bridge's check timer), so nothing is locked. Its own
module: what clients write into the graph is a concern apart from what the bridge reads from it.
"""

from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass, field
from typing import Any

from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message

from feeder_cell.bag.types import message_class
from feeder_cell.bridge.protocol import LEVEL_ERROR, ClientChannel
from feeder_cell.bridge.ws import FoxgloveServer

__all__ = ["ClientPublishers", "PUBLISH_DEPTH", "MATCH_WAIT"]

PUBLISH_DEPTH = 10  # a client's messages, as foxglove_bridge publishes them
# A client's first messages on a new publisher wait (at most this long) until DDS has matched the topic's
# subscribers: a volatile message published before the match is lost to them, and a Foxglove user who
# clicks "publish" once expects it to arrive.
MATCH_WAIT = 2.0


def _type_name(schema_name: str) -> str:
    """``pkg/Name`` (how ROS 1 and some clients name a message) -> ``pkg/msg/Name``."""
    parts = schema_name.split("/")
    return f"{parts[0]}/msg/{parts[1]}" if len(parts) == 2 else schema_name


@dataclass
class _Publisher:
    publisher: Publisher
    msg_class: Any
    topic: str
    type_name: str
    match_deadline: float
    waiting: deque[bytes] = field(default_factory=deque)  # held until the subscribers are matched


class ClientPublishers:
    """The publishers of the clients' channels; refusals and bad messages are told to the client."""

    def __init__(self, node: Node, server: FoxgloveServer) -> None:
        self.node = node
        self.server = server
        self._publishers: dict[tuple[int, int], _Publisher] = {}
        self._refused: set[tuple[int, int]] = set()  # client channels refused at advertise

    def advertise(self, client: int, channel: ClientChannel, where: str) -> None:
        """Make a publisher for a client's channel, or tell the client why not."""
        from rclpy.validate_full_topic_name import validate_full_topic_name

        def refuse(message: str) -> None:
            self._refused.add((client, channel.id))
            self.server.status(client, LEVEL_ERROR, message)

        try:
            validate_full_topic_name(channel.topic)
        except Exception as error:  # noqa: BLE001 -- rclpy's InvalidTopicNameException and its kin
            refuse(f"{where}.topic: {error}".splitlines()[0])
            return
        type_name = _type_name(channel.schema_name)
        try:
            msg_class = message_class(type_name)
        except Exception:  # noqa: BLE001 -- no such package, module or message
            refuse(f"{where}.schemaName: {channel.schema_name!r} is not a ROS message type the bridge has")
            return
        carried = dict(self.node.get_topic_names_and_types()).get(channel.topic, [])
        if carried and type_name not in carried:
            refuse(f"{where}.schemaName: {channel.topic} carries {', '.join(carried)}, not {type_name}")
            return
        qos = QoSProfile(depth=PUBLISH_DEPTH, reliability=ReliabilityPolicy.RELIABLE)
        publisher = self.node.create_publisher(msg_class, channel.topic, qos)
        self._refused.discard((client, channel.id))
        self._publishers[(client, channel.id)] = _Publisher(
            publisher, msg_class, channel.topic, type_name, time.monotonic() + MATCH_WAIT
        )

    def _matched(self, entry: _Publisher) -> bool:
        """Whether the publisher has matched every subscriber the graph shows (its own readers aside)."""
        return entry.publisher.get_subscription_count() >= self.node.count_subscribers(entry.topic)

    def unadvertise(self, client: int, channel: int) -> None:
        """Release a client channel's publisher."""
        self._refused.discard((client, channel))
        entry = self._publishers.pop((client, channel), None)
        if entry is not None:
            self.node.destroy_publisher(entry.publisher)

    def publish(self, client: int, channel: int, payload: bytes) -> None:
        """Publish a client's CDR message (held while the topic's subscribers are being matched)."""
        entry = self._publishers.get((client, channel))
        if entry is None:
            return  # refused at advertise (the client was told then)
        try:
            deserialize_message(payload, entry.msg_class)  # nothing a node cannot read goes out
        except Exception as error:  # noqa: BLE001 -- rclpy raises several kinds for bytes that are not CDR
            self.server.status(
                client,
                LEVEL_ERROR,
                f"client message data: channel {channel} ({entry.topic}): not a CDR {entry.type_name} "
                f"({len(payload)} bytes): {error}".splitlines()[0],
            )
            return
        if entry.waiting or (time.monotonic() < entry.match_deadline and not self._matched(entry)):
            entry.waiting.append(payload)  # sent by flush once matched (order kept)
        else:
            entry.publisher.publish(payload)

    def flush(self, now: float) -> None:
        """Publish the held messages of each publisher now matched, or past its wait."""
        for entry in self._publishers.values():
            if entry.waiting and (self._matched(entry) or now > entry.match_deadline):
                while entry.waiting:
                    entry.publisher.publish(entry.waiting.popleft())

    def client_left(self, client: int) -> None:
        """Release the client's publishers."""
        for key in [k for k in self._publishers if k[0] == client]:
            self.node.destroy_publisher(self._publishers.pop(key).publisher)
        self._refused = {k for k in self._refused if k[0] != client}

    def close(self) -> None:
        """Release every publisher."""
        for entry in self._publishers.values():
            self.node.destroy_publisher(entry.publisher)
        self._publishers.clear()
