"""The rate and real-time-factor figures a device reports itself by (no ROS)."""

from __future__ import annotations

import pytest

from feeder_device.rate import BEHIND_TOLERANCE, RateMonitor


def feed(
    monitor: RateMonitor, rate: float, factor: float, seconds: float, pace: float = 1.0
) -> tuple[float, float]:
    """Tick at ``rate`` per clock second, the clock at ``factor`` per wall second, the model at ``pace``."""
    wall = clock = 0.0
    for k in range(int(seconds * factor * rate) + 1):
        clock = k / rate
        wall = clock / factor
        monitor.tick(wall, clock, pace * clock)
    return wall, clock


def test_a_device_on_time_is_not_behind() -> None:
    monitor = RateMonitor(20.0, 1.0, window=5.0)
    wall, clock = feed(monitor, 20.0, 1.0, 10.0)
    report = monitor.report(wall, clock)
    assert report.measured
    assert report.achieved_rate == pytest.approx(20.0, rel=1e-9)
    assert report.achieved_real_time_factor == pytest.approx(1.0, rel=1e-9)
    assert report.keeping_pace == pytest.approx(1.0, rel=1e-9)
    assert not report.behind


def test_on_a_fast_cell_clock_the_factor_is_measured_against_the_wall() -> None:
    monitor = RateMonitor(20.0, 8.0)
    wall, clock = feed(monitor, 20.0, 8.0, 4.0)
    report = monitor.report(wall, clock)
    assert report.achieved_rate == pytest.approx(20.0) and report.achieved_real_time_factor == pytest.approx(
        8.0
    )
    assert not report.behind


def test_a_slow_rate_or_a_model_that_drops_time_is_behind() -> None:
    slow = RateMonitor(20.0, 1.0)
    wall, clock = feed(slow, 20.0 * (1 - 2 * BEHIND_TOLERANCE), 1.0, 10.0)
    assert slow.report(wall, clock).behind
    dropping = RateMonitor(20.0, 1.0)
    wall, clock = feed(dropping, 20.0, 1.0, 10.0, pace=0.9)
    report = dropping.report(wall, clock)
    assert report.keeping_pace == pytest.approx(0.9) and report.behind


def test_a_stalled_device_decays_but_a_held_clock_is_not_behind() -> None:
    stalled = RateMonitor(20.0)
    wall, clock = feed(stalled, 20.0, 1.0, 2.0)
    assert stalled.report(wall + 2.0, clock + 2.0).achieved_rate < 0.6 * 20.0
    held = RateMonitor(20.0)
    wall, clock = feed(held, 20.0, 1.0, 2.0)
    # The clock does not move: no tick is late, and the old ticks age out of the window unjudged.
    assert not held.report(wall + 2.0, clock).behind
    assert not held.report(wall + 10.0, clock).measured


def test_too_few_ticks_measure_nothing_and_targets_must_be_positive() -> None:
    fresh = RateMonitor(20.0)
    fresh.tick(0.0, 0.0, 0.0)
    assert not fresh.report(0.0, 0.0).measured and not fresh.report(0.0, 0.0).behind
    with pytest.raises(ValueError):
        RateMonitor(0.0)
    with pytest.raises(ValueError):
        RateMonitor(20.0).configure(20.0, -1.0)
