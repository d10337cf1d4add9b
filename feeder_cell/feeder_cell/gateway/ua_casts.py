"""NodeIds and StatusCodes built from built-in values, typed as asyncua declares them.

asyncua annotates its constructors with its marker subclasses of the built-in types (ua.UInt32,
ua.String, ua.Int16, ua.DateTime) yet takes the built-in values themselves: these casts say so to mypy
and change nothing at run time. One module because the address space, the values, the method results
and the service answers all build them.
"""

from __future__ import annotations

from typing import cast

from asyncua import ua

__all__ = ["node_id", "status_code"]


def node_id(identifier: str | int, namespace: int = 0) -> ua.NodeId:
    """Return the NodeId of ``identifier`` in namespace ``namespace``."""
    return ua.NodeId(cast("ua.String | ua.Int32", identifier), cast(ua.Int16, namespace))


def status_code(code: int) -> ua.StatusCode:
    """Return the StatusCode of a ``ua.StatusCodes`` number."""
    return ua.StatusCode(cast(ua.UInt32, code))
