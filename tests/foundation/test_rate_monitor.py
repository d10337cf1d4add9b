"""The rate and real-time-factor figures a device reports itself by (no ROS)."""

from __future__ import annotations

import pytest

from feeder_planner.node_kit.rate import BEHIND_TOLERANCE, RateMonitor


def feed(monitor: RateMonitor, rate: float, factor: float, seconds: float) -> float:
    wall = 0.0
    for k in range(int(seconds * rate) + 1):
        wall = k / rate
        monitor.tick(wall, factor * wall)
    return wall


def test_a_device_on_time_is_not_behind() -> None:
    monitor = RateMonitor(20.0, 1.0, window=5.0)
    end = feed(monitor, 20.0, 1.0, 10.0)
    report = monitor.report(end)
    assert report.measured
    assert report.achieved_rate == pytest.approx(20.0, rel=1e-9)
    assert report.achieved_real_time_factor == pytest.approx(1.0, rel=1e-9)
    assert not report.behind


def test_a_slow_rate_or_slow_simulation_is_behind() -> None:
    slow = RateMonitor(20.0, 1.0)
    feed(slow, 20.0 * (1 - 2 * BEHIND_TOLERANCE), 1.0, 10.0)
    assert slow.report().behind
    lagging = RateMonitor(20.0, 10.0)
    feed(lagging, 20.0, 9.0, 10.0)
    report = lagging.report()
    assert report.achieved_real_time_factor == pytest.approx(9.0)
    assert report.behind


def test_a_stalled_device_decays_and_nothing_is_measured_from_too_few_ticks() -> None:
    monitor = RateMonitor(20.0)
    end = feed(monitor, 20.0, 1.0, 2.0)
    assert monitor.report(end + 2.0).achieved_rate < 0.6 * 20.0
    fresh = RateMonitor(20.0)
    fresh.tick(0.0, 0.0)
    assert not fresh.report(0.0).measured and not fresh.report(0.0).behind


def test_targets_must_be_positive() -> None:
    with pytest.raises(ValueError):
        RateMonitor(0.0)
    with pytest.raises(ValueError):
        RateMonitor(20.0).configure(20.0, -1.0)
