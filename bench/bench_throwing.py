"""Throwing-arm benchmarks: analytic throw-map throughput, limit-set time, analytic vs dynamic (pymunk)."""

from __future__ import annotations

import importlib
import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
from benchlib import median_time

from feeder_planner.parts import load_part, make_part
from feeder_planner.throwing.geometry import arm_part
from feeder_planner.throwing.limit_set import edge_bounds, iterate, limit_set
from feeder_planner.throwing.throw_map import ThrowParams, throw, throw_batch

ROOT = Path(__file__).resolve().parents[1]
# The corpus row: long runs of this many throws from this many starts per stable edge, and limit_set
# with the same cap and grid (its window the default); tests/throwing/test_limit_truth.py runs a subset.
CORPUS_THROWS = 2000
CORPUS_STARTS = 2
EXAMPLES = ROOT / "examples" / "throwing"
TRIANGLE = ThrowParams(-0.005, math.radians(320), -9.66, 0.5)
BRACKET = ThrowParams(-0.0025, math.radians(320), -2.20, 0.5)
# The commit whose attractors.py and limit_set.py hold the previous convergence rule (the grid-cell
# recurrence that issue 25 replaced): the examples' limit sets are timed with both rules in one run.
RULE_BEFORE = "654331da32ef42c8780b82d91149452814df10db"
# The examples with the designs their files and docs/throwing.md name (SI), and the goal edge.
EXAMPLE_DESIGNS = {
    "triangle": (TRIANGLE, 1),
    "bracket": (BRACKET, 0),
    "bracket5": (ThrowParams(-0.0025, math.radians(105), -2.20, 0.5), 4),
    "convex12": (ThrowParams(-0.0003, math.radians(320), -9.66, 0.5), 3),
    "transient5": (ThrowParams(-0.00082, math.radians(106), -2.20, 0.41), 2),
}


def _decagon():
    """An irregular 10-vertex convex part (all edges stable), about 5 cm across."""
    angles = np.linspace(0, 2 * math.pi, 10, endpoint=False) + 0.15 * np.sin(np.arange(10))
    radii = 0.025 * (1 + 0.04 * np.cos(3 * np.arange(10)))
    return arm_part(make_part(np.c_[radii * np.cos(angles), radii * np.sin(angles)].tolist()))


