"""MEMS field array benchmarks: the ideal model's cost in the cell scene, exact integrals vs sampling,
equilibria timing, array speed, fidelity.

``python bench/bench_mems.py --orient [--profile]`` runs only the ideal model's cost (and profiles one
run with cProfile).
"""

from __future__ import annotations

import math
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
for sub in ("feeder_planner", "feeder_sim"):
    if str(ROOT / sub) not in sys.path:
        sys.path.insert(0, str(ROOT / sub))

import numpy as np  # noqa: E402
from benchlib import median_time, row  # noqa: E402

from feeder_planner.mems.equilibria import find_equilibria  # noqa: E402
from feeder_planner.mems.fields import CombinedField, ProgramStep  # noqa: E402
from feeder_planner.parts import load_part, make_part  # noqa: E402
from feeder_sim.mems.scene import Body, Scene, random_poses  # noqa: E402


def washer():
    return make_part([[0, 0], [5, 0], [5, 2], [3, 2], [3, 4], [0, 4]], [[[1, 1], [2, 1], [2, 3], [1, 3]]])


def star(n: int, fold: int):
    t = 2 * math.pi * np.arange(n) / n
    r = (
        1 + 0.3 * np.cos(fold * t) + 0.05 * np.sin(2 * fold * t)
        if fold
        else 1 + 0.3 * np.sin(3 * t) + 0.1 * np.cos(5 * t)
    )
    return make_part(np.c_[r * np.cos(t), r * np.sin(t)].tolist())


def bracket(scale: float):
    return make_part([[0, 0], [4, 0], [4, 1], [1, 1], [1, 3], [0, 3]], unit_scale=scale)


def exact_vs_sampling(quick: bool) -> list[dict]:
    """Time of the exact wrench vs the coarsest cell-centred sampling reaching 1e-4 relative error."""
    from matplotlib.path import Path as MplPath

    part, field = washer(), CombinedField(0.3, (0.7, -0.4))
    pose = (0.3, -0.2, 0.6)
    loops = part.placed(*pose)
    about = np.array(pose[:2])
    exact = field.wrench(loops, about)
    t_exact = median_time(lambda: field.wrench(loops, about), 200 if quick else 1000)
    lo, hi = np.vstack(loops).min(0), np.vstack(loops).max(0)

    def sampled(n: int) -> np.ndarray:
        h = (hi - lo) / n
        xs = lo[0] + h[0] * (np.arange(n) + 0.5)
        ys = lo[1] + h[1] * (np.arange(n) + 0.5)
        gx, gy = np.meshgrid(xs, ys)
        pts = np.column_stack([gx.ravel(), gy.ravel()])
        inside = MplPath(loops[0]).contains_points(pts) & ~MplPath(loops[1]).contains_points(pts)
        f = field.force_density(pts[inside]) * h[0] * h[1]
        r = pts[inside] - about
        return np.array([f[:, 0].sum(), f[:, 1].sum(), (r[:, 0] * f[:, 1] - r[:, 1] * f[:, 0]).sum()])

    scale = np.abs(exact).max()
    n, err = 25, 1.0
    while n <= 6400:
        err = np.abs(sampled(n) - exact).max() / scale
        if err <= 1e-4:
            break
        n *= 2
    t_sample = median_time(lambda: sampled(n), 1 if quick else 3)
    ratio = t_sample / t_exact
    return [
        row(
            "exact wrench (washer, combined field)",
            "time per wrench",
            t_exact * 1e6,
            "us",
            "-",
            "rel. error <= 1e-12 (boundary integrals)",
            True,
        ),
        row(
            "exact vs dense sampling",
            "speed-up at sampling error 1e-4",
            ratio,
            "x",
            ">= 100x",
            f"cell-centred sampling {n}x{n} (error {err:.1e}; exact is 1e-12 more accurate)",
            ratio >= 100,
        ),
    ]


