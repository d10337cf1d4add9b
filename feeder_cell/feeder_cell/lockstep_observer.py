"""What ``feeder launch`` does on the lockstep cell clock: record every quantum whole, and time the run.

The recorder is an observe participant (``feeder_planner.node_kit.lockstep``): at ``/lockstep/quiet``
T every device sample and every reaction of quantum T is in its queue; it drains them, subscribes to
any topic that appeared in the quantum (a device configured by the controller makes its publishers
then) and answers T only once its new readers have matched every publisher of their topics, so the
first samples of a new topic are recorded too, at any pace.
"""

from __future__ import annotations

import time
from typing import Any

from rclpy.executors import Executor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock

from feeder_planner.node_kit.lockstep import NANOSECONDS, Participant

__all__ = ["CellTime", "RecordingObserver"]

# After new readers have matched their publishers, the publishers' side of the match (which DDS
# completes on its own discovery traffic, in no order with the data) is given this long (wall s).
MATCH_SETTLE_S = 0.05


class CellTime:
    """The cell clock as the launch sees it: cell time now, and the pace achieved over the run."""

    def __init__(self, node: Node) -> None:
        self.node = node
        self.first: tuple[int, float] | None = None  # (cell ns, wall s) of the first advance
        self.last: tuple[int, float] | None = None
        self._start_ns = -1
        qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        node.create_subscription(Clock, "/clock", self._on_clock, qos)

    def _on_clock(self, msg: Clock) -> None:
        now_ns = int(msg.clock.sec) * NANOSECONDS + int(msg.clock.nanosec)
        wall = time.monotonic()
        if self._start_ns < 0:
            self._start_ns = now_ns  # the start time the clock holds while its participants join
        elif self.first is None and now_ns > self._start_ns:
            self.first = (now_ns, wall)
        if self.first is not None:
            self.last = (now_ns, wall)

    def now_ns(self) -> int:
        """Return the node clock (cell time under use_sim_time), ns."""
        return int(self.node.get_clock().now().nanoseconds)

    def summary(self) -> dict[str, float]:
        """Cell and wall seconds from the first advance to the last, and their ratio."""
        if self.first is None or self.last is None or self.last[1] <= self.first[1]:
            return {"cell_s": 0.0, "wall_s": 0.0, "achieved_real_time_factor": 0.0}
        cell = (self.last[0] - self.first[0]) / NANOSECONDS
        wall = self.last[1] - self.first[1]
        return {"cell_s": cell, "wall_s": wall, "achieved_real_time_factor": cell / wall}


class RecordingObserver:
    """Holds each quantum until the recorder has taken it in whole (subscribed and matched included)."""

    def __init__(self, node: Node, recorder: Any) -> None:
        self.node = node
        self.recorder = recorder
        self.participant = Participant(node, "observe", hold=True)
        self._topics: list[tuple[str, list[str]]] = []
        self._settle_until = 0.0

    def after_spin(self, executor: Executor) -> None:
        """Drain a quiet announcement and answer it once every new topic is subscribed and matched."""
        self.participant.answer_pending(executor)
        now_ns = self.participant.drained_ns
        if now_ns <= self.participant.answered_ns:
            return
        topics = sorted((name, list(types)) for name, types in self.node.get_topic_names_and_types())
        if topics != self._topics:
            if self.recorder.discover():
                self._settle_until = time.monotonic() + MATCH_SETTLE_S
            if not self._matched():
                return  # looked at again after the next spin
            self._topics = topics
        if time.monotonic() < self._settle_until:
            return
        self.participant.release(now_ns)

    def _matched(self) -> bool:
        for name, subscription in self.recorder.subscriptions().items():
            if subscription.get_publisher_count() < self.node.count_publishers(name):
                return False
        return True

    def holding(self) -> bool:
        """Whether a quantum waits for this recorder (the launch then spins with a short timeout)."""
        return self.participant.drained_ns > self.participant.answered_ns

    def leave(self) -> None:
        """Leave the lockstep (the launch is ending)."""
        self.participant.leave()
