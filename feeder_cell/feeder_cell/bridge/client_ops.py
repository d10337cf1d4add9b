"""Every operation a client sends, on the server's event loop: checked, refused in one line, or handed on.

A request is checked against what is advertised (``bridge.outbound``), the client's own session and what
the bridge allows (read-only, the client-publish allow-list); what is wrong is answered here as an
error status (a failed service call as its failure), and what needs the ROS graph goes to the
:class:`~feeder_cell.bridge.backend.Backend`. The op table in :class:`ClientOps` is the one place a text
operation is routed (``protocol.parse_text`` knows only these ops). Everything runs on the server's
event loop, so nothing is locked. Separate from ``ws`` so that the server's thread, loop and sessions
read apart from the protocol's operations.
"""

from __future__ import annotations

import re
from typing import Any, Callable

from feeder_cell.bridge import protocol
from feeder_cell.bridge.adverts import GraphSnapshot
from feeder_cell.bridge.backend import Backend
from feeder_cell.bridge.outbound import Outbound
from feeder_cell.bridge.protocol import ENCODING, ClientChannel, ClientData, ParameterSetting, ProtocolError
from feeder_cell.bridge.session import Session

__all__ = ["ClientOps", "READ_ONLY"]

READ_ONLY = "refused: the bridge is read-only (--read-only)"


class ClientOps:
    """Take each client frame: route its operation, check it, refuse it or hand it to ``backend``."""

    def __init__(
        self,
        backend: Backend,
        outbound: Outbound,
        read_only: bool,
        client_topics: tuple[re.Pattern[str], ...],
        rewatch: Callable[[], None],
    ) -> None:
        self.backend = backend
        self.outbound = outbound
        self.read_only = read_only
        self.client_topics = client_topics
        self._rewatch = rewatch  # tells the backend what the clients as a whole still want
        # op -> its handler, which takes the op's fields as protocol.parse_text read them.
        self._ops: dict[str, Callable[[Session, Any], None]] = {
            "subscribe": self._on_subscribe,
            "unsubscribe": self._on_unsubscribe,
            "advertise": self._on_advertise,
            "unadvertise": self._on_unadvertise,
            "getParameters": self._on_get_parameters,
            "setParameters": self._on_set_parameters,
            "subscribeParameterUpdates": self._on_subscribe_parameter_updates,
            "unsubscribeParameterUpdates": self._on_unsubscribe_parameter_updates,
            "subscribeConnectionGraph": self._on_subscribe_connection_graph,
            "unsubscribeConnectionGraph": self._on_unsubscribe_connection_graph,
            "fetchAsset": self._on_fetch_asset,
        }

    def receive(self, session: Session, frame: str | bytes) -> None:
        """Take one frame of the client's: a malformed one is answered with its one-line error."""
        try:
            if isinstance(frame, str):
                op, fields = protocol.parse_text(frame)
                self._ops[op](session, fields)
            else:
                item = protocol.parse_binary(frame)
                if isinstance(item, ClientData):
                    self._on_client_data(session, item)
                else:
                    self._on_service_call(session, item)
        except ProtocolError as error:
            session.error(str(error))

    def _on_subscribe(self, session: Session, entries: list[tuple[int, int]]) -> None:
        for i, (subscription, channel) in enumerate(entries):
            where = f"subscribe: subscriptions[{i}]"
            if channel not in self.outbound.channels:
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

    def _on_unsubscribe(self, session: Session, ids: list[int]) -> None:
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

    def _on_advertise(self, session: Session, channels: list[ClientChannel]) -> None:
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

    def _on_unadvertise(self, session: Session, ids: list[int]) -> None:
        for i, channel in enumerate(ids):
            if session.client_channels.pop(channel, None) is None:
                session.error(f"unadvertise: channelIds[{i}]: channel {channel} is not advertised")
            else:
                self.backend.client_unadvertise(session.id, channel)

    def _on_client_data(self, session: Session, data: ClientData) -> None:
        if data.channel_id not in session.client_channels:
            # Once per channel: a client publishing at 100 Hz on a refused channel gets one line, not 100/s.
            if data.channel_id not in session.unknown_reported:
                session.unknown_reported.add(data.channel_id)
                reason = READ_ONLY if self.read_only else "it was not advertised, or was refused"
                session.error(f"client message data: channel {data.channel_id}: {reason}")
            return
        self.backend.client_publish(session.id, data.channel_id, data.payload)

    def _on_service_call(self, session: Session, call: protocol.ServiceCall) -> None:
        def fail(message: str) -> None:
            session.failure(call.service_id, call.call_id, message)

        service = self.outbound.services.get(call.service_id)
        if self.read_only:
            fail(f"service call: {READ_ONLY}")
        elif service is None:
            fail(f"service call request: serviceId: no service {call.service_id} is advertised")
        elif call.encoding != ENCODING:
            fail(f"service call request: encoding: {call.encoding!r} is not supported (only {ENCODING})")
        else:
            self.backend.call_service(session.id, service, call.call_id, call.payload)

    def _on_get_parameters(self, session: Session, fields: tuple[list[str], str | None]) -> None:
        names, request_id = fields
        self.backend.get_parameters(session.id, names, request_id)

    def _on_set_parameters(self, session: Session, fields: tuple[list[ParameterSetting], str | None]) -> None:
        settings, request_id = fields
        if self.read_only:
            session.error(f"setParameters: {READ_ONLY}")
            if request_id is not None and settings:  # the client's view goes back to what the nodes hold
                self.backend.get_parameters(session.id, [s.name for s in settings], request_id)
            return
        self.backend.set_parameters(session.id, settings, request_id)

    def _on_subscribe_parameter_updates(self, session: Session, names: list[str]) -> None:
        if names:
            session.parameters.update(names)
        else:
            session.all_parameters = True
        self._rewatch()

    def _on_unsubscribe_parameter_updates(self, session: Session, names: list[str]) -> None:
        if names:
            session.parameters.difference_update(names)
        else:
            session.parameters.clear()
            session.all_parameters = False
        self._rewatch()

    def _on_subscribe_connection_graph(self, session: Session, _: None) -> None:
        if session.graph is None:
            session.graph = GraphSnapshot()
            self.outbound.send_graph(session)
            self._rewatch()

    def _on_unsubscribe_connection_graph(self, session: Session, _: None) -> None:
        session.graph = None
        self._rewatch()

    def _on_fetch_asset(self, session: Session, _: None) -> None:
        session.error("fetchAsset: the bridge serves no assets (no assets capability)")
