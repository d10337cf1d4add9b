"""The report of an experiment: per scenario, throughput with its interval, cycle times, OEE, shares.

From the results table's rows (docs/experiments.md, "The report"): throughput in good parts per hour with
its 95 % Student-t interval over replications, the cycle-time p50 and p95, availability, performance,
quality and OEE, each device's time shares and the bottleneck, faults seen and handled, and the paired
difference in throughput against the baseline (common random numbers).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import Iterable

import numpy as np

from feeder_cell.experiment.design import Experiment, Scenario
from feeder_cell.experiment.results import DEVICE_STATES
from feeder_cell.experiment.table import Results

__all__ = ["t_quantile_975", "interval", "LevelReport", "report", "format_report"]


def t_quantile_975(dof: int) -> float:
    """Return Student's t quantile 0.975 with ``dof`` degrees of freedom (scipy's, exact)."""
    from scipy.stats import t

    return float(t.ppf(0.975, dof))


def interval(values: Iterable[float]) -> tuple[float, float, int]:
    """Return (mean, 95 % half-width by Student t, n); the half-width is NaN for fewer than 2 values."""
    data = np.array(list(values), float)
    n = len(data)
    if n == 0:
        return math.nan, math.nan, 0
    if n < 2:
        return float(data.mean()), math.nan, 1
    return float(data.mean()), t_quantile_975(n - 1) * float(data.std(ddof=1)) / math.sqrt(n), n


@dataclass
class LevelReport:
    """The report of one scenario."""

    scenario: Scenario
    replications: int
    failed: list[str]
    throughput: tuple[float, float, int]
    p50: float
    p95: float
    availability: float
    performance: float
    quality: float
    oee: float
    shares: dict[str, dict[str, float]]
    bottleneck: str
    faults_seen: int
    faults_handled: int
    difference: tuple[float, float, int] | None
    cpu: float  # mean CPU s of one replication (the fidelity's cost beside its estimate)


def _ok_rows(rows: dict[tuple[int, int], dict[str, str]], scenario: int) -> dict[int, dict[str, str]]:
    return {r: row for (s, r), row in rows.items() if s == scenario and row["status"] == "ok"}


def _throughput(row: dict[str, str]) -> float:
    window = float(row["window_s"])
    return 3600.0 * int(row["good"]) / window if window > 0 else math.nan


def report(experiment: Experiment, results: Results) -> list[LevelReport]:
    """Return the report per scenario from the table's rows (in scenario order)."""
    rows = results.rows
    baseline = _ok_rows(rows, experiment.baseline)
    out = []
    for scenario in experiment.scenarios:
        ok = _ok_rows(rows, scenario.index)
        failed = [
            f"replication {r} (seed {row['seed']}): {row['reason']}"
            for (s, r), row in sorted(rows.items())
            if s == scenario.index and row["status"] != "ok"
        ]
        throughputs = [_throughput(row) for _, row in sorted(ok.items())]
        times = [float(t) for row in ok.values() for t in row["cycle_times"].split(";") if t]
        ideal = min(times) if times else math.nan
        window = sum(float(row["window_s"]) for row in ok.values())
        down = sum(float(row["down_s"]) for row in ok.values())
        good = sum(int(row["good"]) for row in ok.values())
        rejected = sum(int(row["rejected"]) for row in ok.values())
        availability = (window - down) / window if window > 0 else math.nan
        performance = ideal * (good + rejected) / (window - down) if window - down > 0 else math.nan
        quality = good / (good + rejected) if good + rejected else math.nan
        shares: dict[str, dict[str, float]] = {}
        for row in ok.values():
            for device, share in json.loads(row["shares"]).items():
                total = shares.setdefault(device, dict.fromkeys(DEVICE_STATES, 0.0))
                for k in DEVICE_STATES:
                    total[k] += share[k] / len(ok)
        bottleneck = max(shares, key=lambda d: shares[d]["RUNNING"]) if shares else ""
        paired = [
            _throughput(row) - _throughput(baseline[r]) for r, row in sorted(ok.items()) if r in baseline
        ]
        difference = None if scenario.index == experiment.baseline else interval(paired)
        out.append(
            LevelReport(
                scenario,
                len(ok),
                failed,
                interval(throughputs),
                float(np.percentile(times, 50)) if times else math.nan,
                float(np.percentile(times, 95)) if times else math.nan,
                availability,
                performance,
                quality,
                availability * performance * quality,
                shares,
                bottleneck,
                sum(int(row["faults_seen"]) for row in ok.values()),
                sum(int(row["faults_handled"]) for row in ok.values()),
                difference,
                float(np.mean([float(row["cpu_s"]) for row in ok.values()])) if ok else math.nan,
            )
        )
    return out


def _pm(value: tuple[float, float, int]) -> str:
    mean, half, _ = value
    return (
        f"{mean:.2f} +- {half:.2f}" if math.isfinite(half) else f"{mean:.2f} (one replication: no interval)"
    )


def format_report(experiment: Experiment, levels: list[LevelReport]) -> str:
    """Return the report as Markdown text."""
    horizon = (
        f"{experiment.horizon_cycles} cycles"
        if experiment.horizon_cycles is not None
        else f"{experiment.horizon_time:g} s of cell time"
    )
    warmup = (
        f"{experiment.warmup_cycles} cycles"
        if not experiment.warmup_time
        else f"{experiment.warmup_time:g} s"
    )
    lines = [
        f"# Experiment {experiment.path.name} ({experiment.digest})",
        "",
        f"Scene {experiment.scene}, seed {experiment.document.get('seed', 0)}; {experiment.replications} "
        f"replications per scenario (common random numbers), horizon {horizon}, warm-up {warmup}. "
        "Intervals: 95 %, Student t over replications.",
        "",
        "| scenario | reps | good parts/h | cycle p50 s | p95 s | A | P | Q | OEE | bottleneck | faults "
        "seen/handled | vs baseline parts/h | CPU s/rep |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for level in levels:
        base = "baseline" if level.difference is None else _pm(level.difference)
        lines.append(
            f"| {level.scenario.label()} | {level.replications} | {_pm(level.throughput)} | "
            f"{level.p50:.2f} | {level.p95:.2f} | {level.availability:.3f} | {level.performance:.3f} | "
            f"{level.quality:.3f} | "
            f"{level.oee:.3f} | {level.bottleneck} | {level.faults_seen}/{level.faults_handled} | {base} | "
            f"{level.cpu:.2f} |"
        )
    lines += ["", "Device time shares (RUNNING / IDLE / FAULT):", ""]
    for level in levels:
        shares = "; ".join(
            f"{device} {s['RUNNING']:.3f} / {s['IDLE']:.3f} / {s['FAULT']:.3f}"
            for device, s in sorted(level.shares.items())
        )
        lines.append(f"- {level.scenario.label()}: {shares}")
    failed = [f"- {level.scenario.label()}: {f}" for level in levels for f in level.failed]
    if failed:
        lines += ["", "Failed replications:", "", *failed]
    return "\n".join(lines) + "\n"
