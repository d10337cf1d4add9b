"""What ``feeder launch`` does on the lockstep cell clock: record every quantum whole, and time the run.

The recorder is an observe participant (``feeder_planner.node_kit.lockstep``): at ``/lockstep/quiet``
T every device sample and every reaction of quantum T is in its queue; it drains them, subscribes to
any topic that appeared in the quantum (a device configured by the controller makes its publishers
then) and answers T only once its new readers have matched every publisher of their topics, so the
first samples of a new topic are recorded too, at any pace. A message's log time is the cell time of
the quantum it belongs to (the quantum after the last one answered), not the moment it happened to be
taken: so the same run gives the same bag at every pace.
"""

from __future__ import annotations

import time
from typing import Any, Callable

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.exceptions import InvalidHandle
from rclpy.executors import Executor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock

from feeder_planner.node_kit.lockstep import NANOSECONDS, Participant

__all__ = ["CellTime", "RecordingObserver"]

# After new readers have matched their publishers, the quantum is held this long (wall s): the
# publishers' side of the match (which DDS completes on its own discovery traffic, in no order with
# the data) and a latched publisher's history, which it sends on matching (within milliseconds), belong
# to the quantum the topic appeared in. Only a quantum in which topics appear pays it. Not "until no
# message comes": a latched topic published on a wall-clock timer (markers) never falls silent.
MATCH_SETTLE_S = 0.2
# The most a quantum waits for new readers to match (wall s): a publisher the recorder cannot match
# (an incompatible QoS) must not hold the cell; its topic is named in a warning.
MATCH_TIMEOUT_S = 2.0
# At start-up the publishers' side of the match is given longer: a status published once, as the cell
# starts, and replaced soon after is lost from a latched history of one if its writer matched late (a
# loaded machine's discovery takes hundreds of milliseconds).
START_SETTLE_S = 1.0


class CellTime:
    """The cell clock as the launch sees it: cell time now, and the pace achieved over the run."""

    def __init__(self, node: Node) -> None:
        self.node = node
        self.first: tuple[int, float] | None = None  # (cell ns, wall s) of the first advance
        self.last: tuple[int, float] | None = None
        self._start_ns = -1
        self.advanced_ns = 0
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
            if self.last is not None:
                # Summed advances: a rewind (the clock set back to its start) runs the cell again.
                self.advanced_ns += max(0, now_ns - self.last[0])
            self.last = (now_ns, wall)

    def summary(self) -> dict[str, float]:
        """Cell seconds run from the first advance to the last (rewinds run again), wall seconds, ratio."""
        if self.first is None or self.last is None or self.last[1] <= self.first[1]:
            return {"cell_s": 0.0, "wall_s": 0.0, "achieved_real_time_factor": 0.0}
        cell = self.advanced_ns / NANOSECONDS
        wall = self.last[1] - self.first[1]
        return {"cell_s": cell, "wall_s": wall, "achieved_real_time_factor": cell / wall}


