"""The picture of an experiment's report: cycle times, utilisation, main effects, estimate against cost.

One figure, four panels (docs/experiments.md, "Experiments"): the complete cycles' times of each scenario
(pooled over replications), each device's share of time RUNNING, IDLE and FAULT per scenario, each
factor's main effect on throughput (per level, the mean over its scenarios of the replications' good
parts per hour, with the 95 % Student-t interval of the per-replication means), and each scenario's
throughput estimate against its mean CPU seconds per replication: the speed-accuracy trade of a fidelity
factor at the cell level (issue 38 item 7).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.figure import Figure

from feeder_cell.experiment.design import Experiment
from feeder_cell.experiment.report import LevelReport, _ok_rows, _throughput, interval
from feeder_cell.experiment.results import DEVICE_STATES
from feeder_cell.experiment.table import Results
from feeder_cell.plots.common import new_figure

__all__ = ["cost_points", "experiment_figure", "main_effects"]

COLOURS = {"RUNNING": "tab:green", "IDLE": "tab:gray", "FAULT": "tab:red"}


def main_effects(experiment: Experiment, results: Results) -> dict[str, list[tuple[Any, float, float]]]:
    """Return per factor, per level: (level, mean good parts/h, 95 % half-width) over replications.

    Replication i's value at a level is the mean of its throughput over the scenarios at that level (the
    other factors' levels averaged out, each replication paired with itself by common random numbers).
    """
    effects: dict[str, list[tuple[Any, float, float]]] = {}
    for name, levels in experiment.factors.items():
        rows = []
        for level in levels:
            scenarios = [s.index for s in experiment.scenarios if s.levels[name] == level]
            per_replication = []
            for r in range(experiment.replications):
                values = [_throughput(ok[r]) for s in scenarios if r in (ok := _ok_rows(results.rows, s))]
                if len(values) == len(scenarios):
                    per_replication.append(float(np.mean(values)))
            mean, half, _ = interval(per_replication)
            rows.append((level, mean, half))
        effects[name] = rows
    return effects


def cost_points(levels: list[LevelReport]) -> list[tuple[str, float, float, float]]:
    """Return per scenario: (label, mean CPU s per replication, good parts/h, its 95 % half-width)."""
    return [(level.scenario.label(), level.cpu, level.throughput[0], level.throughput[1]) for level in levels]


def experiment_figure(experiment: Experiment, results: Results, levels: list[LevelReport]) -> Figure:
    """Return the report's figure."""
    figure = new_figure((16.0, 4.2))
    histogram, shares, effects, cost = figure.subplots(1, 4)
    for level in levels:
        rows = _ok_rows(results.rows, level.scenario.index)
        times = [float(t) for row in rows.values() for t in row["cycle_times"].split(";") if t]
        if times:
            histogram.hist(times, bins=20, alpha=0.5, label=level.scenario.label())
    histogram.set_xlabel("cycle time (s of cell time)")
    histogram.set_ylabel("cycles")
    histogram.set_title("cycle times")
    histogram.legend(fontsize="small")
    devices = sorted({d for level in levels for d in level.shares})
    width = 0.8 / max(len(levels), 1)
    for k, level in enumerate(levels):
        x = np.arange(len(devices)) + k * width
        bottom = np.zeros(len(devices))
        for state in DEVICE_STATES:
            values = np.array([level.shares.get(d, {}).get(state, 0.0) for d in devices])
            label = state if k == 0 else None
            shares.bar(x, values, width, bottom=bottom, color=COLOURS[state], label=label, edgecolor="white")
            bottom += values
    shares.set_xticks(np.arange(len(devices)) + 0.4 - width / 2, devices, fontsize="small")
    shares.set_ylabel("share of the measured window")
    shares.set_title("utilisation (bars: scenarios in order)")
    shares.legend(fontsize="small", loc="upper center", bbox_to_anchor=(0.5, -0.1), ncols=3)
    for name, effect in main_effects(experiment, results).items():
        at = list(range(len(effect)))
        means = [mean for _, mean, _ in effect]
        halves = [half if np.isfinite(half) else 0.0 for _, _, half in effect]
        effects.errorbar(at, means, yerr=halves, marker="o", capsize=4, label=name)
        for k, (level, mean, _) in enumerate(effect):
            effects.annotate(str(level), (k, mean), textcoords="offset points", xytext=(4, 4))
    effects.set_xlabel("level (index)")
    effects.set_ylabel("good parts per hour (95 % interval)")
    effects.set_title("main effects")
    if experiment.factors:
        effects.legend(fontsize="small")
    for label, cpu, mean, half in cost_points(levels):
        # In the legend, not beside the point: fidelities of about equal cost sit on top of each other.
        error = [half if np.isfinite(half) else 0.0]
        cost.errorbar([cpu], [mean], yerr=error, marker="s", capsize=4, label=label)
    cost.set_xlabel("CPU s per replication")
    cost.set_ylabel("good parts per hour (95 % interval)")
    cost.set_title("estimate against cost")
    if levels:
        cost.legend(fontsize="small")
    return figure