def run(out_dir: Path, quick: bool) -> list[dict]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows: list[dict] = []
    repeats = 3 if quick else 7
    part = _decagon()
    assert part.n == 10, part.n
    p = ThrowParams(-0.3 * part.d_min, 4.0, -9.81, 0.8)
    b = edge_bounds(part, p, points=100)
    rng = np.random.default_rng(0)
    n = 2000
    edges = rng.choice(part.stable_edges, n)
    radii = np.array([rng.uniform(b.low[e], b.max[e]) for e in edges])
    t_batch = median_time(lambda: throw_batch(part, edges, radii, p), repeats)
    m = 100 if quick else 300
    t_scalar = (
        median_time(
            lambda: [throw(part, int(e), float(r), p) for e, r in zip(edges[:m], radii[:m], strict=True)],
            repeats,
        )
        / m
    )
    rate = n / t_batch
    rows.append(
        {
            "benchmark": "throwing: analytic throw map (10-vertex part, batched)",
            "measure": "throughput",
            "value": rate,
            "unit": "throws/s",
            "target": ">= 10000 throws/s",
            "baseline": f"one throw per call: {1 / t_scalar:.0f} throws/s ({rate * t_scalar:.1f}x slower)",
            "met": rate >= 10000,
        }
    )

    tri = arm_part(load_part(EXAMPLES / "triangle.yaml"))
    t_limit = median_time(
        lambda: limit_set(tri, TRIANGLE, goal_edge=1, starts_per_edge=34, throws=300), repeats
    )
    rows.append(
        {
            "benchmark": "throwing: limit set, 102 starts x 300 throws (triangle, with R_max and trigger)",
            "measure": "wall time",
            "value": t_limit,
            "unit": "s",
            "target": "< 5 s",
            "baseline": "-",
            "met": t_limit < 5.0,
        }
    )

    # analytic vs dynamic, against the pymunk step size
    from feeder_sim.throwing.dynamic import dynamic_throw

    steps = [1e-3, 5e-4, 2e-4] if quick else [2e-3, 1e-3, 5e-4, 2e-4, 1e-4]
    per_edge = 3 if quick else 8
    starts = []
    bounds = edge_bounds(tri, TRIANGLE)
    for e in tri.stable_edges:
        starts += [(e, float(r)) for r in np.linspace(bounds.low[e] + 0.01, bounds.max[e], per_edge)]
    ana = [throw(tri, e, r, TRIANGLE) for e, r in starts]
    t_ana = median_time(lambda: [throw(tri, e, r, TRIANGLE) for e, r in starts], repeats) / len(starts)
    agree_rates, errors, ratios = [], [], []
    for step in steps:
        t = time.perf_counter()
        dyn = [dynamic_throw(tri, TRIANGLE, e, r, step=step) for e, r in starts]
        t_dyn = (time.perf_counter() - t) / len(starts)
        same = [(a, d) for a, d in zip(ana, dyn, strict=True) if d.kind == a.kind and d.edge_after == a.edge]
        agree_rates.append(len(same) / len(starts))
        errors.append(
            float(np.median([abs(d.radius_after - a.radius) for a, d in same]) / tri.radius)
            if same
            else math.nan
        )
        ratios.append(t_dyn / t_ana)
        rows.append(
            {
                "benchmark": f"throwing: dynamic vs analytic, pymunk step {step:g} s",
                "measure": "agreement on (edge, jog/flip)",
                "value": agree_rates[-1],
                "unit": "fraction",
                "target": ">= 0.8",
                "baseline": (
                    f"analytic model; median |dR| = {errors[-1]:.3f} part radii; "
                    f"dynamic {ratios[-1]:.0f}x slower"
                ),
                "met": agree_rates[-1] >= 0.8,
            }
        )
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.5))
    for ax, values, label in zip(
        axes,
        (agree_rates, errors, ratios),
        (
            "agreement (edge, jog/flip)",
            "median |R_dyn - R_ana| / part radius",
            "time per throw, dynamic / analytic",
        ),
        strict=True,
    ):
        ax.semilogx(steps, values, "o-")
        ax.set_xlabel("pymunk step (s)")
        ax.set_title(label, fontsize=9)
    fig.tight_layout()
    fig.savefig(out_dir / "throwing_fidelity_vs_step.png", dpi=110)
    plt.close(fig)

    before = _previous_rule()
    rows += _design_rows(tri, quick, before)
    rows += _rule_rows(quick, before)
    rows += _truth_rows(quick, before)

    # Figs. 7 / 8: convergence of a grid of starts to one cycle
    for name, params, throws in (("triangle", TRIANGLE, 150), ("bracket", BRACKET, 150)):
        pa = arm_part(load_part(EXAMPLES / f"{name}.yaml"))
        bb = edge_bounds(pa, params)
        es, rs = [], []
        for e in pa.stable_edges:
            es += [e] * 6
            rs += list(np.linspace(bb.low[e], bb.max[e], 8)[1:-1])
        traj = iterate(pa, params, np.array(es), np.array(rs), throws)
        fig, ax = plt.subplots(figsize=(7, 4))
        for e in pa.stable_edges:
            mask = traj.edge == e
            ax.scatter(np.nonzero(mask)[1], traj.radius[mask] * 100, s=3, label=f"edge {e}")
        ax.set_xlabel("throw")
        ax.set_ylabel("R (cm)")
        ax.set_title(
            f"{name}: {len(es)} starts converge to one cycle "
            f"(cf. paper Fig. {7 if name == 'triangle' else 8})"
        )
        ax.legend(markerscale=4, fontsize=8)
        fig.tight_layout()
        fig.savefig(out_dir / f"throwing_limit_set_{name}.png", dpi=110)
        plt.close(fig)
    return rows


