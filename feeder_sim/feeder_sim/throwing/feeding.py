"""The throwing arm's feed-part goal: throw until the one-bit sensor reads true with the part at rest.

ROS-free: the throwing_arm node's ``~/feed_part`` action drives a ``FeedGoal`` from its ticks, and a test
drives it the same way without ROS. This is the paper's sensor-based feeder (Lynch, Northrop and Pan,
"Stable Limit Sets in a Dynamic Parts Feeder", section V: "a simple one-bit sensor embedded in the arm
can be used to detect if the part is above it ... when the part is detected, it must lie on edge 1"):
the bit the device itself delivers once the part is at rest decides, never the ground truth, so an
injected sensor fault misleads the goal exactly as it would mislead a controller on hardware. The
ground truth (edge, R) is carried along for logging only.

How the goal reads the bit, throw by throw:

- **At rest.** The part is at rest when the goal starts and again when each throw lands. The first
  sensor sample the device delivers from then on is the bit at rest for that throw (before any throw:
  for the start). True ends the goal PRESENTED (0 throws when it reads true at the start).
- **Missing samples** (``sensor_dropout``): the goal waits for a delivered sample over the rest window
  (the node's: ``period x (1 - motion_fraction)`` less one sample, the time the part rests between two
  throws), never longer; with none delivered the bit counts as unread, i.e. not presented (feedback
  ``sensor_at_rest`` false), and the next throw follows on time. Every wait is bounded even without a
  timeout.
- **Throw after throw** through the device's own queue (the same period and motion as ``~/command
  throw``), until the bit reads true, ``max_throws`` throws were judged, or ``timeout`` s of node clock
  passed. A throw in flight always lands first: cancel, timeout and a fault end the goal once the part
  is at rest again (the feedback of that throw is sent), so the feedback count is the throws used. A
  throw's landing judged true after the deadline still presents the part (it is there).
- **Order of the decision** once the bit of a throw is known: a fault of the device, then the bit,
  then cancel, then timeout, then ``max_throws``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum
from typing import Generic, TypeVar

from feeder_device.declarations import deadline_ns
from feeder_planner.errors import InputError
from feeder_planner.limits import MAX_GOAL_TIMEOUT

__all__ = [
    "rest_window_ns",
    "OUTCOME_CODES",
    "FeedRequest",
    "check_feed_goal",
    "ThrowReport",
    "FeedOutcome",
    "FeedGoal",
]

# The result codes of feeder_msgs/action/FeedPart (the node maps names to the message's constants;
# tests/throwing/test_feeding.py checks they agree).
OUTCOME_CODES = {"PRESENTED": 1, "MAX_THROWS": 2, "TIMEOUT": 3, "FAULT": 4, "CANCELED": 5}

Event = TypeVar("Event")


@dataclass(frozen=True)
class FeedRequest:
    """A checked goal: at most ``max_throws`` throws, for at most ``timeout`` s of node clock (0: none)."""

    max_throws: int
    timeout: float


def check_feed_goal(max_throws: object, timeout: object) -> FeedRequest:
    """Return the checked goal, or raise InputError naming ``max_throws`` or ``timeout``.

    Parameters
    ----------
    max_throws
        Throws the goal may use; an integer >= 1.
    timeout
        Seconds of node clock the goal may take; in [0, MAX_GOAL_TIMEOUT] (0: no limit beyond
        ``max_throws``).
    """
    if isinstance(max_throws, bool) or not isinstance(max_throws, int) or max_throws < 1:
        raise InputError("max_throws", f"must be an integer >= 1, got {max_throws!r}")
    if isinstance(timeout, bool) or not isinstance(timeout, (int, float)):
        raise InputError("timeout", f"must be a number of seconds, got {timeout!r}")
    if not math.isfinite(timeout) or timeout < 0:
        raise InputError("timeout", f"must be finite and >= 0 s (0: no limit), got {timeout!r}")
    if timeout > MAX_GOAL_TIMEOUT:
        raise InputError("timeout", f"must be at most {MAX_GOAL_TIMEOUT:.6g} s (a year), got {timeout!r}")
    return FeedRequest(int(max_throws), float(timeout))


def rest_window_ns(period: float, motion_fraction: float, sensor_rate: float) -> int:
    """Return the longest wait (ns) for a delivered sensor sample once the part is at rest.

    The rest time between throws less one sample: an unread bit then asks for the next throw in time
    for it to start a period after the last one, as if the bit had been read.
    """
    rest = period * (1.0 - motion_fraction) - 1.0 / sensor_rate
    return int(round(max(rest, 0.0) * 1e9))


@dataclass(frozen=True)
class ThrowReport(Generic[Event]):
    """One throw of the goal as the feedback reports it.

    ``sensor_at_rest`` is the bit that decided (False when ``read`` is False: no sample was delivered
    over the rest window); ``edge`` and ``radius`` are the ground truth after the throw, for logging;
    ``event`` is whatever the device published for the landing (the node's ThrowEvent).
    """

    throws: int
    sensor_at_rest: bool
    read: bool
    edge: int
    radius: float
    event: Event | None


@dataclass(frozen=True)
class FeedOutcome:
    """How a goal ended: the outcome's name and code, why, and the state it left (ground truth logged)."""

    name: str
    message: str
    throws: int
    sensor_at_rest: bool
    edge: int
    radius: float
    fault_code: int = 0
    fault_text: str = ""

    @property
    def code(self) -> int:
        """The FeedPart result code of the outcome."""
        return OUTCOME_CODES[self.name]


class _Phase(Enum):
    AT_REST = "at rest, the bit not judged yet"
    WANT_THROW = "the next throw asked of the device"
    IN_FLIGHT = "a throw in flight"
    DONE = "ended"


class FeedGoal(Generic[Event]):
    """One ``~/feed_part`` goal, fed what the device does tick by tick; it asks for throws and ends.

    The device calls, within each of its ticks: ``throw_started`` when it starts a throw the goal asked
    for (``wants_throw``), ``landed`` when a throw comes to rest (or faults), ``sample`` with each sensor
    sample it delivers while the part is at rest (None: the sample was dropped), and ``tick`` once the
    tick is over. ``cancel`` asks the goal to end after the throw in flight; ``end_now`` ends it at once
    (the device stopped or was deactivated). ``reports`` collects the feedback, ``outcome`` the end.

    Parameters
    ----------
    request
        The checked goal.
    start_ns
        Node-clock time the goal started (ns); the timeout counts from here.
    rest_window_ns
        How long (ns) to wait for a delivered sample once the part is at rest.
    edge, radius
        Ground truth at the start (for the result of a goal that throws nothing).
    """

    def __init__(
        self, request: FeedRequest, start_ns: int, rest_window_ns: int, edge: int, radius: float
    ) -> None:
        self.request = request
        self.start_ns = start_ns
        self.deadline_ns = deadline_ns(start_ns, request.timeout)
        self.throws = 0
        self.reports: list[ThrowReport[Event]] = []
        self.outcome: FeedOutcome | None = None
        self.cancel_reason = ""
        self._phase = _Phase.AT_REST
        self._rest_since = start_ns
        self._rest_window = rest_window_ns
        self._bit: tuple[bool, bool] | None = None  # (bit, read) of the rest being judged
        self._landing: tuple[int, float, Event | None] | None = None  # the throw awaiting its bit
        self._edge, self._radius = edge, radius
        self._last_bit = False

    # --- what the device asks ---------------------------------------------------------------------
    def wants_throw(self, now_ns: int) -> bool:
        """Whether the goal asks the device for a throw at ``now_ns`` (the device's period still applies).

        Not once a cancel is asked or the deadline has passed: no throw starts after either.
        """
        past = self.deadline_ns is not None and now_ns >= self.deadline_ns
        return self._phase is _Phase.WANT_THROW and not self.cancel_reason and not past

    @property
    def done(self) -> bool:
        """Whether the goal has ended (``outcome`` says how)."""
        return self.outcome is not None

    @property
    def in_flight(self) -> bool:
        """Whether a throw of the goal is in flight."""
        return self._phase is _Phase.IN_FLIGHT

    # --- what the device tells ---------------------------------------------------------------------
    def throw_started(self) -> None:
        """Count the throw the device started because the goal asked (``wants_throw`` was true)."""
        if self._phase is _Phase.WANT_THROW:
            self.throws += 1
            self._phase = _Phase.IN_FLIGHT

    def landed(self, now_ns: int, edge: int, radius: float, event: Event | None = None) -> None:
        """Take the landing of the goal's throw at (edge, radius): ground truth, -1 and NaN when lost."""
        if self._phase is not _Phase.IN_FLIGHT:
            return
        self._phase = _Phase.AT_REST
        self._rest_since = now_ns
        self._bit = None
        self._landing = (edge, radius, event)
        self._edge, self._radius = edge, radius

    def sample(self, bit: bool | None) -> None:
        """Take a sensor sample the device delivered with the part at rest (None: dropped)."""
        if self._phase is _Phase.AT_REST and self._bit is None and bit is not None:
            self._bit = (bool(bit), True)

    def tick(self, now_ns: int, fault: tuple[int, str] | None, in_flight: bool) -> None:
        """Close the device's tick: judge the bit at rest, or end the goal, or ask for a throw.

        Parameters
        ----------
        now_ns
            Node-clock time of the tick.
        fault
            (code, text) of the fault that stops the device, or None.
        in_flight
            Whether the device shows a throw in flight after this tick.
        """
        if self.done:
            return
        if self._phase is _Phase.IN_FLIGHT:
            if in_flight:
                return  # cancel, timeout and a fault wait for the landing
            # The throw vanished without landing: the part was lost in the air.
            code, text = fault if fault is not None else (0, "the throw in flight never landed")
            self._finish("FAULT", f"device faulted during the goal: {text}", code, text)
            return
        if (
            self._phase is _Phase.AT_REST
            and self._bit is None
            and now_ns - self._rest_since >= self._rest_window
        ):
            self._bit = (False, False)  # no sample delivered over the rest window: unread, not presented
        judged = self._judge()
        timed_out = self.deadline_ns is not None and now_ns >= self.deadline_ns
        if fault is not None:
            self._flush_unread()
            self._finish("FAULT", f"device faulted during the goal: {fault[1]}", fault[0], fault[1])
        elif judged is True:
            self._finish("PRESENTED", self._presented_message())
        elif self.cancel_reason:
            self._flush_unread()
            self._finish("CANCELED", f"{self.cancel_reason} after {self._throws_text()}")
        elif timed_out:
            self._flush_unread()
            self._finish(
                "TIMEOUT",
                f"timeout of {self.request.timeout:g} s (node clock) passed after {self._throws_text()}, "
                "never presented",
            )
        elif judged is False:
            if self.throws >= self.request.max_throws:
                self._finish(
                    "MAX_THROWS",
                    f"max_throws {self.request.max_throws} thrown, the sensor never read true at rest",
                )
            else:
                self._phase = _Phase.WANT_THROW

    def cancel(self, reason: str) -> None:
        """End the goal CANCELED once the part is at rest (after the throw in flight, if any)."""
        if not self.done and not self.cancel_reason:
            self.cancel_reason = reason

    def end_now(self, name: str, message: str, fault_code: int = 0, fault_text: str = "") -> None:
        """End the goal at once (the device stopped or stopped being active); a landed throw is reported."""
        if self.done:
            return
        self._flush_unread()
        self._finish(name, message, fault_code, fault_text)

    # --- inside -----------------------------------------------------------------------------------
    def _judge(self) -> bool | None:
        """Return the bit of the rest being judged once it is known (reporting its throw), else None."""
        if self._phase is not _Phase.AT_REST or self._bit is None:
            return None
        bit, read = self._bit
        self._last_bit = bit
        self._report(bit, read)
        self._bit = None
        self._phase = _Phase.WANT_THROW  # provisional: tick() ends the goal or keeps it
        return bit

    def _report(self, bit: bool, read: bool) -> None:
        if self._landing is None:
            return  # the start's bit: no throw to report
        edge, radius, event = self._landing
        self._landing = None
        self.reports.append(ThrowReport(self.throws, bit, read, edge, radius, event))

    def _flush_unread(self) -> None:
        """Report a throw that landed but whose bit was not delivered yet (as unread)."""
        if self._phase is _Phase.AT_REST and self._landing is not None:
            self._last_bit = False
            self._report(False, False)

    def _throws_text(self) -> str:
        return f"{self.throws} throw{'' if self.throws == 1 else 's'}"

    def _presented_message(self) -> str:
        truth = f"edge {self._edge}, R {self._radius:.4g} m" if self._edge >= 0 else "unknown"
        return (
            f"presented after {self._throws_text()}: the sensor read true at rest "
            f"(ground truth, for logging: {truth})"
        )

    def _finish(self, name: str, message: str, fault_code: int = 0, fault_text: str = "") -> None:
        self._phase = _Phase.DONE
        self.outcome = FeedOutcome(
            name, message, self.throws, self._last_bit, self._edge, self._radius, fault_code, fault_text
        )
