"""Where the exact stable region's time goes, per LP and per solver phase, on a connected brick wall.

    python tools/profile_region.py ROWS COLUMNS [--simplex-only]

One line per support LP (its direction, the vertex found, the pivots of its last simplex run, its time and
whether it went the interior point route), then the phase totals of ``WarmLP.seconds``: Clarabel's interior
point, HiGHS's crossover, the simplex runs. Issue 15's walls: 20 16 (3,504 contact points), 32 29 (10,580).
``--simplex-only`` turns the interior point route off (the baseline: restarted simplex from kept bases).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from feeder_planner.assembly.generate import brick_wall
from feeder_planner.assembly.lp import LP_PHASES
from feeder_planner.assembly.model import assembly_from_document
from feeder_planner.assembly.planner import prepare
from feeder_planner.assembly.region import cone_region
from feeder_planner.assembly.support import SupportOracle
from feeder_planner.assembly.tolerances import FAR_PIVOTS


class _LoggedOracle:
    """The wall's SupportOracle, printing one line per LP."""

    def __init__(self, oracle: SupportOracle) -> None:
        self.oracle = oracle

    @property
    def calls(self) -> int:
        return self.oracle.calls

    def __call__(self, direction: np.ndarray) -> tuple[float, np.ndarray]:
        far_before = self.oracle.far_solves
        started = time.perf_counter()
        value, g = self.oracle(direction)
        elapsed = time.perf_counter() - started
        route = "interior point" if self.oracle.far_solves > far_before else "simplex restart"
        print(
            f"  LP {self.oracle.calls:2d}  direction {np.round(direction, 3)}  g {np.round(g, 4)}  "
            f"pivots {self.oracle.lp.pivots:6d}  {elapsed:7.3f} s  {route}"
        )
        return value, g


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("rows", type=int)
    parser.add_argument("columns", type=int)
    parser.add_argument("--simplex-only", action="store_true", help="no interior point route (the baseline)")
    args = parser.parse_args()
    started = time.perf_counter()
    prepared = prepare(assembly_from_document(brick_wall(args.rows, args.columns)))
    system = prepared.system
    set_up = time.perf_counter() - started
    print(
        f"{args.rows}x{args.columns} wall: {len(prepared.contacts)} contact points, "
        f"LP {system.A.shape[0]} rows x {system.columns + 3} columns, contacts and set-up {set_up:.2f} s"
    )
    oracle = SupportOracle(system, None if args.simplex_only else FAR_PIVOTS)
    started = time.perf_counter()
    region = cone_region(_LoggedOracle(oracle), system.facets)
    total = time.perf_counter() - started
    print(f"region: {region.kind}, {len(region.normals)} facets, {region.lp_count} LPs, {total:.2f} s")
    lp = oracle.lp
    counts = {"interior_point": oracle.far_solves, "crossover": lp.crossovers, "simplex": lp.solves}
    for phase in LP_PHASES:
        print(f"  {phase:15s} {lp.seconds[phase]:7.3f} s  ({counts[phase]} runs)")
    print(f"  {'other':15s} {total - sum(lp.seconds.values()):7.3f} s  (hulls, checks, set-up)")


if __name__ == "__main__":
    main()