def _design_rows(tri, quick: bool, before: tuple[object, object] | None = None) -> list[dict]:
    """Issue 14 item 5: the batched 20 x 20 design search against the per-design loop, robust throughput."""
    from feeder_planner.throwing.design import search, search_loop
    from feeder_planner.throwing.studies import robust_study

    out: list[dict] = []
    offsets = np.linspace(-0.008, -0.001, 20)
    speeds = np.radians(np.linspace(250, 400, 20))
    t0 = time.perf_counter()
    batched = search(tri, 1, offsets, speeds, TRIANGLE.gravity, TRIANGLE.mu)
    t_batched = time.perf_counter() - t0
    # Today's loop (one limit set per design) on a 5 x 5 corner of the grid, per design, in the same run.
    sub_h, sub_w = offsets[::4], speeds[::4]
    t0 = time.perf_counter()
    search_loop(tri, 1, sub_h, sub_w, TRIANGLE.gravity, TRIANGLE.mu)
    per_design = (time.perf_counter() - t0) / (len(sub_h) * len(sub_w))
    unique = sum(r.unique for r in batched.designs)
    previous = ""
    if before is not None:
        # The same batched search with the previous convergence rule (issue 25), in the same run.
        t0 = time.perf_counter()
        old = before[1].search(tri, 1, offsets, speeds, TRIANGLE.gravity, TRIANGLE.mu)  # type: ignore[attr-defined]
        previous = (
            f"; previous rule: batched {time.perf_counter() - t0:.1f} s, "
            f"{sum(r.unique for r in old.designs)}/400 unique"
        )
    out.append(
        {
            "benchmark": "throwing: throw-design 20 x 20 (h, W) grid, triangle, batched",
            "measure": "wall time",
            "value": t_batched,
            "unit": "s",
            "target": "< 10 s",
            "baseline": (
                f"per-design loop: {per_design:.2f} s a design (5 x 5 sample), {400 * per_design:.0f} s for "
                f"400 ({400 * per_design / t_batched:.0f}x slower); {unique}/400 designs unique{previous}"
            ),
            "met": t_batched < 10.0,
        }
    )
    samples = 4 if quick else 10
    # Eight grid points (tasks) so that two workers have work to share; start-up is reported apart.
    grid = (np.array([-0.007, -0.005, -0.003, -0.001]), np.radians([300.0, 340.0]))
    rates, startup = {}, {}
    for workers in (1, 2):
        study = robust_study(
            tri, 1, *grid, TRIANGLE.gravity, TRIANGLE.mu, samples, 0.03, 0.03, 0.03, seed=0, workers=workers
        )
        rates[workers] = len(study.points) * samples / study.seconds
        startup[workers] = study.startup
    for workers in (1, 2):
        out.append(
            {
                "benchmark": f"throwing: robust study (8 grid points x {samples} perturbed designs), "
                + (f"{workers} Dask workers (LocalCluster)" if workers > 1 else "one process"),
                "measure": "throughput",
                "value": rates[workers],
                "unit": "limit sets/s",
                "target": "reported",
                "baseline": (
                    f"one process {rates[1]:.1f}/s; cluster start-up {startup[workers]:.1f} s not counted"
                    if workers > 1
                    else "-"
                ),
                "met": True,
            }
        )
    return out


def _previous_rule() -> tuple[object, object] | None:
    """Return the previous rule's limit_set and design modules, loaded from git (None: no git history).

    attractors.py, limit_set.py and design.py of RULE_BEFORE are written to a temporary package
    ``throwing_before`` whose modules import each other instead of today's; everything else they use
    (the throw map, the sensor, the tolerances) is today's, so only the rule differs.
    """
    folder = Path(tempfile.mkdtemp(prefix="rule_before_"))
    package = folder / "throwing_before"
    package.mkdir()
    (package / "__init__.py").write_text("")
    for name in ("attractors", "limit_set", "design"):
        shown = subprocess.run(
            [
                "git",
                "-C",
                str(ROOT),
                "show",
                f"{RULE_BEFORE}:feeder_planner/feeder_planner/throwing/{name}.py",
            ],
            capture_output=True,
            text=True,
        )
        if shown.returncode:
            return None
        text = shown.stdout
        for other in ("attractors", "limit_set"):
            text = text.replace(f"feeder_planner.throwing.{other}", f"throwing_before.{other}")
        (package / f"{name}.py").write_text(text)
    sys.path.insert(0, str(folder))
    return importlib.import_module("throwing_before.limit_set"), importlib.import_module(
        "throwing_before.design"
    )


def _rule_rows(quick: bool, before: tuple[object, object] | None) -> list[dict]:
    """Issue 25 item 4: limit-set with the defaults on the examples, today's rule against the previous one.

    CPU time of this process (the machine is shared), the best of two alternating runs per rule.
    """
    if before is None:
        return [
            {
                "benchmark": "throwing: limit-set defaults on the examples, rule of issue 25 vs the previous",
                "measure": "time ratio",
                "value": math.nan,
                "unit": "x",
                "target": "<= 2",
                "baseline": f"not measured: no git history with {RULE_BEFORE[:10]}",
                "met": False,
            }
        ]
    old_limit_set = before[0].limit_set  # type: ignore[attr-defined]
    times: dict[str, tuple[float, float, int, int]] = {}
    for name, (params, goal) in EXAMPLE_DESIGNS.items():
        part = arm_part(load_part(EXAMPLES / f"{name}.yaml"))
        best = {"new": math.inf, "old": math.inf}
        used = {"new": 0, "old": 0}
        for _ in range(1 if quick else 2):
            for label, function in (("old", old_limit_set), ("new", limit_set)):
                start = time.process_time()
                result = function(part, params, goal_edge=goal)
                best[label] = min(best[label], time.process_time() - start)
                used[label] = result.throws_used
        times[name] = (best["old"], best["new"], used["old"], used["new"])
    worst = max(new / old for old, new, _, _ in times.values())
    total_old = sum(t[0] for t in times.values())
    total_new = sum(t[1] for t in times.values())
    return [
        {
            "benchmark": "throwing: limit-set defaults on the examples, rule of issue 25 vs the previous",
            "measure": "worst time ratio (CPU)",
            "value": worst,
            "unit": "x",
            "target": "<= 2",
            "baseline": "; ".join(
                f"{name} {old:.2f} -> {new:.2f} s ({used_old} -> {used_new} throws)"
                for name, (old, new, used_old, used_new) in times.items()
            )
            + f"; all {total_old:.1f} -> {total_new:.1f} s",
            "met": worst <= 2.0,
        }
    ]


