"""The bridge's WebSocket side: one asyncio server (``websockets``) serving both subprotocol names.

It knows nothing of ROS. It keeps what the protocol needs per client (``bridge.session``: subscriptions,
client channels, parameter and graph subscriptions, the time source, the outgoing queues), answers
malformed or refused requests itself (``bridge.client_ops``), and hands every request that needs the
ROS graph to a :class:`~feeder_cell.bridge.backend.Backend`. The backend (``bridge.server``) runs on the
ROS thread and answers through this server's thread-safe methods, each of which only queues a call of
``bridge.outbound`` onto the server's event loop. This module owns the thread, the loop and the sessions.
"""

from __future__ import annotations

import asyncio
import itertools
import re
import ssl
import threading
import time
from typing import Callable, TypeVarTuple, Unpack

from websockets.asyncio.server import ServerConnection, serve
from websockets.exceptions import ConnectionClosed

from feeder_cell.bridge import protocol
from feeder_cell.bridge.adverts import Channel, GraphSnapshot, Service
from feeder_cell.bridge.backend import Backend
from feeder_cell.bridge.client_ops import ClientOps
from feeder_cell.bridge.outbound import Outbound
from feeder_cell.bridge.protocol import ENCODING, ParameterEntry
from feeder_cell.bridge.session import Session

__all__ = ["Backend", "Channel", "Service", "FoxgloveServer", "GraphSnapshot"]

MAX_FRAME = 8 * 2**20  # bytes of one client frame (a message to publish, a service request)
STOP_TIMEOUT = 10.0  # s to wait for the server's thread at close

Arguments = TypeVarTuple("Arguments")


