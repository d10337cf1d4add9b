"""`make demo`: check the environment, run the planners on the papers' examples, run cell cycles, record.

Every planner step also draws its result (``--plot``) and the recorded run's timeline is drawn
(``feeder bag-plot``), all into ``bags/demo-STAMP-pictures/`` beside the bag (bags/ is not versioned);
the paths are printed at the end.
"""

from __future__ import annotations

import datetime
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FEEDER = [sys.executable, "-m", "feeder_cell.cli.main"]

# (title, picture file, feeder arguments): the planners, on example files of examples/; each step draws its
# result into the picture (--plot) in the demo's pictures folder.
PLANNER_STEPS: tuple[tuple[str, str, list[str]], ...] = (
    (
        "MEMS: a plus shape (4-fold symmetric) in the radial field plus a small constant field",
        "mems_plus_equilibria.png",
        ["equilibria", "examples/mems/plus.yaml", "--delta", "0.01"],
    ),
    (
        "MEMS: a non-symmetric bracket, one stable equilibrium",
        "mems_bracket_equilibria.png",
        ["equilibria", "examples/mems/bracket.yaml", "--delta", "0.1"],
    ),
    (
        "Throwing arm: the paper's triangle (g = -966 cm/s^2, h = -0.5 cm, 320 deg/s), its limit set",
        "throwing_triangle_limit_set.png",
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
        "Throwing arm: a small design search around the paper's design, trigger range per (h, W)",
        "throwing_triangle_design.png",
        [
            "throw-design",
            "examples/throwing/triangle.yaml",
            "--offsets",
            "-0.5",
            "0",
            "--release-speeds",
            "300deg",
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
        "assembly_cube_in_corner_region.png",
        ["stable-region", "examples/assembly/cube_in_corner.yaml", "--mu", "0"],
    ),
    (
        "Assembly fixture: a block in an L bracket with mu = 0.2 (Fig. 14)",
        "assembly_block_in_l_bracket_region.png",
        ["stable-region", "examples/assembly/block_in_l_bracket.yaml", "--mu", "0.2"],
    ),
    (
        "Assembly fixture: the block in the L bracket tilted 45 deg, its contact forces",
        "assembly_block_in_l_bracket_forces.png",
        [
            "check-stability",
            "examples/assembly/block_in_l_bracket.yaml",
            "--mu",
            "0.2",
            "--g",
            "-1",
            "0",
            "-1",
        ],
    ),
)
# The cell: every device, planner and the reference controller, on one lockstep cell clock as fast as they
# allow (the launch prints the factor it achieved). The controller runs the scene's cycles and exits;
# with it the launch ends (on_exit: shutdown).
SCENE = ROOT / "feeder_cell" / "scenes" / "cell.yaml"
REAL_TIME_FACTOR = "max"
# A bound on the whole cell step, should the controller never end (every wait of its own is bounded).
SCENE_MAX_SECONDS = "600"


# The last step: a small production experiment on the ROS-free cell loop (docs/experiments.md): sequential
# against pipelined control, with random arrivals and parts lost now and then, 4 replications each.
EXPERIMENT = ROOT / "examples" / "experiments" / "policy.yaml"


def step(title: str, args: list[str]) -> bool:
    print(f"\n== {title}\n$ feeder {' '.join(args)}", flush=True)
    result = subprocess.run([*FEEDER, *args], cwd=ROOT)
    if result.returncode != 0:
        print(f"!! step failed with exit status {result.returncode}", flush=True)
    return result.returncode == 0


def print_cycle_metrics(logs: Path) -> bool:
    """Print the controller's cycle lines and its end (its log, one line per cycle); False if none."""
    found = sorted(logs.glob("cell.cell_controller-*.log"))
    print("\n== The cycle metrics (the cell controller's log)", flush=True)
    if not found:
        print(f"!! no cell controller log in {logs}", flush=True)
        return False
    lines = [
        line.strip()
        for line in found[-1].read_text(errors="replace").splitlines()
        if any(key in line for key in ("]: cycle ", "cell FINISHED", "cell STOPPED", "-> RETRY", "-> RESET"))
    ]
    print("\n".join(lines) or "!! the controller logged no cycle", flush=True)
    return any("cell FINISHED" in line for line in lines)


def print_pictures(pictures: Path) -> bool:
    """Print the path of every picture the demo drew; False if there is none."""
    found = sorted(pictures.glob("*.png"))
    print(f"\n== Pictures ({len(found)}): open them with any image viewer", flush=True)
    for path in found:
        print(f"  {path.relative_to(ROOT)}", flush=True)
    return bool(found)


def main() -> int:
    # A private domain unless the user chose one: the demo must not drive someone else's cell.
    os.environ.setdefault("ROS_DOMAIN_ID", str(100 + os.getpid() % 50))
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    if not step("Environment check", ["doctor"]):
        return 1
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y%m%d-%H%M%S")
    bag = ROOT / "bags" / f"demo-{stamp}"
    pictures = ROOT / "bags" / f"demo-{stamp}-pictures"
    pictures.mkdir(parents=True, exist_ok=True)
    ok = all(
        [
            step(title, [*args, "--plot", str((pictures / name).relative_to(ROOT))])
            for title, name, args in PLANNER_STEPS
        ]
    )
    if not SCENE.is_file():
        print(f"!! the cell scene {SCENE.relative_to(ROOT)} is missing", flush=True)
        return 1
    logs = Path(tempfile.mkdtemp(prefix="feeder-demo-"))
    ok &= step(
        "The cell: devices, planners and the cell controller in lockstep, as fast as they go, recorded",
        [
            "launch",
            str(SCENE.relative_to(ROOT)),
            "--real-time-factor",
            REAL_TIME_FACTOR,
            "--duration",
            SCENE_MAX_SECONDS,
            "--record",
            str(bag.relative_to(ROOT)),
            "--log-dir",
            str(logs),
        ],
    )
    ok &= print_cycle_metrics(logs)
    if bag.exists():
        ok &= step("What was recorded", ["bag-info", str(bag.relative_to(ROOT))])
        timeline = pictures / "cell_timeline.png"
        ok &= step(
            "The recorded run's timeline",
            ["bag-plot", str(bag.relative_to(ROOT)), "--output", str(timeline.relative_to(ROOT))],
        )
        print(f"\nReplay it with: source env.sh && feeder play {bag.relative_to(ROOT)}")
    else:
        print(f"!! no bag at {bag.relative_to(ROOT)}", flush=True)
        ok = False
    results = pictures / "policy"
    ok &= step(
        "A production experiment without ROS: parts per hour, sequential against pipelined control",
        [
            "experiment",
            str(EXPERIMENT.relative_to(ROOT)),
            "--quiet",
            "--results",
            str(results.with_suffix(".csv").relative_to(ROOT)),
            "--report",
            str(results.with_suffix(".md").relative_to(ROOT)),
            "--plot",
            str(results.with_suffix(".png").relative_to(ROOT)),
        ],
    )
    ok &= print_pictures(pictures)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
