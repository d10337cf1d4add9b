"""The Foxglove WebSocket protocol v1 on the wire: frames the bridge sends, and client messages read strictly.

Both subprotocol names carry the same messages: ``foxglove.websocket.v1`` is the name of the published
specification (foxglove/ws-protocol, docs/spec.md), which @foxglove/ws-protocol, Lichtblick, older
Foxglove builds and the clients of the ROS foxglove_bridge offer; ``foxglove.sdk.v1`` is the name the
Foxglove SDK and current Foxglove give the same v1 messages (the SDK's additions, playback control and
assets, are capabilities this bridge does not announce, so no client sends them). Nothing here imports
ROS: a client message is parsed into a plain dataclass, and anything wrong with it raises
:class:`ProtocolError`, whose one-line text names the operation, the field and what is wrong.
"""

from __future__ import annotations

import json
import math
import struct
from dataclasses import dataclass
from typing import Callable, Mapping, NotRequired, TypedDict

__all__ = [
    "SUBPROTOCOLS",
    "ENCODING",
    "LEVEL_INFO",
    "LEVEL_WARNING",
    "LEVEL_ERROR",
    "ProtocolError",
    "ClientChannel",
    "ParameterSetting",
    "ServiceCall",
    "ClientData",
    "ParameterEntry",
    "ParameterJson",
    "parse_text",
    "parse_binary",
    "message_data",
    "time_frame",
    "service_response",
    "to_json",
]

# Preferred first: a client that offers both (current Foxglove) gets the SDK's name.
SUBPROTOCOLS = ("foxglove.sdk.v1", "foxglove.websocket.v1")
# The one message encoding: ROS 2 CDR, both ways (schemas are ros2msg).
ENCODING = "cdr"
# A status message's levels.
LEVEL_INFO, LEVEL_WARNING, LEVEL_ERROR = 0, 1, 2

# Opcodes of binary frames (little-endian integers after the opcode byte).
OP_MESSAGE_DATA = 0x01
OP_TIME = 0x02
OP_SERVICE_CALL_RESPONSE = 0x03
CLIENT_OP_MESSAGE_DATA = 0x01
CLIENT_OP_SERVICE_CALL_REQUEST = 0x02

UINT32_MAX = 2**32 - 1
_HEADER = struct.Struct("<BIQ")  # opcode, subscription id, receive time (ns)
_TIME = struct.Struct("<BQ")
_SERVICE_HEADER = struct.Struct("<BIII")  # opcode, service id, call id, encoding length


class ProtocolError(ValueError):
    """A client message the bridge cannot take; ``str()`` is one line naming where and what."""

    def __init__(self, where: str, problem: str) -> None:
        super().__init__(f"{where}: {problem}")
        self.where = where
        self.problem = problem


@dataclass(frozen=True)
class ClientChannel:
    """A channel a client advertises to publish on (clientPublish)."""

    id: int
    topic: str
    encoding: str
    schema_name: str


@dataclass(frozen=True)
class ParameterSetting:
    """One entry of setParameters: ``value`` None means the client left it undefined (unset)."""

    name: str
    value: object  # the JSON value as sent, converted to the node's type by bridge.params.from_json
    type: str | None


# A parameter's value on the wire (a byte array travels as its base64 text).
ParameterJson = bool | int | float | str | list[bool] | list[int] | list[float] | list[str]


class ParameterEntry(TypedDict):
    """One parameter as parameterValues lists it: no ``value`` when it is not set (or was deleted)."""

    name: str
    value: NotRequired[ParameterJson]
    type: NotRequired[str]  # float64, float64_array or byte_array: how to read a value JSON blurs


@dataclass(frozen=True)
class ServiceCall:
    """A binary service call request."""

    service_id: int
    call_id: int
    encoding: str
    payload: bytes


@dataclass(frozen=True)
class ClientData:
    """A binary client message data frame (a message to publish on an advertised client channel)."""

    channel_id: int
    payload: bytes


