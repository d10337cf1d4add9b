"""Measured publish rate and real-time factor of a device, against what it was configured to hold.

A device that falls behind must say so at once rather than slow down silently; this is the measurement
it says it from. Three clocks meet here, read as plain seconds (no rclpy):

- the wall clock (steady), which the real-time factor is measured against;
- the node clock (ROS time: the wall clock, or the cell clock under ``use_sim_time``), which the
  device's timers run on and its configured rate is stated in;
- the device's own simulated time, which must keep pace with the node clock.

A device keeps up when it ticks at its configured rate per second of the node clock and its simulated
time advances one second per second of the node clock. Whether the node clock itself runs at the
configured real-time factor is the cell clock's business; the achieved factor (simulated seconds per
wall second) is reported beside it. A held or stepped cell clock is therefore not "behind": its ticks
come when the clock moves, and nothing is late.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

__all__ = ["BEHIND_TOLERANCE", "RateMonitor", "RateReport"]

# A device counts as behind when a figure is more than 2 % below its target: the tolerance the
# managed-devices issue states for "holds its rate".
BEHIND_TOLERANCE = 0.02

# The window the figures are measured over (wall seconds): long enough that one late timer callback on
# a loaded 2-core machine does not flip the verdict, short enough that a lasting lag shows in seconds.
DEFAULT_WINDOW = 5.0

# Fewer ticks than this in the window measure nothing yet (a rate from two samples is noise).
MIN_TICKS = 5

# No tick while the node clock advanced this many configured periods: the device has stalled.
STALL_PERIODS = 2.0


@dataclass(frozen=True)
class RateReport:
    """Configured and achieved figures over the last window; ``measured`` is False until enough ticks."""

    configured_rate: float  # Hz of the node clock
    achieved_rate: float  # ticks per second of the node clock
    configured_real_time_factor: float
    achieved_real_time_factor: float  # simulated seconds per wall second
    keeping_pace: float  # simulated seconds per second of the node clock (1 when the model keeps up)
    measured: bool

    @property
    def behind(self) -> bool:
        """Whether the device ticks or simulates more than BEHIND_TOLERANCE slower than its node clock."""
        if not self.measured:
            return False
        floor = 1.0 - BEHIND_TOLERANCE
        return self.achieved_rate < floor * self.configured_rate or self.keeping_pace < floor


class RateMonitor:
    """Sliding window over a device's ticks: (wall s, node clock s, simulated s) per tick."""

    def __init__(
        self, configured_rate: float, configured_real_time_factor: float = 1.0, window: float = DEFAULT_WINDOW
    ) -> None:
        if not configured_rate > 0 or not configured_real_time_factor >= 0 or not window > 0:
            raise ValueError("rate and window must be > 0, the real-time factor >= 0 (0: no pace)")
        self.configured_rate = configured_rate
        self.configured_real_time_factor = configured_real_time_factor
        self.window = window
        self._samples: deque[tuple[float, float, float]] = deque()

    def reset(self) -> None:
        """Forget every tick (after a pause, a reconfiguration or a clock change)."""
        self._samples.clear()

    def configure(self, rate: float, real_time_factor: float) -> None:
        """Change the targets (rate in Hz of the node clock) and start measuring afresh."""
        if not rate > 0 or not real_time_factor >= 0:
            raise ValueError("rate must be > 0, the real-time factor >= 0 (0: no pace)")
        self.configured_rate, self.configured_real_time_factor = rate, real_time_factor
        self.reset()

    def tick(self, wall: float, clock: float, simulated: float) -> None:
        """Record one tick: wall time, node-clock time and the device's simulated time, in seconds."""
        if self._samples and clock < self._samples[-1][1]:
            self.reset()  # the node clock was set back (a new cell clock): measure afresh
        self._samples.append((wall, clock, simulated))
        while self._samples and self._samples[0][0] < wall - self.window:
            self._samples.popleft()

    def report(self, wall: float, clock: float) -> RateReport:
        """Return the figures over the window, ``wall`` and ``clock`` being the present readings."""
        unmeasured = RateReport(self.configured_rate, 0.0, self.configured_real_time_factor, 0.0, 0.0, False)
        samples = self._samples
        while samples and samples[0][0] < wall - self.window:
            samples.popleft()  # a held clock stops the ticks: old ones age out, nothing is judged
        if len(samples) < MIN_TICKS:
            return unmeasured
        first_wall, first_clock, first_sim = samples[0]
        last_wall, last_clock, last_sim = samples[-1]
        clock_span = last_clock - first_clock
        # A device whose clock moves on without it has stalled: measure to now, so its rate decays.
        if clock - last_clock > STALL_PERIODS / self.configured_rate:
            clock_span = clock - first_clock
        wall_span = last_wall - first_wall
        if clock_span <= 0 or wall_span <= 0:
            return unmeasured
        return RateReport(
            self.configured_rate,
            (len(samples) - 1) / clock_span,
            self.configured_real_time_factor,
            (last_sim - first_sim) / wall_span,
            (last_sim - first_sim) / clock_span,
            True,
        )
