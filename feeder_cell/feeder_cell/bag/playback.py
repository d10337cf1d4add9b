"""Replay timing and controls without rclpy: the playback window, the bag clock and the play loop.

The player node (:mod:`feeder_cell.bag.player`) feeds this module messages from a bag and a publish
function; everything about *when* a message goes out (rate, pause, seek, play-next, burst, loop, delay,
start offset and end of the window) is decided here, so it can be tested without DDS.

Times: ``bag`` times are the nanosecond receive stamps stored in the bag; ``wall`` times are
``time.monotonic()`` seconds (or the clock given to :class:`BagClock`).
"""

from __future__ import annotations

import math
import threading
import time
from collections import deque
from dataclasses import dataclass
from typing import Callable, Generic, Iterator, NamedTuple, TypeVar

from feeder_planner.errors import InputError

__all__ = ["BagClock", "Item", "Playback", "Window", "check_rate", "playback_window"]

NS = 1_000_000_000
# A waiting loop wakes at least this often (seconds) to notice keep_going() turning false.
WAKE_PERIOD = 0.1


# What a message goes to: the player's connection id, whatever its caller chooses (a topic name).
Key = TypeVar("Key")


class Item(NamedTuple, Generic[Key]):
    """One message of the bag: what it goes to (a connection or topic), its bag time and its bytes."""

    key: Key
    stamp: int
    data: bytes


@dataclass(frozen=True)
class Window:
    """The part of the bag that is played: bag times ``start`` to ``end`` (ns, both inclusive)."""

    start: int
    end: int


def playback_window(
    bag_start: int,
    bag_end: int,
    start_offset: float = 0.0,
    duration: float | None = None,
    until: float | None = None,
) -> Window:
    """Return the played window of a bag spanning ``bag_start`` .. ``bag_end`` (ns).

    Parameters
    ----------
    bag_start, bag_end
        First and last message stamps of the bag, ns.
    start_offset
        Seconds after the bag's first message where playback starts (``--start-offset``, >= 0).
    duration
        Seconds of bag time played from the start (``--playback-duration``, > 0), or None.
    until
        Bag timestamp (seconds since the epoch) where playback stops (``--playback-until``), or None.
        With both ``duration`` and ``until``, the earlier end wins (as ros2 bag play does).

    Raises
    ------
    InputError
        Naming the flag, for a negative or non-finite value, an offset past the bag's end, or an end
        before the start.
    """
    if not (math.isfinite(start_offset) and start_offset >= 0):
        raise InputError("--start-offset", f"must be a finite number >= 0 seconds, got {start_offset}")
    start = bag_start + round(start_offset * NS)
    if start > bag_end:
        raise InputError(
            "--start-offset",
            f"{start_offset} s is past the bag's end ({(bag_end - bag_start) / NS:.3f} s after its start)",
        )
    end = bag_end
    if duration is not None:
        if not (math.isfinite(duration) and duration > 0):
            raise InputError("--playback-duration", f"must be a finite number > 0 seconds, got {duration}")
        end = min(end, start + round(duration * NS))
    if until is not None:
        if not (math.isfinite(until) and until >= 0):
            raise InputError("--playback-until", f"must be a finite timestamp >= 0 seconds, got {until}")
        stop = round(until * NS)
        if stop < start:
            raise InputError(
                "--playback-until",
                f"{until} is before the playback start {start / NS:.9f} (bag time, seconds since the epoch)",
            )
        end = min(end, stop)
    return Window(start, end)


def check_rate(rate: float, field: str = "rate") -> float:
    """Return ``rate`` if it is a finite number > 0, else raise InputError naming ``field``."""
    if not (isinstance(rate, (int, float)) and math.isfinite(rate) and rate > 0):
        raise InputError(field, f"must be a finite number > 0, got {rate}")
    return float(rate)


