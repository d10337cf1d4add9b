"""Recording and replaying rosbag2 MCAP bags with rclpy and rosbags (ros2bag is not available here)."""

from feeder_cell.bag.player import open_bag, play
from feeder_cell.bag.qos import from_bag_qos, to_bag_qos
from feeder_cell.bag.recorder import DEFAULT_EXCLUDED, Recorder, TopicStats, missing_topics
from feeder_cell.bag.types import message_class, typestore

__all__ = [
    "DEFAULT_EXCLUDED",
    "Recorder",
    "TopicStats",
    "from_bag_qos",
    "message_class",
    "missing_topics",
    "open_bag",
    "play",
    "to_bag_qos",
    "typestore",
]
