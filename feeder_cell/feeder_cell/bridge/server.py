"""The ROS side of ``feeder bridge``: the live graph as Foxglove channels, services, parameters and clock.

Every ``GRAPH_PERIOD`` the bridge looks at the graph: topics become channels (``bridge.topics``),
services are advertised and called (``bridge.services``, through ``bridge.calls``), the nodes that take
parameter requests are noted (``bridge.node_parameters``), whether /clock runs is told
(``bridge.clock_feed``), and a watched connection graph is snapshot (``bridge.graph``). Clients'
publishers are ``bridge.client_publishers``. :class:`GraphBridge` owns the node, the work queue and the
timers, and hands each request to the part it concerns.

Threads: the WebSocket server (``bridge.ws``) runs on its own thread and calls this class's backend
methods there; each one only queues the work and wakes the executor with a guard condition, so all rclpy
calls (every part's methods) happen on the ROS thread, and no part is locked. Answers go back through
the server's thread-safe methods.
"""

from __future__ import annotations

import re
import ssl
import time
from collections import deque
from typing import Callable

from rclpy.node import Node

from feeder_cell.bridge.adverts import Service
from feeder_cell.bridge.calls import ServiceCalls
from feeder_cell.bridge.client_publishers import ClientPublishers
from feeder_cell.bridge.clock_feed import ClockFeed
from feeder_cell.bridge.defaults import (
    DEFAULT_ADDRESS,
    DEFAULT_CLIENT_TOPICS,
    DEFAULT_PORT,
    DEFAULT_SERVICE_TIMEOUT,
)
from feeder_cell.bridge.graph import ConnectionGraph
from feeder_cell.bridge.node_parameters import NodeParameters
from feeder_cell.bridge.protocol import ClientChannel, ParameterSetting
from feeder_cell.bridge.services import BridgedServices
from feeder_cell.bridge.topics import TopicChannels
from feeder_cell.bridge.ws import FoxgloveServer

__all__ = ["DEFAULT_ADDRESS", "DEFAULT_PORT", "GRAPH_PERIOD", "GraphBridge"]

GRAPH_PERIOD = 1.0  # s between two looks at the graph (topics, services, nodes)
CHECK_PERIOD = 0.05  # s between two looks at the calls in flight (a server matched, a deadline passed)


