"""Robustness studies of throwing-arm designs, in one process or on a Dask cluster (issue 14 item 5).

For every (h, W) of a grid, N perturbed designs are drawn (h, W and mu each scaled by 1 + sigma z with
z standard normal, from one seeded generator, grid point by grid point) and evaluated with the batched
design search (``design.evaluate``). A grid point reports the probability that a perturbed design still
has a unique limit set and that it still has an open trigger range for the goal edge. Every grid point
is one task; a task's result depends only on its designs, so the single-process run and any cluster
run give the same numbers for the same seed.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from feeder_planner.dask_cluster import MAX_WORKERS, dask_client
from feeder_planner.errors import InputError
from feeder_planner.throwing.design import Design, DesignRow, check_grid, evaluate
from feeder_planner.throwing.geometry import ArmPart
from feeder_planner.throwing.sensor import check_sensing_height

__all__ = ["RobustPoint", "RobustStudy", "perturbed_designs", "robust_study", "MAX_PERTURBED", "MAX_WORKERS"]

# Perturbed designs of one study at most: 10^5 limit sets take about an hour on two cores here.
MAX_PERTURBED = 100_000


@dataclass(frozen=True)
class RobustPoint:
    """One grid point of a robustness study: how often its perturbed designs keep their properties."""

    offset: float
    speed: float
    samples: int
    unique: float
    trigger: float
    invalid: int

    def to_json(self) -> dict[str, Any]:
        """Return one point of `feeder throw-design --robust --json` (SI)."""
        return {
            "offset": self.offset,
            "release_speed": self.speed,
            "samples": self.samples,
            "p_unique": self.unique,
            "p_trigger": self.trigger,
            "invalid": self.invalid,
        }


@dataclass(frozen=True)
class RobustStudy:
    """Every grid point of a study and the most robust one (highest p_trigger, then p_unique)."""

    goal_edge: int
    samples: int
    seed: int
    sigmas: dict[str, float]
    points: list[RobustPoint]
    workers: int
    seconds: float  # evaluating the designs (a cluster's start-up not included)
    startup: float = 0.0  # starting or connecting to the cluster (s)

    @property
    def best(self) -> RobustPoint | None:
        """Return the point with the highest probability of an open trigger range (None if all 0)."""
        good = [p for p in self.points if p.trigger > 0]
        return max(good, key=lambda p: (p.trigger, p.unique)) if good else None

    def to_json(self) -> dict[str, Any]:
        """Return the `feeder throw-design --robust --json` object."""
        best = self.best
        return {
            "goal_edge": self.goal_edge,
            "samples": self.samples,
            "seed": self.seed,
            "sigmas": self.sigmas,
            "points": [p.to_json() for p in self.points],
            "best": None if best is None else best.to_json(),
            "workers": self.workers,
            "limit_sets_per_second": len(self.points) * self.samples / self.seconds if self.seconds else None,
            "startup_seconds": self.startup,
        }


def _check_sigma(name: str, value: float) -> float:
    """Return a relative sigma if it is finite and in [0, 1), else raise InputError naming it."""
    if not math.isfinite(value) or not 0 <= value < 1:
        raise InputError(name, f"must be a relative standard deviation in [0, 1), got {value!r}")
    return value


def perturbed_designs(
    offsets: np.ndarray,
    speeds: np.ndarray,
    mu: float,
    samples: int,
    sigmas: tuple[float, float, float],
    seed: int,
) -> list[list[Design]]:
    """Return per grid point (offset-major) its ``samples`` perturbed designs, from one seeded generator.

    ``sigmas`` = (offset, speed, mu), each relative: a value v becomes v (1 + sigma z), z ~ N(0, 1).
    """
    rng = np.random.default_rng(seed)
    s_h, s_w, s_mu = sigmas
    out = []
    for h in offsets:
        for w in speeds:
            z = rng.standard_normal((samples, 3))
            out.append(
                [
                    Design(float(h) * (1 + s_h * a), float(w) * (1 + s_w * b), float(mu) * (1 + s_mu * c))
                    for a, b, c in z
                ]
            )
    return out


def _valid(part: ArmPart, design: Design) -> bool:
    """Return whether a perturbed design is one the model takes (W > 0, mu > 0, h > -d_min)."""
    return design.speed > 0 and design.mu > 0 and design.offset > -part.d_min


def evaluate_point(
    part: ArmPart,
    goal_edge: int,
    designs: list[Design],
    gravity: float,
    sensing_height: float | None,
) -> tuple[int, int, int]:
    """Return (designs with a unique limit set, with an open trigger range, invalid) of one grid point.

    The task a worker runs; a perturbation outside the model's domain counts as neither.
    """
    valid = [d for d in designs if _valid(part, d)]
    rows: list[DesignRow] = evaluate(part, goal_edge, valid, gravity, sensing_height) if valid else []
    unique = sum(1 for r in rows if r.unique)
    trigger = sum(1 for r in rows if r.unique and r.trigger is not None)
    return unique, trigger, len(designs) - len(valid)


def robust_study(
    part: ArmPart,
    goal_edge: int,
    offsets: np.ndarray,
    speeds: np.ndarray,
    gravity: float,
    mu: float,
    samples: int,
    speed_sigma: float,
    offset_sigma: float,
    mu_sigma: float,
    seed: int = 0,
    sensing_height: float | None = None,
    workers: int = 1,
    scheduler: str | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> RobustStudy:
    """Return the robustness study of a (h, W) grid: per point, P(unique) and P(open trigger range).

    ``workers`` 1 and no ``scheduler``: in this process. Otherwise on Dask: a LocalCluster of
    ``workers`` single-threaded worker processes, or the existing cluster at ``scheduler``. The
    result is the same either way for the same ``seed`` (every point is one task).
    """
    check_grid(part, goal_edge, offsets, speeds)
    if samples < 1:
        raise InputError("robust", f"must be >= 1 perturbed designs per grid point, got {samples}")
    total = samples * len(offsets) * len(speeds)
    if total > MAX_PERTURBED:
        raise InputError("robust", f"{total} perturbed designs; one study takes at most {MAX_PERTURBED}")
    if not 1 <= workers <= MAX_WORKERS:
        raise InputError("workers", f"must be in 1..{MAX_WORKERS}, got {workers}")
    if sensing_height is not None:
        check_sensing_height(sensing_height)
    sigmas = (
        _check_sigma("offset_sigma", offset_sigma),
        _check_sigma("speed_sigma", speed_sigma),
        _check_sigma("mu_sigma", mu_sigma),
    )
    tasks = perturbed_designs(offsets, speeds, mu, samples, sigmas, seed)
    startup = 0.0
    if workers == 1 and scheduler is None:
        start = time.perf_counter()
        counts = []
        for designs in tasks:
            counts.append(evaluate_point(part, goal_edge, designs, gravity, sensing_height))
            if progress is not None:
                progress(len(counts), len(tasks))
        seconds = time.perf_counter() - start
    else:
        counts, startup, seconds = _on_dask(
            part, goal_edge, tasks, gravity, sensing_height, workers, scheduler, progress
        )
    grid = [(float(h), float(w)) for h in offsets for w in speeds]
    points = [
        RobustPoint(h, w, samples, u / samples, t / samples, bad)
        for (h, w), (u, t, bad) in zip(grid, counts, strict=True)
    ]
    return RobustStudy(
        goal_edge,
        samples,
        seed,
        {"offset": sigmas[0], "speed": sigmas[1], "mu": sigmas[2]},
        points,
        workers,
        seconds,
        startup,
    )


def _on_dask(
    part: ArmPart,
    goal_edge: int,
    tasks: list[list[Design]],
    gravity: float,
    sensing_height: float | None,
    workers: int,
    scheduler: str | None,
    progress: Callable[[int, int], None] | None,
) -> tuple[list[tuple[int, int, int]], float, float]:
    """Run every task on Dask: (results in task order, start-up s, compute s); the cluster always closes."""
    from dask.distributed import as_completed

    begin = time.perf_counter()
    with dask_client(workers, scheduler) as client:
        startup = time.perf_counter() - begin
        start = time.perf_counter()
        shared = client.scatter(part, broadcast=True)
        futures = [
            client.submit(evaluate_point, shared, goal_edge, designs, gravity, sensing_height, pure=False)
            for designs in tasks
        ]
        index = {f.key: k for k, f in enumerate(futures)}
        results: list[tuple[int, int, int] | None] = [None] * len(tasks)
        for done, future in enumerate(as_completed(futures), start=1):
            results[index[future.key]] = future.result()
            if progress is not None:
                progress(done, len(tasks))
        return [r for r in results if r is not None], startup, time.perf_counter() - start
