"""`feeder throw`, `feeder limit-set` and `feeder throw-design`: the throwing-arm planner (contract 3)."""

from __future__ import annotations

import argparse
import sys
from typing import Callable

import numpy as np

from feeder_cell.cli.common import add_json_flag, angle, emit, finite_float
from feeder_cell.cli.main import EXIT_NOT_CERTIFIED
from feeder_cell.cli.throwing_studies import (
    EXIT_INTERRUPTED,
    add_robust_flags,
    attractor_lines,
    growing_text,
    run_robust,
    run_with_progress,
)
from feeder_cell.plots.flag import add_plot_flag, write_plot
from feeder_planner.errors import InputError
from feeder_planner.limits import (
    check_flag_length,
    check_limit_set_counts,
    check_throw_design,
    check_throw_flight,
)
from feeder_planner.parts import Part, load_part
from feeder_planner.throwing import (
    DEFAULT_STARTS_PER_EDGE,
    DEFAULT_THROWS,
    BelowGraspError,
    DesignSearch,
    LimitSet,
    OffsetBelowDMinError,
    ThrowParams,
    ThrowResult,
    arm_part,
    check_sensing_height,
    limit_set,
    search,
)
from feeder_planner.throwing.tolerances import SENSING_HEIGHT_FRACTION
from feeder_planner.units import LENGTH_UNITS
from feeder_sim.throwing import FIDELITIES, FIDELITY_ALIASES, fidelity_throw

__all__ = ["CONVENTIONS", "FLAGS", "register", "run_throw", "run_limit_set", "run_design"]

CONVENTIONS = """Frame at the arm pivot; gravity (0, G) with G < 0; the arm's top surface is y = H while
horizontal; a throw turns the arm counter-clockwise and releases at angular speed W > 0 (impulsive).
R is the x coordinate of the part's centre of mass resting on the horizontal arm. Hull vertices are
numbered counter-clockwise from the first file vertex on the hull; edge i joins vertex i to i+1.
Lengths on the command line (R, H, G in length/s^2, sensing height) are in the part file's
length_unit; W is rad/s, or deg/s with a 'deg' suffix (320deg). JSON output is SI (m, rad, s).
Exit 2 on bad input, 3 when a result cannot be certified (e.g. no invariant set)."""

LIMIT_SET_RULE = """Each start is thrown until its tail confirms (issue 25): from two windows on, its last
n/2 throws must show the same edges, radius ranges (to 1 % of the widest edge span or a tenth of the
range) and exact cycle (or none) as its last n/4, and the start must have kept to them twice as long
as it ever kept to a stretch it then left. A start that does not confirm within --throws is counted in
"unconverged_starts" and in no attractor. Starts whose tails share edges, cycle and radii form one
attractor, and everything reported of it comes from the tails (the transients are not in them).
--json adds "attractors": per attractor its edges, edge_radius_ranges, periodic, cycle (one period,
null when quasi-periodic), pattern (one round as blocks: [edge, min visits, max visits]),
throws_per_round [min, mean, max], basin (fraction of starts), longest_transient, and
assumption_violations (fraction of its throws with lift_off, slip, off_arm). longest_transient: the
most throws any start of its basin took before its state stayed on the attractor's edges, each within
its radius range; a sensor in the trigger range tells the goal edge only after that many throws from
such a start. "unique": one attractor from every start; "cycle" only for a periodic unique one.
"trigger_note" says why there is no trigger range, naming the attractor and edge that rule one out.
A radius range is the closure of the tails' visits (the approach to the attractor cut off); the trigger
range is read on the tails and on the older states of their stays that may be visits. A start whose
tail would confirm but that a radius range still widens when --throws runs out is unconverged (counted
in "unconverged_starts", in no attractor): the answer is printed, one line on stderr names the edges,
and the exit status is 3 ("raise --throws"). Exit 3 also when no start confirms within --throws."""

FLAGS = {
    "radius": "--radius",
    "offset": "--offset",
    "offsets": "--offsets",
    "release_speed": "--release-speed",
    "gravity": "--gravity",
    "mu": "--mu",
    "edge": "--edge",
    "goal_edge": "--goal-edge",
    "sensing_height": "--sensing-height",
}


