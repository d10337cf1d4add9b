"""An experiment file: the scene, the factors and their levels, replications, horizon, warm-up, baseline.

``load_experiment`` reads and checks one (docs/experiments.md, "Experiments"); every error is one line
naming the field and the file. The scenarios are the full factorial of the factors' levels; each level is
checked as the node checks the parameter, and the scene's random inputs (seed, arrivals, faults) may be
replaced by the experiment's.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from feeder_cell.experiment.arrivals import arrivals_from_mapping, scene_seed
from feeder_cell.experiment.cell_scene import (
    CONTROLLER_SPECS,
    DEVICES,
    PARAMETER_CLASSES,
    check_scene,
    controller_parameters,
    device_parameters,
)
from feeder_cell.experiment.faults_process import faults_from_mapping
from feeder_cell.experiment.results import QUANTUM
from feeder_planner.errors import InputError
from feeder_planner.fields_io import load_yaml_mapping
from feeder_planner.parameter_specs import specs_of

__all__ = ["MAX_REPLICATIONS", "MAX_SCENARIOS", "Scenario", "Experiment", "load_experiment", "scene_of"]

MAX_REPLICATIONS = 100_000
MAX_SCENARIOS = 1_000
MAX_CYCLES = 1_000_000
MAX_HORIZON_TIME = 365 * 24 * 3600.0  # s: a year of cell time
FIELDS = ("scene", "factors", "replications", "horizon", "warmup", "baseline", "seed", "arrivals", "faults")


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
    scene = scene_of(scene_document, scene_path)
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


def scene_of(document: dict[str, Any], scene_path: Path) -> Any:
    """Parse and check the scene document (with the experiment's inputs) as the loop reads scenes."""
    from feeder_cell.launcher import scene_from_mapping

    return check_scene(scene_from_mapping(document, scene_path.parent))


def _check_level(executable: str, parameter: str, level: Any, scene: Any, where: str) -> None:
    """Check one level as the node would check its parameter; raise naming the level."""
    values = next(dict(n.parameters) for n in scene.nodes if n.executable == executable)
    values[parameter] = level
    try:
        if executable in DEVICES:
            device_parameters(PARAMETER_CLASSES[executable], values, executable)
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
