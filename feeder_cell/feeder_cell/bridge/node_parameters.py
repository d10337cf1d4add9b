"""ROS parameters of the graph's nodes for clients: read, set, and followed on /parameter_events.

Parameters are read and set through each node's standard parameter services (the nodes that offer all
three of ``PARAMETER_SERVICES``), with idempotent requests (``bridge.calls``, resent while unanswered);
a value a client sets is converted to the type the node declared it with (``bridge.params``), and every
problem is told to the client as one error line naming the request's field. While some client wants
updates, /parameter_events is followed. Runs on the ROS thread only (work queue, discovery timer and the
calls' callbacks), so nothing is locked. Its own module: the parameter requests and their answers are
one concern; ``bridge.params`` only converts values.
"""

from __future__ import annotations

from typing import Callable

from rcl_interfaces.msg import Parameter, ParameterEvent, ParameterValue
from rcl_interfaces.srv import GetParameters, ListParameters, SetParameters
from rclpy.client import Client
from rclpy.node import Node
from rclpy.qos import qos_profile_parameter_events
from rclpy.subscription import Subscription

from feeder_cell.bridge import params as param_json
from feeder_cell.bridge.calls import ServiceCalls
from feeder_cell.bridge.protocol import LEVEL_ERROR, LEVEL_WARNING, ParameterEntry, ParameterSetting
from feeder_cell.bridge.ws import FoxgloveServer
from feeder_planner.node_kit.qos import request_qos

__all__ = ["NodeParameters", "PARAMETER_TIMEOUT", "PARAMETER_SERVICES"]

PARAMETER_TIMEOUT = 5.0  # s a node has to answer a parameter request
# Parameter services every rclpy and rclcpp node offers; a node with all three takes parameter requests.
PARAMETER_SERVICES = ("list_parameters", "get_parameters", "set_parameters")
# A node's parameter values by name, and the problems met reading them.
ReadDone = Callable[[dict[str, ParameterValue], list[str]], None]


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


class NodeParameters:
    """The parameters of the nodes that take parameter requests, for ``server``'s clients."""

    def __init__(self, node: Node, server: FoxgloveServer, calls: ServiceCalls, me: str) -> None:
        self.node = node
        self.server = server
        self.calls = calls
        self.me = me  # the bridge's own node, whose parameters are not offered
        self.parameter_nodes: set[str] = set()
        self._parameter_clients: dict[str, tuple[Client, Client, Client]] = {}  # node -> (list, get, set)
        self._parameter_events: Subscription | None = None

    def see(self, providers: dict[str, tuple[str, ...]]) -> None:
        """Take the services' providers discovery found: the nodes that take parameter requests now."""
        self.parameter_nodes = {
            node
            for node in {n for ids in providers.values() for n in ids}
            if node != self.me and all(f"{node}/{s}" in providers for s in PARAMETER_SERVICES)
        }
        for node in [n for n in self._parameter_clients if n not in self.parameter_nodes]:
            for client in self._parameter_clients.pop(node):
                self.node.destroy_client(client)

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

            self.calls.call(
                self._parameter_client(node, 1),
                GetParameters.Request(names=wanted),
                got,
                PARAMETER_TIMEOUT,
                resend=True,
            )

        self.calls.call(
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

    def get_parameters(self, client: int, names: list[str], request_id: str | None) -> None:
        """Read parameters (all of every node when ``names`` is empty) and answer with their values."""
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

    def set_parameters(self, client: int, settings: list[ParameterSetting], request_id: str | None) -> None:
        """Set parameters on their nodes, then answer with their values when asked."""
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
            self.calls.call(
                self._parameter_client(node, 2), request, answered, PARAMETER_TIMEOUT, resend=True
            )

        self._read_node(node, names, current)

    def watch_parameters(self, watched: bool) -> None:
        """Follow /parameter_events while some client wants updates."""
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
