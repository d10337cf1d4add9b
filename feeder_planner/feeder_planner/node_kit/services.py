"""The guard around every service callback: errors become ``ok=False`` with a one-line ``error``."""

from __future__ import annotations

import functools
import traceback
from typing import Callable, Protocol, TypeVar

from rclpy.node import Node

from feeder_planner.errors import FeederError, InputError, SolverError

__all__ = ["ServiceResponse", "service_guard"]


class ServiceResponse(Protocol):
    """Every feeder service response carries ``ok`` and ``error``."""

    ok: bool
    error: str


Request = TypeVar("Request")
Response = TypeVar("Response", bound=ServiceResponse)
Callback = Callable[[Request, Response], Response]


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
                node.get_logger().error(f"{callback.__name__} failed:\n{traceback.format_exc()}")
                message = f"internal error: {type(error).__name__}: {error}"
            node.get_logger().warning(f"{callback.__name__}: {message}")
            response.ok = False
            response.error = message
            return response

        return guarded

    return decorate
