"""What the WebSocket server tells its clients on its own: adverts, messages, the cell time, answers.

It keeps what the bridge has advertised (channels, services, the connection graph) and the cell time,
which a new session is greeted with (``bridge.ws``) and a client's requests are checked against
(``bridge.client_ops``), and fans each change out to the sessions. ``FoxgloveServer``'s public methods
are called on the ROS thread and only post these methods onto the server's event loop, so everything
here runs on the loop thread and nothing is locked. Separate from ``ws`` so that the server's thread,
loop and sessions read apart from what flows out to the clients.
"""

from __future__ import annotations

import asyncio
import time
from typing import Mapping

from feeder_cell.bridge import protocol
from feeder_cell.bridge.adverts import Channel, GraphSnapshot, Service
from feeder_cell.bridge.protocol import ParameterEntry
from feeder_cell.bridge.session import Session

__all__ = ["Outbound", "TIME_PERIOD"]

TIME_PERIOD = 0.02  # s: Time frames go out at most at 50 Hz (the cell clock may tick at 1 kHz)


class Outbound:
    """The advertised channels, services, graph and cell time, and their fan-out to ``sessions``."""

    def __init__(self, sessions: dict[int, Session], read_only: bool) -> None:
        self._sessions = sessions  # the server's own dict: sessions come and go there
        self.read_only = read_only
        self.channels: dict[int, Channel] = {}
        self.services: dict[int, Service] = {}
        self.graph = GraphSnapshot()
        self.clock_running = False
        self.clock_ns = 0
        self._time_sent = 0.0
        self._time_pending = False

    def advertise(self, channels: list[Channel]) -> None:
        """Announce new channels to every client."""
        for channel in channels:
            self.channels[channel.id] = channel
        for session in self._sessions.values():
            session.send({"op": "advertise", "channels": [c.advert() for c in channels]})

    def unadvertise(self, ids: list[int]) -> None:
        """Withdraw channels (their subscriptions end)."""
        for channel in ids:
            self.channels.pop(channel, None)
        for session in self._sessions.values():
            for channel in ids:
                subscription = session.by_channel.pop(channel, None)
                if subscription is not None:
                    del session.subscriptions[subscription]
            session.send({"op": "unadvertise", "channelIds": ids})

    def advertise_services(self, services: list[Service]) -> None:
        """Announce new services (not to clients of a read-only bridge, which may not call them)."""
        for service in services:
            self.services[service.id] = service
        if not self.read_only:
            for session in self._sessions.values():
                session.send({"op": "advertiseServices", "services": [s.advert() for s in services]})

    def unadvertise_services(self, ids: list[int]) -> None:
        """Withdraw services."""
        for service in ids:
            self.services.pop(service, None)
        if not self.read_only:
            for session in self._sessions.values():
                session.send({"op": "unadvertiseServices", "serviceIds": ids})

    def message(self, channel: int, client: int, payload: bytes, wall_ns: int) -> None:
        """Forward one message of a channel to the client that subscribed it."""
        session = self._sessions.get(client)
        subscription = None if session is None else session.by_channel.get(channel)
        if session is None or subscription is None:
            return  # unsubscribed while the message was on its way
        stamp = self.clock_ns if session.follows_clock else wall_ns
        session.send_data(protocol.message_data(subscription, stamp, payload))

    def set_clock_running(self, running: bool) -> None:
        """Whether the graph has a /clock publisher (decides the time source of new clients)."""
        self.clock_running = running

    def time(self, stamp_ns: int) -> None:
        """Take the cell clock's latest time (nanoseconds); clients that follow it get it throttled."""
        self.clock_ns = stamp_ns
        if self._time_pending:
            return
        wait = self._time_sent + TIME_PERIOD - time.monotonic()
        if wait > 0:
            self._time_pending = True  # the newest time goes out when the period is over
            asyncio.get_running_loop().call_later(wait, self._flush_time)
        else:
            self._flush_time()

    def _flush_time(self) -> None:
        self._time_pending = False
        self._time_sent = time.monotonic()
        frame = protocol.time_frame(self.clock_ns)
        for session in self._sessions.values():
            if session.follows_clock:
                session.send_data(frame)

    def service_failure(self, client: int, service: int, call_id: int, message: str) -> None:
        """Answer a service call with why it has no response."""
        session = self._sessions.get(client)
        if session is not None:
            session.failure(service, call_id, message)

    def to_client(self, client: int, message: Mapping[str, object] | bytes) -> None:
        """Send a message to one client, if it is still connected."""
        session = self._sessions.get(client)
        if session is not None:
            session.send(message)

    def parameter_update(self, parameters: list[ParameterEntry]) -> None:
        """Parameters that changed on their nodes: to every client subscribed to them."""
        for session in self._sessions.values():
            wanted = [p for p in parameters if session.wants_parameter(p["name"])]
            if wanted:
                session.send({"op": "parameterValues", "parameters": wanted})

    def set_graph(self, snapshot: GraphSnapshot) -> None:
        """Take the connection graph as it is now: to every client subscribed to it."""
        self.graph = snapshot
        for session in self._sessions.values():
            self.send_graph(session)

    def send_graph(self, session: Session) -> None:
        """Send a client subscribed to the graph what changed since its last snapshot."""
        if session.graph is None:
            return
        update = self.graph.update_from(session.graph)
        if update is not None:
            session.send(update)
        session.graph = self.graph
