"""Measured publish rate and real-time factor of a device, against what it was configured to hold.

A device that falls behind real time must say so at once rather than slow down silently; this is the
measurement it says it from. No rclpy here: the clock readings come in as plain seconds.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

__all__ = ["BEHIND_TOLERANCE", "RateMonitor", "RateReport"]

# A device counts as behind when the achieved rate or real-time factor is more than 2 % below the
# configured one: the tolerance the managed-devices issue states for "holds its rate".
BEHIND_TOLERANCE = 0.02

# The window the figures are measured over (wall seconds): long enough that one late timer callback
# on a loaded 2-core machine does not flip the verdict, short enough that a lasting lag shows in seconds.
DEFAULT_WINDOW = 5.0

# No tick for this many configured periods: the device has stalled, not merely jittered.
STALL_PERIODS = 2.0

# Fewer ticks than this in the window measure nothing yet (a rate from two samples is noise).
MIN_TICKS = 5


@dataclass(frozen=True)
class RateReport:
    """Configured and achieved figures over the last window; ``measured`` is False until enough ticks."""

    configured_rate: float
    achieved_rate: float
    configured_real_time_factor: float
    achieved_real_time_factor: float
    measured: bool

    @property
    def behind(self) -> bool:
        """Whether the rate or the real-time factor is more than BEHIND_TOLERANCE below its target."""
        if not self.measured:
            return False
        slow_rate = self.achieved_rate < (1.0 - BEHIND_TOLERANCE) * self.configured_rate
        slow_time = (
            self.achieved_real_time_factor < (1.0 - BEHIND_TOLERANCE) * self.configured_real_time_factor
        )
        return slow_rate or slow_time


class RateMonitor:
    """Sliding-window rate of a device's ticks (wall clock) and of its simulated time per wall second."""

    def __init__(
        self, configured_rate: float, configured_real_time_factor: float = 1.0, window: float = DEFAULT_WINDOW
    ) -> None:
        if not configured_rate > 0 or not configured_real_time_factor > 0 or not window > 0:
            raise ValueError("rate, real-time factor and window must be > 0")
        self.configured_rate = configured_rate
        self.configured_real_time_factor = configured_real_time_factor
        self.window = window
        self._samples: deque[tuple[float, float]] = deque()  # (wall s, simulated s)

    def reset(self) -> None:
        """Forget every tick (after a pause, a reconfiguration or a clock change)."""
        self._samples.clear()

    def configure(self, rate: float, real_time_factor: float) -> None:
        """Change the targets and start measuring afresh."""
        if not rate > 0 or not real_time_factor > 0:
            raise ValueError("rate and real-time factor must be > 0")
        self.configured_rate, self.configured_real_time_factor = rate, real_time_factor
        self.reset()

    def tick(self, wall: float, simulated: float) -> None:
        """Record one tick at wall time ``wall`` (s) with the device's simulated time ``simulated`` (s)."""
        self._samples.append((wall, simulated))
        while self._samples and self._samples[0][0] < wall - self.window:
            self._samples.popleft()

    def report(self, wall: float | None = None) -> RateReport:
        """Return the figures over the window; a device that stopped ticking sees its rate decay."""
        samples = self._samples
        if len(samples) < MIN_TICKS:
            return RateReport(self.configured_rate, 0.0, self.configured_real_time_factor, 0.0, False)
        first_wall, first_sim = samples[0]
        last_wall, last_sim = samples[-1]
        span = last_wall - first_wall
        # A device that stopped ticking: measure to now, so its rate decays instead of freezing.
        if wall is not None and wall - last_wall > STALL_PERIODS / self.configured_rate:
            span = wall - first_wall
        if span <= 0:
            return RateReport(self.configured_rate, 0.0, self.configured_real_time_factor, 0.0, False)
        rate = (len(samples) - 1) / span
        factor = (last_sim - first_sim) / span
        return RateReport(self.configured_rate, rate, self.configured_real_time_factor, factor, True)