class BagClock:
    """The bag time that playback has reached: runs at ``rate`` times the wall clock unless paused.

    The clock is an anchor (a bag time and the wall time it holds at) and a rate; pausing, a rate change
    and a jump re-anchor it, so due times never drift however often the controls are used. Not locked:
    :class:`Playback` holds its lock around every use.
    """

    def __init__(
        self,
        bag_time: int,
        rate: float = 1.0,
        paused: bool = False,
        wall: Callable[[], float] = time.monotonic,
    ):
        self._wall = wall
        self.rate = check_rate(rate)
        self.paused = paused
        self._anchor_bag = bag_time
        self._anchor_wall = wall()

    def now(self) -> int:
        """Return the bag time reached (ns); before a delayed start it stays at the start."""
        if self.paused:
            return self._anchor_bag
        elapsed = max(0.0, self._wall() - self._anchor_wall)
        return self._anchor_bag + round(elapsed * self.rate * NS)

    def wall_due(self, bag_time: int) -> float:
        """Return the wall time at which ``bag_time`` is reached (inf while paused)."""
        if self.paused:
            return math.inf
        return self._anchor_wall + (bag_time - self._anchor_bag) / NS / self.rate

    def jump(self, bag_time: int, delay: float = 0.0) -> None:
        """Hold ``bag_time`` now, or ``delay`` wall seconds from now (the clock stands until then)."""
        self._anchor_bag = bag_time
        self._anchor_wall = self._wall() + delay

    def pause(self) -> None:
        """Stop the clock where it is."""
        if not self.paused:
            self.jump(self.now())
            self.paused = True

    def resume(self) -> None:
        """Let the clock run on from where it stopped."""
        if self.paused:
            self.jump(self._anchor_bag)
            self.paused = False

    def set_rate(self, rate: float) -> None:
        """Change the speed factor from now on (a bad rate raises InputError; the old one stays)."""
        rate = check_rate(rate)
        now = self.now()
        if self._wall() >= self._anchor_wall:
            self.jump(now)  # a clock still in its start delay keeps its delayed start
        self.rate = rate