def equilibria_timing(quick: bool) -> list[dict]:
    rows = []
    repeats = 5 if quick else 15
    for label, part in (
        ("64-vertex non-symmetric", star(64, 0)),
        ("64-vertex 4-fold symmetric", star(64, 4)),
    ):
        for method, target in (("numeric", 0.050), ("asymptotic", 0.010)):
            find_equilibria(part, 1e-3, method)
            t = median_time(lambda part=part, method=method: find_equilibria(part, 1e-3, method), repeats)
            rows.append(
                row(
                    f"all equilibria, {label}",
                    f"{method} method, delta 1e-3",
                    t * 1e3,
                    "ms",
                    f"< {target * 1e3:.0f} ms",
                    "median wall time",
                    t < target,
                )
            )
    return rows


def array_speed(quick: bool) -> list[dict]:
    """Steps per second of the `array` model (edge integrals of prefix-summed cell forces) and, in the same
    run, of the same model summing every covered cell's exact area and moments (the previous method)."""
    rows = []
    for scale, label in (
        (0.5e-3, "2 mm part (about 20x15 cells covered)"),
        (1e-3, "4 mm part (about 40x30 cells)"),
    ):
        part = bracket(scale)
        rates = {}
        for method in ("edges", "cells"):
            scene = Scene(
                [Body(part, np.array([1e-4, -2e-4, 0.4]))],
                (ProgramStep(CombinedField(0.3), math.inf),),
                "array",
                array=(100, 100, 1e-4),
            )
            if method == "cells":
                scene.forces.wrench = scene.forces.wrench_by_cells
            steps = (200 if quick else 1000) // (1 if method == "edges" else 4)
            scene.run(steps * 1e-4 / 10, 1e-4)
            t = median_time(
                lambda scene=scene, steps=steps: [scene.step(1e-4) for _ in range(steps)], 3 if quick else 5
            )
            rates[method] = steps / t
        rate = rates["edges"]
        rows.append(
            row(
                f"array model 100x100 cells, {label}",
                "simulation steps per second",
                rate,
                "steps/s",
                ">= 1000",
                f"one part, forward Euler, exact covered areas; cell-by-cell sum "
                f"{rates['cells']:.0f} steps/s in this run ({rate / rates['cells']:.1f}x)",
                rate >= 1000,
            )
        )
    return rows


# The cell scene's array (feeder_cell/scenes/cell.yaml): the plus at the node's random placement for seed 7
# in a 1 mm disc, the cell controller's default program (one combined field, delta 0.2, forever), the
# default drag and the scene's 2.5e-3 s time_step, which the node steps in whole.
CELL_PART = ROOT / "examples" / "mems" / "plus.yaml"
CELL_SEED, CELL_RADIUS, CELL_DELTA, CELL_TIME_STEP = 7, 1e-3, 0.2, 2.5e-3
# Long enough to orient (the plus settles in about 15 s; it rests only after about 23 s, so every second
# of it is integrated): what the node costs while the cell waits on the array.
CELL_DURATION = 15.0


def cell_scene() -> Scene:
    """Return the cell scene's array as its node configures it: one plus, ideal fidelity."""
    start = random_poses(1, CELL_RADIUS, CELL_SEED)[0]
    program = (ProgramStep(CombinedField(CELL_DELTA), math.inf),)
    return Scene([Body(load_part(CELL_PART), start)], program, "ideal")


def orient_cost(duration: float) -> tuple[float, Scene]:
    """Return the CPU seconds of orienting the cell scene's plus for ``duration`` s, and the scene.

    CPU time of this process, not wall time: the others' load on the shared cores does not count.
    """
    scene = cell_scene()
    steps = int(round(duration / CELL_TIME_STEP))
    start = time.process_time()
    for _ in range(steps):
        scene.step(CELL_TIME_STEP)
    return time.process_time() - start, scene


