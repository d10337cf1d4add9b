"""Message type definitions for bags: the Jazzy standard types plus this workspace's feeder_msgs.

Topics of service and action types are recorded too: a service's ``_service_event`` topic carries
``pkg/srv/Name_Event`` and an action's hidden feedback topic ``pkg/action/Name_FeedbackMessage``.
rosbags' typestore knows messages only (and its definition text generator accepts ``/msg/`` names
only), so these types are read from the type description that rosidl installs next to every interface
(``share/pkg/srv/Name.json``, ``share/pkg/action/Name.json``): the fields of every type the interface
refers to and the exact rosidl type hashes (RIHS01) of each.
"""

from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path
from typing import Any

from rosbags.interfaces import Nodetype, Typestore
from rosbags.interfaces.typing import BaseDesc, Constdefs, Fielddefs, FieldDesc, NameDesc, Typesdict
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

OWN_INTERFACE_PACKAGES = ("feeder_msgs",)

# type_description_interfaces/msg/FieldType: base type ids, and the offsets of the array kinds.
_BASE_TYPES = {
    2: "int8",
    3: "uint8",
    4: "int16",
    5: "uint16",
    6: "int32",
    7: "uint32",
    8: "int64",
    9: "uint64",
    10: "float32",
    11: "float64",
    13: "char",
    15: "bool",
    16: "byte",
    17: "string",
    18: "wstring",
    21: "string",  # bounded string (string_capacity)
    22: "wstring",
}
_NESTED = 1
_ARRAY, _BOUNDED_SEQUENCE, _SEQUENCE = 48, 96, 144

SEPARATOR = "=" * 80


def _share_dir(package: str) -> Path | None:
    from ament_index_python.packages import PackageNotFoundError, get_package_share_directory

    try:
        return Path(get_package_share_directory(package))
    except PackageNotFoundError:
        return None


@lru_cache(maxsize=1)
def typestore() -> Typestore:
    """Jazzy's types, with the .msg files of our own interface packages registered on top."""
    store = get_typestore(Stores.ROS2_JAZZY)
    for package in OWN_INTERFACE_PACKAGES:
        share = _share_dir(package)
        if share is None:
            continue
        definitions: Typesdict = {}
        for path in sorted((share / "msg").glob("*.msg")):
            if not path.exists():  # a symlinked install keeps the link of an interface since removed
                continue
            type_name = f"{package}/msg/{path.stem}"
            parsed = get_types_from_msg(path.read_text(), type_name)
            described = _described_fields(path.with_suffix(".json"), type_name)
            if described is not None:
                # The fields as built: with a symlinked install the .msg is the live source, which may be
                # ahead of the generated code the nodes publish with (the .json is generated with it).
                constants = parsed[type_name][0] if type_name in parsed else []
                parsed[type_name] = (constants, described[0])
                _msg_hashes[type_name] = described[1]
            definitions.update(parsed)
        store.register(definitions)
    return store


_msg_hashes: dict[str, str] = {}


def _described_fields(path: Path, type_name: str) -> tuple[Fielddefs, str] | None:
    """Return a type's fields and hash from its rosidl type description file, or None without one."""
    if not path.is_file():
        return None
    document = json.loads(path.read_text())
    description = document["type_description_msg"]["type_description"]
    if description["type_name"] != type_name:
        return None
    hashes = {h["type_name"]: h["hash_string"] for h in document["type_hashes"]}
    fields = [(f["name"], _field_type(f["type"])) for f in description["fields"]]
    return fields, hashes.get(type_name, "")


# Per service or action type: its fields (as rosbags field definitions) and its rosidl type hash.
_interface_types: dict[str, tuple[Fielddefs, str]] = {}
_loaded: set[str] = set()


def _field_type(field_type: dict[str, Any]) -> FieldDesc:
    """Return the rosbags field definition of a type description's field type."""
    type_id = field_type["type_id"]
    kind, base = divmod(type_id, 48)
    kind *= 48
    if base == _NESTED:
        element: BaseDesc | NameDesc = (Nodetype.NAME, field_type["nested_type_name"])
    elif base in _BASE_TYPES:
        element = (
            Nodetype.BASE,
            (_BASE_TYPES[base], field_type["string_capacity"] if base in (21, 22) else 0),
        )
    else:
        raise ValueError(f"field type id {type_id} has no ROS 2 .msg equivalent")
    if kind == 0:
        return element
    if kind == _ARRAY:
        return (Nodetype.ARRAY, (element, field_type["capacity"]))
    if kind == _BOUNDED_SEQUENCE:
        return (Nodetype.SEQUENCE, (element, field_type["capacity"]))
    return (Nodetype.SEQUENCE, (element, 0))


