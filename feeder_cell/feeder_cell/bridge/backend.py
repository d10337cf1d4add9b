"""The WebSocket side's one view of the ROS graph: the :class:`Backend` it hands requests to.

``bridge.ws`` and ``bridge.client_ops`` call it; ``bridge.server.GraphBridge`` implements it. Its own
module so that the WebSocket side depends on this interface, never on the ROS side.
"""

from __future__ import annotations

from typing import Protocol

from feeder_cell.bridge.adverts import Service
from feeder_cell.bridge.protocol import ClientChannel, ParameterSetting

__all__ = ["Backend"]


class Backend(Protocol):
    """What the WebSocket side asks of the ROS graph; every method is called on the server's thread."""

    def subscribe(self, client: int, channel: int) -> None:
        """Start forwarding the channel's topic to the client."""

    def unsubscribe(self, client: int, channel: int) -> None:
        """Stop forwarding the channel's topic to the client."""

    def call_service(self, client: int, service: Service, call_id: int, payload: bytes) -> None:
        """Call the service with a CDR request; answer with service_response or service_failure."""

    def get_parameters(self, client: int, names: list[str], request_id: str | None) -> None:
        """Answer with parameter_values (all parameters of every node when ``names`` is empty)."""

    def set_parameters(self, client: int, settings: list[ParameterSetting], request_id: str | None) -> None:
        """Set parameters on their nodes; refusals as error statuses; then parameter_values when asked."""

    def watch_parameters(self, watched: bool) -> None:
        """Whether some client wants parameter updates."""

    def watch_graph(self, watched: bool) -> None:
        """Whether some client wants connection graph updates."""

    def follow_clock(self, follow: bool) -> None:
        """Whether some client follows the cell clock (then ``time`` is fed)."""

    def client_advertise(self, client: int, channel: ClientChannel, where: str) -> None:
        """Prepare publishing on a client's channel (its topic already allowed); refusals as statuses."""

    def client_unadvertise(self, client: int, channel: int) -> None:
        """Forget a client channel."""

    def client_publish(self, client: int, channel: int, payload: bytes) -> None:
        """Publish a CDR message on a client channel."""

    def client_left(self, client: int) -> None:
        """Release everything made for the client."""