class RecordingObserver:
    """Holds each quantum until the recorder has taken it in whole (subscribed and matched included)."""

    def __init__(self, node: Node, quantum_ns: int, recorder: Any = None) -> None:
        self.node = node
        self.quantum_ns = quantum_ns
        self.recorder = recorder  # set before ``start`` (the recorder's clock is ``log_time_ns``)
        self.participant: Participant | None = None  # made by ``start``: joining holds the clock
        self._topics: list[tuple[str, list[str]]] = []
        self._settling = False
        self._quiet_since = 0.0
        self._matching_since = 0.0

    def start(
        self,
        executor: Executor,
        keep_going: Callable[[], bool],
        nodes: list[tuple[str, str]],
        timeout_s: float = 30.0,
        participants: tuple[str, ...] = (),
    ) -> None:
        """Subscribe to every topic of the scene's ``nodes`` (name, namespace), wait until matched, join.

        The clock holds its start time until every expected participant has joined, so the topics the
        scene's nodes made at start-up (latched descriptions, statuses) are recorded whole, at the start
        time, whatever the order in which the processes came up. A node's publishers are discovered in
        one burst after the node itself: they are taken once each node's list has stayed the same for
        MATCH_SETTLE_S.
        """
        deadline = time.monotonic() + timeout_s
        while keep_going() and not self.recorder.clock_started() and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.01)
        # The other participants join at the end of their construction, their publishers made: until each
        # has (the clock's /diagnostics lists its members, once a second), a node's list of publishers may
        # look settled while it is still being built (a status topic taken up after the bring-up it
        # reports: only its latched last message recorded).
        joined: set[str] = set()

        def on_diagnostics(msg: DiagnosticArray) -> None:
            for status in msg.status:
                if status.name.endswith(": lockstep"):
                    members = next((v.value for v in status.values if v.key == "participants"), "")
                    joined.update(m.rsplit(" (", 1)[0].strip() for m in members.split(", ") if m)

        diagnostics = self.node.create_subscription(DiagnosticArray, "/diagnostics", on_diagnostics, 10)
        while keep_going() and time.monotonic() < deadline and not set(participants) <= joined:
            executor.spin_once(timeout_sec=0.01)
        self.node.destroy_subscription(diagnostics)
        stable_since, seen = time.monotonic(), self._publishers(nodes)
        while keep_going() and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.01)
            now = self._publishers(nodes)
            if now != seen or not all(now):
                stable_since, seen = time.monotonic(), now
            elif time.monotonic() - stable_since >= MATCH_SETTLE_S:
                break
        self._topics = self._graph_topics()
        self.recorder.discover()
        self._matching_since = time.monotonic()
        while keep_going() and time.monotonic() < deadline and not self._matched():
            executor.spin_once(timeout_sec=0.01)
        settle_until = time.monotonic() + START_SETTLE_S
        while keep_going() and time.monotonic() < settle_until:
            executor.spin_once(timeout_sec=0.01)
        self.participant = Participant(self.node, "observe", hold=True)

    def _publishers(self, nodes: list[tuple[str, str]]) -> list[int]:
        counts = []
        for name, namespace in nodes:
            try:
                counts.append(len(self.node.get_publisher_names_and_types_by_node(name, namespace or "/")))
            except Exception:  # noqa: BLE001 - rclpy raises its own NodeNameNonExistentError: not yet seen
                counts.append(0)
        return counts

    def _graph_topics(self) -> list[tuple[str, list[str]]]:
        return sorted((name, list(types)) for name, types in self.node.get_topic_names_and_types())

    def _quiet(self) -> bool:
        """Whether MATCH_SETTLE_S has passed since every new reader matched (latched histories are in)."""
        return time.monotonic() - self._quiet_since >= MATCH_SETTLE_S

    def after_spin(self, executor: Executor) -> None:
        """Drain a quiet announcement and answer it once every new topic is subscribed and matched."""
        if self.participant is None:
            return
        self.participant.answer_pending(executor)
        now_ns = self.participant.drained_ns
        if now_ns <= self.participant.answered_ns:
            return
        topics = self._graph_topics()
        if topics != self._topics:
            if self.recorder.discover():
                self._settling, self._matching_since = True, time.monotonic()
            if not self._matched():
                return  # looked at again after the next spin
            self._topics = topics
            self._quiet_since = time.monotonic()
        if self._settling:
            if not self._quiet():
                return
            self._settling = False
        self._take_everything()
        self.participant.release(now_ns)

    def _take_everything(self) -> None:
        """Take every sample still in a recorded reader's history before the quantum is answered.

        The drain takes what the wait set reports ready, and that can miss a sample already in a reader's
        history: with the controller hosted, its FEED status was acknowledged by this reader (its answer
        waits for that, ``Participant.delivered``) before the clock announced the quantum's end, and the
        recorder still logged it a quantum late (2 CI runs in about 10). Taking from each reader until it
        is empty does not depend on that report.
        """
        for subscription in self.recorder.subscriptions().values():
            while True:
                try:
                    with subscription.handle:
                        taken = subscription.handle.take_message(subscription.msg_type, subscription.raw)
                except InvalidHandle:
                    break  # replaced meanwhile (a topic's reader widened)
                if taken is None:
                    break
                subscription.callback(*taken)

    def log_time_ns(self) -> int:
        """Return the log time of a message taken now: the end of the quantum it belongs to."""
        answered = self.participant.answered_ns if self.participant is not None else 0
        if answered <= 0:
            return int(self.node.get_clock().now().nanoseconds)  # start-up: the start time
        return answered + self.quantum_ns

    def _matched(self) -> bool:
        """Whether every reader has matched every publisher of its topic (or MATCH_TIMEOUT_S passed)."""
        unmatched = [
            name
            for name, subscription in self.recorder.subscriptions().items()
            if subscription.get_publisher_count() < self.node.count_publishers(name)
        ]
        if unmatched and time.monotonic() - self._matching_since > MATCH_TIMEOUT_S:
            self.node.get_logger().warning(
                f"recording on: not every publisher matched within {MATCH_TIMEOUT_S:g} s on "
                f"{', '.join(sorted(unmatched))} (its first messages may be missing)"
            )
            return True
        return not unmatched

    def holding(self) -> bool:
        """Whether a quantum waits for this recorder (the launch then spins with a short timeout)."""
        p = self.participant
        return p is not None and p.drained_ns > p.answered_ns

    def leave(self) -> None:
        """Leave the lockstep (the launch is ending)."""
        if self.participant is not None:
            self.participant.leave()
