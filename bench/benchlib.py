"""Shared pieces of the device benchmarks: median timing, the table's row format, a free ROS domain."""

from __future__ import annotations

import fcntl
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any, Callable


def median_time_and_result(function: Callable[[], Any], repeats: int) -> tuple[float, Any]:
    """Return the median wall time of ``repeats`` calls (s) and the last result.

    The median is robust to the odd slow call on a shared machine.
    """
    times, result = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        result = function()
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def median_time(function: Callable[[], Any], repeats: int) -> float:
    """Median wall time of ``repeats`` calls (s)."""
    return median_time_and_result(function, repeats)[0]


def row(benchmark: str, measure: str, value: float, unit: str, target: str, baseline: str, met: bool) -> dict:
    """One line of the `make bench` table."""
    return {
        "benchmark": benchmark,
        "measure": measure,
        "value": float(value),
        "unit": unit,
        "target": target,
        "baseline": baseline,
        "met": bool(met),
    }


def holds_rate(figures: dict[str, float]) -> bool:
    """Whether a device's /diagnostics figures hold its configured rate and real-time factor.

    Within the devices' own tolerance (``feeder_device.rate.BEHIND_TOLERANCE``), the one ``behind_real_time``
    is judged by, so a bench and the device agree on what "holds" means.
    """
    from feeder_device.rate import BEHIND_TOLERANCE

    floor = 1.0 - BEHIND_TOLERANCE
    return (
        figures["achieved_rate_hz"] >= floor * figures["configured_rate_hz"]
        and figures["achieved_real_time_factor"] >= floor * figures["configured_real_time_factor"]
    )


def lease_domain(bench: str) -> tuple[int, Any]:
    """Return a ROS domain no test run holds (the test harness's lock files), held until the handle closes."""
    for domain in range(60, 102):
        handle = open(Path(tempfile.gettempdir()) / f"feeder-ros-domain-{domain}.lock", "w")
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return domain, handle
        except OSError:
            handle.close()
    raise RuntimeError(f"no free ROS domain for the {bench} bench")
