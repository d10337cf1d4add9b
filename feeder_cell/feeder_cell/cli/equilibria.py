"""`feeder equilibria`: all equilibria of a part in the unit radial plus a constant field (contract 3)."""

from __future__ import annotations

import argparse
import math
from typing import Any

from feeder_cell.cli.common import add_json_flag, emit, finite_float
from feeder_cell.plots.flag import add_plot_flag, write_plot
from feeder_planner.errors import InputError
from feeder_planner.mems import METHODS, find_equilibria
from feeder_planner.parts import load_part

__all__ = ["HELP", "register", "run"]

HELP = """All equilibria (stable and unstable) of a planar part in the unit radial field f(r) = -r/|r|
centred at the plane origin plus the constant field -delta*(0, 1), 0 <= delta < 1 (force per unit
area, dimensionless strength). A configuration (x, y, theta) rotates the part by theta (radians,
counter-clockwise) about its centroid and puts the centroid at (x, y) metres in the plane frame.
The pivot point is given in the part frame (file frame translated so the centroid is the origin),
metres. Methods: 'asymptotic' (Table 1 / Theorem 7, small delta), 'numeric' (zero crossings of the
equilibrium curve, any delta; classification by the Hessian of U in (x, y, theta)), 'auto' (the
asymptotic result when the numeric method certifies it, else the numeric one).
Exit 2 on bad input, 3 when no method can certify a result."""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add this module's subcommands to the feeder parser."""
    parser = subparsers.add_parser(
        "equilibria",
        help="equilibria of a part in radial + constant fields",
        description=HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "part",
        metavar="PART",
        help="part file: YAML (contract section 2), or DXF, SVG, STL, STEP (docs/cli.md, Importing parts)",
    )
    parser.add_argument(
        "--delta",
        type=finite_float,
        required=True,
        help="strength of the constant field relative to the radial one, 0 <= D < 1",
    )
    parser.add_argument("--method", choices=METHODS, default="auto", help="default: auto")
    add_json_flag(parser)
    add_plot_flag(parser)
    parser.set_defaults(handler=run)


def _summary(result: dict[str, Any]) -> str:
    """Return the human summary of the ``--json`` object (EquilibriaResult.to_json())."""
    lines = [
        f"pivot (part frame): ({result['pivot'][0]:.6g}, {result['pivot'][1]:.6g}) m, "
        f"area {result['area']:.6g} m^2, delta {result['delta']:g}, method {result['method']}"
    ]
    if not result["details"].get("certified", True):
        lines.append(
            "  note: asymptotic result (limit delta -> 0, Theorem 7), not certified at this delta; "
            "use --method auto or numeric for a certified answer"
        )
    for e in result["equilibria"]:
        kind = "stable  " if e["stable"] else "unstable"
        lines.append(
            f"  {kind} x={e['x']:+.6e} m  y={e['y']:+.6e} m  theta={e['theta']:.9f} rad "
            f"({math.degrees(e['theta']):.4f} deg)"
        )
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    """Print the equilibria of the part file for --delta and --method; return the exit status."""
    part = load_part(args.part)
    try:
        result = find_equilibria(part, args.delta, args.method)
    except InputError as error:
        if error.source is None and error.field == "delta":  # name the flag, as it was given
            raise InputError("--delta", error.problem) from None
        raise
    emit(args, result.to_json(), _summary)
    write_plot(args, "equilibria", part, result)
    return 0
