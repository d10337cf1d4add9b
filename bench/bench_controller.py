"""The lockstep cell as fast as it goes: the cell scene under the reference controller in each layout.

Runs the cell scene (`feeder_cell/scenes/cell.yaml`: the three devices, their planners and the cell
controller) with `feeder launch --real-time-factor max` on its own ROS domain in three layouts: the cell
host with the controller as its own process (the default), the controller hosted too
(`--host-controller`), and one process per node (the baseline). Steady state: from the end of cycle 1 to
the end of cycle n (the controller's log stamps each cycle's end), cell seconds per wall second, cycles
per wall minute, and every process's CPU seconds per simulated second from /proc snapshots at those two
moments. In lockstep no device drops a sample (the determinism test counts them); what is measured here is
how fast. Then the demo scene with recording for 20 s of wall time. Medians of 3 interleaved runs (1 with
--quick).
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


def _processes(domain: int) -> dict[int, tuple[str, float]]:
    """CPU seconds (user + system) of every process on ROS domain ``domain``, by pid: (name, CPU s)."""
    found: dict[int, tuple[str, float]] = {}
    tick = os.sysconf("SC_CLK_TCK")
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            if f"ROS_DOMAIN_ID={domain}".encode() not in (entry / "environ").read_bytes().split(b"\0"):
                continue
            argv = (entry / "cmdline").read_bytes().decode(errors="replace").split("\0")
            fields = (entry / "stat").read_text().rpartition(")")[2].split()
        except OSError:
            continue
        name = "cell_host" if "feeder_cell.host" in argv else Path(argv[1] if len(argv) > 1 else argv[0]).name
        if name in ("main.py", "-m") or "feeder_cell.cli.main" in argv:
            name = "feeder launch"
        found[int(entry.name)] = (name, (int(fields[11]) + int(fields[12])) / tick)
    return found


def _cycle_lines(folder: Path) -> list[tuple[float, float]]:
    """(wall stamp, cell s) of each finished cycle, from the controller's log (its own or the host's)."""
    lines: list[tuple[float, float]] = []
    for log in folder.glob("*.log"):
        for match in CYCLE_LINE.finditer(log.read_text(errors="replace")):
            lines.append((float(match.group(1)), float(match.group(2))))
    return sorted(lines)


CYCLE_LINE = re.compile(r"\[(\d+\.\d+)\] \[cell\.cell_controller\]: cycle \d+: ([0-9.]+) s")


def steady_run(cycles: int, domain: int, *flags: str) -> dict[str, Any]:
    """Run the cell scene for ``cycles`` + 1 cycles at max; measure cycles 2..``cycles`` + ... steadily.

    Steady state: from the end of cycle 1 to the end of the last measured cycle (one more runs, so the
    CPU snapshot is taken while everything still runs): cell s per wall s, cycles per wall minute, and each
    process's CPU s per simulated s over that span (start-up excluded).
    """
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        scene = _scene_with(cycles + 1, folder)
        env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
        command = [*FEEDER, "launch", str(scene), "--log-dir", str(folder / "logs"), "--real-time-factor"]
        launch = subprocess.Popen(
            [*command, "max", "--json", *flags],
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        snapshots: dict[int, dict[int, tuple[str, float]]] = {}
        deadline = time.monotonic() + RUN_WALL_LIMIT_S
        try:
            while launch.poll() is None and time.monotonic() < deadline and len(snapshots) < 2:
                done = len(_cycle_lines(folder / "logs"))
                for mark in (1, cycles):
                    if done >= mark and mark not in snapshots:
                        snapshots[mark] = _processes(domain)
                time.sleep(0.02)
            launch.communicate(timeout=RUN_WALL_LIMIT_S)
        finally:
            if launch.poll() is None:
                launch.kill()
                launch.communicate()
        lines = _cycle_lines(folder / "logs")
    if len(snapshots) < 2 or len(lines) < cycles:
        raise RuntimeError(f"the cell scene did not run {cycles} cycles at max ({len(lines)} in the logs)")
    wall = lines[cycles - 1][0] - lines[0][0]
    cell = sum(cell_s for _, cell_s in lines[1:cycles])
    cpu: dict[str, float] = {}
    for pid, (process, after) in snapshots[cycles].items():
        before = snapshots[1].get(pid, (process, after))[1]
        cpu[process] = cpu.get(process, 0.0) + (after - before) / cell
    return {
        "factor": cell / wall,
        "cycles_per_minute": 60.0 * (cycles - 1) / wall,
        "mean_cycle": cell / (cycles - 1),
        "cpu": cpu,
    }


LAYOUTS = {
    "controller own process": (),
    "controller hosted": ("--host-controller",),
    "one process per node": ("--one-process-per-node",),
}
TARGETS = {"controller own process": 20.0, "controller hosted": 40.0, "one process per node": 0.0}


def _demo(domain: int) -> float:
    """The demo scene at max with recording on, 20 s of wall time: its achieved real-time factor."""
    with tempfile.TemporaryDirectory() as folder:
        env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
        launch = subprocess.run(
            [
                *(*FEEDER, "launch", str(DEMO), "--log-dir", f"{folder}/logs", "--real-time-factor", "max"),
                *("--record", f"{folder}/bag", "--duration", "20", "--json"),
            ],
            env=env,
            capture_output=True,
            text=True,
            timeout=RUN_WALL_LIMIT_S,
        )
        return float(json.loads(launch.stdout)["cell_time"]["achieved_real_time_factor"])


def run(out_dir: Path, quick: bool) -> list[dict]:
    """Return the lockstep rows: the cell scene in each layout (steady state), the demo scene recorded."""
    domain = 80 + os.getpid() % 10
    repeats = 1 if quick else 3
    cycles = 3 if quick else 4
    # Interleaved repeats: a slow spell of the shared machine falls on every layout alike.
    results: dict[str, list[dict[str, Any]]] = {layout: [] for layout in LAYOUTS}
    for _ in range(repeats):
        for layout, flags in LAYOUTS.items():
            results[layout].append(steady_run(cycles, domain, *flags))
    rows = []
    baseline = statistics.median(r["factor"] for r in results["one process per node"])
    for layout, runs in results.items():
        factor = statistics.median(r["factor"] for r in runs)
        per_minute = statistics.median(r["cycles_per_minute"] for r in runs)
        names = sorted({name for r in runs for name in r["cpu"]})
        cpu = {name: statistics.median(r["cpu"].get(name, 0.0) for r in runs) for name in names}
        target = TARGETS[layout]
        rows.append(
            row(
                "controller",
                f"cell scene at max, {layout}: steady state over cycles 2..{cycles}",
                factor,
                "x real time",
                f">= {target:g}" if target else "(baseline)",
                f"median of {repeats}; {factor / baseline:.2f}x the one-process-per-node layout in the same "
                f"run; every cycle {runs[0]['mean_cycle']:.2f} s of cell time; {per_minute:.1f} cycles per "
                "wall minute",
                factor >= target,
            )
        )
        rows.append(
            row(
                "controller",
                f"CPU s per simulated s per process at max, {layout} (steady state)",
                sum(cpu.values()),
                "CPU s / cell s",
                "(reported)",
                ", ".join(
                    f"{n} {v:.3f}" for n, v in sorted(cpu.items(), key=lambda kv: -kv[1]) if v >= 0.0005
                ),
                True,
            )
        )
    demo = statistics.median(_demo(domain) for _ in range(repeats))
    rows.append(
        row(
            "controller",
            "demo scene at --real-time-factor max with recording (20 s of wall time, lockstep, hosted)",
            demo,
            "x real time",
            ">= 20",
            f"median of {repeats}",
            demo >= 20,
        )
    )
    return rows
