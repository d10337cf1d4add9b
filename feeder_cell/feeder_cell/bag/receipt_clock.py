"""Log times on sim time: the cell time ``/clock`` read when a message reached the recorder's process.

A sim-time node's clock is the last ``/clock`` its executor took, through a depth-1 reader (rclpy's time
source, as rclcpp's). Stamping a message with that clock when its callback runs, as rosbag2 does, gives a
backlog the newest clock: in ci50 a recorder whose executor fell 0.3 s behind stamped messages 1.5 s of
cell time late (the cell ran 5x), while the messages had reached the process on time. So each ``/clock``
tick is kept with the time it reached the process (the middleware's ``received_timestamp``), and a
message's log time is the cell time of the last tick that reached the process before it did. Both
timestamps are taken where the middleware receives the samples, not where the executor runs, so a
stalled executor no longer moves the stamps.
"""

from __future__ import annotations

import bisect
from typing import Any

# Ticks kept by the time they reached the process: a message whose callback runs later than this after
# its arrival gets the oldest tick kept, which is later than its true cell time.
HISTORY_NS = 60_000_000_000
# The clock reader's depth: the ticks that may wait while the executor is behind (at the cell clock's
# 1 kHz, one second).
CLOCK_DEPTH = 1000


class ReceiptTicks:
    """``/clock`` ticks by the time they reached this process: which cell time held at a given arrival.

    ROS-free. Arrival times are the middleware's (system time, ns), cell times ``/clock``'s (ns).
    """

    def __init__(self, history_ns: int = HISTORY_NS) -> None:
        if history_ns <= 0:
            raise ValueError(f"history_ns: must be > 0 ns, got {history_ns}")
        self.history_ns = history_ns
        self._arrivals: list[int] = []
        self._cell: list[int] = []
        self._pruned = False  # whether ticks were dropped from the front of the history

    def add(self, arrival_ns: int, cell_ns: int) -> None:
        """Keep a tick; ticks older than the history (by arrival) are dropped."""
        # Ticks arrive in order from one writer; a second writer's may interleave, so insert in place.
        at = bisect.bisect_right(self._arrivals, arrival_ns)
        self._arrivals.insert(at, arrival_ns)
        self._cell.insert(at, cell_ns)
        old = bisect.bisect_left(self._arrivals, self._arrivals[-1] - self.history_ns)
        if old > len(self._arrivals) // 2:  # in halves: amortised O(1) per tick
            del self._arrivals[:old], self._cell[:old]
            self._pruned = True

    def at(self, arrival_ns: int) -> int:
        """Return the cell time of the last tick that arrived at or before ``arrival_ns``; 0 before the first.

        No arrival time (0, a middleware that does not give one): the newest tick's cell time, as the
        node's clock would read. Older than every tick kept: 0 if the history is whole, else the oldest kept.
        """
        if not self._arrivals:
            return 0
        if arrival_ns <= 0:
            return self._cell[-1]
        at = bisect.bisect_right(self._arrivals, arrival_ns)
        if at:
            return self._cell[at - 1]
        return self._cell[0] if self._pruned else 0

    def __len__(self) -> int:
        return len(self._arrivals)


class CellTimeAtReceipt:
    """A recorder's log time on sim time: a ``/clock`` reader of its own, deep enough for a backlog.

    :meth:`stamp` first takes the ticks waiting in the reader: every tick that reached the process before
    the message is then known, however the executor ordered the two callbacks.
    """

    def __init__(self, node: Any, history_ns: int = HISTORY_NS) -> None:
        from rclpy.qos import QoSProfile, ReliabilityPolicy
        from rosgraph_msgs.msg import Clock

        self._clock_type = Clock
        self.ticks = ReceiptTicks(history_ns)
        # Best effort matches a /clock writer of either reliability.
        qos = QoSProfile(depth=CLOCK_DEPTH, reliability=ReliabilityPolicy.BEST_EFFORT)
        self._reader = node.create_subscription(Clock, "/clock", self._on_tick, qos)

    def _on_tick(self, message: Any, info: Any) -> None:
        self.ticks.add(
            int(info["received_timestamp"]), message.clock.sec * 1_000_000_000 + message.clock.nanosec
        )

    def _take_waiting(self) -> None:
        # Single-threaded executor (feeder record): nothing else takes from this reader meanwhile, and
        # a take that finds the reader empty is skipped by the executor.
        with self._reader.handle:
            while (taken := self._reader.handle.take_message(self._clock_type, False)) is not None:
                self._on_tick(*taken)

    def stamp(self, info: dict[str, int]) -> int:
        """Return the log time of a message with this receipt ``info``: the cell time when it arrived."""
        self._take_waiting()
        return self.ticks.at(int(info.get("received_timestamp", 0)))
