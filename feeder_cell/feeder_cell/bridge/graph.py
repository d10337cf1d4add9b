"""The connection graph for clients that subscribed to it: who publishes, subscribes and provides what.

While some client watches the graph, every discovery (``GraphBridge.discover``) makes a snapshot of the
publishers and subscribers of each topic and the providers of each service, by node name, and hands it
to the server when it changed; the server sends each client the difference. Runs on the ROS thread only
(discovery timer and work queue), so nothing is locked. Its own module: the graph a viewer draws is a
concern apart from what the bridge advertises.
"""

from __future__ import annotations

from typing import Callable

from rclpy.node import Node
from rclpy.topic_endpoint_info import TopicEndpointInfo

from feeder_cell.bridge.adverts import GraphSnapshot
from feeder_cell.bridge.ws import FoxgloveServer

__all__ = ["ConnectionGraph", "full_name"]


def full_name(node: str, namespace: str) -> str:
    """Return a node's fully qualified name, as the graph names it."""
    return f"{namespace.rstrip('/')}/{node}"


class ConnectionGraph:
    """Snapshots of ``node``'s graph for ``server`` while watched; ``discover`` looks at the graph anew."""

    def __init__(self, node: Node, server: FoxgloveServer, discover: Callable[[], None]) -> None:
        self.node = node
        self.server = server
        self._discover = discover  # the bridge's discovery, which calls see() with what it found
        self._watch_graph = False
        self._graph = GraphSnapshot()

    def see(
        self, publishers: dict[str, list[TopicEndpointInfo]], providers: dict[str, tuple[str, ...]]
    ) -> None:
        """Take what discovery found: the server gets the snapshot when watched and changed."""
        if self._watch_graph:
            self._send_graph(publishers, providers)

    def _send_graph(
        self, publishers: dict[str, list[TopicEndpointInfo]], providers: dict[str, tuple[str, ...]]
    ) -> None:
        def names(infos: list[TopicEndpointInfo]) -> tuple[str, ...]:
            return tuple(sorted({full_name(i.node_name, i.node_namespace) for i in infos}))

        snapshot = GraphSnapshot(
            publishers={t: names(infos) for t, infos in publishers.items() if infos},
            subscribers={
                t: ids for t in publishers if (ids := names(self.node.get_subscriptions_info_by_topic(t)))
            },
            providers=providers,
        )
        if snapshot != self._graph:
            self._graph = snapshot
            self.server.graph(snapshot)

    def set_watch_graph(self, watched: bool) -> None:
        """Whether some client watches the graph; a new watch starts from an empty snapshot, now."""
        self._watch_graph = watched
        if watched:
            self._graph = GraphSnapshot()
            self._discover()
