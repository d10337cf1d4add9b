"""The bridge's WebSocket side: one asyncio server (``websockets``) serving both subprotocol names.

It knows nothing of ROS. It keeps what the protocol needs per client (subscriptions, client channels,
parameter and graph subscriptions, the time source), answers malformed or refused requests itself, and
hands every request that needs the ROS graph to a :class:`Backend`. The backend (``bridge.server``) runs
on the ROS thread and answers through this server's thread-safe methods, each of which only queues a
call onto the server's event loop.

Every client has two outgoing queues: control messages (advertisements, answers, statuses), which are
never dropped, and data (message data, time), of which at most ``DATA_BACKLOG`` frames wait; when a
client reads slower than the cell publishes, its oldest data frame is dropped and it is told how many
were (a status at most every ``DROP_REPORT_PERIOD``), as the ROS foxglove_bridge does with its
message backlog. A client whose control queue passes ``CONTROL_BACKLOG`` is disconnected.
"""

from __future__ import annotations

import asyncio
import itertools
import re
import ssl
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from typing import Callable, Mapping, Protocol, TypeVarTuple, Unpack

from websockets.asyncio.server import ServerConnection, serve
from websockets.exceptions import ConnectionClosed

from feeder_cell.bridge import protocol
from feeder_cell.bridge.protocol import (
    ENCODING,
    ClientChannel,
    ClientData,
    ParameterEntry,
    ParameterSetting,
    ProtocolError,
)

__all__ = ["Backend", "Channel", "Service", "FoxgloveServer", "GraphSnapshot"]

DATA_BACKLOG = 1024  # data frames waiting per client (foxglove_bridge's message_backlog_size default)
CONTROL_BACKLOG = 10000  # control messages waiting per client before it is cut off
DROP_REPORT_PERIOD = 5.0  # s between two "dropped" statuses to one client
TIME_PERIOD = 0.02  # s: Time frames go out at most at 50 Hz (the cell clock may tick at 1 kHz)
MAX_FRAME = 8 * 2**20  # bytes of one client frame (a message to publish, a service request)
STOP_TIMEOUT = 10.0  # s to wait for the server's thread at close
LEVEL_INFO, LEVEL_WARNING, LEVEL_ERROR = 0, 1, 2
READ_ONLY = "refused: the bridge is read-only (--read-only)"

Arguments = TypeVarTuple("Arguments")


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