def _common(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "part",
        metavar="PART",
        help="part file: YAML (contract section 2), or DXF, SVG, STL, STEP (docs/cli.md, Importing parts)",
    )
    parser.add_argument(
        "--offset", type=finite_float, required=True, help="H: arm surface height at the pivot"
    )
    parser.add_argument("--release-speed", type=angle, required=True, help="W > 0: release angular speed")
    parser.add_argument("--gravity", type=finite_float, required=True, help="G < 0: gravity, length/s^2")
    parser.add_argument("--mu", type=finite_float, required=True, help="friction coefficient arm-part, > 0")
    add_json_flag(parser)


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add this module's subcommands to the feeder parser."""
    fmt = argparse.RawDescriptionHelpFormatter
    p = subparsers.add_parser(
        "throw",
        help="one application of the throw map",
        description="One throw and catch (i0, R0) -> (i1, R1), jog or flip.\n" + CONVENTIONS,
        formatter_class=fmt,
    )
    _common(p)
    p.add_argument("--edge", type=int, required=True, help="I: stable hull edge the part rests on")
    p.add_argument(
        "--radius", type=finite_float, required=True, help="R: throwing radius (>= R_grasp of the edge)"
    )
    p.add_argument(
        "--fidelity",
        choices=(*FIDELITIES, *FIDELITY_ALIASES),
        default="paper",
        help="paper: the paper's model (default; analytic is the same); contact: paper plus lift-off "
        "and Coulomb impacts; dynamic: pymunk (no flight time or impact count: null in --json)",
    )
    p.set_defaults(handler=_guard(run_throw))
    q = subparsers.add_parser(
        "limit-set",
        help="grasp radii, forward limit set and sensor trigger range",
        description="Grasp radii (eqs. 1-4), R_flip and R_max (Prop. IV.4), the forward limit "
        "set from a grid of starts (Figs. 7, 8) and the sensor trigger radius range "
        "for the goal edge.\n" + LIMIT_SET_RULE + "\n" + CONVENTIONS,
        formatter_class=fmt,
    )
    _common(q)
    q.add_argument("--goal-edge", type=int, default=None, help="E: edge the sensor must single out")
    q.add_argument(
        "--sensing-height",
        type=finite_float,
        default=None,
        help=f"sensor sensing height (default {100 * SENSING_HEIGHT_FRACTION:g}%% of the part radius)",
    )
    q.add_argument(
        "--starts-per-edge",
        type=int,
        default=DEFAULT_STARTS_PER_EDGE,
        help=f"grid starts per stable edge (default {DEFAULT_STARTS_PER_EDGE})",
    )
    q.add_argument(
        "--throws",
        type=int,
        default=DEFAULT_THROWS,
        help=f"cap on throws per start; each start stops once its tail confirms (default {DEFAULT_THROWS})",
    )
    add_plot_flag(q)
    q.set_defaults(handler=_guard(run_limit_set))
    d = subparsers.add_parser(
        "throw-design",
        help="search offset and release speed for a sensor-based feeder",
        description="Try every (H, W) of the given lists; report each design's cycle and trigger "
        "range and the unique-cycle design with the widest range.\n" + CONVENTIONS,
        formatter_class=fmt,
    )
    d.add_argument("part", metavar="PART")
    d.add_argument("--offsets", type=finite_float, nargs="+", required=True, help="H values to try")
    d.add_argument("--release-speeds", type=angle, nargs="+", required=True, help="W values to try")
    d.add_argument("--gravity", type=finite_float, required=True)
    d.add_argument("--mu", type=finite_float, required=True)
    d.add_argument("--goal-edge", type=int, required=True)
    d.add_argument("--sensing-height", type=finite_float, default=None)
    add_robust_flags(d)
    add_json_flag(d)
    add_plot_flag(d)
    d.set_defaults(handler=_guard(run_design))


