"""Shared pieces of the device benchmarks: median timing and the table's row format."""

from __future__ import annotations

import statistics
import time
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
