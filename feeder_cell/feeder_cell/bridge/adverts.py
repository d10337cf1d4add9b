"""What the bridge advertises to clients: channels (topics), services, and the connection graph.

Plain frozen values, no ROS and no WebSocket: the ROS side (``bridge.server``) makes them from the graph,
and the WebSocket side (``bridge.ws``) keeps them and writes each as its advertisement. Their own
module: this is the vocabulary both sides share, and the server's parts (``session``, ``outbound``,
``backend``) need it without importing the server.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from feeder_cell.bridge.protocol import ENCODING

__all__ = ["Channel", "Service", "GraphSnapshot"]


@dataclass(frozen=True)
class Channel:
    """A topic advertised to clients."""

    id: int
    topic: str
    schema_name: str
    schema: str

    def advert(self) -> dict[str, object]:
        """Return the channel as an Advertise message lists it."""
        return {
            "id": self.id,
            "topic": self.topic,
            "encoding": ENCODING,
            "schemaName": self.schema_name,
            "schema": self.schema,
            "schemaEncoding": "ros2msg",
        }


@dataclass(frozen=True)
class Service:
    """A ROS service advertised to clients: its type and the ros2msg text of its two halves."""

    id: int
    name: str
    type: str
    request_schema: str
    response_schema: str

    def advert(self) -> dict[str, object]:
        """Return the service as an Advertise Services message lists it."""

        def half(suffix: str, schema: str) -> dict[str, str]:
            return {
                "encoding": ENCODING,
                "schemaName": f"{self.type}_{suffix}",
                "schemaEncoding": "ros2msg",
                "schema": schema,
            }

        return {
            "id": self.id,
            "name": self.name,
            "type": self.type,
            "request": half("Request", self.request_schema),
            "response": half("Response", self.response_schema),
            # The fields before request/response existed, for clients of the older specification.
            "requestSchema": self.request_schema,
            "responseSchema": self.response_schema,
        }


@dataclass(frozen=True)
class GraphSnapshot:
    """Who publishes and subscribes each topic and provides each service (node names)."""

    publishers: dict[str, tuple[str, ...]] = field(default_factory=dict)
    subscribers: dict[str, tuple[str, ...]] = field(default_factory=dict)
    providers: dict[str, tuple[str, ...]] = field(default_factory=dict)

    def update_from(self, before: GraphSnapshot) -> dict[str, object] | None:
        """Return the connectionGraphUpdate that turns ``before`` into this snapshot (None: no change)."""
        topics = set(self.publishers) | set(self.subscribers)
        old_topics = set(before.publishers) | set(before.subscribers)
        published = [
            {"name": t, "publisherIds": list(self.publishers.get(t, ()))}
            for t in sorted(topics)
            if t not in old_topics or self.publishers.get(t, ()) != before.publishers.get(t, ())
        ]
        subscribed = [
            {"name": t, "subscriberIds": list(self.subscribers.get(t, ()))}
            for t in sorted(topics)
            if t not in old_topics or self.subscribers.get(t, ()) != before.subscribers.get(t, ())
        ]
        services = [
            {"name": s, "providerIds": list(ids)}
            for s, ids in sorted(self.providers.items())
            if before.providers.get(s) != ids
        ]
        removed_topics = sorted(old_topics - topics)
        removed_services = sorted(set(before.providers) - set(self.providers))
        if not (published or subscribed or services or removed_topics or removed_services):
            return None
        return {
            "op": "connectionGraphUpdate",
            "publishedTopics": published,
            "subscribedTopics": subscribed,
            "advertisedServices": services,
            "removedTopics": removed_topics,
            "removedServices": removed_services,
        }