class GraphBridge:
    """Serve ``node``'s ROS graph at ws://address:port; ``close`` stops the server and what it made."""

    def __init__(
        self,
        node: Node,
        address: str = DEFAULT_ADDRESS,
        port: int = DEFAULT_PORT,
        read_only: bool = False,
        client_topics: tuple[str, ...] = DEFAULT_CLIENT_TOPICS,
        service_timeout: float = DEFAULT_SERVICE_TIMEOUT,
        tls: ssl.SSLContext | None = None,
    ) -> None:
        self.node = node
        self.me = node.get_fully_qualified_name()
        self.service_timeout = service_timeout
        self._work: deque[tuple[str, Callable[[], None]]] = deque()  # (what, the work)
        self._guard = node.create_guard_condition(self._drain)
        self.server = FoxgloveServer(
            self, address, port, read_only, tuple(re.compile(p) for p in client_topics), tls=tls
        )
        self.port = self.server.port
        # The parts answer through the server, so they come after it; a client's request queued meanwhile
        # waits in _work, which only the executor drains, after this constructor.
        self._calls = ServiceCalls()
        self._topics = TopicChannels(node, self.server)
        self._services = BridgedServices(node, self.server, self._calls, self.me, service_timeout)
        self._parameters = NodeParameters(node, self.server, self._calls, self.me)
        self._clock = ClockFeed(node, self.server)
        self._graph = ConnectionGraph(node, self.server, self.discover)
        self._publishers = ClientPublishers(node, self.server)
        self.discover()
        node.create_timer(GRAPH_PERIOD, self.discover)
        node.create_timer(CHECK_PERIOD, self._check_calls)

    # --- the queue from the WebSocket thread ------------------------------------------------------------
    def _submit(self, what: str, work: Callable[[], None]) -> None:
        """Queue ``work`` for the ROS thread; ``what`` names it in the error line if it fails."""
        self._work.append((what, work))
        self._guard.trigger()

    def _drain(self) -> None:
        while self._work:
            name, work = self._work.popleft()
            try:
                work()
            except Exception as error:  # noqa: BLE001 -- one failed request must not end the bridge
                self.node.get_logger().error(f"bridge: {name}: {type(error).__name__}: {error}")

    # Backend (bridge.backend.Backend): called on the WebSocket thread, run on the ROS thread. Each work's
    # name is the one the bridge's log has always given it.
    def subscribe(self, client: int, channel: int) -> None:
        """Forward the channel's topic to the client."""
        self._submit("_subscribe", lambda: self._topics.subscribe(client, channel))

    def unsubscribe(self, client: int, channel: int) -> None:
        """Stop forwarding the channel's topic to the client."""
        self._submit("_unsubscribe", lambda: self._topics.unsubscribe(client, channel))

    def call_service(self, client: int, service: Service, call_id: int, payload: bytes) -> None:
        """Call a service with a CDR request."""
        self._submit("_call_service", lambda: self._services.call_service(client, service, call_id, payload))

    def get_parameters(self, client: int, names: list[str], request_id: str | None) -> None:
        """Read parameters (all of every node when ``names`` is empty)."""
        self._submit("_get_parameters", lambda: self._parameters.get_parameters(client, names, request_id))

    def set_parameters(self, client: int, settings: list[ParameterSetting], request_id: str | None) -> None:
        """Set parameters on their nodes."""
        self._submit("_set_parameters", lambda: self._parameters.set_parameters(client, settings, request_id))

    def watch_parameters(self, watched: bool) -> None:
        """Follow /parameter_events while some client wants updates."""
        self._submit("_watch_parameters", lambda: self._parameters.watch_parameters(watched))

    def watch_graph(self, watched: bool) -> None:
        """Send connection graph snapshots while some client wants them."""
        self._submit("_set_watch_graph", lambda: self._graph.set_watch_graph(watched))

    def follow_clock(self, follow: bool) -> None:
        """Follow /clock while some client keeps cell time."""
        self._submit("_follow_clock", lambda: self._clock.follow_clock(follow))

    def client_advertise(self, client: int, channel: ClientChannel, where: str) -> None:
        """Make a publisher for a client's channel."""
        self._submit("_client_advertise", lambda: self._publishers.advertise(client, channel, where))

    def client_unadvertise(self, client: int, channel: int) -> None:
        """Release a client channel's publisher."""
        self._submit("_client_unadvertise", lambda: self._publishers.unadvertise(client, channel))

    def client_publish(self, client: int, channel: int, payload: bytes) -> None:
        """Publish a client's CDR message."""
        self._submit("_client_publish", lambda: self._publishers.publish(client, channel, payload))

    def client_left(self, client: int) -> None:
        """Release everything made for a client."""
        self._submit("_client_left", lambda: self._client_left(client))

    def _client_left(self, client: int) -> None:
        self._topics.client_left(client)
        self._publishers.client_left(client)

    # --- the ROS thread's own work ---------------------------------------------------------------------
    def discover(self) -> None:
        """Advertise the topics and services that appeared, withdraw those that went."""
        publishers = self._topics.discover()
        providers = self._services.discover()
        self._parameters.see(providers)
        self._clock.see(publishers)
        self._graph.see(publishers, providers)

    def _check_calls(self) -> None:
        now = time.monotonic()
        self._publishers.flush(now)
        self._calls.check(now)

    def close(self) -> None:
        """Stop serving, then release every subscription, publisher and client made."""
        self.server.close()
        self._topics.close()
        self._publishers.close()
