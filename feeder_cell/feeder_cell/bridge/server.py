"""The ROS side of ``feeder bridge``: the live graph as Foxglove channels, services, parameters and clock.

Every ``GRAPH_PERIOD`` the bridge looks at the graph. A topic with a publisher, of one type we can
describe, becomes a channel with its ``ros2msg`` schema (``bridge.schemas``) and ``cdr`` encoding; a
topic whose publishers are all gone is withdrawn. Every service (except hidden ones, such as an action's
``_action/*`` services, and the bridge's own) is advertised with its request and response schemas, and a
call is made with an rclpy client and answered with the node's response, or with why there is none.
Parameters are read and set through each node's standard parameter services; updates come from
``/parameter_events``. A client that follows the cell clock (one was running when it connected) is fed
``/clock``.

Subscriptions are made per client and channel, as raw rclpy subscriptions matching what the publishers
offer (reliable unless one is best effort, transient-local when one is latched): so every client, however
late, gets the latched markers and descriptions from DDS itself, as with the ROS foxglove_bridge.

Threads: the WebSocket server (``bridge.ws``) runs on its own thread and calls this class's backend
methods there; each one only queues the work and wakes the executor with a guard condition, so all rclpy
calls happen on the ROS thread. Answers go back through the server's thread-safe methods.
"""

from __future__ import annotations

import itertools
import re
import ssl
import time
from collections import deque
from dataclasses import dataclass, field
from typing import Any, Callable, TypeVarTuple, Unpack

from rcl_interfaces.msg import Parameter, ParameterEvent, ParameterValue
from rcl_interfaces.srv import GetParameters, ListParameters, SetParameters
from rclpy.client import Client
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_parameter_events
from rclpy.serialization import deserialize_message, serialize_message
from rclpy.subscription import Subscription
from rclpy.topic_endpoint_info import TopicEndpointInfo
from rosgraph_msgs.msg import Clock

from feeder_cell.bag.qos import matching_qos, offered_qos
from feeder_cell.bag.types import message_class
from feeder_cell.bridge import params as param_json
from feeder_cell.bridge.adverts import Channel, GraphSnapshot, Service
from feeder_cell.bridge.defaults import (
    DEFAULT_ADDRESS,
    DEFAULT_CLIENT_TOPICS,
    DEFAULT_PORT,
    DEFAULT_SERVICE_TIMEOUT,
)
from feeder_cell.bridge.protocol import (
    LEVEL_ERROR,
    LEVEL_WARNING,
    ClientChannel,
    ParameterEntry,
    ParameterSetting,
)
from feeder_cell.bridge.schemas import schema_of, service_schemas
from feeder_cell.bridge.ws import FoxgloveServer
from feeder_planner.node_kit.qos import request_qos

__all__ = ["DEFAULT_ADDRESS", "DEFAULT_PORT", "GRAPH_PERIOD", "GraphBridge"]

GRAPH_PERIOD = 1.0  # s between two looks at the graph (topics, services, nodes)
CHECK_PERIOD = 0.05  # s between two looks at the calls in flight (a server matched, a deadline passed)
SUBSCRIPTION_DEPTH = 10  # a viewer wants the newest samples, a latched topic its history
PUBLISH_DEPTH = 10  # a client's messages, as foxglove_bridge publishes them
SERVER_WAIT = 5.0  # s a call waits for its service's server to be matched before it fails
# s after which an idempotent request with no answer is sent again: a server drops the reply to a client
# whose reply reader it has not matched yet (DDS matches the two ends apart), so a new client's first
# request can go unanswered (a CI run: the bridge's first parameter set on a node came back empty).
RESEND_S = 1.0
# A client's first messages on a new publisher wait (at most this long) until DDS has matched the topic's
# subscribers: a volatile message published before the match is lost to them, and a Foxglove user who
# clicks "publish" once expects it to arrive.
MATCH_WAIT = 2.0
PARAMETER_TIMEOUT = 5.0  # s a node has to answer a parameter request
# Parameter services every rclpy and rclcpp node offers; a node with all three takes parameter requests.
PARAMETER_SERVICES = ("list_parameters", "get_parameters", "set_parameters")

