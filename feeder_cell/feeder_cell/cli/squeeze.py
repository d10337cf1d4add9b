"""`feeder squeeze-plan PART`: Goldberg's shortest squeeze plan for a part, with its certificate."""

from __future__ import annotations

import argparse
import math
from typing import Any

from feeder_cell.cli.common import add_json_flag, angle, emit, finite_float
from feeder_cell.plots.flag import add_plot_flag
from feeder_planner.errors import InputError
from feeder_planner.parts import load_part
from feeder_planner.squeeze import (
    check_certificate,
    distinguishable_groups,
    hull_symmetry_order,
    plan_squeezes,
    squeeze_function,
)
from feeder_planner.squeeze.plan import Plan
from feeder_planner.squeeze.squeeze_function import SqueezeFunction

__all__ = ["HELP", "describe", "register", "run"]

HELP = """Plan the shortest sequence of parallel-jaw squeezes that brings a part from any orientation to
one orientation, up to the symmetry of its squeeze function (Goldberg 1993, frictionless and
quasi-static). PART is a part file (contract section 2). Prints the diameter function's stable
orientations (the widths the jaws read there), the symmetry period, the plan's gripper angles, its
final orientation and its margin (the smallest distance of any intermediate orientation from an
unstable one: the gripper angle error the plan tolerates). Angles are radians in the world frame; the
part's orientation is that of its file frame. --plot draws the diameter function, the squeeze function
and the plan's steps. Exit 2 on bad input (a degenerate hull names the vertices)."""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``squeeze-plan`` to the feeder parser."""
    parser = subparsers.add_parser(
        "squeeze-plan",
        help="shortest squeeze plan orienting a part with a parallel-jaw gripper (Goldberg)",
        description=HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("part", metavar="PART", help="part file (YAML)")
    parser.add_argument(
        "--first-angle",
        type=angle,
        default=0.0,
        metavar="A",
        help="gripper angle of the first squeeze (rad, or deg with the suffix; default 0)",
    )
    parser.add_argument(
        "--resolution",
        type=_resolution,
        default=1e-4,
        metavar="M",
        help="jaw-width sensor resolution (m) for the orientations one reading tells apart (default 1e-4)",
    )
    add_json_flag(parser)
    add_plot_flag(parser)
    parser.set_defaults(handler=run)


def _resolution(text: str) -> float:
    """Argparse type of --resolution: a finite length > 0 (m)."""
    value = finite_float(text)
    if value <= 0.0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text!r}")
    return value


def describe(name: str, squeeze: SqueezeFunction, plan: Plan, resolution: float) -> dict[str, Any]:
    """Return the JSON object of squeeze-plan (SI units, radians)."""
    diameter = squeeze.diameter
    result: dict[str, Any] = {
        "name": name,
        "hull_vertices": len(diameter.hull),
        "hull_symmetry": hull_symmetry_order(diameter.hull),
        "stable_orientations": [{"angle": m.angle, "width": m.width} for m in diameter.minima],
        "unstable_orientations": [{"angle": m.angle, "width": m.width} for m in diameter.maxima],
        "steps_per_period": squeeze.steps_per_period(),
        "sensor_groups": [list(g) for g in distinguishable_groups(squeeze, resolution)],
    }
    result.update(plan.to_json())
    return result


def _summary(result: dict[str, Any]) -> str:
    """Return the human summary of squeeze-plan."""
    period = result["symmetry_period"]
    lines = [
        f"{result['name']}: hull of {result['hull_vertices']} vertices (rotational symmetry "
        f"{result['hull_symmetry']}), squeeze function period {period:.6f} rad "
        f"({math.degrees(period):.3f} deg), {result['steps_per_period']} stable orientations a period",
        "  stable orientations (rad: width m): "
        + ", ".join(f"{s['angle']:.6f}: {s['width']:.6g}" for s in result["stable_orientations"]),
        f"  plan: {result['squeezes']} squeezes at "
        + ", ".join(f"{a:.6f}" for a in result["angles"])
        + " rad",
        f"  final orientation {result['final_orientation']:.6f} rad modulo {period:.6f}; "
        f"margin {result['margin']:.6f} rad",
        f"  certificate: {len(result['intervals'])} initial intervals cover [0, 2 pi), every one ends there",
        "  friction tolerance: "
        + (
            "any (one squeeze)"
            if result["friction_tolerance"] is None
            else f"no squeeze after the first jams below mu {result['friction_tolerance']:.4g}"
        ),
        f"  jaw-width sensor: {len(result['sensor_groups'])} groups of stable orientations told apart",
    ]
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    """Plan for PART, check the plan's certificate, print it; draw it with --plot."""
    part = load_part(args.part)
    try:
        squeeze = squeeze_function(part.outer, "vertices")
    except InputError as error:
        raise error.with_source(str(args.part)) from None
    plan = plan_squeezes(squeeze, args.first_angle)
    check_certificate(squeeze, plan)
    result = describe(part.name, squeeze, plan, args.resolution)
    for key in ("margin", "friction_tolerance"):
        if not math.isfinite(result[key]):
            result[key] = None  # one squeeze: no orientation in between (JSON has no infinity)
    emit(args, result, _summary_safe)
    if args.plot is not None:
        from feeder_cell.cli.squeeze_plot import squeeze_figure
        from feeder_cell.plots.common import write_figure

        path = write_figure(squeeze_figure(part.name, squeeze, plan), args.plot)
        if not args.json:
            print(f"plot: {path}")
    return 0


def _summary_safe(result: dict[str, Any]) -> str:
    """Return the summary with a one-squeeze plan's margin said in words."""
    if result["margin"] is None:
        return _summary({**result, "margin": math.inf}).replace("margin inf rad", "no margin (one squeeze)")
    return _summary(result)
