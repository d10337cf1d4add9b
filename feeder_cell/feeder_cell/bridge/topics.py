"""The graph's topics as Foxglove channels, and each client's subscriptions to them.

A topic with a publisher, of one type we can describe, becomes a channel with its ``ros2msg`` schema
(``bridge.schemas``) and ``cdr`` encoding; a topic whose publishers are all gone is withdrawn.
Subscriptions are made per client and channel, as raw rclpy subscriptions matching what the publishers
offer (reliable unless one is best effort, transient-local when one is latched): so every client, however
late, gets the latched markers and descriptions from DDS itself, as with the ROS foxglove_bridge; when
the offer changes, every subscription of the topic is made anew. Runs on the ROS thread only (discovery
timer and work queue), so nothing is locked. Its own module: channels and what feeds them are one
concern, apart from services, parameters and client publishing.
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass, field

from rclpy.node import Node
from rclpy.subscription import Subscription
from rclpy.topic_endpoint_info import TopicEndpointInfo

from feeder_cell.bag.qos import matching_qos, offered_qos
from feeder_cell.bag.types import message_class
from feeder_cell.bridge.adverts import Channel
from feeder_cell.bridge.protocol import LEVEL_ERROR
from feeder_cell.bridge.schemas import schema_of
from feeder_cell.bridge.ws import FoxgloveServer

__all__ = ["TopicChannels", "SUBSCRIPTION_DEPTH"]

SUBSCRIPTION_DEPTH = 10  # a viewer wants the newest samples, a latched topic its history


@dataclass
class _Topic:
    name: str
    type_name: str
    channel: Channel
    offer: tuple[bool, bool]  # (reliable, latched) the publishers offer now
    subscriptions: dict[int, Subscription] = field(default_factory=dict)  # client -> its subscription
    subscribed_offer: tuple[bool, bool] | None = None


class TopicChannels:
    """The channels advertised to ``server``'s clients, and the subscriptions that feed each client."""

    def __init__(self, node: Node, server: FoxgloveServer) -> None:
        self.node = node
        self.server = server
        self._channel_ids = itertools.count(1)
        self.topics: dict[str, _Topic] = {}
        self.by_channel: dict[int, _Topic] = {}
        self.skipped: set[str] = set()  # topics we cannot describe, warned about once

    def discover(self) -> dict[str, list[TopicEndpointInfo]]:
        """Advertise the topics that appeared, withdraw those that went; return every topic's publishers."""
        publishers: dict[str, list[TopicEndpointInfo]] = {}
        for name, type_names in self.node.get_topic_names_and_types():
            publishers[name] = self.node.get_publishers_info_by_topic(name)
            if publishers[name]:
                self._see_topic(name, type_names, publishers[name])
        gone = [name for name in self.topics if not publishers.get(name)]
        if gone:
            self.server.unadvertise([self.topics[name].channel.id for name in gone])
            for name in gone:
                self._remove_topic(name)
        # A skipped topic that comes back is looked at again.
        self.skipped &= {name for name, infos in publishers.items() if infos}
        return publishers

    def _see_topic(self, name: str, type_names: list[str], infos: list[TopicEndpointInfo]) -> None:
        offer = offered_qos(infos)
        topic = self.topics.get(name)
        if topic is not None:
            if offer != topic.offer:  # a latched or best-effort publisher came or went: match it anew
                topic.offer = offer
                for client in list(topic.subscriptions):
                    self.unsubscribe(client, topic.channel.id)
                    self.subscribe(client, topic.channel.id)
            return
        if name in self.skipped:
            return
        schema = schema_of(type_names[0]) if len(type_names) == 1 else None
        if schema is None:
            self.skipped.add(name)
            self.node.get_logger().warning(f"not bridged: {name} ({', '.join(type_names)}): no schema")
            return
        channel = Channel(next(self._channel_ids), name, schema[0], schema[1])
        topic = _Topic(name, type_names[0], channel, offer)
        self.topics[name] = topic
        self.by_channel[channel.id] = topic
        self.server.advertise([channel])

    def _remove_topic(self, name: str) -> None:
        topic = self.topics.pop(name)
        self.by_channel.pop(topic.channel.id, None)
        for subscription in topic.subscriptions.values():
            self.node.destroy_subscription(subscription)
        topic.subscriptions.clear()

    def subscribe(self, client: int, channel: int) -> None:
        """Forward the channel's topic to the client."""
        topic = self.by_channel.get(channel)
        if topic is None or client in topic.subscriptions:
            return  # withdrawn while the request was on its way (the client is told by the unadvertise)
        channel_id = topic.channel.id

        def forward(data: bytes) -> None:
            self.server.message(channel_id, client, data, time.time_ns())

        try:
            msg_class = message_class(topic.type_name)
        except Exception as error:  # noqa: BLE001 -- described (schema) but its Python class is missing
            self.server.status(
                client, LEVEL_ERROR, f"subscribe: {topic.name}: no {topic.type_name} here: {error}"
            )
            return
        topic.subscriptions[client] = self.node.create_subscription(
            msg_class, topic.name, forward, matching_qos(*topic.offer, SUBSCRIPTION_DEPTH), raw=True
        )

    def unsubscribe(self, client: int, channel: int) -> None:
        """Stop forwarding the channel's topic to the client."""
        topic = self.by_channel.get(channel)
        subscription = None if topic is None else topic.subscriptions.pop(client, None)
        if subscription is not None:
            self.node.destroy_subscription(subscription)

    def client_left(self, client: int) -> None:
        """Release the client's subscriptions."""
        for topic in self.topics.values():
            subscription = topic.subscriptions.pop(client, None)
            if subscription is not None:
                self.node.destroy_subscription(subscription)

    def close(self) -> None:
        """Release every subscription (the channels are forgotten)."""
        for name in list(self.topics):
            self._remove_topic(name)
