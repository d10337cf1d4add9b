"""Production experiments on the ROS-free cell loop: factors, levels, replications, and the report.

An experiment file names a scene, factors (a node's parameter with its levels), the replications per
scenario, the horizon and the warm-up (docs/experiments.md, "Experiments"). Every scenario (one level
of each factor: the full factorial) runs replications 0..n-1, replication i with the scene's streams of
replication i in every scenario (common random numbers). Each replication is one ``CellLoop`` run; its
row goes to the results table as it ends, so an interrupted experiment resumes where it stopped. The
report gives per scenario: throughput in good parts per hour with its 95 % Student-t interval, the
cycle-time p50 and p95, availability, performance, quality and OEE, each device's time shares, the
bottleneck, faults seen and handled, and the paired difference in throughput against the baseline.

Measured window: from the end of the warm-up (its cycles, or the first cycle end at or after its time)
to the end of the horizon's last cycle. With W its cell time, G good parts, R rejected, D the cell time
down (a device in FAULT or the controller in RECOVER) and c* the ideal cycle time (the shortest
complete cycle of the scenario over all its replications):

    throughput = 3600 G / W   availability A = (W - D) / W   performance P = c* (G + R) / (W - D)
    quality Q = G / (G + R)   OEE = A P Q = c* G / W

This module runs the replications: one loop run each (``run_replication``, a plain function of plain data
that a Dask worker runs as this process does), in this process or on Dask, or one replayed as a ROS scene;
a replication that raises becomes a failed row with its reason (``guarded``) and the experiment goes on.
The other parts, one concept each: ``design`` (the experiment file and its scenarios), ``table`` (the
results table), ``report`` (the measures and the Markdown report) and ``loop`` (the cell loop); their
public names are importable from here too, as the CLI, the benchmark and the tests import them.
"""

from __future__ import annotations

import importlib
import json
import time
import traceback
from pathlib import Path
from typing import Any, Callable

import yaml

from feeder_cell.experiment.design import (
    MAX_REPLICATIONS,
    MAX_SCENARIOS,
    Experiment,
    Scenario,
    load_experiment,
    scene_of,
)
from feeder_cell.experiment.loop import scene_loop
from feeder_cell.experiment.report import (
    LevelReport,
    _ok_rows,
    _throughput,
    format_report,
    interval,
    report,
    t_quantile_975,
)
from feeder_cell.experiment.results import DEVICE_STATES, QUANTUM, CycleRecord, LoopResult
from feeder_cell.experiment.table import COLUMNS, Results, iterate_rows, sorted_rows_text
from feeder_planner.dask_cluster import MAX_WORKERS, dask_client
from feeder_planner.errors import InputError

__all__ = [
    "COLUMNS",
    "Experiment",
    "LevelReport",
    "MAX_REPLICATIONS",
    "MAX_SCENARIOS",
    "Results",
    "Scenario",
    "format_report",
    "guarded",
    "interval",
    "iterate_rows",
    "load_experiment",
    "replay_scene",
    "report",
    "run_dask",
    "run_local",
    "run_replication",
    "sorted_rows_text",
    "t_quantile_975",
    "task_arguments",
    "tasks",
    "warmup_cut",
    "_ok_rows",
    "_throughput",
]


def _overrides(levels: dict[str, Any], executables: dict[str, str]) -> dict[str, dict[str, Any]]:
    out: dict[str, dict[str, Any]] = {}
    for name, level in levels.items():
        node, _, parameter = name.partition(".")
        out.setdefault(executables[node], {})[parameter] = level
    return out


def warmup_cut(cycles: list[CycleRecord], warmup_cycles: int, warmup_time: float) -> int | None:
    """Return how many of ``cycles`` are the warm-up, or None while it has not ended.

    Its cycles, or every cycle up to the first that ends at or after its time.
    """
    if warmup_time > 0:
        return next((k + 1 for k, c in enumerate(cycles) if c.end >= warmup_time - 1e-9), None)
    return warmup_cycles if len(cycles) >= warmup_cycles else None


def run_replication(
    scene_document: dict[str, Any],
    scene_dir: str,
    levels: dict[str, Any],
    replication: int,
    horizon_cycles: int | None,
    horizon_time: float | None,
    warmup_cycles: int,
    warmup_time: float,
) -> dict[str, Any]:
    """Run one replication; return its row's measured values (an exception is the caller's to record).

    A plain function of plain data, so that a Dask worker runs it as this process does.
    """
    start = time.process_time()
    result = _run_loop(
        scene_document,
        scene_dir,
        levels,
        replication,
        horizon_cycles,
        horizon_time,
        warmup_cycles,
        warmup_time,
    )
    return _measure(result, warmup_cycles, warmup_time, time.process_time() - start)