def _load_interface(package: str, kind: str, name: str) -> None:
    """Read ``share/package/kind/name.json`` and remember every service or action type it describes."""
    key = f"{package}/{kind}/{name}"
    if key in _loaded:
        return
    _loaded.add(key)
    share = _share_dir(package)
    path = None if share is None else share / kind / f"{name}.json"
    if path is None or not path.is_file():
        return
    document = json.loads(path.read_text())
    hashes = {h["type_name"]: h["hash_string"] for h in document["type_hashes"]}
    described = document["type_description_msg"]
    store = typestore()
    for description in [described["type_description"], *described["referenced_type_descriptions"]]:
        type_name = description["type_name"]
        if "/msg/" in type_name:
            continue  # messages come from the typestore (and their packages' .msg files)
        fields = [(f["name"], _field_type(f["type"])) for f in description["fields"]]
        _interface_types[type_name] = (fields, hashes.get(type_name, ""))
        # Registered so that the rest of rosbags (and our checks) know the type exists.
        store.register({type_name: ([], fields)})


def is_known(type_name: str) -> bool:
    """Return whether a bag can describe ``type_name`` (a message, or a service or action type)."""
    if type_name in typestore().fielddefs:
        return True
    parts = type_name.split("/")
    if len(parts) != 3 or parts[1] not in ("srv", "action"):
        return False
    package, kind, name = parts
    _load_interface(package, kind, name.split("_", 1)[0])
    return type_name in _interface_types


def _short_name(type_name: str) -> str:
    """``pkg/msg/Name`` -> ``pkg/Name``: how .msg text (and rosbag2's definitions) name a nested type."""
    package, _, name = type_name.split("/")
    return f"{package}/{name}"


def _field_text(name: str, definition: FieldDesc, nested: list[str]) -> str:
    node_type, detail = definition
    if node_type == Nodetype.BASE:
        base, bound = detail
        return f"{base}<={bound} {name}" if bound else f"{base} {name}"
    if node_type == Nodetype.NAME:
        nested.append(detail)
        return f"{_short_name(detail)} {name}"
    element, count = detail
    if node_type == Nodetype.ARRAY:
        suffix = f"[{count}]"
    else:
        suffix = f"[<={count}]" if count else "[]"
    element_type, element_detail = element
    if element_type == Nodetype.BASE:
        base, bound = element_detail
        return f"{base}<={bound}{suffix} {name}" if bound else f"{base}{suffix} {name}"
    nested.append(element_detail)
    return f"{_short_name(element_detail)}{suffix} {name}"


def _fields_of(type_name: str) -> Fielddefs:
    if type_name in _interface_types:
        return _interface_types[type_name][0]
    return list(typestore().fielddefs[type_name][1])


def _constants_of(type_name: str) -> Constdefs:
    if type_name in _interface_types:
        return []  # type descriptions carry no constants; decoding does not need them
    return list(typestore().fielddefs[type_name][0])


def _definition_text(type_name: str) -> str:
    """Return the ros2msg definition of a type with every nested type after it (as rosbag2 writes it)."""
    blocks: list[str] = []
    done: set[str] = set()
    pending = [type_name]
    while pending:
        current = pending.pop(0)
        if current in done:
            continue
        done.add(current)
        nested: list[str] = []
        lines = [f"{ctype} {cname}={value}" for cname, ctype, value in _constants_of(current)]
        lines += [_field_text(name, definition, nested) for name, definition in _fields_of(current)]
        text = "\n".join(lines) + "\n"
        blocks.append(text if current == type_name else f"{SEPARATOR}\nMSG: {_short_name(current)}\n{text}")
        pending += [n for n in nested if n not in done]
    return "".join(blocks)


def connection_definition(type_name: str) -> tuple[str, str]:
    """Return the message definition text and RIHS01 type hash a bag stores for ``type_name``.

    Raises
    ------
    KeyError
        The type is not known (see :func:`is_known`).
    """
    if not is_known(type_name):
        raise KeyError(type_name)
    if type_name in _interface_types:
        return _definition_text(type_name), _interface_types[type_name][1]
    store = typestore()
    msgdef, _ = store.generate_msgdef(type_name, ros_version=2)
    return msgdef, _msg_hashes.get(type_name) or str(store.hash_rihs01(type_name))


def type_hash(type_name: str) -> str | None:
    """Return the RIHS01 hash of a known type, or None."""
    try:
        return connection_definition(type_name)[1]
    except Exception:  # noqa: BLE001 -- a type rosbags cannot describe
        return None


def message_class(type_name: str) -> type:
    """Return the rclpy message class of ``pkg/msg/Type`` (or ``pkg/srv/Type``, ``pkg/action/Type``)."""
    import importlib

    package, kind, name = type_name.split("/")
    module = importlib.import_module(f"{package}.{kind}")
    if hasattr(module, name):
        return getattr(module, name)
    # Service and action parts are attributes of the interface class: Trigger_Event is Trigger.Event,
    # FeedPart_FeedbackMessage is FeedPart.Impl.FeedbackMessage.
    base, _, part = name.partition("_")
    interface = getattr(module, base)
    if kind == "srv":
        return getattr(interface, part)
    if part in ("Goal", "Result", "Feedback"):
        return getattr(interface, part)
    return getattr(interface.Impl, part)
