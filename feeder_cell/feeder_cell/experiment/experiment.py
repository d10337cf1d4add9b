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
"""

from __future__ import annotations

import csv
import hashlib
import importlib
import itertools
import json
import math
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator

import numpy as np
import yaml

from feeder_cell.experiment.arrivals import arrivals_from_mapping, scene_seed
from feeder_cell.experiment.faults_process import faults_from_mapping
from feeder_cell.experiment.loop import (
    CONTROLLER_SPECS,
    DEVICE_STATES,
    DEVICES,
    PARAMETER_CLASSES,
    QUANTUM,
    CycleRecord,
    LoopResult,
    _device_parameters,
    check_scene,
    controller_parameters,
    scene_loop,
)
from feeder_planner.dask_cluster import MAX_WORKERS, dask_client
from feeder_planner.errors import InputError
from feeder_planner.fields_io import load_yaml_mapping
from feeder_planner.parameter_specs import specs_of

__all__ = [
    "Experiment",
    "Scenario",
    "load_experiment",
    "run_replication",
    "run_local",
    "run_dask",
    "replay_scene",
    "Results",
    "report",
    "t_quantile_975",
    "MAX_REPLICATIONS",
    "MAX_SCENARIOS",
]

MAX_REPLICATIONS = 100_000
MAX_SCENARIOS = 1_000
MAX_CYCLES = 1_000_000
MAX_HORIZON_TIME = 365 * 24 * 3600.0  # s: a year of cell time
FIELDS = ("scene", "factors", "replications", "horizon", "warmup", "baseline", "seed", "arrivals", "faults")
COLUMNS = (
    "experiment",
    "scenario",
    "levels",
    "replication",
    "seed",
    "status",
    "reason",
    "end_state",
    "cycles",
    "good",
    "rejected",
    "window_s",
    "down_s",
    "faults_seen",
    "faults_handled",
    "cycle_times",
    "shares",
    "cpu_s",
)


@dataclass(frozen=True)
class Scenario:
    """One combination of levels: factor name -> level, in the file's factor order."""

    index: int
    levels: dict[str, Any]

    def label(self) -> str:
        """Return the scenario as a report shows it, e.g. ``throwing_arm.period=0.4``."""
        return ", ".join(f"{k}={v}" for k, v in self.levels.items()) or "(the scene as it is)"


@dataclass(frozen=True)
class Experiment:
    """A checked experiment: the scene file, the scenarios, replications, horizon, warm-up, baseline."""

    path: Path
    scene: Path
    factors: dict[str, list[Any]]
    replications: int
    horizon_cycles: int | None
    horizon_time: float | None
    warmup_cycles: int
    warmup_time: float
    baseline: int  # the scenario the paired differences are taken against
    document: dict[str, Any]  # the scene's document with the experiment's seed, arrivals and faults
    digest: str  # of the experiment and scene documents: a results table belongs to one experiment
    scenarios: tuple[Scenario, ...] = field(default_factory=tuple)