def ideal_orient_cost(quick: bool) -> list[dict]:
    """CPU s per simulated s of the ideal model orienting the cell scene's plus (median of repeats)."""
    # The whole 15 s even when quick (a fifth of a CPU second a run): a shorter run is mostly the first
    # second's transient, whose shorter steps would not be the figure the target is about.
    duration = CELL_DURATION
    runs = [orient_cost(duration) for _ in range(3 if quick else 5)]
    cost = statistics.median(cpu for cpu, _ in runs) / duration
    stepper = runs[-1][1].stepper
    return [
        row(
            "ideal model, cell scene's plus orienting (delta 0.2, time_step 2.5e-3 s)",
            "CPU s per simulated s",
            cost,
            "CPU s/s",
            "<= 0.01",
            f"{duration:g} s simulated, median of {len(runs)}; {stepper.evaluations / duration:.0f} "
            f"evaluations and {stepper.substeps / duration:.0f} Heun steps per simulated s",
            cost <= 0.01,
        )
    ]


def fidelity_trade(out_dir: Path, quick: bool) -> list[dict]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    part = bracket(1e-3)
    delta = 0.3
    target = find_equilibria(part, delta, "numeric").stable[0]
    start = np.array([target.x + 3e-4, target.y - 2e-4, target.theta + 0.5])
    duration = 1.5 if quick else 3.0
    runs = [("ideal", {}, dt) for dt in ((5e-4,) if quick else (1e-3, 5e-4, 2.5e-4))]
    pitches = (4e-4, 2e-4, 1e-4) if quick else (4e-4, 2e-4, 1e-4, 5e-5)
    runs += [("array", {"array": (int(round(0.01 / p)), int(round(0.01 / p)), p)}, 5e-4) for p in pitches]
    runs += [("dynamic", {}, 1e-3)]
    points, rows = [], []
    for fidelity, kw, dt in runs:
        scene = Scene(
            [Body(part, start.copy())], (ProgramStep(CombinedField(delta), math.inf),), fidelity, **kw
        )
        t0 = time.perf_counter()
        scene.run(duration, dt)
        cost = (time.perf_counter() - t0) / duration
        pose = scene.bodies[0].pose
        error = (
            abs(math.remainder(pose[2] - target.theta, 2 * math.pi))
            + math.hypot(pose[0] - target.x, pose[1] - target.y) / part.radius
        )
        label = fidelity if fidelity != "array" else f"array pitch {kw['array'][2] * 1e6:.0f} um"
        if fidelity == "ideal":
            label += f" dt {dt:g}"
        points.append((label, cost, error))
        rows.append(
            row(
                "fidelity trade (4 mm bracket, delta 0.3)",
                f"{label}: final pose error",
                error,
                "rad + pos/radius",
                "-",
                f"cost {cost:.3g} s wall per simulated s; reference: planner",
                True,
            )
        )
    fig, ax = plt.subplots(figsize=(6, 4))
    for label, cost, error in points:
        ax.loglog(cost, max(error, 1e-16), "o")
        ax.annotate(label, (cost, max(error, 1e-16)), fontsize=7)
    ax.set_xlabel("wall seconds per simulated second")
    ax.set_ylabel("final pose error vs planned equilibrium")
    ax.set_title("MEMS array fidelity: accuracy vs cost")
    fig.tight_layout()
    fig.savefig(out_dir / "mems_fidelity_trade.png", dpi=120)
    plt.close(fig)
    return rows


def run(out_dir: Path, quick: bool) -> list[dict]:
    """All MEMS benchmark rows (see module docstring); plots go to out_dir."""
    out_dir.mkdir(parents=True, exist_ok=True)
    return (
        ideal_orient_cost(quick)
        + exact_vs_sampling(quick)
        + equilibria_timing(quick)
        + array_speed(quick)
        + fidelity_trade(out_dir, quick)
    )


def profile_orient(duration: float) -> None:
    """Print the cProfile of one orienting run, the 25 most expensive functions by their own time."""
    import cProfile
    import pstats

    profiler = cProfile.Profile()
    profiler.runcall(orient_cost, duration)
    pstats.Stats(profiler).sort_stats("tottime").print_stats(25)


if __name__ == "__main__":
    import json

    quick = "--full" not in sys.argv
    if "--profile" in sys.argv:
        profile_orient(CELL_DURATION)
    rows = ideal_orient_cost(quick) if "--orient" in sys.argv else run(Path("/tmp/bench_mems"), quick)
    for r in rows:
        print(json.dumps(r))
