"""Message type definitions for bags: the Jazzy standard types plus this workspace's feeder_msgs."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

from rosbags.interfaces import Typestore
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

OWN_INTERFACE_PACKAGES = ("feeder_msgs",)


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
        definitions: dict = {}
        for path in sorted((share / "msg").glob("*.msg")):
            definitions.update(get_types_from_msg(path.read_text(), f"{package}/msg/{path.stem}"))
        store.register(definitions)
    return store


def message_class(type_name: str) -> type:
    """Return the rclpy message class of ``pkg/msg/Type``."""
    import importlib

    package, kind, name = type_name.split("/")
    return getattr(importlib.import_module(f"{package}.{kind}"), name)
