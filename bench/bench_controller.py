"""The lockstep cell as fast as it goes: the cell scene under the reference controller, the demo scene.

Runs the cell scene (`feeder_cell/scenes/cell.yaml`: the three devices, their planners and the cell
controller) with `feeder launch --real-time-factor max --json` on its own ROS domain; the launch ends
when the controller has run its cycles (on_exit: shutdown). From the launch's summary: the real-time
factor achieved (cell seconds over wall seconds after the first quantum) and every node's CPU seconds;
from the controller's log: the cycles and their cell times. In lockstep no device drops a sample (the
determinism test counts them); what is measured here is how fast. Then the demo scene for 20 s of wall
time. Medians of 3 runs (1 with --quick).
"""

from __future__ import annotations

import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from benchlib import row

from feeder_cell.launcher import scene_copy

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "feeder_cell" / "scenes" / "cell.yaml"
FEEDER = [sys.executable, "-m", "feeder_cell.cli.main"]
DEMO = ROOT / "feeder_cell" / "scenes" / "demo.yaml"
RUN_WALL_LIMIT_S = 240.0


def _scene_with(cycles: int, folder: Path) -> Path:
    """Write the cell scene with the controller's cycle count set (paths made absolute)."""
    return scene_copy(SCENE, folder, {"cell_controller": {"cycles": cycles}})


def _launch(scene: Path, folder: str, domain: int, *extra: str) -> tuple[dict[str, Any], float]:
    """Run ``feeder launch SCENE --real-time-factor max --json``; return its summary and the wall time."""
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    started = time.monotonic()
    launch = subprocess.run(
        [*FEEDER, "launch", str(scene), "--log-dir", folder, "--real-time-factor", "max", "--json", *extra],
        env=env,
        capture_output=True,
        text=True,
        timeout=RUN_WALL_LIMIT_S,
    )
    wall = time.monotonic() - started
    if launch.returncode != 0 and not launch.stdout.strip():
        raise RuntimeError(f"feeder launch failed: {launch.stderr.strip().splitlines()[-1:]}")
    return json.loads(launch.stdout), wall


def _cycles(folder: str) -> tuple[int, float]:
    """Cycles completed and the mean cycle time (cell s), from the controller's log."""
    log = next(Path(folder).glob("cell.cell_controller-*.log")).read_text()
    times = [float(m) for m in re.findall(r"\]: cycle \d+: ([0-9.]+) s", log)]
    return len(times), (statistics.mean(times) if times else float("nan"))


def _cpu_per_cell_second(summary: dict[str, Any]) -> dict[str, float]:
    """CPU seconds per simulated second per node (start-up included: it is part of a controller test)."""
    cell = summary["cell_time"]["cell_s"]
    return {
        n["name"].rsplit("/", 1)[1]: n["cpu_s"] / cell
        for n in summary["nodes"]
        if n.get("cpu_s") and cell > 0
    }


def run(out_dir: Path, quick: bool) -> list[dict]:
    """Return the lockstep rows: the cell scene and the demo scene at max, medians of repeats."""
    domain = 80 + os.getpid() % 10
    repeats = 1 if quick else 3
    cycles = 2 if quick else 3
    cell: list[dict[str, Any]] = []
    for _ in range(repeats):
        with tempfile.TemporaryDirectory() as folder:
            summary, wall = _launch(_scene_with(cycles, Path(folder)), folder, domain)
            done, mean_cycle = _cycles(folder)
            cell.append(
                {
                    "factor": summary["cell_time"]["achieved_real_time_factor"],
                    "cycles_per_minute": 60.0 * done / wall,
                    "cycles": done,
                    "mean_cycle": mean_cycle,
                    "cpu": _cpu_per_cell_second(summary),
                }
            )
    factor = statistics.median(r["factor"] for r in cell)
    per_minute = statistics.median(r["cycles_per_minute"] for r in cell)
    finished = all(r["cycles"] == cycles for r in cell)
    cpu = {name: statistics.median(r["cpu"].get(name, 0.0) for r in cell) for name in cell[0]["cpu"]}
    demo: list[float] = []
    for _ in range(repeats):
        with tempfile.TemporaryDirectory() as folder:
            summary, _ = _launch(DEMO, folder, domain, "--duration", "20")
            demo.append(summary["cell_time"]["achieved_real_time_factor"])
    return [
        row(
            "controller",
            f"cell scene, reference controller, --real-time-factor max ({cycles} cycles, lockstep)",
            factor,
            "x real time",
            ">= 20",
            f"median of {repeats}; every cycle {cell[0]['mean_cycle']:.2f} s of cell time; before lockstep "
            "below 1x",
            factor >= 20 and finished,
        ),
        row(
            "controller",
            "cycles per wall minute at max (start-up and bring-up included)",
            per_minute,
            "cycles/min",
            "(reported)",
            "before lockstep 3.5 at factor 1",
            finished,
        ),
        row(
            "controller",
            "CPU s per simulated s, per node, at max (start-up included)",
            sum(cpu.values()),
            "CPU s / cell s",
            "(reported)",
            ", ".join(f"{name} {value:.3f}" for name, value in sorted(cpu.items(), key=lambda kv: -kv[1])),
            True,
        ),
        row(
            "controller",
            "demo scene at --real-time-factor max (20 s of wall time, lockstep)",
            statistics.median(demo),
            "x real time",
            ">= 30",
            f"median of {repeats}",
            statistics.median(demo) >= 30,
        ),
    ]
