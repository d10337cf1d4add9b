"""Attractor summaries, progress, Ctrl-C and robustness studies for `feeder limit-set` / `throw-design`."""

from __future__ import annotations

import argparse
import sys
import time
from typing import Callable, TypeVar

import numpy as np

from feeder_cell.cli.common import emit, finite_float
from feeder_cell.cli.ctrl_c import check_ctrl_c
from feeder_cell.cli.main import EXIT_INTERRUPTED
from feeder_planner.errors import InputError
from feeder_planner.parts import Part
from feeder_planner.throwing.geometry import arm_part
from feeder_planner.throwing.limit_set import LimitSet
from feeder_planner.throwing.studies import RobustStudy, robust_study

__all__ = [
    "ATTRACTORS",
    "EXIT_INTERRUPTED",
    "PROGRESS_AFTER",
    "add_robust_flags",
    "attractor_lines",
    "growing_text",
    "run_with_progress",
    "run_robust",
]

ATTRACTORS = """Each start is thrown until its state recurs at the start grid's resolution (at most --throws
throws); starts whose recurrent sets meet form one attractor. --json adds "attractors": per attractor
its edges, edge_radius_ranges, periodic, cycle (one period, null when quasi-periodic), pattern (one
round as blocks: [edge, min visits, max visits]), throws_per_round [min, mean, max], basin (fraction
of starts), longest_transient (throws), assumption_violations (fraction of its throws with lift_off,
slip, off_arm). "unique": one attractor from every start; "cycle" only for a periodic unique one.
Exit 3 when no start recurs within --throws (the attractor search did not converge)."""

# Progress lines go to stderr only for work that has already taken this long (s).
PROGRESS_AFTER = 2.0

T = TypeVar("T")


def growing_text(result: LimitSet) -> str:
    """Return what a limit set says of the starts whose radius range still grew at the cap (issue 35)."""
    edges = ", ".join(str(e) for e in result.growing_edges)
    return (
        f"{len(result.growing)} start(s) still widened the radius range of edge(s) {edges} when the "
        f"{result.throws} throws ran out: those ranges would read too narrow, so they are in no attractor"
    )


def attractor_lines(result: LimitSet, unit: float) -> list[str]:
    """Return the summary lines of a limit set's attractors, lengths in file units."""
    lines = []
    if not result.converged:
        lines.append(
            f"attractor search: {result.unconverged} of {result.starts} starts did not recur within "
            f"{result.throws} throws (raise --throws)"
        )
    if result.growing:
        lines.append(f"  {growing_text(result)}")
    for k, a in enumerate(result.attractors):
        kind = f"periodic, cycle {a.cycle}" if a.periodic else "quasi-periodic"
        if a.pattern and not a.periodic:
            kind += ", round " + " ".join(
                f"{e}x{lo}" + (f"-{hi}" if hi != lo else "") for e, lo, hi in a.pattern
            )
        per = (
            ""
            if a.throws_per_round is None
            else f", {a.throws_per_round[1]:.1f} throws per round ({a.throws_per_round[0]}-"
            f"{a.throws_per_round[2]})"
        )
        lines.append(
            f"attractor {k}: edges {a.edges}, {kind}{per}; basin {a.basin:.3g} of the starts, "
            f"longest transient {a.longest_transient} throws"
        )
        ranges = ", ".join(
            f"{e}: [{lo / unit:.4g}, {hi / unit:.4g}]" for e, (lo, hi) in a.edge_radius_ranges.items()
        )
        lines.append(f"  R per edge (file units) {ranges}")
        v = a.violations
        lines.append(
            f"  throws breaking the model's assumptions: lift_off {v['lift_off']:.3g}, slip {v['slip']:.3g}, "
            f"off_arm {v['off_arm']:.3g}"
        )
    return lines


