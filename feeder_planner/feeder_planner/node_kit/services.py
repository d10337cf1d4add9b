"""Serving requests: the guard around every service callback, and the request queue every server gets.

- **Guarded.** Errors become ``ok=False`` with a one-line ``error`` naming the field; a bug is logged
  whole and answered ``internal error``; the node lives on. A message never quotes more than
  ``MAX_ERROR_CHARS`` of a request (a 10 MB string is not sent back).
- **Queued deep.** Every service and action server keeps ``request_queue_depth`` requests (parameter,
  default 1000; rclpy's default keeps 10 and drops the rest of a burst without a word).
- **Off the main group.** A planner gives each service its own callback group (``serve(...,
  own_group=True)``) and spins a multi-threaded executor (``run_node(threads=...)``): a long request
  occupies one thread, while the node's topics, timers and its other services go on being served.
"""

from __future__ import annotations

import functools
import traceback
from typing import Any, Callable, Protocol, TypeVar

from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.node import Node
from rclpy.service import Service

from feeder_planner.errors import FeederError, InputError, SolverError
from feeder_planner.node_kit.parameters import ParameterSpec
from feeder_planner.node_kit.qos import DEFAULT_REQUEST_QUEUE_DEPTH, MAX_REQUEST_QUEUE_DEPTH, request_qos

__all__ = [
    "MAX_ERROR_CHARS",
    "REQUEST_QUEUE_PARAMETER",
    "ServiceResponse",
    "check_queue_depth",
    "request_queue_depth",
    "serve",
    "service_guard",
]

# A reply's error line is for a person and a log: long enough for any field path and limit, never a
# request's whole (possibly huge) contents.
MAX_ERROR_CHARS = 1000


def check_queue_depth(value: object) -> str | None:
    """Check ``request_queue_depth``: an integer in [1, MAX_REQUEST_QUEUE_DEPTH]."""
    ok = isinstance(value, int) and not isinstance(value, bool) and 1 <= value <= MAX_REQUEST_QUEUE_DEPTH
    return None if ok else f"must be an integer in [1, {MAX_REQUEST_QUEUE_DEPTH}], got {value!r}"


REQUEST_QUEUE_PARAMETER = ParameterSpec(
    "request_queue_depth",
    DEFAULT_REQUEST_QUEUE_DEPTH,
    "requests each service and action server keeps while busy (a burst beyond it is dropped by DDS)",
    check_queue_depth,
    read_only=True,
)


class ServiceResponse(Protocol):
    """Every feeder service response carries ``ok`` and ``error``."""

    ok: bool
    error: str


Request = TypeVar("Request")
Response = TypeVar("Response", bound=ServiceResponse)
Callback = Callable[[Request, Response], Response]


def request_queue_depth(node: Node) -> int:
    """Return the node's ``request_queue_depth`` (the default when undeclared or invalid).

    A managed device validates the parameter at configure (naming it); its servers exist before that,
    so an invalid value gets the default queue until then rather than a node that cannot start.
    """
    if not node.has_parameter(REQUEST_QUEUE_PARAMETER.name):
        return DEFAULT_REQUEST_QUEUE_DEPTH
    value = node.get_parameter(REQUEST_QUEUE_PARAMETER.name).value
    return int(value) if check_queue_depth(value) is None else DEFAULT_REQUEST_QUEUE_DEPTH


def serve(
    node: Node, srv_type: Any, name: str, callback: Callable[[Any, Any], Any], *, own_group: bool = False
) -> Service:
    """Create a service with the node's deep request queue; ``own_group`` serves it off the main group.

    Parameters
    ----------
    node
        The serving node.
    srv_type, name
        The service type and name (``~/...`` for a private name).
    callback
        The (usually guarded) callback.
    own_group
        Give the service a callback group of its own: under a multi-threaded executor its requests then
        run beside the node's timers, subscriptions and other services, one at a time per service.
    """
    group = MutuallyExclusiveCallbackGroup() if own_group else None
    return node.create_service(
        srv_type, name, callback, qos_profile=request_qos(request_queue_depth(node)), callback_group=group
    )


def _short(text: str) -> str:
    return text if len(text) <= MAX_ERROR_CHARS else text[: MAX_ERROR_CHARS - 3] + "..."


def service_guard(node: Node) -> Callable[[Callback[Request, Response]], Callback[Request, Response]]:
    """Decorate a service callback so that a bad request is answered, never raised; the node lives on."""

    def decorate(callback: Callback[Request, Response]) -> Callback[Request, Response]:
        @functools.wraps(callback)
        def guarded(request: Request, response: Response) -> Response:
            try:
                result = callback(request, response)
                result.ok = True
                result.error = ""
                return result
            except InputError as error:
                message = f"bad request: {error}"
            except SolverError as error:
                message = f"not certified: {error}"
            except FeederError as error:
                message = str(error)
            except Exception as error:  # a bug must not take the node down; log it whole
                node.get_logger().error(f"{callback.__name__} failed:\n{_short(traceback.format_exc())}")
                message = f"internal error: {type(error).__name__}: {error}"
            message = _short(message)
            node.get_logger().warning(f"{callback.__name__}: {message}")
            response.ok = False
            response.error = message
            return response

        return guarded

    return decorate
