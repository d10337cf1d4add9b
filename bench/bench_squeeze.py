"""Squeeze gripper fidelities: the plan's success rate against friction and jaw speed, and cost per squeeze.

Goldberg's plan is certified in the ideal model (frictionless, quasi-static). The dynamic fidelity (pymunk:
Coulomb friction between pads and part, a finite jaw speed) runs the same plan from random initial
orientations; a run succeeds when it ends within SUCCESS_TOLERANCE of the plan's final orientation modulo
the symmetry period. A run whose simulation breaks down (a pad through the part) counts as a failure.
The cost per squeeze is the median wall time of one squeeze in each fidelity.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
from benchlib import median_time, row

from feeder_planner.errors import SolverError
from feeder_planner.parts import load_part
from feeder_planner.squeeze import SqueezeFunction, frictional_squeeze, plan_squeezes, squeeze_function
from feeder_sim.squeeze.dynamic import dynamic_squeeze
from feeder_sim.squeeze.ideal import ideal_squeeze

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
SUCCESS_TOLERANCE = 0.05  # rad: far inside the plan's margin (0.32 rad for the rectangle)


def _success_rate(
    part: np.ndarray,
    angles: tuple[float, ...],
    final: float,
    period: float,
    starts: np.ndarray,
    friction: float,
    speed: float,
) -> float:
    """Fraction of ``starts`` that the dynamic fidelity brings to ``final`` modulo ``period``."""
    good = 0
    for theta in starts:
        try:
            for alpha in angles:
                theta = alpha + dynamic_squeeze(part, float(theta) - alpha, friction, speed).orientation
        except SolverError:
            continue
        good += abs(math.remainder(float(theta) - final, period)) < SUCCESS_TOLERANCE
    return good / len(starts)


def _predicted_end(sf: SqueezeFunction, angles: tuple[float, ...], theta: float, mu: float) -> float:
    """The plan's end from ``theta`` in the quasi-static frictional model."""
    for alpha in angles:
        theta = alpha + frictional_squeeze(sf, theta - alpha, mu)
    return theta


def run(out_dir: Path, quick: bool) -> list[dict]:
    """The sweep, its rows and its plot (bench/results/squeeze_fidelity.png)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    count = 200 if quick else 1000
    frictions = (0.0, 0.3) if quick else (0.0, 0.3, 0.6)
    speeds = (0.05, 0.5)
    part = load_part(EXAMPLES / "squeeze" / "rectangle.yaml").outer
    sf = squeeze_function(part)
    plan = plan_squeezes(sf)
    starts = np.random.default_rng(40).uniform(0.0, 2.0 * math.pi, count)
    rates: dict[tuple[float, float], float] = {}
    for speed in speeds:
        for mu in frictions:
            rates[(mu, speed)] = _success_rate(
                part, plan.angles, plan.certificate.final, sf.period, starts, mu, speed
            )
    # The quasi-static prediction (feeder_planner.squeeze.frictional_squeeze: a squeeze jams when the
    # contact chord lies in the friction cone), on the same starts and a fine grid of friction.
    grid = np.linspace(0.0, 0.8, 81)
    predicted = [
        float(
            np.mean(
                [
                    abs(
                        math.remainder(
                            _predicted_end(sf, plan.angles, float(t), float(mu)) - plan.certificate.final,
                            sf.period,
                        )
                    )
                    < SUCCESS_TOLERANCE
                    for t in starts
                ]
            )
        )
        for mu in grid
    ]
    ideal_cost = median_time(lambda: ideal_squeeze(part, 0.3), 25)
    dynamic_cost = median_time(lambda: dynamic_squeeze(part, 0.3, 0.0, 0.1), 5 if quick else 15)
    fig, ax = plt.subplots(figsize=(5.5, 3.8))
    for speed in speeds:
        ax.plot(frictions, [rates[(mu, speed)] for mu in frictions], "o-", label=f"jaw speed {speed:g} m/s")
    ax.plot(grid, predicted, "-", color="0.3", linewidth=1, label="quasi-static friction cone")
    ax.axhline(1.0, color="0.6", linestyle=":", label="ideal (certified)")
    ax.set_xlabel("friction coefficient between jaws and part")
    ax.set_ylabel(f"plan success rate ({count} starts)")
    ax.set_ylim(-0.02, 1.05)
    ax.set_title(
        f"rectangle, plan of {len(plan.angles)}: ideal {ideal_cost * 1e6:.0f} us, "
        f"dynamic {dynamic_cost * 1e3:.1f} ms a squeeze",
        fontsize="small",
    )
    ax.legend(fontsize="small")
    fig.tight_layout()
    fig.savefig(out_dir / "squeeze_fidelity.png", dpi=120)
    plt.close(fig)
    rows = [
        row(
            "squeeze",
            f"dynamic plan success, mu {mu:g}, jaw {speed:g} m/s ({count} starts)",
            rate,
            "fraction",
            "1 at mu 0",
            "ideal 1.0",
            rate >= 0.99 if mu == 0.0 else True,
        )
        for (mu, speed), rate in rates.items()
    ]
    for mu in frictions:
        k = int(np.argmin(np.abs(grid - mu)))
        rows.append(
            row(
                "squeeze",
                f"quasi-static predicted success, mu {mu:g}",
                predicted[k],
                "fraction",
                "-",
                "-",
                True,
            )
        )
    rows.append(row("squeeze", "ideal squeeze cost", ideal_cost * 1e6, "us", "-", "-", True))
    rows.append(
        row("squeeze", "dynamic squeeze cost (mu 0, 0.1 m/s)", dynamic_cost * 1e3, "ms", "-", "-", True)
    )
    return rows


if __name__ == "__main__":
    import sys

    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("/tmp")
    started = time.perf_counter()
    for r in run(out, "--full" not in sys.argv):
        print(f"{r['measure']}: {r['value']:.4g} {r['unit']}")
    print(f"took {time.perf_counter() - started:.1f} s")
