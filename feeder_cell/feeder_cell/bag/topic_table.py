"""The recording's topics as a bag declares them: type, definition, type hash, offered profiles, count.

``metadata.yaml`` lists every profile a topic's publishers offered, as rosbag2 does, while the MCAP
channel keeps the profile it was created with; snapshot bags are declared from the same table on the
snapshot writer's thread. Separate from the readers (``topic_readers``), which match the publishers:
this is what the bag says about each topic.

Locking: ``lock`` is the recorder's (the same object); it guards ``info`` and ``stats`` (and the bag's
channels ``declare`` adds) as it did when they were the recorder's own.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

from rosbags.interfaces import Qos

from feeder_cell.bag.disk_bag import DiskBag
from feeder_cell.bag.snapshot import TopicInfo
from feeder_cell.bag.types import connection_definition

__all__ = ["TopicStats", "TopicTable"]


@dataclass
class TopicStats:
    """Messages recorded on one topic."""

    type_name: str
    count: int = 0


class TopicTable:
    """Each recorded topic's declaration, and ``stats`` (the recorder's dict): its message count."""

    def __init__(self, stats: dict[str, TopicStats], lock: threading.Lock) -> None:
        self.stats = stats
        self.lock = lock
        self.info: dict[str, TopicInfo] = {}

    def declare(self, name: str, type_name: str, profile: Qos, disk: DiskBag | None) -> None:
        """Declare a topic, or one more profile its publishers offer, in the bag if any (the lock held)."""
        info = self.info.get(name)
        if info is None:
            msgdef, rihs01 = connection_definition(type_name)
            self.info[name] = TopicInfo(type_name, msgdef, rihs01, (profile,))
            if disk is not None:
                disk.add_connection(name, type_name, msgdef, rihs01, profile)
            self.stats[name] = TopicStats(type_name)
        elif profile not in info.profiles:
            # The MCAP channel keeps the profile it was created with; metadata.yaml, written at
            # close, lists every profile the topic's publishers offered, as rosbag2 does.
            self.info[name] = TopicInfo(info.type_name, info.msgdef, info.rihs01, (*info.profiles, profile))
            if disk is not None:
                disk.add_profile(name, profile)

    def known(self) -> dict[str, TopicInfo]:
        """Every subscribed topic's declaration (for the snapshot writer's thread)."""
        with self.lock:
            return dict(self.info)