Arguments = TypeVarTuple("Arguments")
# A service's answer: (its response, None) or (None, why there is none). The call machinery assumes
# nothing of the response; each caller's callback takes its own service's response type.
Done = Callable[[object, str | None], None]
# A node's parameter values by name, and the problems met reading them.
ReadDone = Callable[[dict[str, ParameterValue], list[str]], None]


def _hidden(name: str) -> bool:
    """Return whether a ROS name is hidden (a segment starts with an underscore), as ros2 lists hide it."""
    return any(part.startswith("_") for part in name.split("/"))


def _full_name(node: str, namespace: str) -> str:
    return f"{namespace.rstrip('/')}/{node}"


def _type_name(schema_name: str) -> str:
    """``pkg/Name`` (how ROS 1 and some clients name a message) -> ``pkg/msg/Name``."""
    parts = schema_name.split("/")
    return f"{parts[0]}/msg/{parts[1]}" if len(parts) == 2 else schema_name


@dataclass
class _Topic:
    name: str
    type_name: str
    channel: Channel
    offer: tuple[bool, bool]  # (reliable, latched) the publishers offer now
    subscriptions: dict[int, Subscription] = field(default_factory=dict)  # client -> its subscription
    subscribed_offer: tuple[bool, bool] | None = None


@dataclass
class _Service:
    service: Service
    srv_class: Any
    client: Client | None = None  # made at the first call


@dataclass
class _Call:
    """A service request in flight: sent once its server is matched, failed at its deadline."""

    client: Client
    request: Any
    done: Done
    timeout: float
    server_deadline: float
    deadline: float
    future: Any = None
    finished: bool = False
    resend: bool = False  # an idempotent request (a parameter read, or a set of the same values)
    sent_at: float = 0.0
    sent: list[Any] = field(default_factory=list)  # every request's future, the earlier ones too


@dataclass
class _Publisher:
    publisher: Publisher
    msg_class: Any
    topic: str
    type_name: str
    match_deadline: float
    waiting: deque[bytes] = field(default_factory=deque)  # held until the subscribers are matched