class FoxgloveServer:
    """Serve the Foxglove WebSocket protocol at ws://address:port (wss:// with ``tls``) on its own thread."""

    def __init__(
        self,
        backend: Backend,
        address: str,
        port: int,
        read_only: bool,
        client_topics: tuple[re.Pattern[str], ...],
        name: str = "feeder bridge",
        tls: ssl.SSLContext | None = None,
    ) -> None:
        self.backend = backend
        self.address = address
        self.tls = tls
        self.read_only = read_only
        self.client_topics = client_topics
        self.name = name
        self.session_id = str(time.time_ns())
        self.port = port
        self._sessions: dict[int, Session] = {}
        self._ids = itertools.count(1)
        self._out = Outbound(self._sessions, read_only)
        self._ops = ClientOps(backend, self._out, read_only, client_topics, self._rewatch)
        self._watching = {"parameters": False, "graph": False, "clock": False}
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stop: asyncio.Event | None = None
        self._ready = threading.Event()
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name="feeder-bridge-ws", daemon=True)
        self._thread.start()
        self._ready.wait()
        if self._error is not None:
            raise self._error

    # --- the server's thread ------------------------------------------------------------------------
    def _run(self) -> None:
        loop = asyncio.new_event_loop()
        self._loop = loop
        try:
            loop.run_until_complete(self._main())
        except BaseException as error:  # noqa: BLE001 -- handed to the constructor, which raises it
            self._error = error
        finally:
            self._ready.set()  # never leave the constructor waiting, whatever ended the loop
            loop.close()

    async def _main(self) -> None:
        self._stop = asyncio.Event()
        try:
            server = await serve(
                self._serve_client,
                self.address,
                self.port,
                subprotocols=list(protocol.SUBPROTOCOLS),  # type: ignore[arg-type]
                compression=None,  # deflating every CDR frame costs more CPU than loopback bandwidth
                max_size=MAX_FRAME,
                ssl=self.tls,  # both subprotocols over TLS on the same port; a plain ws:// client fails
            )
        except OSError as error:
            self._error = error
            self._ready.set()
            return
        self.port = server.sockets[0].getsockname()[1] if server.sockets else self.port
        self._ready.set()
        await self._stop.wait()
        server.close()
        await server.wait_closed()

    def _capabilities(self, follows_clock: bool) -> list[str]:
        capabilities = ["parameters", "parametersSubscribe", "connectionGraph"]
        if not self.read_only:
            capabilities += ["services", "clientPublish"]
        if follows_clock:
            capabilities.append("time")
        return capabilities

    async def _serve_client(self, ws: ServerConnection) -> None:
        # A client that connects while a cell clock runs follows it for the whole connection: its time
        # and the stamps of its messages are cell time (the protocol wants both from one source).
        session = Session(next(self._ids), ws, self._out.clock_running)
        self._sessions[session.id] = session
        writer = asyncio.get_running_loop().create_task(session.write())
        session.send(
            {
                "op": "serverInfo",
                "name": self.name,
                "capabilities": self._capabilities(session.follows_clock),
                "supportedEncodings": [ENCODING],
                "metadata": {"ROS_DISTRO": "jazzy"},
                "sessionId": self.session_id,
            }
        )
        session.send({"op": "advertise", "channels": [c.advert() for c in self._out.channels.values()]})
        if not self.read_only and self._out.services:
            session.send(
                {"op": "advertiseServices", "services": [s.advert() for s in self._out.services.values()]}
            )
        if session.follows_clock:
            self._rewatch()
            if self._out.clock_ns:
                session.send_data(protocol.time_frame(self._out.clock_ns))
        try:
            async for frame in ws:
                self._ops.receive(session, frame)
        except ConnectionClosed:
            pass
        finally:
            del self._sessions[session.id]
            self.backend.client_left(session.id)
            self._rewatch()
            writer.cancel()

    def _rewatch(self) -> None:
        """Tell the backend what the clients as a whole still want (only on a change)."""
        sessions = self._sessions.values()
        wanted = {
            "parameters": any(s.all_parameters or s.parameters for s in sessions),
            "graph": any(s.graph is not None for s in sessions),
            "clock": any(s.follows_clock for s in sessions),
        }
        for key, value in wanted.items():
            if value != self._watching[key]:
                self._watching[key] = value
                {
                    "parameters": self.backend.watch_parameters,
                    "graph": self.backend.watch_graph,
                    "clock": self.backend.follow_clock,
                }[key](value)

    def allowed_topic(self, topic: str) -> bool:
        """Whether a client may publish on ``topic`` (a full name)."""
        return self._ops.allowed_topic(topic)

    # --- called from the ROS thread ------------------------------------------------------------------
    def _post(self, function: Callable[[Unpack[Arguments]], None], *args: Unpack[Arguments]) -> None:
        loop = self._loop
        if loop is None or loop.is_closed():
            return
        try:
            loop.call_soon_threadsafe(function, *args)
        except RuntimeError:
            pass  # the loop closed between the check and the call: the server is stopping

    def advertise(self, channels: list[Channel]) -> None:
        """Announce new channels to every client."""
        self._post(self._out.advertise, channels)

    def unadvertise(self, ids: list[int]) -> None:
        """Withdraw channels (their subscriptions end)."""
        self._post(self._out.unadvertise, ids)

    def advertise_services(self, services: list[Service]) -> None:
        """Announce new services (not to clients of a read-only bridge, which may not call them)."""
        self._post(self._out.advertise_services, services)

    def unadvertise_services(self, ids: list[int]) -> None:
        """Withdraw services."""
        self._post(self._out.unadvertise_services, ids)

    def message(self, channel: int, client: int, payload: bytes, wall_ns: int) -> None:
        """Forward one message of a channel to the client that subscribed it."""
        self._post(self._out.message, channel, client, payload, wall_ns)

    def clock_running(self, running: bool) -> None:
        """Whether the graph has a /clock publisher (decides the time source of new clients)."""
        self._post(self._out.set_clock_running, running)

    def time(self, stamp_ns: int) -> None:
        """Take the cell clock's latest time (nanoseconds)."""
        self._post(self._out.time, stamp_ns)

    def service_response(self, client: int, service: int, call_id: int, payload: bytes) -> None:
        """Answer a service call with the ROS response (CDR)."""
        self._post(
            self._out.to_client, client, protocol.service_response(service, call_id, ENCODING, payload)
        )

    def service_failure(self, client: int, service: int, call_id: int, message: str) -> None:
        """Answer a service call with why it has no response."""
        self._post(self._out.service_failure, client, service, call_id, message)

    def parameter_values(self, client: int, parameters: list[ParameterEntry], request_id: str | None) -> None:
        """Answer getParameters (or setParameters) with the nodes' values."""
        message: dict[str, object] = {"op": "parameterValues", "parameters": parameters}
        if request_id is not None:
            message["id"] = request_id
        self._post(self._out.to_client, client, message)

    def parameter_update(self, parameters: list[ParameterEntry]) -> None:
        """Parameters that changed on their nodes: to every client subscribed to them."""
        self._post(self._out.parameter_update, parameters)

    def status(self, client: int, level: int, message: str) -> None:
        """Send a status line to one client."""
        self._post(self._out.to_client, client, {"op": "status", "level": level, "message": message})

    def graph(self, snapshot: GraphSnapshot) -> None:
        """Take the connection graph as it is now."""
        self._post(self._out.set_graph, snapshot)

    def close(self) -> None:
        """Close every connection and stop the server's thread."""
        loop, stop = self._loop, self._stop
        if loop is not None and stop is not None and not loop.is_closed():
            try:
                loop.call_soon_threadsafe(stop.set)
            except RuntimeError:
                pass
        self._thread.join(STOP_TIMEOUT)
