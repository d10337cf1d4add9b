"""A Foxglove WebSocket server of the live ROS graph: every topic a channel, raw CDR both ways unchanged.

Every ``GRAPH_PERIOD`` the bridge looks at the graph: a topic seen for the first time (one type, one we
can describe) becomes a channel with its ``ros2msg`` schema (``bridge.schemas``) and ``cdr`` encoding; a
topic whose publishers are all gone is removed. Subscriptions are made only for channels a client
subscribes to (``ServerListener.on_subscribe``), as raw rclpy subscriptions matching what the publishers
offer (reliable unless one is best effort, transient-local when one is latched, so a late viewer gets the
latched markers and descriptions), and released when the last client leaves. The Foxglove server calls
back from its own thread; those callbacks only record the wish, which the ROS thread applies within
``APPLY_PERIOD``.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from typing import Any

import foxglove
from foxglove import Channel, Schema
from foxglove.websocket import ChannelView, Client, ServerListener
from rclpy.node import Node

from feeder_cell.bag.qos import matching_qos, offered_qos
from feeder_cell.bag.types import message_class
from feeder_cell.bridge.defaults import DEFAULT_ADDRESS, DEFAULT_PORT
from feeder_cell.bridge.schemas import schema_of

__all__ = ["DEFAULT_ADDRESS", "DEFAULT_PORT", "GRAPH_PERIOD", "APPLY_PERIOD", "GraphBridge"]

# The graph is looked at once a second (new topics appear, vanished ones go); client subscriptions are
# applied ten times a second.
GRAPH_PERIOD = 1.0
APPLY_PERIOD = 0.1
# Depth of a bridged subscription: a viewer wants the newest samples, a latched topic its history.
SUBSCRIPTION_DEPTH = 10


@dataclass
class _Topic:
    type_name: str
    channel: Channel
    subscribers: set[int] = field(default_factory=set)  # Foxglove client ids
    subscription: Any = None
    offer: tuple[bool, bool] | None = None  # (reliable, latched) of the subscription made


class _Listener(ServerListener):
    """Records the clients' subscriptions per channel id (called from the server's thread)."""

    def __init__(self, bridge: GraphBridge) -> None:
        self.bridge = bridge

    def on_subscribe(self, client: Client, channel: ChannelView) -> None:
        with self.bridge.lock:
            self.bridge.wanted.setdefault(channel.id, set()).add(client.id)

    def on_unsubscribe(self, client: Client, channel: ChannelView) -> None:
        with self.bridge.lock:
            self.bridge.wanted.get(channel.id, set()).discard(client.id)


class GraphBridge:
    """Serve ``node``'s ROS graph at ws://address:port; ``close`` stops the server and the subscriptions."""

    def __init__(self, node: Node, address: str = DEFAULT_ADDRESS, port: int = DEFAULT_PORT) -> None:
        self.node = node
        self.lock = threading.Lock()
        self.wanted: dict[int, set[int]] = {}  # channel id -> client ids (written by the listener)
        self.topics: dict[str, _Topic] = {}
        self.by_channel: dict[int, str] = {}
        self.skipped: set[str] = set()  # topics we cannot describe, warned about once
        self.context = foxglove.Context()
        self.server = foxglove.start_server(
            name="feeder bridge",
            host=address,
            port=port,
            server_listener=_Listener(self),
            supported_encodings=["cdr"],
            context=self.context,
        )
        self.port = self.server.port
        self.discover()
        node.create_timer(GRAPH_PERIOD, self.discover)
        node.create_timer(APPLY_PERIOD, self.apply_subscriptions)

    def discover(self) -> None:
        """Advertise the topics that appeared, remove those whose publishers are all gone."""
        seen = set()
        for name, type_names in self.node.get_topic_names_and_types():
            if not self.node.get_publishers_info_by_topic(name):
                continue  # only subscribers: nothing to bridge (yet)
            seen.add(name)
            if name in self.topics or name in self.skipped:
                continue
            schema = schema_of(type_names[0]) if len(type_names) == 1 else None
            if schema is None:
                self.skipped.add(name)
                self.node.get_logger().warning(f"not bridged: {name} ({', '.join(type_names)}): no schema")
                continue
            schema_name, text = schema
            channel = Channel(
                name,
                schema=Schema(name=schema_name, encoding="ros2msg", data=text.encode()),
                message_encoding="cdr",
                context=self.context,
            )
            self.topics[name] = _Topic(type_names[0], channel)
            self.by_channel[channel.id()] = name
        for name in [n for n in self.topics if n not in seen]:
            self._remove(name)
        self.skipped &= seen  # a topic that comes back is looked at again

    def _remove(self, name: str) -> None:
        topic = self.topics.pop(name)
        self.by_channel.pop(topic.channel.id(), None)
        if topic.subscription is not None:
            self.node.destroy_subscription(topic.subscription)
        topic.channel.close()

    def _offer(self, name: str) -> tuple[bool, bool]:
        return offered_qos(self.node.get_publishers_info_by_topic(name))

    def apply_subscriptions(self) -> None:
        """Subscribe to the channels some client wants, with the publishers' QoS; drop the others."""
        with self.lock:
            wanted = {cid: set(clients) for cid, clients in self.wanted.items()}
        for channel_id, name in list(self.by_channel.items()):
            topic = self.topics[name]
            topic.subscribers = wanted.get(channel_id, set())
            if not topic.subscribers:
                if topic.subscription is not None:
                    self.node.destroy_subscription(topic.subscription)
                    topic.subscription, topic.offer = None, None
                continue
            offer = self._offer(name)
            if topic.subscription is not None and offer == topic.offer:
                continue
            if topic.subscription is not None:
                self.node.destroy_subscription(topic.subscription)
            qos = matching_qos(*offer, SUBSCRIPTION_DEPTH)
            channel = topic.channel

            def forward(data: bytes, channel: Channel = channel) -> None:
                channel.log(data, log_time=time.time_ns())

            topic.subscription = self.node.create_subscription(
                message_class(topic.type_name), name, forward, qos, raw=True
            )
            topic.offer = offer

    def close(self) -> None:
        """Stop serving: remove every channel and subscription, then the server."""
        for name in list(self.topics):
            self._remove(name)
        self.server.stop()
