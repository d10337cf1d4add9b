"""`make demo`: check the environment, run each planner on the papers' examples, run the cell, record it."""

from __future__ import annotations

import datetime
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FEEDER = [sys.executable, "-m", "feeder_cell.cli.main"]

# (title, feeder arguments): the planners, on example files of examples/.
PLANNER_STEPS: tuple[tuple[str, list[str]], ...] = (
    (
        "MEMS: a plus shape (4-fold symmetric) in the radial field plus a small constant field",
        ["equilibria", "examples/mems/plus.yaml", "--delta", "0.01"],
    ),
    (
        "MEMS: a non-symmetric bracket, one stable equilibrium",
        ["equilibria", "examples/mems/bracket.yaml", "--delta", "0.1"],
    ),
    (
        "Throwing arm: the paper's triangle (g = -966 cm/s^2, h = -0.5 cm, 320 deg/s), its limit set",
        [
            "limit-set",
            "examples/throwing/triangle.yaml",
            "--offset",
            "-0.5",
            "--release-speed",
            "320deg",
            "--gravity",
            "-966",
            "--mu",
            "0.5",
            "--goal-edge",
            "1",
        ],
    ),
    (
        "Assembly fixture: a cube in a corner, frictionless (the octant of Fig. 11)",
        ["stable-region", "examples/assembly/cube_in_corner.yaml", "--mu", "0"],
    ),
    (
        "Assembly fixture: a block in an L bracket with mu = 0.2 (Fig. 14)",
        ["stable-region", "examples/assembly/block_in_l_bracket.yaml", "--mu", "0.2"],
    ),
)
SCENE = ROOT / "examples" / "scenes" / "demo.yaml"
SCENE_SECONDS = "20"


def step(title: str, args: list[str]) -> bool:
    print(f"\n== {title}\n$ feeder {' '.join(args)}", flush=True)
    result = subprocess.run([*FEEDER, *args], cwd=ROOT)
    if result.returncode != 0:
        print(f"!! step failed with exit status {result.returncode}", flush=True)
    return result.returncode == 0


def main() -> int:
    # A private domain unless the user chose one: the demo must not drive someone else's cell.
    os.environ.setdefault("ROS_DOMAIN_ID", str(100 + os.getpid() % 50))
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    if not step("Environment check", ["doctor"]):
        return 1
    ok = all([step(title, args) for title, args in PLANNER_STEPS])
    if SCENE.is_file():
        stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y%m%d-%H%M%S")
        bag = ROOT / "bags" / f"demo-{stamp}"
        ok &= step(
            "The cell: every simulator and planner node, recorded",
            [
                "launch",
                str(SCENE.relative_to(ROOT)),
                "--duration",
                SCENE_SECONDS,
                "--record",
                str(bag.relative_to(ROOT)),
            ],
        )
        if bag.exists():
            ok &= step("What was recorded", ["bag-info", str(bag.relative_to(ROOT))])
            print(f"\nReplay it with: source env.sh && feeder play {bag.relative_to(ROOT)}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