class Playback(Generic[Key]):
    """The play loop and its controls (pause, resume, toggle, play-next, seek, rate, burst).

    ``source(start)`` returns the bag's messages from bag time ``start`` on, in stamp order; ``publish``
    sends one. :meth:`run` plays the window at the clock's pace, calling ``publish`` from the caller's
    thread; the control methods may be called from any other thread (service callbacks, keyboard) and
    take effect at once. Up to ``read_ahead`` messages are read ahead of the one being waited for.
    """

    def __init__(
        self,
        source: Callable[[int], Iterator[Item[Key]]],
        window: Window,
        publish: Callable[[Item[Key]], None],
        rate: float = 1.0,
        start_paused: bool = False,
        loop: bool = False,
        delay: float = 0.0,
        read_ahead: int = 1000,
        wall: Callable[[], float] = time.monotonic,
    ) -> None:
        if not (math.isfinite(delay) and delay >= 0):
            raise InputError("--delay", f"must be a finite number >= 0 seconds, got {delay}")
        if not (isinstance(read_ahead, int) and read_ahead >= 1):
            raise InputError("--read-ahead-queue-size", f"must be an integer >= 1, got {read_ahead}")
        self._source, self.window, self._publish = source, window, publish
        self.loop, self.delay, self.read_ahead = loop, delay, read_ahead
        self._wall = wall
        self._lock = threading.Condition()
        self.clock = BagClock(window.start, rate, start_paused, wall)
        self.clock.jump(window.start, delay)
        self._buffer: deque[Item[Key]] = deque()
        self._messages: Iterator[Item[Key]] = iter(())
        self._exhausted = False
        self._restart(window.start)
        self.published = 0
        self.loops = 0
        # (wall time of the publish call, bag stamp) of every message the loop published on time, for the
        # timing benchmark; only kept when asked for (a list, None: not kept).
        self.timing: list[tuple[float, int]] | None = None

    # -- reading ------------------------------------------------------------------------------------

    def _restart(self, start: int) -> None:
        self._buffer.clear()
        self._messages = self._source(start)
        self._exhausted = False

    def _fill(self) -> None:
        while not self._exhausted and len(self._buffer) < self.read_ahead:
            item = next(self._messages, None)
            if item is None or item.stamp > self.window.end:
                self._exhausted = True
                return
            if item.stamp >= self.window.start:
                self._buffer.append(item)

    def _next_item(self) -> Item[Key] | None:
        if not self._buffer:
            self._fill()
        return self._buffer[0] if self._buffer else None

    def _send(self, item: Item[Key]) -> None:
        self._buffer.popleft()
        self._publish(item)
        self.published += 1
        if len(self._buffer) < self.read_ahead // 2:
            self._fill()  # top up in the gaps rather than on every message

    # -- the loop -----------------------------------------------------------------------------------

    def run(self, keep_going: Callable[[], bool] = lambda: True) -> int:
        """Play until the window is done (every loop of it, with ``loop``) or ``keep_going()`` is false.

        Returns the number of messages published (by the loop, play-next and burst together).
        """
        with self._lock:
            while keep_going():
                item = self._next_item()
                if item is None:
                    if not self.loop:
                        break
                    self.loops += 1
                    self._restart(self.window.start)
                    self.clock.jump(self.window.start, self.delay)
                    if self._next_item() is None:
                        break  # an empty window never fills: do not spin
                    continue
                wait = self.clock.wall_due(item.stamp) - self._wall()
                if wait > 0:
                    self._lock.wait(min(wait, WAKE_PERIOD))
                    continue  # a control may have changed the clock or the next message meanwhile
                if self.timing is not None:
                    self.timing.append((self._wall(), item.stamp))
                self._send(item)
            return self.published

    # -- controls (any thread) ----------------------------------------------------------------------

    def now(self) -> int:
        """Return the bag time playback has reached (ns), what ``/clock`` publishes."""
        with self._lock:
            return self.clock.now()

    def is_paused(self) -> bool:
        """Return whether playback is paused."""
        with self._lock:
            return self.clock.paused

    def pause(self) -> None:
        """Pause playback (a no-op when paused)."""
        with self._lock:
            self.clock.pause()
            self._lock.notify_all()

    def resume(self) -> None:
        """Resume playback (a no-op when playing)."""
        with self._lock:
            self.clock.resume()
            self._lock.notify_all()

    def toggle_paused(self) -> bool:
        """Pause if playing, resume if paused; return whether it is paused now."""
        with self._lock:
            if self.clock.paused:
                self.clock.resume()
            else:
                self.clock.pause()
            self._lock.notify_all()
            return self.clock.paused

    def rate(self) -> float:
        """Return the speed factor."""
        with self._lock:
            return self.clock.rate

    def set_rate(self, rate: float) -> bool:
        """Set the speed factor; False (and no change) unless it is a finite number > 0."""
        with self._lock:
            try:
                self.clock.set_rate(rate)
            except InputError:
                return False
            self._lock.notify_all()
            return True

    def seek(self, bag_time: int) -> bool:
        """Go on from bag time ``bag_time`` (ns); False (and no change) outside the window."""
        with self._lock:
            if not self.window.start <= bag_time <= self.window.end:
                return False
            self._restart(bag_time)
            self.clock.jump(bag_time)
            self._lock.notify_all()
            return True

    def play_next(self) -> bool:
        """While paused, publish the next message now and hold the clock at its stamp.

        Returns False when playback is not paused or no message is left in the window.
        """
        with self._lock:
            if not self.clock.paused:
                return False
            item = self._next_item()
            if item is None:
                return False
            self._send(item)
            self.clock.jump(item.stamp)
            return True

    def burst(self, count: int) -> int:
        """While paused, publish the next ``count`` messages (0: the rest of the window) at once.

        Returns how many were published: 0 when playback is not paused.
        """
        with self._lock:
            if not self.clock.paused or count < 0:
                return 0
            sent = 0
            while count == 0 or sent < count:
                item = self._next_item()
                if item is None:
                    break
                self._send(item)
                self.clock.jump(item.stamp)
                sent += 1
            return sent