def run_with_progress(name: str, work: Callable[[Callable[[int, int], None]], T]) -> T | None:
    """Run ``work(progress)``; progress lines on stderr past PROGRESS_AFTER s; None after Ctrl-C.

    Ctrl-C ends the work at once with one line on stderr saying how far it got (no traceback).
    """
    start = time.monotonic()
    state = {"done": 0, "total": 0}

    def progress(done: int, total: int) -> None:
        state["done"], state["total"] = done, total
        check_ctrl_c()
        elapsed = time.monotonic() - start
        if elapsed >= PROGRESS_AFTER and done < total:
            sys.stderr.write(
                f"feeder {name}: {done} of {total} done ({elapsed:.0f} s; "
                f"about {elapsed * (total - done) / max(done, 1):.0f} s left)\n"
            )
            sys.stderr.flush()

    try:
        return work(progress)
    except KeyboardInterrupt:
        sys.stderr.write(
            f"feeder {name}: interrupted after {state['done']} of {state['total'] or '?'}; no result\n"
        )
        return None


def _nonnegative(text: str) -> float:
    """Argparse type: a finite number >= 0."""
    value = finite_float(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {text}")
    return value


def add_robust_flags(parser: argparse.ArgumentParser) -> None:
    """Add --robust N, the sigmas, --seed, --workers and --scheduler to `throw-design`."""
    parser.add_argument(
        "--robust",
        type=int,
        default=None,
        metavar="N",
        help="robustness study: N perturbed designs per grid point; reports P(unique) and P(trigger)",
    )
    for name, what in (("speed", "W"), ("offset", "H"), ("mu", "mu")):
        parser.add_argument(
            f"--{name}-sigma",
            type=_nonnegative,
            default=0.0,
            help=f"relative standard deviation of {what} in a --robust study (0.03: 3%%)",
        )
    parser.add_argument("--seed", type=int, default=0, help="seed of the --robust perturbations")
    parser.add_argument(
        "--workers", type=int, default=1, help="Dask LocalCluster worker processes for --robust (1: none)"
    )
    parser.add_argument(
        "--scheduler", default=None, metavar="ADDRESS", help="run --robust on this Dask scheduler"
    )


def _summary_robust(r: RobustStudy, s: float) -> str:
    """Return the robustness table, lengths in file units."""
    lines = [f"{'H':>10} {'W rad/s':>9} P(unique) P(trigger) invalid  ({r.samples} perturbed designs each)"]
    for p in r.points:
        lines.append(
            f"{p.offset / s:>10.4g} {p.speed:>9.4g} {p.unique:>9.3f} {p.trigger:>10.3f} {p.invalid:>7}"
        )
    b = r.best
    lines.append(
        "most robust: none" if b is None else f"most robust: H={b.offset / s:.4g}, W={b.speed:.4g} rad/s"
    )
    return "\n".join(lines)


def run_robust(args: argparse.Namespace, part: Part, height: float | None) -> int:
    """Run `feeder throw-design --robust N`: the robustness study of the grid."""
    if args.robust < 1:
        raise InputError("--robust", f"must be >= 1, got {args.robust}")
    if args.workers < 1:
        raise InputError("--workers", f"must be >= 1, got {args.workers}")
    s = part.unit_scale
    try:
        result = _robust(args, part, height, s)
    except InputError as error:
        if error.source is None and error.field in ROBUST_FLAGS:
            raise InputError(ROBUST_FLAGS[error.field], error.problem) from None
        raise
    if result is None:
        return EXIT_INTERRUPTED
    emit(args, result.to_json(), lambda _: _summary_robust(result, s))
    return 0


# The study's field names as the command line spells them.
ROBUST_FLAGS = {
    "robust": "--robust",
    "workers": "--workers",
    "offset_sigma": "--offset-sigma",
    "speed_sigma": "--speed-sigma",
    "mu_sigma": "--mu-sigma",
}


def _robust(args: argparse.Namespace, part: Part, height: float | None, s: float) -> RobustStudy | None:
    """Return the study the flags ask for (None after Ctrl-C)."""
    return run_with_progress(
        "throw-design",
        lambda progress: robust_study(
            arm_part(part),
            args.goal_edge,
            np.array([h * s for h in args.offsets]),
            np.array(args.release_speeds),
            args.gravity * s,
            args.mu,
            args.robust,
            args.speed_sigma,
            args.offset_sigma,
            args.mu_sigma,
            args.seed,
            height,
            args.workers,
            args.scheduler,
            progress,
        ),
    )