class _Gather:
    """Collects the answers of several nodes and calls ``finish`` with all of them once the last arrives."""

    def __init__(self, count: int, finish: Callable[[list[ParameterEntry]], None]) -> None:
        self.left = count
        self.values: list[ParameterEntry] = []
        self.finish = finish
        if count == 0:
            finish([])

    def add(self, values: list[ParameterEntry]) -> None:
        self.values += values
        self.left -= 1
        if self.left == 0:
            self.finish(self.values)


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
        self._channel_ids = itertools.count(1)
        self._service_ids = itertools.count(1)
        self.topics: dict[str, _Topic] = {}
        self.by_channel: dict[int, _Topic] = {}
        self.skipped: set[str] = set()  # topics we cannot describe, warned about once
        self.services: dict[str, _Service] = {}
        self.skipped_services: set[str] = set()
        self.parameter_nodes: set[str] = set()
        self._parameter_clients: dict[str, tuple[Client, Client, Client]] = {}  # node -> (list, get, set)
        self._service_types: dict[str, list[str]] = {}
        self._calls: list[_Call] = []
        self._publishers: dict[tuple[int, int], _Publisher] = {}
        self._refused: set[tuple[int, int]] = set()  # client channels refused at advertise
        self._parameter_events: Subscription | None = None
        self._clock: Subscription | None = None
        self._watch_graph = False
        self._graph = GraphSnapshot()
        self._clock_running = False
        self.server = FoxgloveServer(
            self, address, port, read_only, tuple(re.compile(p) for p in client_topics), tls=tls
        )
        self.port = self.server.port
        self.discover()
        node.create_timer(GRAPH_PERIOD, self.discover)
        node.create_timer(CHECK_PERIOD, self._check_calls)

    # --- the queue from the WebSocket thread ------------------------------------------------------------
    def _submit(self, function: Callable[[Unpack[Arguments]], None], *args: Unpack[Arguments]) -> None:
        self._work.append((function.__name__, lambda: function(*args)))
        self._guard.trigger()

    def _drain(self) -> None:
        while self._work:
            name, work = self._work.popleft()
            try:
                work()
            except Exception as error:  # noqa: BLE001 -- one failed request must not end the bridge
                self.node.get_logger().error(f"bridge: {name}: {type(error).__name__}: {error}")

    # Backend (bridge.backend.Backend): called on the WebSocket thread, run on the ROS thread.
    def subscribe(self, client: int, channel: int) -> None:
        """Forward the channel's topic to the client."""
        self._submit(self._subscribe, client, channel)

    def unsubscribe(self, client: int, channel: int) -> None:
        """Stop forwarding the channel's topic to the client."""
        self._submit(self._unsubscribe, client, channel)

    def call_service(self, client: int, service: Service, call_id: int, payload: bytes) -> None:
        """Call a service with a CDR request."""
        self._submit(self._call_service, client, service, call_id, payload)

    def get_parameters(self, client: int, names: list[str], request_id: str | None) -> None:
        """Read parameters (all of every node when ``names`` is empty)."""
        self._submit(self._get_parameters, client, names, request_id)

    def set_parameters(self, client: int, settings: list[ParameterSetting], request_id: str | None) -> None:
        """Set parameters on their nodes."""
        self._submit(self._set_parameters, client, settings, request_id)

    def watch_parameters(self, watched: bool) -> None:
        """Follow /parameter_events while some client wants updates."""
        self._submit(self._watch_parameters, watched)

    def watch_graph(self, watched: bool) -> None:
        """Send connection graph snapshots while some client wants them."""
        self._submit(self._set_watch_graph, watched)

    def follow_clock(self, follow: bool) -> None:
        """Follow /clock while some client keeps cell time."""
        self._submit(self._follow_clock, follow)

    def client_advertise(self, client: int, channel: ClientChannel, where: str) -> None:
        """Make a publisher for a client's channel."""
        self._submit(self._client_advertise, client, channel, where)

    def client_unadvertise(self, client: int, channel: int) -> None:
        """Release a client channel's publisher."""
        self._submit(self._client_unadvertise, client, channel)

    def client_publish(self, client: int, channel: int, payload: bytes) -> None:
        """Publish a client's CDR message."""
        self._submit(self._client_publish, client, channel, payload)

    def client_left(self, client: int) -> None:
        """Release everything made for a client."""
        self._submit(self._client_left, client)

    # --- the graph ---------------------------------------------------------------------------------------
    def discover(self) -> None:
        """Advertise the topics and services that appeared, withdraw those that went."""
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
        providers = self._providers()
        self._see_services(providers)
        self.parameter_nodes = {
            node
            for node in {n for ids in providers.values() for n in ids}
            if node != self.me and all(f"{node}/{s}" in providers for s in PARAMETER_SERVICES)
        }
        for node in [n for n in self._parameter_clients if n not in self.parameter_nodes]:
            for client in self._parameter_clients.pop(node):
                self.node.destroy_client(client)
        running = bool(publishers.get("/clock"))
        if running != self._clock_running:
            self._clock_running = running
            self.server.clock_running(running)
        if self._watch_graph:
            self._send_graph(publishers, providers)

    def _see_topic(self, name: str, type_names: list[str], infos: list[TopicEndpointInfo]) -> None:
        offer = offered_qos(infos)
        topic = self.topics.get(name)
        if topic is not None:
            if offer != topic.offer:  # a latched or best-effort publisher came or went: match it anew
                topic.offer = offer
                for client in list(topic.subscriptions):
                    self._unsubscribe(client, topic.channel.id)
                    self._subscribe(client, topic.channel.id)
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

    def _providers(self) -> dict[str, tuple[str, ...]]:
        """Every service of the graph and the nodes that provide it (the graph's own names)."""
        providers: dict[str, set[str]] = {}
        self._service_types = {}
        for node_name, namespace in self.node.get_node_names_and_namespaces():
            full = _full_name(node_name, namespace)
            try:
                services = self.node.get_service_names_and_types_by_node(node_name, namespace)
            except Exception:  # noqa: BLE001 -- the node left between the two graph queries
                continue
            for service, types in services:
                providers.setdefault(service, set()).add(full)
                self._service_types[service] = types
        return {name: tuple(sorted(nodes)) for name, nodes in providers.items()}

    def _see_services(self, providers: dict[str, tuple[str, ...]]) -> None:
        wanted = {name for name, nodes in providers.items() if not _hidden(name) and nodes != (self.me,)}
        new = []
        for name in sorted(wanted - set(self.services) - self.skipped_services):
            types = self._service_types.get(name, [])
            described = service_schemas(types[0]) if len(types) == 1 else None
            srv_class = None
            if described is not None:
                try:
                    srv_class = message_class(types[0])
                except Exception:  # noqa: BLE001 -- described by its .json but no Python class installed
                    described = None
            if described is None or srv_class is None:
                self.skipped_services.add(name)
                self.node.get_logger().warning(f"not bridged: service {name} ({', '.join(types)}): no schema")
                continue
            service = Service(next(self._service_ids), name, types[0], described[0], described[1])
            self.services[name] = _Service(service, srv_class)
            new.append(service)
        if new:
            self.server.advertise_services(new)
        gone = [name for name in self.services if name not in wanted]
        if gone:
            self.server.unadvertise_services([self.services[name].service.id for name in gone])
            for name in gone:
                entry = self.services.pop(name)
                if entry.client is not None:
                    self.node.destroy_client(entry.client)
        self.skipped_services &= wanted

    def _send_graph(
        self, publishers: dict[str, list[TopicEndpointInfo]], providers: dict[str, tuple[str, ...]]
    ) -> None:
        def names(infos: list[TopicEndpointInfo]) -> tuple[str, ...]:
            return tuple(sorted({_full_name(i.node_name, i.node_namespace) for i in infos}))

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

    def _set_watch_graph(self, watched: bool) -> None:
        self._watch_graph = watched
        if watched:
            self._graph = GraphSnapshot()
            self.discover()

    # --- subscriptions -------------------------------------------------------------------------------------
    def _subscribe(self, client: int, channel: int) -> None:
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

    def _unsubscribe(self, client: int, channel: int) -> None:
        topic = self.by_channel.get(channel)
        subscription = None if topic is None else topic.subscriptions.pop(client, None)
        if subscription is not None:
            self.node.destroy_subscription(subscription)

    # --- calls ----------------------------------------------------------------------------------------------
    def _call(self, client: Client, request: Any, done: Done, timeout: float, resend: bool = False) -> None:
        """Call a service without blocking: ``done(response, None)`` or ``done(None, why)`` later.

        ``resend``: the request is idempotent and is sent again every RESEND_S until an answer comes.
        """
        now = time.monotonic()
        call = _Call(
            client, request, done, timeout, now + min(SERVER_WAIT, timeout), now + timeout, resend=resend
        )
        self._calls.append(call)
        self._send(call)

    def _send(self, call: _Call) -> None:
        if call.client.service_is_ready():
            call.sent_at = time.monotonic()
            future = call.client.call_async(call.request)
            call.future = future
            call.sent.append(future)
            future.add_done_callback(lambda _: self._finish(call, answered=future))

    def _finish(self, call: _Call, error: str | None = None, answered: Any = None) -> None:
        if call.finished:
            return
        if answered is not None and answered is not call.future:
            call.future = answered  # an earlier send was answered after all: its answer is as good
        for future in call.sent:  # the requests not answered are no longer waited for
            if future is not call.future or error is not None:
                call.client.remove_pending_request(future)
        call.finished = True
        self._calls.remove(call)
        if error is not None:
            call.done(None, error)
            return
        try:
            response = call.future.result()
        except Exception as failure:  # noqa: BLE001 -- whatever rclpy raised is the answer's reason
            call.done(None, f"{type(failure).__name__}: {failure}")
        else:
            call.done(response, None)

    def _check_calls(self) -> None:
        now = time.monotonic()
        for entry in self._publishers.values():
            if entry.waiting and (self._matched(entry) or now > entry.match_deadline):
                while entry.waiting:
                    entry.publisher.publish(entry.waiting.popleft())
        for call in list(self._calls):
            if call.future is None:
                self._send(call)
                if call.future is None and now > call.server_deadline:
                    self._finish(call, f"no server of {call.client.srv_name} within {SERVER_WAIT:g} s")
            elif now > call.deadline:
                self._finish(call, f"{call.client.srv_name} did not answer within {call.timeout:g} s")
            elif call.resend and not call.future.done() and now - call.sent_at > RESEND_S:
                self._send(call)  # the earlier request stays pending: whichever is answered first counts

    def _call_service(self, client: int, service: Service, call_id: int, payload: bytes) -> None:
        def fail(message: str) -> None:
            self.server.service_failure(client, service.id, call_id, message)

        entry = self.services.get(service.name)
        if entry is None or entry.service.id != service.id:
            fail(f"service {service.name} is gone from the graph")
            return
        request_type = f"{service.type}_Request"
        try:
            request = deserialize_message(payload, entry.srv_class.Request)
        except Exception as error:  # noqa: BLE001 -- rclpy raises several kinds for bytes that are not CDR
            fail(f"service call request: payload: not a CDR {request_type} ({len(payload)} bytes): {error}")
            return
        if entry.client is None:
            entry.client = self.node.create_client(entry.srv_class, service.name, qos_profile=request_qos())

        def done(response: Any, error: str | None) -> None:
            if error is not None:
                fail(error)
            else:
                self.server.service_response(client, service.id, call_id, serialize_message(response))

        self._call(entry.client, request, done, self.service_timeout)

    # --- parameters -----------------------------------------------------------------------------------------
    def _parameter_client(self, node: str, index: int) -> Client:
        if node not in self._parameter_clients:
            qos = request_qos()
            self._parameter_clients[node] = (
                self.node.create_client(ListParameters, f"{node}/list_parameters", qos_profile=qos),
                self.node.create_client(GetParameters, f"{node}/get_parameters", qos_profile=qos),
                self.node.create_client(SetParameters, f"{node}/set_parameters", qos_profile=qos),
            )
        return self._parameter_clients[node][index]

    def _read_node(self, node: str, names: list[str] | None, done: ReadDone) -> None:
        """Read ``names`` (None: all) of a node: ``done({name: ParameterValue}, problems)``."""

        def listed(response: ListParameters.Response, error: str | None) -> None:
            if error is not None:
                done({}, [f"{node}: {error}"])
                return
            known = list(response.result.names)
            wanted = known if names is None else [n for n in names if n in known]
            problems = [f"{node}.{n}: the node has no such parameter" for n in names or [] if n not in known]
            if not wanted:
                done({}, problems)
                return

            def got(answer: GetParameters.Response, failure: str | None) -> None:
                if failure is not None:
                    done({}, [*problems, f"{node}: {failure}"])
                else:
                    done(dict(zip(wanted, answer.values, strict=False)), problems)

            self._call(
                self._parameter_client(node, 1),
                GetParameters.Request(names=wanted),
                got,
                PARAMETER_TIMEOUT,
                resend=True,
            )

        self._call(
            self._parameter_client(node, 0), ListParameters.Request(), listed, PARAMETER_TIMEOUT, resend=True
        )

    def _group(
        self, client: int, operation: str, field_of: Callable[[int], str], names: list[str]
    ) -> dict[str, list[tuple[int, str]]]:
        """Parameter names by node: {node: [(index in the request, parameter)]}; bad names are told."""
        groups: dict[str, list[tuple[int, str]]] = {}
        for i, name in enumerate(names):
            split = param_json.split_name(name)
            if split is None:
                self.server.status(
                    client,
                    LEVEL_ERROR,
                    f"{operation}: {field_of(i)}: {name!r} is not a parameter name (/node.name)",
                )
            elif split[0] not in self.parameter_nodes:
                self.server.status(
                    client,
                    LEVEL_ERROR,
                    f"{operation}: {field_of(i)}: no node {split[0]} takes parameter requests",
                )
            else:
                groups.setdefault(split[0], []).append((i, split[1]))
        return groups

    def _tell(self, client: int, operation: str, problems: list[str], level: int = LEVEL_ERROR) -> None:
        for problem in problems:
            self.server.status(client, level, f"{operation}: {problem}")

    def _get_parameters(self, client: int, names: list[str], request_id: str | None) -> None:
        operation = "getParameters"
        if names:
            groups = {
                node: [p for _, p in items]
                for node, items in self._group(
                    client, operation, lambda i: f"parameterNames[{i}]", names
                ).items()
            }
            wanted: dict[str, list[str] | None] = dict(groups)
        else:
            wanted = {node: None for node in sorted(self.parameter_nodes)}
        gather = _Gather(len(wanted), lambda values: self.server.parameter_values(client, values, request_id))
        for node, node_names in wanted.items():

            def done(values: dict[str, ParameterValue], problems: list[str], node: str = node) -> None:
                # Every parameter asked for by name that is missing is an error; a node that does not
                # answer while all are read is only a warning (the others' values still come).
                self._tell(client, operation, problems, LEVEL_ERROR if names else LEVEL_WARNING)
                gather.add([param_json.to_json(f"{node}.{n}", v) for n, v in values.items()])

            self._read_node(node, node_names, done)

    def _set_parameters(self, client: int, settings: list[ParameterSetting], request_id: str | None) -> None:
        operation = "setParameters"
        groups = self._group(client, operation, lambda i: f"parameters[{i}].name", [s.name for s in settings])
        gather = _Gather(
            len(groups),
            lambda values: (
                None if request_id is None else self.server.parameter_values(client, values, request_id)
            ),
        )
        for node, items in groups.items():
            self._set_on_node(client, node, [(i, name, settings[i]) for i, name in items], gather)

    def _set_on_node(
        self, client: int, node: str, items: list[tuple[int, str, ParameterSetting]], gather: _Gather
    ) -> None:
        operation = "setParameters"
        names = [name for _, name, _ in items]

        def report(values: dict[str, ParameterValue], problems: list[str]) -> None:
            self._tell(client, operation, problems)
            gather.add([param_json.to_json(f"{node}.{n}", v) for n, v in values.items()])

        def current(values: dict[str, ParameterValue], problems: list[str]) -> None:
            # Each value is converted to the type the node declared the parameter with.
            self._tell(client, operation, problems)
            parameters = []
            for i, name, setting in items:
                if name not in values:
                    continue
                try:
                    value = param_json.from_json(setting.value, setting.type, values[name].type)
                except ValueError as error:
                    declared = param_json.TYPE_NAMES.get(values[name].type, "?")
                    self._tell(
                        client, operation, [f"parameters[{i}].value: {node}.{name} is a {declared}: {error}"]
                    )
                    continue
                parameters.append(Parameter(name=name, value=value))
            if not parameters:
                self._read_node(node, names, report)
                return

            def answered(response: SetParameters.Response, error: str | None) -> None:
                if error is not None:
                    self._tell(client, operation, [f"{node}: {error}"])
                else:
                    # The node's own reason for each refusal (read-only, out of range, invalid).
                    refused = [
                        f"{node}.{p.name}: {r.reason or 'refused'}"
                        for p, r in zip(parameters, response.results, strict=False)
                        if not r.successful
                    ]
                    self._tell(client, operation, refused)
                self._read_node(node, names, report)

            request = SetParameters.Request(parameters=parameters)
            self._call(self._parameter_client(node, 2), request, answered, PARAMETER_TIMEOUT, resend=True)

        self._read_node(node, names, current)

    def _watch_parameters(self, watched: bool) -> None:
        if watched and self._parameter_events is None:
            self._parameter_events = self.node.create_subscription(
                ParameterEvent, "/parameter_events", self._on_parameter_event, qos_profile_parameter_events
            )
        elif not watched and self._parameter_events is not None:
            self.node.destroy_subscription(self._parameter_events)
            self._parameter_events = None

    def _on_parameter_event(self, event: ParameterEvent) -> None:
        if event.node == self.me:
            return
        values = [
            param_json.to_json(f"{event.node}.{p.name}", p.value)
            for p in [*event.new_parameters, *event.changed_parameters]
        ]
        values += [{"name": f"{event.node}.{p.name}"} for p in event.deleted_parameters]
        if values:
            self.server.parameter_update(values)

    # --- the cell clock ------------------------------------------------------------------------------------
    def _follow_clock(self, follow: bool) -> None:
        if follow and self._clock is None:
            # Best effort matches every /clock writer, reliable or not; only the newest time matters.
            qos = QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)
            self._clock = self.node.create_subscription(
                Clock, "/clock", lambda m: self.server.time(m.clock.sec * 10**9 + m.clock.nanosec), qos
            )
        elif not follow and self._clock is not None:
            self.node.destroy_subscription(self._clock)
            self._clock = None

    # --- client publishing ----------------------------------------------------------------------------------
    def _client_advertise(self, client: int, channel: ClientChannel, where: str) -> None:
        from rclpy.validate_full_topic_name import validate_full_topic_name

        def refuse(message: str) -> None:
            self._refused.add((client, channel.id))
            self.server.status(client, LEVEL_ERROR, message)

        try:
            validate_full_topic_name(channel.topic)
        except Exception as error:  # noqa: BLE001 -- rclpy's InvalidTopicNameException and its kin
            refuse(f"{where}.topic: {error}".splitlines()[0])
            return
        type_name = _type_name(channel.schema_name)
        try:
            msg_class = message_class(type_name)
        except Exception:  # noqa: BLE001 -- no such package, module or message
            refuse(f"{where}.schemaName: {channel.schema_name!r} is not a ROS message type the bridge has")
            return
        carried = dict(self.node.get_topic_names_and_types()).get(channel.topic, [])
        if carried and type_name not in carried:
            refuse(f"{where}.schemaName: {channel.topic} carries {', '.join(carried)}, not {type_name}")
            return
        qos = QoSProfile(depth=PUBLISH_DEPTH, reliability=ReliabilityPolicy.RELIABLE)
        publisher = self.node.create_publisher(msg_class, channel.topic, qos)
        self._refused.discard((client, channel.id))
        self._publishers[(client, channel.id)] = _Publisher(
            publisher, msg_class, channel.topic, type_name, time.monotonic() + MATCH_WAIT
        )

    def _matched(self, entry: _Publisher) -> bool:
        """Whether the publisher has matched every subscriber the graph shows (its own readers aside)."""
        return entry.publisher.get_subscription_count() >= self.node.count_subscribers(entry.topic)

    def _client_unadvertise(self, client: int, channel: int) -> None:
        self._refused.discard((client, channel))
        entry = self._publishers.pop((client, channel), None)
        if entry is not None:
            self.node.destroy_publisher(entry.publisher)

    def _client_publish(self, client: int, channel: int, payload: bytes) -> None:
        entry = self._publishers.get((client, channel))
        if entry is None:
            return  # refused at advertise (the client was told then)
        try:
            deserialize_message(payload, entry.msg_class)  # nothing a node cannot read goes out
        except Exception as error:  # noqa: BLE001 -- rclpy raises several kinds for bytes that are not CDR
            self.server.status(
                client,
                LEVEL_ERROR,
                f"client message data: channel {channel} ({entry.topic}): not a CDR {entry.type_name} "
                f"({len(payload)} bytes): {error}".splitlines()[0],
            )
            return
        if entry.waiting or (time.monotonic() < entry.match_deadline and not self._matched(entry)):
            entry.waiting.append(payload)  # sent by _check_calls once matched (order kept)
        else:
            entry.publisher.publish(payload)

    def _client_left(self, client: int) -> None:
        for topic in self.topics.values():
            subscription = topic.subscriptions.pop(client, None)
            if subscription is not None:
                self.node.destroy_subscription(subscription)
        for key in [k for k in self._publishers if k[0] == client]:
            self.node.destroy_publisher(self._publishers.pop(key).publisher)
        self._refused = {k for k in self._refused if k[0] != client}

    def close(self) -> None:
        """Stop serving, then release every subscription, publisher and client made."""
        self.server.close()
        for name in list(self.topics):
            self._remove_topic(name)
        for entry in self._publishers.values():
            self.node.destroy_publisher(entry.publisher)
        self._publishers.clear()