def _short(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _uint32(op: str, where: str, value: object) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= UINT32_MAX:
        raise ProtocolError(
            f"{op}: {where}", f"must be a whole number in [0, {UINT32_MAX}], got {_short(value)}"
        )
    return value


def _string(op: str, where: str, value: object) -> str:
    if not isinstance(value, str):
        raise ProtocolError(f"{op}: {where}", f"must be a string, got {_short(value)}")
    return value


def _list(op: str, where: str, value: object) -> list[object]:
    if not isinstance(value, list):
        raise ProtocolError(f"{op}: {where}", f"must be an array, got {_short(value)}")
    return value


def _object(op: str, where: str, value: object) -> dict[str, object]:
    if not isinstance(value, dict):
        raise ProtocolError(f"{op}: {where}", f"must be an object, got {_short(value)}")
    return value


def _field(op: str, message: dict[str, object], name: str, where: str | None = None) -> object:
    if name not in message:
        raise ProtocolError(f"{op}: {where or name}", "missing")
    return message[name]


def _names(op: str, message: dict[str, object]) -> list[str]:
    names = _list(op, "parameterNames", message.get("parameterNames", []))
    return [_string(op, f"parameterNames[{i}]", name) for i, name in enumerate(names)]


def _request_id(op: str, message: dict[str, object]) -> str | None:
    value = message.get("id")
    return None if value is None else _string(op, "id", value)


def _subscribe(message: dict[str, object]) -> list[tuple[int, int]]:
    op = "subscribe"
    out = []
    for i, item in enumerate(_list(op, "subscriptions", _field(op, message, "subscriptions"))):
        entry = _object(op, f"subscriptions[{i}]", item)
        out.append(
            (
                _uint32(op, f"subscriptions[{i}].id", _field(op, entry, "id", f"subscriptions[{i}].id")),
                _uint32(
                    op,
                    f"subscriptions[{i}].channelId",
                    _field(op, entry, "channelId", f"subscriptions[{i}].channelId"),
                ),
            )
        )
    return out


def _ids(op: str, message: dict[str, object], name: str) -> list[int]:
    values = _list(op, name, _field(op, message, name))
    return [_uint32(op, f"{name}[{i}]", v) for i, v in enumerate(values)]


def _advertise(message: dict[str, object]) -> list[ClientChannel]:
    op = "advertise"
    out = []
    for i, item in enumerate(_list(op, "channels", _field(op, message, "channels"))):
        entry = _object(op, f"channels[{i}]", item)
        where = f"channels[{i}]"
        out.append(
            ClientChannel(
                id=_uint32(op, f"{where}.id", _field(op, entry, "id", f"{where}.id")),
                topic=_string(op, f"{where}.topic", _field(op, entry, "topic", f"{where}.topic")),
                encoding=_string(op, f"{where}.encoding", _field(op, entry, "encoding", f"{where}.encoding")),
                schema_name=_string(
                    op, f"{where}.schemaName", _field(op, entry, "schemaName", f"{where}.schemaName")
                ),
            )
        )
    return out


PARAMETER_TYPES = ("byte_array", "float64", "float64_array")


def _settings(message: dict[str, object]) -> list[ParameterSetting]:
    op = "setParameters"
    out = []
    for i, item in enumerate(_list(op, "parameters", _field(op, message, "parameters"))):
        entry = _object(op, f"parameters[{i}]", item)
        name = _string(op, f"parameters[{i}].name", _field(op, entry, "name", f"parameters[{i}].name"))
        kind = entry.get("type")
        if kind is not None and not (isinstance(kind, str) and kind in PARAMETER_TYPES):
            raise ProtocolError(
                f"{op}: parameters[{i}].type",
                f"must be one of {', '.join(PARAMETER_TYPES)}, got {_short(kind)}",
            )
        out.append(ParameterSetting(name, entry.get("value"), kind))
    return out


# op -> the reader of its fields (what parse_text returns for it).
_READERS: dict[str, Callable[[dict[str, object]], object]] = {
    "subscribe": _subscribe,
    "unsubscribe": lambda m: _ids("unsubscribe", m, "subscriptionIds"),
    "advertise": _advertise,
    "unadvertise": lambda m: _ids("unadvertise", m, "channelIds"),
    "getParameters": lambda m: (_names("getParameters", m), _request_id("getParameters", m)),
    "setParameters": lambda m: (_settings(m), _request_id("setParameters", m)),
    "subscribeParameterUpdates": lambda m: _names("subscribeParameterUpdates", m),
    "unsubscribeParameterUpdates": lambda m: _names("unsubscribeParameterUpdates", m),
    "subscribeConnectionGraph": lambda m: None,
    "unsubscribeConnectionGraph": lambda m: None,
    "fetchAsset": lambda m: None,
}
CLIENT_OPS = tuple(_READERS)


def parse_text(text: str) -> tuple[str, object]:
    """Return (op, its fields) of a client's JSON message.

    Raises
    ------
    ProtocolError
        Not JSON, not an object, no or an unknown ``op``, or a field missing or of the wrong type.
    """
    try:
        message = json.loads(text)
    except (ValueError, RecursionError) as error:
        raise ProtocolError("text message", f"not JSON ({error})") from None
    if not isinstance(message, dict):
        raise ProtocolError("text message", f"must be a JSON object with an op, got {type(message).__name__}")
    if "op" not in message:
        raise ProtocolError("op", "missing")
    op = message["op"]
    if not isinstance(op, str) or op not in _READERS:
        raise ProtocolError("op", f"unknown operation {_short(op)} (known: {', '.join(CLIENT_OPS)})")
    return op, _READERS[op](message)


def parse_binary(frame: bytes) -> ServiceCall | ClientData:
    """Return the client's binary message: a service call request or message data.

    Raises
    ------
    ProtocolError
        Empty, an unknown opcode, or shorter than its header says.
    """
    if not frame:
        raise ProtocolError("binary message", "empty")
    opcode = frame[0]
    if opcode == CLIENT_OP_MESSAGE_DATA:
        if len(frame) < 5:
            raise ProtocolError("client message data", f"{len(frame)} byte(s), the header alone is 5")
        (channel_id,) = struct.unpack_from("<I", frame, 1)
        return ClientData(channel_id, bytes(frame[5:]))
    if opcode == CLIENT_OP_SERVICE_CALL_REQUEST:
        if len(frame) < 13:
            raise ProtocolError("service call request", f"{len(frame)} byte(s), the header alone is 13")
        _, service_id, call_id, length = _SERVICE_HEADER.unpack_from(frame, 0)
        if 13 + length > len(frame):
            raise ProtocolError(
                "service call request: encoding length", f"{length} runs past the end ({len(frame)} bytes)"
            )
        try:
            encoding = bytes(frame[13 : 13 + length]).decode("utf-8")
        except UnicodeDecodeError:
            raise ProtocolError("service call request: encoding", "not UTF-8") from None
        return ServiceCall(service_id, call_id, encoding, bytes(frame[13 + length :]))
    raise ProtocolError(
        "binary message: opcode",
        f"unknown opcode 0x{opcode:02x} (0x01 message data, 0x02 service call request)",
    )


def message_data(subscription_id: int, stamp_ns: int, payload: bytes) -> bytes:
    """Return a Message Data frame."""
    return _HEADER.pack(OP_MESSAGE_DATA, subscription_id, stamp_ns) + payload


def time_frame(stamp_ns: int) -> bytes:
    """Return a Time frame."""
    return _TIME.pack(OP_TIME, stamp_ns)


def service_response(service_id: int, call_id: int, encoding: str, payload: bytes) -> bytes:
    """Return a Service Call Response frame."""
    name = encoding.encode()
    return _SERVICE_HEADER.pack(OP_SERVICE_CALL_RESPONSE, service_id, call_id, len(name)) + name + payload


def _finite(value: object) -> object:
    """JSON has no NaN or infinity (a browser's JSON.parse refuses them): they travel as null."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, list):
        return [_finite(v) for v in value]
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    return value


def to_json(message: Mapping[str, object]) -> str:
    """Return a server JSON message as text (compact, strict JSON)."""
    return json.dumps(_finite(message), separators=(",", ":"), allow_nan=False)
