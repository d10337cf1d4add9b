"""The graph's services as the bridge advertises them, and a client's call of one.

Every service (except hidden ones, such as an action's ``_action/*`` services, and the bridge's own) is
advertised with its request and response schemas; a service that left is withdrawn. A client's call is
made with an rclpy client (``bridge.calls``) and answered with the node's response, or with why there is
none. Everything runs on the ROS thread (the bridge's discovery timer and its work queue), so nothing is
locked. Its own module: which services exist and how a client calls one is one concern, apart from
topics and parameters.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Any

from rclpy.client import Client
from rclpy.node import Node
from rclpy.serialization import deserialize_message, serialize_message

from feeder_cell.bag.types import message_class
from feeder_cell.bridge.adverts import Service
from feeder_cell.bridge.calls import ServiceCalls
from feeder_cell.bridge.graph import full_name
from feeder_cell.bridge.schemas import service_schemas
from feeder_cell.bridge.ws import FoxgloveServer
from feeder_planner.node_kit.qos import request_qos

__all__ = ["BridgedServices"]


def _hidden(name: str) -> bool:
    """Return whether a ROS name is hidden (a segment starts with an underscore), as ros2 lists hide it."""
    return any(part.startswith("_") for part in name.split("/"))


@dataclass
class _Service:
    service: Service
    srv_class: Any
    client: Client | None = None  # made at the first call


class BridgedServices:
    """The services advertised to ``server``'s clients, called through ``calls``."""

    def __init__(
        self, node: Node, server: FoxgloveServer, calls: ServiceCalls, me: str, service_timeout: float
    ) -> None:
        self.node = node
        self.server = server
        self.calls = calls
        self.me = me  # the bridge's own node, whose services are not advertised
        self.service_timeout = service_timeout
        self._service_ids = itertools.count(1)
        self.services: dict[str, _Service] = {}
        self.skipped_services: set[str] = set()
        self._service_types: dict[str, list[str]] = {}

    def discover(self) -> dict[str, tuple[str, ...]]:
        """Advertise the services that appeared, withdraw those that went; return every provider."""
        providers = self._providers()
        self._see_services(providers)
        return providers

    def _providers(self) -> dict[str, tuple[str, ...]]:
        """Every service of the graph and the nodes that provide it (the graph's own names)."""
        providers: dict[str, set[str]] = {}
        self._service_types = {}
        for node_name, namespace in self.node.get_node_names_and_namespaces():
            full = full_name(node_name, namespace)
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

    def call_service(self, client: int, service: Service, call_id: int, payload: bytes) -> None:
        """Call a service with a client's CDR request; answer with its response or why there is none."""

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

        self.calls.call(entry.client, request, done, self.service_timeout)