def _measure(result: LoopResult, warmup_cycles: int, warmup_time: float, cpu: float) -> dict[str, Any]:
    """Return the measured window's figures of one replication's result."""
    cycles = result.cycles
    # The warm-up ends at its last cycle's end; a cell that stopped before it has no measured window.
    found = warmup_cut(cycles, warmup_cycles, warmup_time)
    cut = len(cycles) if found is None else found
    before = cycles[cut - 1] if cut > 0 and cut <= len(cycles) else None
    measured = cycles[cut:]
    last = cycles[-1] if cycles else None
    start_end = before.end if before is not None else 0.0
    window = (last.end if last is not None else 0.0) - start_end
    if not measured:
        window = 0.0
    quanta_before = before.device_quanta if before is not None else {}
    down_before = before.down_quanta if before is not None else 0
    shares: dict[str, dict[str, float]] = {}
    if last is not None and measured:
        for device, counts in last.device_quanta.items():
            prior = quanta_before.get(device, dict.fromkeys(DEVICE_STATES, 0))
            spent = {k: counts[k] - prior.get(k, 0) for k in DEVICE_STATES}
            total = sum(spent.values()) or 1
            shares[device] = {k: v / total for k, v in spent.items()}
    down = ((last.down_quanta - down_before) * QUANTUM) if (last is not None and measured) else 0.0
    return {
        "end_state": result.end_state
        if not result.stop_reason
        else f"{result.end_state}: {result.stop_reason}",
        "cycles": sum(c.complete for c in measured),
        "good": sum(c.presented for c in measured),
        "rejected": sum(c.rejected for c in measured),
        "window_s": round(window, 9),
        "down_s": round(down, 9),
        "faults_seen": sum(c.faults_seen for c in measured),
        "faults_handled": sum(c.faults_handled for c in measured),
        "cycle_times": ";".join(f"{c.time:.3f}" for c in measured if c.complete),
        "shares": json.dumps(shares, sort_keys=True),
        "cpu_s": round(cpu, 4),
    }


def tasks(experiment: Experiment, results: Results) -> list[tuple[Scenario, int]]:
    """Return the replications still to run, scenario by scenario."""
    return [
        (scenario, r)
        for scenario in experiment.scenarios
        for r in range(experiment.replications)
        if not results.done(scenario.index, r)
    ]


def task_arguments(experiment: Experiment, scenario: Scenario, replication: int) -> tuple[Any, ...]:
    """Return the arguments of ``run_replication`` for one task."""
    return (
        experiment.document,
        str(experiment.scene.parent),
        scenario.levels,
        replication,
        experiment.horizon_cycles,
        experiment.horizon_time,
        experiment.warmup_cycles,
        experiment.warmup_time,
    )


def guarded(function: Callable[..., dict[str, Any]], *arguments: Any) -> dict[str, Any]:
    """Run a replication; an exception becomes a failed row with its reason (the experiment goes on)."""
    try:
        values = function(*arguments)
        values["status"] = "ok"
        return values
    except Exception as error:  # noqa: BLE001 - a replication that raises is recorded, never fatal
        where = traceback.extract_tb(error.__traceback__)[-1]
        reason = f"{type(error).__name__}: {error} (at {Path(where.filename).name}:{where.lineno})"
        return {"status": "failed", "reason": " ".join(reason.split())[:500]}


def run_local(
    experiment: Experiment, results: Results, progress: Callable[[int, int], None] | None = None
) -> None:
    """Run the missing replications in this process, appending each row as it ends."""
    todo = tasks(experiment, results)
    for done, (scenario, replication) in enumerate(todo, start=1):
        values = guarded(run_replication, *task_arguments(experiment, scenario, replication))
        results.append(scenario, replication, values)
        if progress is not None:
            progress(done, len(todo))


