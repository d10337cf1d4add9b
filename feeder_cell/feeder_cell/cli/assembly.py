"""`feeder stable-region` and `feeder check-stability`: stable gravity directions of an assembly file."""

from __future__ import annotations

import argparse
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from feeder_cell.cli.common import add_json_flag, emit, finite_float
from feeder_cell.plots.flag import add_plot_flag, write_plot
from feeder_planner.assembly import (
    DEFAULT_FACETS,
    KINDS,
    STANDARD_GRAVITY,
    CheckResult,
    PreparedAssembly,
    check_result,
    load_assembly,
    prepare,
    region_result,
    unit_gravity,
    validate_facets,
    validate_mu,
)

__all__ = ["register"]

CONVENTIONS = (
    "Frames and signs: g is the direction gravity pulls, a unit vector in the assembly file's frame "
    "(it is normalised if not unit). A direction g is stable when contact forces at the contact "
    "points balance every free body (potential stability, paper eq. 9), friction linearised by a "
    f"K-facet pyramid inscribed in the Coulomb cone (K={DEFAULT_FACETS} is the paper's). The stable set is "
    "{unit g : n.g <= 0 for n in normals, e.g = 0 for e in equalities}. JSON is SI: metres, "
    f"newtons (for |g| = {STANDARD_GRAVITY} m/s^2), radians, steradians. Exit 2: bad input; 3: not certified."
)


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add stable-region and check-stability to the feeder parser."""
    region = subparsers.add_parser(
        "stable-region",
        help="the whole set of gravity directions for which an assembly is potentially stable",
        description="Compute the exact region of stable gravity directions of an assembly (a convex "
        f"spherical polygon or a degenerate kind: {', '.join(KINDS)}). " + CONVENTIONS,
    )
    _common(region)
    region.add_argument(
        "--exact-cone",
        action="store_true",
        help="also measure K = 4, 8, 16, 32 pyramids against the exact circular cone "
        "(area in sr and Hausdorff angle in rad)",
    )
    region.set_defaults(handler=_stable_region)
    check = subparsers.add_parser(
        "check-stability",
        help="whether one gravity direction is stable, with contact forces",
        description="Solve the stability LP (paper eq. 9) for one gravity direction. " + CONVENTIONS,
    )
    _common(check)
    check.add_argument(
        "--g",
        nargs=3,
        type=finite_float,
        required=True,
        metavar=("GX", "GY", "GZ"),
        help="gravity direction in the assembly frame (any non-zero length)",
    )
    check.add_argument(
        "--exact-cone",
        action="store_true",
        help="also decide the direction under the exact circular friction cone (a second-order "
        "cone program); undecided only on the boundary, to tolerance",
    )
    check.set_defaults(handler=_check_stability)


def _common(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("assembly", metavar="ASSEMBLY", help="assembly YAML file (contract section 2)")
    parser.add_argument(
        "--mu",
        type=finite_float,
        default=None,
        help="Coulomb friction coefficient for every contact (>= 0; default: the file's)",
    )
    parser.add_argument(
        "--facets",
        type=int,
        default=DEFAULT_FACETS,
        help=f"facets K >= 3 of the friction pyramid (default {DEFAULT_FACETS})",
    )
    add_json_flag(parser)
    add_plot_flag(parser)


def _prepared(args: argparse.Namespace) -> PreparedAssembly:
    """Load the assembly file with the flags' mu and K, each flag checked by the core's one definition."""
    mu = validate_mu(args.mu, "--mu")
    facets = validate_facets(args.facets, "--facets")
    return prepare(load_assembly(args.assembly), mu, facets)


def _stable_region(args: argparse.Namespace) -> int:
    """Run ``feeder stable-region``."""
    result = region_result(_prepared(args), exact_cone=args.exact_cone)
    emit(args, result.to_json(), _region_summary)
    write_plot(args, "stable-region", result)
    return 0


def _region_summary(result: dict[str, Any]) -> str:
    """Summarise a region for people: kind, counts, area, centre, vertices and constraints.

    It reads the JSON object, so it shows exactly what ``--json`` prints (unit vectors without noise).
    """
    lines = [
        f"{result['assembly']}: stable region is {result['kind']} ({result['contacts']} contact points, "
        f"K = {result['facets']}, {result['lp_count']} LPs)",
        f"  area {result['area_sr']:.6g} sr ({result['area_sr'] / (4 * math.pi):.4%} of the sphere)",
    ]
    if result["center"] is not None:
        lines.append(f"  centre g = {_vec(result['center'])}")
    lines += [f"  vertex {_vec(v)}" for v in result["vertices"]]
    lines += [f"  n.g <= 0 for n = {_vec(n)}" for n in result["normals"]]
    lines += [f"  e.g == 0 for e = {_vec(e)}" for e in result["equalities"]]
    return "\n".join(lines)


def _check_stability(args: argparse.Namespace) -> int:
    """Run ``feeder check-stability``."""
    g = np.asarray(args.g, dtype=float)
    if np.all(np.isfinite(g)) and not np.isfinite(np.linalg.norm(g)):
        g = g / np.abs(g).max()  # a direction: components near the double's range would overflow its norm
    unit_gravity(g, "--g")  # refuses a zero direction before the file is read; check_result normalises g
    prepared = _prepared(args)
    result = check_result(prepared, g, exact_cone=args.exact_cone)
    emit(args, result.to_json(), lambda _: _check_summary(result))
    write_plot(args, "check-stability", prepared.assembly, result)
    return 0


def _check_summary(result: CheckResult) -> str:
    """Summarise a check for people, with the exact cone's verdict when asked for."""
    text = _pyramid_summary(result)
    if result.exact_cone is not None:
        verdict = {True: "stable", False: "NOT stable", None: "undecided (on the boundary, to tolerance)"}
        text += f"\nexact circular friction cone: {verdict[result.exact_cone.stable]}"
    return text


def _pyramid_summary(result: CheckResult) -> str:
    """Summarise the pyramid LP's verdict: margin and non-zero contact forces, or the unbalanced bodies."""
    if result.stable:
        text = f"stable for g = {_vec(result.g)} (angular margin {result.margin_rad:.6g} rad)"
        loads = [
            f"  {f.a} on {f.b} at {_vec(f.point)}: force {_vec(f.force)} N"
            for f in result.forces or ()
            if np.linalg.norm(f.force) > 0
        ]
        return "\n".join([text] + loads)
    return (
        f"NOT stable for g = {_vec(result.g)}; bodies that cannot be balanced: "
        f"{', '.join(result.unbalanced_bodies) or '(none identified)'}"
    )


def _vec(v: Sequence[float] | np.ndarray) -> str:
    """Format a vector as (x, y, z) with 6 significant digits."""
    return "(" + ", ".join(f"{x:.6g}" for x in v) + ")"