class _Session:
    """One connected client: what it subscribed and advertised, and its outgoing queues."""

    def __init__(self, client_id: int, ws: ServerConnection, follows_clock: bool) -> None:
        self.id = client_id
        self.ws = ws
        self.follows_clock = follows_clock
        self.subscriptions: dict[int, int] = {}  # subscription id -> channel id
        self.by_channel: dict[int, int] = {}  # channel id -> subscription id
        self.client_channels: dict[int, ClientChannel] = {}
        self.unknown_reported: set[int] = set()  # client channel ids an error was sent for (once each)
        self.parameters: set[str] = set()
        self.all_parameters = False
        self.graph: GraphSnapshot | None = None  # last snapshot sent, when subscribed to the graph
        self.control: deque[str | bytes] = deque()
        self.data: deque[bytes] = deque()
        self.wake = asyncio.Event()
        self.dropped = 0
        self.reported_drop = 0.0

    def send(self, message: Mapping[str, object] | bytes) -> None:
        self.control.append(message if isinstance(message, bytes) else protocol.to_json(message))
        if len(self.control) > CONTROL_BACKLOG:
            self.control.clear()
            asyncio.get_running_loop().create_task(
                self.ws.close(1008, "client too slow: control backlog full")
            )
        self.wake.set()

    def send_data(self, frame: bytes) -> None:
        if len(self.data) >= DATA_BACKLOG:
            self.data.popleft()  # the oldest: a viewer wants the newest samples
            self.dropped += 1
        self.data.append(frame)
        self.wake.set()

    def status(self, level: int, message: str) -> None:
        self.send({"op": "status", "level": level, "message": message})

    def error(self, message: str) -> None:
        self.status(LEVEL_ERROR, message)

    async def write(self) -> None:
        """Send what is queued, control first, until the connection closes."""
        try:
            while True:
                await self.wake.wait()
                self.wake.clear()
                while self.control or self.data:
                    frame = self.control.popleft() if self.control else self.data.popleft()
                    await self.ws.send(frame)
                    self._report_drops()
        except ConnectionClosed:
            pass

    def _report_drops(self) -> None:
        now = time.monotonic()
        if self.dropped and now - self.reported_drop >= DROP_REPORT_PERIOD:
            self.status(
                LEVEL_WARNING,
                f"{self.dropped} message(s) dropped: this client reads slower than the cell publishes "
                f"(at most {DATA_BACKLOG} wait)",
            )
            self.dropped, self.reported_drop = 0, now

    def wants_parameter(self, name: str) -> bool:
        return self.all_parameters or name in self.parameters


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
        self._sessions: dict[int, _Session] = {}
        self._ids = itertools.count(1)
        self._channels: dict[int, Channel] = {}
        self._services: dict[int, Service] = {}
        self._graph = GraphSnapshot()
        self._clock_running = False
        self._clock_ns = 0
        self._time_sent = 0.0
        self._time_pending = False
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
        session = _Session(next(self._ids), ws, self._clock_running)
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
        session.send({"op": "advertise", "channels": [c.advert() for c in self._channels.values()]})
        if not self.read_only and self._services:
            session.send(
                {"op": "advertiseServices", "services": [s.advert() for s in self._services.values()]}
            )
        if session.follows_clock:
            self._rewatch()
            if self._clock_ns:
                session.send_data(protocol.time_frame(self._clock_ns))
        try:
            async for frame in ws:
                self._receive(session, frame)
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

    def _receive(self, session: _Session, frame: str | bytes) -> None:
        try:
            if isinstance(frame, str):
                op, fields = protocol.parse_text(frame)
                getattr(self, f"_on_{op}")(session, fields)
            else:
                item = protocol.parse_binary(frame)
                if isinstance(item, ClientData):
                    self._on_client_data(session, item)
                else:
                    self._on_service_call(session, item)
        except ProtocolError as error:
            session.error(str(error))

    # --- client operations --------------------------------------------------------------------------
    def _on_subscribe(self, session: _Session, entries: list[tuple[int, int]]) -> None:
        for i, (subscription, channel) in enumerate(entries):
            where = f"subscribe: subscriptions[{i}]"
            if channel not in self._channels:
                session.error(f"{where}.channelId: no channel {channel} is advertised")
            elif subscription in session.subscriptions:
                session.error(f"{where}.id: subscription id {subscription} is in use")
            elif channel in session.by_channel:
                session.error(
                    f"{where}.channelId: channel {channel} is already subscribed "
                    f"(subscription {session.by_channel[channel]})"
                )
            else:
                session.subscriptions[subscription] = channel
                session.by_channel[channel] = subscription
                self.backend.subscribe(session.id, channel)

    def _on_unsubscribe(self, session: _Session, ids: list[int]) -> None:
        for i, subscription in enumerate(ids):
            channel = session.subscriptions.pop(subscription, None)
            if channel is None:
                session.error(f"unsubscribe: subscriptionIds[{i}]: no subscription {subscription}")
                continue
            del session.by_channel[channel]
            self.backend.unsubscribe(session.id, channel)

    def allowed_topic(self, topic: str) -> bool:
        """Whether a client may publish on ``topic`` (a full name)."""
        return any(p.fullmatch(topic) for p in self.client_topics)

    def _on_advertise(self, session: _Session, channels: list[ClientChannel]) -> None:
        if self.read_only:
            session.error(f"advertise: {READ_ONLY}")
            return
        for i, channel in enumerate(channels):
            where = f"advertise: channels[{i}]"
            topic = channel.topic if channel.topic.startswith("/") else f"/{channel.topic}"
            if channel.encoding != ENCODING:
                session.error(f"{where}.encoding: {channel.encoding!r} is not supported (only {ENCODING})")
            elif channel.id in session.client_channels:
                session.error(f"{where}.id: channel {channel.id} is already advertised")
            elif not self.allowed_topic(topic):
                patterns = ", ".join(p.pattern for p in self.client_topics) or "(none)"
                session.error(f"{where}.topic: {topic} is not in the client-publish allow-list ({patterns})")
            else:
                accepted = ClientChannel(channel.id, topic, channel.encoding, channel.schema_name)
                session.client_channels[channel.id] = accepted
                session.unknown_reported.discard(channel.id)
                self.backend.client_advertise(session.id, accepted, where)

    def _on_unadvertise(self, session: _Session, ids: list[int]) -> None:
        for i, channel in enumerate(ids):
            if session.client_channels.pop(channel, None) is None:
                session.error(f"unadvertise: channelIds[{i}]: channel {channel} is not advertised")
            else:
                self.backend.client_unadvertise(session.id, channel)

    def _on_client_data(self, session: _Session, data: ClientData) -> None:
        if data.channel_id not in session.client_channels:
            # Once per channel: a client publishing at 100 Hz on a refused channel gets one line, not 100/s.
            if data.channel_id not in session.unknown_reported:
                session.unknown_reported.add(data.channel_id)
                reason = READ_ONLY if self.read_only else "it was not advertised, or was refused"
                session.error(f"client message data: channel {data.channel_id}: {reason}")
            return
        self.backend.client_publish(session.id, data.channel_id, data.payload)

    def _on_service_call(self, session: _Session, call: protocol.ServiceCall) -> None:
        def fail(message: str) -> None:
            self._failure(session, call.service_id, call.call_id, message)

        service = self._services.get(call.service_id)
        if self.read_only:
            fail(f"service call: {READ_ONLY}")
        elif service is None:
            fail(f"service call request: serviceId: no service {call.service_id} is advertised")
        elif call.encoding != ENCODING:
            fail(f"service call request: encoding: {call.encoding!r} is not supported (only {ENCODING})")
        else:
            self.backend.call_service(session.id, service, call.call_id, call.payload)

    def _on_getParameters(self, session: _Session, fields: tuple[list[str], str | None]) -> None:  # noqa: N802
        names, request_id = fields
        self.backend.get_parameters(session.id, names, request_id)

    def _on_setParameters(  # noqa: N802
        self, session: _Session, fields: tuple[list[ParameterSetting], str | None]
    ) -> None:
        settings, request_id = fields
        if self.read_only:
            session.error(f"setParameters: {READ_ONLY}")
            if request_id is not None and settings:  # the client's view goes back to what the nodes hold
                self.backend.get_parameters(session.id, [s.name for s in settings], request_id)
            return
        self.backend.set_parameters(session.id, settings, request_id)

    def _on_subscribeParameterUpdates(self, session: _Session, names: list[str]) -> None:  # noqa: N802
        if names:
            session.parameters.update(names)
        else:
            session.all_parameters = True
        self._rewatch()

    def _on_unsubscribeParameterUpdates(self, session: _Session, names: list[str]) -> None:  # noqa: N802
        if names:
            session.parameters.difference_update(names)
        else:
            session.parameters.clear()
            session.all_parameters = False
        self._rewatch()

    def _on_subscribeConnectionGraph(self, session: _Session, _: None) -> None:  # noqa: N802
        if session.graph is None:
            session.graph = GraphSnapshot()
            self._send_graph(session)
            self._rewatch()

    def _on_unsubscribeConnectionGraph(self, session: _Session, _: None) -> None:  # noqa: N802
        session.graph = None
        self._rewatch()

    def _on_fetchAsset(self, session: _Session, _: None) -> None:  # noqa: N802
        session.error("fetchAsset: the bridge serves no assets (no assets capability)")

    def _send_graph(self, session: _Session) -> None:
        if session.graph is None:
            return
        update = self._graph.update_from(session.graph)
        if update is not None:
            session.send(update)
        session.graph = self._graph

    def _failure(self, session: _Session, service_id: int, call_id: int, message: str) -> None:
        session.send(
            {"op": "serviceCallFailure", "serviceId": service_id, "callId": call_id, "message": message}
        )

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
        self._post(self._advertise, channels)

    def _advertise(self, channels: list[Channel]) -> None:
        for channel in channels:
            self._channels[channel.id] = channel
        for session in self._sessions.values():
            session.send({"op": "advertise", "channels": [c.advert() for c in channels]})

    def unadvertise(self, ids: list[int]) -> None:
        """Withdraw channels (their subscriptions end)."""
        self._post(self._unadvertise, ids)

    def _unadvertise(self, ids: list[int]) -> None:
        for channel in ids:
            self._channels.pop(channel, None)
        for session in self._sessions.values():
            for channel in ids:
                subscription = session.by_channel.pop(channel, None)
                if subscription is not None:
                    del session.subscriptions[subscription]
            session.send({"op": "unadvertise", "channelIds": ids})

    def advertise_services(self, services: list[Service]) -> None:
        """Announce new services (not to clients of a read-only bridge, which may not call them)."""
        self._post(self._advertise_services, services)

    def _advertise_services(self, services: list[Service]) -> None:
        for service in services:
            self._services[service.id] = service
        if not self.read_only:
            for session in self._sessions.values():
                session.send({"op": "advertiseServices", "services": [s.advert() for s in services]})

    def unadvertise_services(self, ids: list[int]) -> None:
        """Withdraw services."""
        self._post(self._unadvertise_services, ids)

    def _unadvertise_services(self, ids: list[int]) -> None:
        for service in ids:
            self._services.pop(service, None)
        if not self.read_only:
            for session in self._sessions.values():
                session.send({"op": "unadvertiseServices", "serviceIds": ids})

    def message(self, channel: int, client: int, payload: bytes, wall_ns: int) -> None:
        """Forward one message of a channel to the client that subscribed it."""
        self._post(self._message, channel, client, payload, wall_ns)

    def _message(self, channel: int, client: int, payload: bytes, wall_ns: int) -> None:
        session = self._sessions.get(client)
        subscription = None if session is None else session.by_channel.get(channel)
        if session is None or subscription is None:
            return  # unsubscribed while the message was on its way
        stamp = self._clock_ns if session.follows_clock else wall_ns
        session.send_data(protocol.message_data(subscription, stamp, payload))

    def clock_running(self, running: bool) -> None:
        """Whether the graph has a /clock publisher (decides the time source of new clients)."""
        self._post(self._set_clock_running, running)

    def _set_clock_running(self, running: bool) -> None:
        self._clock_running = running

    def time(self, stamp_ns: int) -> None:
        """Take the cell clock's latest time (nanoseconds)."""
        self._post(self._time, stamp_ns)

    def _time(self, stamp_ns: int) -> None:
        self._clock_ns = stamp_ns
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
        frame = protocol.time_frame(self._clock_ns)
        for session in self._sessions.values():
            if session.follows_clock:
                session.send_data(frame)

    def service_response(self, client: int, service: int, call_id: int, payload: bytes) -> None:
        """Answer a service call with the ROS response (CDR)."""
        self._post(self._to_client, client, protocol.service_response(service, call_id, ENCODING, payload))

    def service_failure(self, client: int, service: int, call_id: int, message: str) -> None:
        """Answer a service call with why it has no response."""
        self._post(self._service_failure, client, service, call_id, message)

    def _service_failure(self, client: int, service: int, call_id: int, message: str) -> None:
        session = self._sessions.get(client)
        if session is not None:
            self._failure(session, service, call_id, message)

    def _to_client(self, client: int, message: Mapping[str, object] | bytes) -> None:
        session = self._sessions.get(client)
        if session is not None:
            session.send(message)

    def parameter_values(self, client: int, parameters: list[ParameterEntry], request_id: str | None) -> None:
        """Answer getParameters (or setParameters) with the nodes' values."""
        message: dict[str, object] = {"op": "parameterValues", "parameters": parameters}
        if request_id is not None:
            message["id"] = request_id
        self._post(self._to_client, client, message)

    def parameter_update(self, parameters: list[ParameterEntry]) -> None:
        """Parameters that changed on their nodes: to every client subscribed to them."""
        self._post(self._parameter_update, parameters)

    def _parameter_update(self, parameters: list[ParameterEntry]) -> None:
        for session in self._sessions.values():
            wanted = [p for p in parameters if session.wants_parameter(p["name"])]
            if wanted:
                session.send({"op": "parameterValues", "parameters": wanted})

    def status(self, client: int, level: int, message: str) -> None:
        """Send a status line to one client."""
        self._post(self._to_client, client, {"op": "status", "level": level, "message": message})

    def graph(self, snapshot: GraphSnapshot) -> None:
        """Take the connection graph as it is now."""
        self._post(self._set_graph, snapshot)

    def _set_graph(self, snapshot: GraphSnapshot) -> None:
        self._graph = snapshot
        for session in self._sessions.values():
            self._send_graph(session)

    def close(self) -> None:
        """Close every connection and stop the server's thread."""
        loop, stop = self._loop, self._stop
        if loop is not None and stop is not None and not loop.is_closed():
            try:
                loop.call_soon_threadsafe(stop.set)
            except RuntimeError:
                pass
        self._thread.join(STOP_TIMEOUT)