def _guard(handler: Callable[[argparse.Namespace], int]) -> Callable[[argparse.Namespace], int]:
    """Name command-line flags (not internal names) in input errors."""

    def run(args: argparse.Namespace) -> int:
        try:
            return handler(args)
        except InputError as error:
            if error.source is None and error.field in FLAGS:
                raise InputError(FLAGS[error.field], error.problem) from None
            raise

    return run


def _params(args: argparse.Namespace, part: Part) -> ThrowParams:
    """Return the design parameters of the flags, lengths converted from the file's unit to metres."""
    scale = part.unit_scale
    return ThrowParams(args.offset * scale, args.release_speed, args.gravity * scale, args.mu)


def _unit_name(part: Part) -> str:
    """Return the name of the part file's length unit."""
    return next((name for name, scale in LENGTH_UNITS.items() if scale == part.unit_scale), "m")


def _summary_throw(r: ThrowResult, unit: float) -> str:
    """Return the one-line summary of a throw, lengths in file units."""
    counted = "pymunk" if r.fidelity == "dynamic" else f"{r.impacts} impact(s), flight {r.flight_time:.4g} s"
    events = [name for name in ("lift_off", "slip") if getattr(r, name)] if r.fidelity == "contact" else []
    return (
        f"edge {r.start_edge} at R={r.start_radius / unit:.6g} -> edge {r.edge} at "
        f"R={r.radius / unit:.6g} (file units): {r.kind}, {r.turns} whole turn(s), {counted}"
        + ("" if r.fidelity == "paper" else f" [{r.fidelity}{': ' + ', '.join(events) if events else ''}]")
    )


def run_throw(args: argparse.Namespace) -> int:
    """Run `feeder throw`: one application of the throw map."""
    part = load_part(args.part)
    params = _params(args, part)
    scale = part.unit_scale
    check_throw_design(params.speed, params.gravity, params.offset, "--release-speed", "--offset")
    check_throw_flight(
        args.radius * scale,
        params.speed,
        params.gravity,
        abs(params.offset) + 2.0 * part.radius,
        "--radius",
        "--release-speed",
    )
    try:
        result = fidelity_throw(
            arm_part(part), args.edge, args.radius * part.unit_scale, params, args.fidelity
        )
    except BelowGraspError as error:
        raise error.in_unit(part.unit_scale, _unit_name(part)) from None  # as the flag was given
    payload = result.to_json()
    if result.fidelity == "dynamic":  # pymunk certifies neither a flight time nor an impact count
        payload["flight_time"] = payload["impacts"] = None
    emit(args, payload, lambda _: _summary_throw(result, part.unit_scale))
    return 0


def _summary_limit(result: LimitSet, unit: float) -> str:
    """Return the summary of a limit set, lengths in file units."""
    b = result.bounds
    lines = [f"stable edges {result.stable_edges}; invariant set (Prop. IV.4): {b.invariant}"]
    for i in b.grasp:
        lines.append(
            f"  edge {i}: R_grasp {b.grasp[i] / unit:.6g}  R_flip {b.flip[i] / unit:.6g}"
            f"  R_max {b.max[i] / unit:.6g}"
        )
    c = result.cycle
    lines.append(
        (
            "cycle: none (the one attractor is quasi-periodic)"
            if result.unique
            else "cycle: none common to all starts"
        )
        if c is None
        else f"cycle: edges {c.edges}, {c.throws_per_cycle:.1f} throws per cycle ({c.throws_range[0]}-"
        f"{c.throws_range[1]}), unique from all {result.starts} starts"
    )
    lines += attractor_lines(result, unit)
    for e, (lo, hi) in result.edge_radius_ranges.items():
        lines.append(f"  edge {e} in the limit set: R in [{lo / unit:.6g}, {hi / unit:.6g}]")
    t = result.trigger
    lines.append(
        "trigger: none" + (f" ({result.trigger_note})" if result.trigger_note else "")
        if t is None
        else f"trigger for edge {result.goal_edge}: sensor radius in [{t[0] / unit:.6g}, "
        f"{t[1] / unit:.6g}] (file units)"
    )
    return "\n".join(lines)


