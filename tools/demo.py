"""`make demo`: check the environment, run each planner on the papers' examples, then run the cell and record it."""

from __future__ import annotations

import datetime
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FEEDER = [sys.executable, "-m", "feeder_planner.cli.main"]

# (title, feeder arguments): the planners, on example files of examples/.
PLANNER_STEPS: tuple[tuple[str, list[str]], ...] = ()
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
        ok &= step("The cell: every simulator and planner node, recorded",
                   ["launch", str(SCENE.relative_to(ROOT)), "--duration", SCENE_SECONDS, "--record", str(bag.relative_to(ROOT))])
        if bag.exists():
            ok &= step("What was recorded", ["bag-info", str(bag.relative_to(ROOT))])
            print(f"\nReplay it with: source env.sh && feeder play {bag.relative_to(ROOT)}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