# --- Dask ---------------------------------------------------------------------------------------------------
def run_dask(
    experiment: Experiment,
    results: Results,
    workers: int,
    scheduler: str | None,
    progress: Callable[[int, int], None] | None = None,
) -> tuple[float, float]:
    """Run the missing replications on Dask, appending each row as it ends; return (start-up s, work s).

    Rows go in the order they end. The start-up is the cluster's start or connection and the workers'
    arrival; the work runs from the submission to the last row.

    ``scheduler`` None: a LocalCluster of ``workers`` single-threaded processes (the setup of the
    throwing-design studies, ``feeder_planner.throwing.studies``); else the cluster at that address.
    Rows are keyed by (scenario, replication) and each replication is seeded by its index alone, so the
    table's values do not depend on the workers or the order.
    """
    from dask.distributed import as_completed

    if not 1 <= workers <= MAX_WORKERS:
        raise InputError("--workers", f"must be in 1..{MAX_WORKERS}, got {workers}")
    todo = tasks(experiment, results)
    begin = time.perf_counter()
    with dask_client(workers, scheduler, field="--scheduler") as client:
        # The models' imports (numpy, scipy, the planner, the simulators: seconds per process) belong to
        # the start-up, not to the first replication each worker runs.
        client.run(importlib.import_module, "feeder_cell.experiment.loop")
        submitted = time.perf_counter()
        futures = {
            client.submit(guarded, run_replication, *task_arguments(experiment, s, r), pure=False): (s, r)
            for s, r in todo
        }
        for done, future in enumerate(as_completed(futures), start=1):
            scenario, replication = futures[future]
            results.append(scenario, replication, future.result())
            if progress is not None:
                progress(done, len(todo))
        return submitted - begin, time.perf_counter() - submitted


# --- replay as a ROS scene ---------------------------------------------------------------------------------
def replay_scene(
    experiment: Experiment, scenario: int, replication: int, folder: Path
) -> tuple[Path, list[str]]:
    """Write the scene that replays one replication in ROS; return it and the loop's cycle lines.

    The scene file with the experiment's seed, arrivals and faults, the scenario's levels, the controller's
    ``replication`` set to the replication and its ``cycles`` to as many as the loop's run of it had (the
    warm-up's and the horizon's). The loop's lines say what the ROS run must show (``cycle k: T s``).
    """
    from feeder_cell.launcher import scene_copy

    if not 0 <= scenario < len(experiment.scenarios):
        raise InputError("--scenario", f"must be in 0..{len(experiment.scenarios) - 1}, got {scenario}")
    if not 0 <= replication < experiment.replications:
        raise InputError("--replay", f"must be in 0..{experiment.replications - 1}, got {replication}")
    chosen = experiment.scenarios[scenario]
    scene = scene_of(experiment.document, experiment.scene)
    executables = {n.node_name: n.executable for n in scene.nodes}
    overrides = _overrides(chosen.levels, executables)
    controller = next(n.parameters for n in scene.nodes if n.executable == "cell_controller")
    policy = {**controller, **overrides.get("cell_controller", {})}.get("policy", "sequential")
    if policy != "sequential":
        # The ROS reference controller refuses it at start: say so before a scene is launched.
        raise InputError("--scenario", f"{chosen.label()}: {policy} runs in the ROS-free loop only, so far")
    arguments = task_arguments(experiment, chosen, replication)
    cycles = _run_loop(*arguments).cycles
    overrides.setdefault("cell_controller", {}).update(cycles=len(cycles), replication=replication)
    folder.mkdir(parents=True, exist_ok=True)
    path = scene_copy(experiment.scene, folder, overrides)
    document = yaml.safe_load(path.read_text())
    for key in ("seed", "arrivals", "faults"):
        if experiment.document.get(key) is not None:
            document[key] = experiment.document[key]
    path.write_text(yaml.safe_dump(document))
    lines = [f"cycle {c.cycle}: {c.time:.2f} s, {c.throws} throws" for c in cycles]
    return path, lines


def _run_loop(
    scene_document: dict[str, Any],
    scene_dir: str,
    levels: dict[str, Any],
    replication: int,
    horizon_cycles: int | None,
    horizon_time: float | None,
    warmup_cycles: int,
    warmup_time: float,
) -> LoopResult:
    """Run the loop of one replication until the warm-up and the horizon are complete."""
    from feeder_cell.launcher import scene_from_mapping

    scene = scene_from_mapping(scene_document, Path(scene_dir))
    executables = {n.node_name: n.executable for n in scene.nodes}

    def until(cycles: list[CycleRecord]) -> bool:
        cut = warmup_cut(cycles, warmup_cycles, warmup_time)
        if cut is None:
            return False
        if horizon_cycles is not None:
            return len(cycles) - cut >= horizon_cycles
        assert horizon_time is not None
        return cycles[-1].end - (cycles[cut - 1].end if cut > 0 else 0.0) >= horizon_time - 1e-9

    return scene_loop(scene, replication, _overrides(levels, executables)).run(until)