def _positive_int(value: int, flag: str) -> int:
    """Return ``value`` if it is >= 1, else raise InputError naming ``flag``."""
    if value < 1:
        raise InputError(flag, f"must be >= 1, got {value}")
    return value


def _height(args: argparse.Namespace, part: Part) -> float | None:
    """Return --sensing-height in metres (None: the default), checked in the unit it was given in."""
    if args.sensing_height is None:
        return None
    check_flag_length(args.sensing_height * part.unit_scale, "--sensing-height")
    return check_sensing_height(args.sensing_height) * part.unit_scale


def run_limit_set(args: argparse.Namespace) -> int:
    """Run `feeder limit-set`: grasp radii, the forward limit set and the sensor trigger range."""
    part = load_part(args.part)
    params = _params(args, part)
    check_throw_design(params.speed, params.gravity, params.offset, "--release-speed", "--offset")
    check_limit_set_counts(args.starts_per_edge, args.throws, "--starts-per-edge", "--throws")
    height = _height(args, part)
    starts = _positive_int(args.starts_per_edge, "--starts-per-edge")
    throws = _positive_int(args.throws, "--throws")
    try:
        # A part with many hull vertices takes minutes: say how far it is, and stop cleanly on Ctrl-C.
        result = run_with_progress(
            "limit-set",
            lambda progress: limit_set(
                arm_part(part),
                params,
                args.goal_edge,
                starts,
                throws,
                sensing_height=height,
                keep_trajectories=args.plot is not None,  # the plot draws every start's states
                progress=progress,
            ),
        )
    except OffsetBelowDMinError as error:
        raise error.in_unit(part.unit_scale, _unit_name(part)) from None  # as the flag was given
    if result is None:
        return EXIT_INTERRUPTED
    emit(args, result.to_json(), lambda _: _summary_limit(result, part.unit_scale))
    write_plot(args, "limit-set", result, part.unit_scale, part.name)
    if result.growing:
        # A range still widening when the throws ran out would read too narrow: the answer stands for
        # the starts that confirmed, and asks for more throws (issue 35).
        sys.stderr.write(f"feeder limit-set: {growing_text(result)}; raise --throws\n")
        return EXIT_NOT_CERTIFIED
    return 0


def _summary_design(r: DesignSearch, s: float) -> str:
    """Return the design table, lengths in file units (``s`` metres per unit)."""
    lines = [f"{'H':>10} {'W rad/s':>9} unique cycle / trigger range (file units)"]
    for row in r.designs:
        tr = row.trigger
        text = f"[{tr[0] / s:.4g}, {tr[1] / s:.4g}]" if tr else row.note
        lines.append(f"{row.offset / s:>10.4g} {row.speed:>9.4g} {str(row.unique):6} {row.cycle} {text}")
    b = r.best
    lines.append("best: none" if b is None else f"best: H={b.offset / s:.4g}, W={b.speed:.4g} rad/s")
    return "\n".join(lines)


def run_design(args: argparse.Namespace) -> int:
    """Run `feeder throw-design`: every (H, W) of the grid and the best sensor-based design."""
    part = load_part(args.part)
    s = part.unit_scale
    check_throw_design(
        max(abs(w) for w in args.release_speeds),
        args.gravity * s,
        max(abs(h) for h in args.offsets) * s,
        "--release-speeds",
        "--offsets",
    )
    if args.robust is not None:
        return run_robust(args, part, _height(args, part))
    try:
        result = run_with_progress(
            "throw-design",
            lambda progress: search(
                arm_part(part),
                args.goal_edge,
                np.array([h * s for h in args.offsets]),
                np.array(args.release_speeds),
                args.gravity * s,
                args.mu,
                _height(args, part),
                progress=progress,
            ),
        )
    except OffsetBelowDMinError as error:
        raise error.in_unit(s, _unit_name(part)) from None  # as the flag was given
    if result is None:
        return EXIT_INTERRUPTED
    emit(args, result.to_json(), lambda _: _summary_design(result, s))
    write_plot(args, "throw-design", result, s, part.name)
    return 0