def _truth_rows(quick: bool, before: tuple[object, object] | None = None) -> list[dict]:
    """Issue 25 item 3: limit_set against long plain iteration on the seeded corpus (tests/throwing).

    The previous rule's limit_set is judged on the same designs and truths, as the baseline.
    """
    sys.path.insert(0, str(ROOT / "tests" / "throwing"))
    from truth_corpus import CORPUS_PARTS, QUICK_PARTS

    parts = QUICK_PARTS if quick else CORPUS_PARTS
    previous = None if before is None else before[0].limit_set  # type: ignore[attr-defined]
    return _corpus_rows(_corpus_report(0, parts, previous), parts, previous is not None)


def _corpus_report(first: int, end: int, previous: Any = None, progress: bool = False) -> Any:
    """Return truth_corpus's report on corpus parts ``first``..``end`` - 1 at the row's settings."""
    sys.path.insert(0, str(ROOT / "tests" / "throwing"))
    from truth_corpus import corpus_designs, evaluate

    designs = [d for k in range(first, end) for d in corpus_designs(k)]
    return evaluate(designs, CORPUS_THROWS, CORPUS_STARTS, baseline=previous, progress=progress)


def _corpus_rows(report: Any, parts: int, with_previous: bool) -> list[dict]:
    """Return the corpus rows of ``report`` (over ``parts`` parts): edges and cycles, ranges, triggers."""
    share = report.agree / report.unambiguous if report.unambiguous else math.nan
    was = f"; previous rule: {report.baseline_agree} of {report.unambiguous} agree" if with_previous else ""
    return [
        {
            "benchmark": f"throwing: limit set vs long iteration, seeded corpus ({parts} parts)",
            "measure": "agreement on unambiguous designs",
            "value": share,
            "unit": "fraction",
            "target": "1.0",
            "baseline": report.figure() + was + "".join(f" | {m}" for m in (report.mismatches or [])[:5]),
            "met": share == 1.0,
        },
        # Issue 35: on the designs whose attractors agree, every attractor's radius range and every goal
        # edge's trigger range (as limit_set reads it) against the long runs' last halves
        # (truth_corpus.compare_ranges: within RANGE_GAPS mean gaps of the members' recent quarters), next
        # to the agreement on edges and cycles; the full corpus without --quick (80 parts).
        *(
            {
                "benchmark": f"throwing: limit set vs long iteration, seeded corpus ({parts} parts)",
                "measure": f"agreement on {what} (designs agreeing on edges and cycles)",
                "value": count / report.agree if report.agree else math.nan,
                "unit": "fraction",
                "target": "1.0",
                "baseline": f"{count} of {report.agree}; {report.unsafe_triggers} trigger(s) reaching beyond "
                f"the long runs'; distances from theirs: {report.distances()}"
                + "".join(f" | {m}" for m in (report.range_mismatches or [])[:5]),
                "met": count == report.agree,
            }
            for what, count in (
                ("radius ranges", report.ranges_agree),
                ("trigger ranges", report.triggers_agree),
            )
        ),
    ]


def _corpus_main(args: list[str]) -> None:
    """The corpus rows in pieces, for a machine where the whole corpus is too long for one process.

    ``--corpus FIRST:END OUT.json``: judge parts FIRST..END-1 (no previous rule), print each design's
    verdict and save the report; ``--corpus-rows PARTS A.json B.json ...``: merge the saved reports of
    disjoint parts and print the rows, as the full run's.
    """
    import dataclasses
    import json

    sys.path.insert(0, str(ROOT / "tests" / "throwing"))
    from truth_corpus import CorpusReport

    if args[0] == "--corpus":
        first, end = (int(v) for v in args[1].split(":"))
        report = _corpus_report(first, end, progress=True)
        Path(args[2]).write_text(json.dumps(dataclasses.asdict(report)))
        print(report.figure())
        print(report.distances())
        return
    merged = CorpusReport.merged([CorpusReport(**json.loads(Path(f).read_text())) for f in args[2:]])
    for row in _corpus_rows(merged, int(args[1]), False):
        print(row)
    print(merged.distances())
    print("\n".join(merged.range_mismatches or []))


if __name__ == "__main__":
    import sys

    if sys.argv[1:2] in (["--corpus"], ["--corpus-rows"]):
        _corpus_main(sys.argv[1:])
        sys.exit(0)
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("/tmp/bench_throwing")
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.time()
    for row in run(out, quick="--full" not in sys.argv):
        print(row)
    print(f"{time.time() - t0:.1f} s")
