"""Conversion between rclpy QoS profiles and the rosbags QoS records stored in bag metadata."""

from __future__ import annotations

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

_ZERO = QosTime(0, 0)


def to_bag_qos(reliable: bool, transient_local: bool, depth: int = 10) -> Qos:
    """Return the bag's QoS record of a publisher with these policies."""
    return Qos(
        QosHistory.KEEP_LAST,
        depth,
        QosReliability.RELIABLE if reliable else QosReliability.BEST_EFFORT,
        QosDurability.TRANSIENT_LOCAL if transient_local else QosDurability.VOLATILE,
        _ZERO,
        _ZERO,
        QosLiveliness.AUTOMATIC,
        _ZERO,
        False,
    )


def from_bag_qos(profiles: list[Qos] | tuple[Qos, ...], depth: int = 10) -> QoSProfile:
    """Return a publisher profile that offers what the recorded publishers offered (latched stays latched)."""
    reliable = not profiles or all(p.reliability != QosReliability.BEST_EFFORT for p in profiles)
    latched = any(p.durability == QosDurability.TRANSIENT_LOCAL for p in profiles)
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=depth,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
    )
