"""`feeder stable-region` and `feeder check-stability`: stable gravity directions of an assembly file."""

from __future__ import annotations

import argparse
import math

import numpy as np

from feeder_cell.cli.common import add_json_flag, emit, finite_float
from feeder_planner.assembly.model import load_assembly
from feeder_planner.assembly.planner import (
    DEFAULT_FACETS,
    PreparedAssembly,
    check_result,
    prepare,
    region_result,
)
from feeder_planner.errors import InputError

CONVENTIONS = (
    "Frames and signs: g is the direction gravity pulls, a unit vector in the assembly file's frame "
    "(it is normalised if not unit). A direction g is stable when contact forces at the contact "
    "points balance every free body (potential stability, paper eq. 9), friction linearised by a "
    "K-facet pyramid inscribed in the Coulomb cone (K=4 is the paper's). The stable set is "
    "{unit g : n.g <= 0 for n in normals, e.g = 0 for e in equalities}. JSON is SI: metres, "
    "newtons (for |g| = 9.80665 m/s^2), radians, steradians. Exit 2: bad input; 3: not certified."
)


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add stable-region and check-stability to the feeder parser."""
    region = subparsers.add_parser(
        "stable-region",
        help="the whole set of gravity directions for which an assembly is potentially stable",
        description="Compute the exact region of stable gravity directions of an assembly (a convex spherical "
        "polygon or a degenerate kind: empty, point, antipodal_pair, arc, great_circle, region, "
        "hemisphere, sphere). " + CONVENTIONS,
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


def _prepared(args: argparse.Namespace) -> PreparedAssembly:
    if args.mu is not None and args.mu < 0:
        raise InputError("--mu", f"must be >= 0, got {args.mu!r}")
    if args.facets < 3:
        raise InputError("--facets", f"must be an integer >= 3, got {args.facets!r}")
    return prepare(load_assembly(args.assembly), args.mu, args.facets)


def _stable_region(args: argparse.Namespace) -> int:
    prepared = _prepared(args)
    result = region_result(prepared)
    if args.exact_cone:
        from feeder_planner.assembly.exact_cone import compare_pyramids

        result["exact_cone"] = compare_pyramids(prepared.assembly, prepared.contacts)
    emit(args, result, _region_summary)
    return 0


def _region_summary(result: dict) -> str:
    lines = [
        f"{result['assembly']}: stable region is {result['kind']} ({result['contacts']} contact points, "
        f"K = {result['facets']}, {result['lp_count']} LPs)",
        f"  area {result['area_sr']:.6g} sr ({result['area_sr'] / (4 * math.pi):.4%} of the sphere)",
    ]
    if result["center"] is not None:
        lines.append(f"  centre g = {_vec(result['center'])}")
    for v in result["vertices"]:
        lines.append(f"  vertex {_vec(v)}")
    for n in result["normals"]:
        lines.append(f"  n.g <= 0 for n = {_vec(n)}")
    for e in result["equalities"]:
        lines.append(f"  e.g == 0 for e = {_vec(e)}")
    return "\n".join(lines)


def _check_stability(args: argparse.Namespace) -> int:
    g = np.asarray(args.g, dtype=float)
    if np.linalg.norm(g) < 1e-12:
        raise InputError("--g", "must be a non-zero direction")
    prepared = _prepared(args)
    result = check_result(prepared, g)
    if args.exact_cone:
        from feeder_planner.assembly.exact_cone import check_exact

        verdict = check_exact(prepared.assembly, prepared.contacts, g)
        result["exact_cone"] = {"stable": verdict.stable, "method": verdict.method}
    emit(args, result, _check_summary)
    return 0


def _check_summary(result: dict) -> str:
    text = _pyramid_summary(result)
    if "exact_cone" in result:
        verdict = {True: "stable", False: "NOT stable", None: "undecided (on the boundary, to tolerance)"}
        text += f"\nexact circular friction cone: {verdict[result['exact_cone']['stable']]}"
    return text


def _pyramid_summary(result: dict) -> str:
    if result["stable"]:
        text = f"stable for g = {_vec(result['g'])} (angular margin {result['margin_rad']:.6g} rad)"
        loads = [
            f"  {f['a']} on {f['b']} at {_vec(f['point'])}: force {_vec(f['force'])} N"
            for f in result.get("forces", [])
            if np.linalg.norm(f["force"]) > 0
        ]
        return "\n".join([text] + loads)
    return (
        f"NOT stable for g = {_vec(result['g'])}; bodies that cannot be balanced: "
        f"{', '.join(result['unbalanced_bodies']) or '(none identified)'}"
    )


def _vec(v: list[float]) -> str:
    return "(" + ", ".join(f"{x:.6g}" for x in v) + ")"
