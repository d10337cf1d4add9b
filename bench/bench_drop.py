"""Drop distributions (docs/experiments.md): the two fidelities' answers on the examples and their cost.

quasi_static (capture intervals, exact) against dynamic (pymunk drops, e = 0, mu = 0.5, from 0.1 mm,
seeded; tabulated afresh here, not read from the cache). Rows: each fidelity's CPU cost per part, the
triangle's largest disagreement in standard errors (it should be within sampling error), and the
bracket's short edge (the 0.7 cm side, edge 1) at both fidelities, where a shallow basin makes them
differ. 4,000 drops (1,000 with --quick).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np
from benchlib import row

from feeder_planner.parts import load_part
from feeder_planner.throwing.drop import quasi_static_drop
from feeder_planner.throwing.geometry import arm_part
from feeder_sim.throwing.drop import DropSettings, dynamic_drop

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "throwing"
QUASI_REPEATS = 200
# The issue's measurement of the bracket's short edge from 0.1 mm: 9.6 % +- 0.9 % (a 95 % interval, so a
# standard error of 0.9 / 1.96 points); met when ours is within two combined standard errors of it.
ISSUE_SHARE, ISSUE_ERROR = 0.096, 0.009 / 1.96


def run(out_dir: Path, quick: bool) -> list[dict]:
    """Return the benchmark's rows (out_dir unused: no plots)."""
    drops = 1000 if quick else 4000
    rows: list[dict] = []
    results = {}
    for name in ("triangle", "bracket"):
        part = arm_part(load_part(EXAMPLES / f"{name}.yaml"))
        started = time.process_time()
        for _ in range(QUASI_REPEATS):
            exact = quasi_static_drop(part)
        quasi_cost = (time.process_time() - started) / QUASI_REPEATS
        started = time.process_time()
        with tempfile.TemporaryDirectory() as cache:
            dynamic = dynamic_drop(part, DropSettings(drops=drops), Path(cache))
        dynamic_cost = time.process_time() - started
        results[name] = (exact, dynamic)
        rows.append(
            row(
                f"drop {name}",
                "quasi_static CPU per part",
                quasi_cost * 1e6,
                "us",
                "< 1000",
                "",
                quasi_cost < 1e-3,
            )
        )
        rows.append(
            row(
                f"drop {name}",
                f"dynamic CPU per part ({drops} drops)",
                dynamic_cost,
                "s",
                "< 60 (once, then cached)",
                f"quasi_static {quasi_cost * 1e6:.0f} us",
                dynamic_cost < 60.0,
            )
        )
    exact, dynamic = results["triangle"]
    error = np.sqrt(exact.probabilities * (1 - exact.probabilities) / dynamic.samples)
    worst = float(np.max(np.abs(dynamic.probabilities - exact.probabilities) / error))
    rows.append(
        row(
            "drop triangle",
            "largest dynamic - quasi_static difference, per edge",
            worst,
            "standard errors",
            "<= 3",
            "",
            worst <= 3,
        )
    )
    exact, dynamic = results["bracket"]
    share, se = float(dynamic.probabilities[1]), float(dynamic.standard_error[1])
    rows.append(
        row(
            "drop bracket",
            "short edge: dynamic share from 0.1 mm",
            100 * share,
            f"% (+- {100 * se:.2f})",
            "issue: 9.6 +- 0.9 (95 %)",
            f"quasi_static {100 * exact.probabilities[1]:.2f} %",
            abs(share - ISSUE_SHARE) <= 2 * float(np.hypot(se, ISSUE_ERROR)),
        )
    )
    return rows