def _count(value: Any, where: str, low: int, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise InputError(where, f"must be an integer in [{low}, {high}], got {value!r}")
    return value


def _time(value: Any, where: str, low: float) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputError(where, f"must be a finite time in s, got {value!r}")
    if not low <= value <= MAX_HORIZON_TIME:
        raise InputError(where, f"must be in [{low:g}, {MAX_HORIZON_TIME:g}] s, got {value!r}")
    return float(value)


def _span(value: Any, where: str, allow_zero: bool) -> tuple[int | None, float | None]:
    """Read ``{cycles: N}`` or ``{time: S}`` (one of them)."""
    if not isinstance(value, dict) or len(value) != 1 or not set(value) <= {"cycles", "time"}:
        raise InputError(where, f"must be {{cycles: N}} or {{time: S}} (s of cell time), got {value!r}")
    low = 0 if allow_zero else 1
    if "cycles" in value:
        return _count(value["cycles"], f"{where}.cycles", low, MAX_CYCLES), None
    return None, _time(value["time"], f"{where}.time", 0.0 if allow_zero else QUANTUM)


def _factor_target(name: str, executables: dict[str, str]) -> tuple[str, str]:
    """Return (executable, parameter) of a factor ``NODE.PARAMETER``, or raise naming the factor."""
    where = f"factors.{name}"
    node, dot, parameter = name.partition(".")
    if not dot or not node or not parameter:
        raise InputError(where, "must be NODE.PARAMETER (a node of the scene and one of its parameters)")
    executable = executables.get(node)
    if executable is None:
        raise InputError(where, f"names no node of the scene (nodes: {', '.join(sorted(executables))})")
    if executable in DEVICES:
        known = {s.name for s in specs_of(PARAMETER_CLASSES[executable])}
    elif executable == "cell_controller":
        known = set(CONTROLLER_SPECS)
    else:
        raise InputError(where, f"{node} ({executable}) is not a node the cell loop runs")
    if parameter not in known:
        raise InputError(where, f"{node} has no parameter {parameter!r} (it has: {', '.join(sorted(known))})")
    return executable, parameter


def load_experiment(path: str | Path) -> Experiment:
    """Read and check an experiment file; every error is one line naming the field (and the file)."""
    path = Path(path)
    try:
        return _load(path)
    except InputError as error:
        raise error.with_source(str(path)) from None


def _load(path: Path) -> Experiment:
    document = load_yaml_mapping(path)
    for key in document:
        if key not in FIELDS:
            raise InputError(str(key), f"is not a field of an experiment (fields: {', '.join(FIELDS)})")
    if "scene" not in document or not isinstance(document["scene"], str) or not document["scene"]:
        raise InputError("scene", "must name a scene file (relative to the experiment file)")
    scene_path = (path.resolve().parent / document["scene"]).resolve()
    if not scene_path.is_file():
        raise InputError("scene", f"no such file: {scene_path}")
    scene_document = load_yaml_mapping(scene_path)
    # The experiment's random inputs replace the scene's, checked by the scene's own rules.
    for key in ("seed", "arrivals", "faults"):
        if key in document:
            scene_document[key] = document[key]
    scene_seed(scene_document)
    if scene_document.get("arrivals") is not None:
        arrivals_from_mapping(scene_document["arrivals"])
    if scene_document.get("faults") is not None:
        faults_from_mapping(scene_document["faults"])
    scene = _scene_of(scene_document, scene_path)
    executables = {n.node_name: n.executable for n in scene.nodes}
    factors_value = document.get("factors", {}) or {}
    if not isinstance(factors_value, dict):
        raise InputError("factors", "must map NODE.PARAMETER to a list of levels")
    factors: dict[str, list[Any]] = {}
    for name, levels in factors_value.items():
        executable, parameter = _factor_target(str(name), executables)
        where = f"factors.{name}"
        if not isinstance(levels, list) or not levels:
            raise InputError(where, f"must be a non-empty list of levels, got {levels!r}")
        if len({json.dumps(v, sort_keys=True) for v in levels}) != len(levels):
            raise InputError(where, f"has a level twice: {levels!r}")
        for k, level in enumerate(levels):
            _check_level(executable, parameter, level, scene, f"{where}[{k}]")
        factors[str(name)] = list(levels)
    replications = _count(document.get("replications", 1), "replications", 1, MAX_REPLICATIONS)
    horizon_cycles, horizon_time = _span(document.get("horizon", {"cycles": 10}), "horizon", False)
    warmup_cycles, warmup_time = _span(document.get("warmup", {"cycles": 0}), "warmup", True)
    combos = list(itertools.product(*factors.values())) if factors else [()]
    if len(combos) > MAX_SCENARIOS:
        raise InputError("factors", f"{len(combos)} scenarios; an experiment runs at most {MAX_SCENARIOS}")
    scenarios = tuple(Scenario(i, dict(zip(factors, combo, strict=True))) for i, combo in enumerate(combos))
    baseline = _baseline(document.get("baseline"), factors, scenarios)
    digest = hashlib.sha256(
        json.dumps([document, scene_document], sort_keys=True, default=str).encode()
    ).hexdigest()[:16]
    return Experiment(
        path,
        scene_path,
        factors,
        replications,
        horizon_cycles,
        horizon_time,
        warmup_cycles or 0,
        warmup_time or 0.0,
        baseline,
        scene_document,
        digest,
        scenarios,
    )


def _scene_of(document: dict[str, Any], scene_path: Path) -> Any:
    """Parse and check the scene document (with the experiment's inputs) as the loop reads scenes."""
    from feeder_cell.launcher import scene_from_mapping

    return check_scene(scene_from_mapping(document, scene_path.parent))


def _check_level(executable: str, parameter: str, level: Any, scene: Any, where: str) -> None:
    """Check one level as the node would check its parameter; raise naming the level."""
    values = next(dict(n.parameters) for n in scene.nodes if n.executable == executable)
    values[parameter] = level
    try:
        if executable in DEVICES:
            _device_parameters(PARAMETER_CLASSES[executable], values, executable)
        else:
            controller_parameters(values)
    except InputError as error:
        raise InputError(where, f"{error.field}: {error.problem}") from None


def _baseline(value: Any, factors: dict[str, list[Any]], scenarios: tuple[Scenario, ...]) -> int:
    """Return the baseline scenario's index: each factor's given level, or its first."""
    if value is None:
        return 0
    if not isinstance(value, dict):
        raise InputError("baseline", "must map factors to one of their levels")
    for name, level in value.items():
        if name not in factors:
            raise InputError(f"baseline.{name}", "is not a factor of the experiment")
        if level not in factors[name]:
            raise InputError(f"baseline.{name}", f"must be one of the factor's levels {factors[name]!r}")
    wanted = {name: value.get(name, levels[0]) for name, levels in factors.items()}
    return next(s.index for s in scenarios if s.levels == wanted)


# --- one replication ---------------------------------------------------------------------------------------
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


# --- the results table -------------------------------------------------------------------------------------
class Results:
    """The CSV table: one row per replication, appended and flushed as each ends; read back to resume."""

    def __init__(self, path: Path, experiment: Experiment) -> None:
        self.path = path
        self.experiment = experiment
        self.rows: dict[tuple[int, int], dict[str, str]] = {}
        if path.exists() and path.stat().st_size > 0:
            with path.open(newline="") as handle:
                reader = csv.DictReader(handle)
                if tuple(reader.fieldnames or ()) != COLUMNS:
                    raise InputError("--results", f"{path} is not a results table of feeder experiment")
                for row in reader:
                    if row["experiment"] != experiment.digest:
                        raise InputError(
                            "--results",
                            f"{path} holds rows of another experiment ({row['experiment']}, this one is "
                            f"{experiment.digest}): remove it or name another file",
                        )
                    self.rows[(int(row["scenario"]), int(row["replication"]))] = row
        else:
            path.parent.mkdir(parents=True, exist_ok=True)
            with path.open("w", newline="") as handle:
                csv.DictWriter(handle, COLUMNS).writeheader()

    def done(self, scenario: int, replication: int) -> bool:
        """Whether the table already has this replication (finished or failed)."""
        return (scenario, replication) in self.rows

    def append(self, scenario: Scenario, replication: int, values: dict[str, Any]) -> None:
        """Append one row and flush it to disk before returning."""
        row = {column: "" for column in COLUMNS}
        row.update(
            experiment=self.experiment.digest,
            scenario=str(scenario.index),
            levels=json.dumps(scenario.levels, sort_keys=True),
            replication=str(replication),
            seed=str(self.experiment.document.get("seed", 0)),
        )
        row.update({k: str(v) for k, v in values.items()})
        with self.path.open("a", newline="") as handle:
            csv.DictWriter(handle, COLUMNS).writerow(row)
            handle.flush()
        self.rows[(scenario.index, replication)] = row


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


# --- the report ------------------------------------------------------------------------------------------
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


def iterate_rows(results: Results) -> Iterator[dict[str, str]]:
    """Yield the table's rows in (scenario, replication) order (the same whatever order they ended in)."""
    for key in sorted(results.rows):
        yield results.rows[key]


def sorted_rows_text(results: Results) -> str:
    """Return the rows' measured values in key order without timings (equal across worker counts)."""
    keep = [c for c in COLUMNS if c != "cpu_s"]
    return "\n".join(",".join(row[c] for c in keep) for row in iterate_rows(results))


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
    scene = _scene_of(experiment.document, experiment.scene)
    executables = {n.node_name: n.executable for n in scene.nodes}
    arguments = task_arguments(experiment, chosen, replication)
    cycles = _run_loop(*arguments).cycles
    overrides = _overrides(chosen.levels, executables)
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
