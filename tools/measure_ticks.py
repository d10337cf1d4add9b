"""CPU time of cell-scene-like simulation per model, ROS-free: where issue 23's "cheap ticks" are measured.

Drives each model the way its node's tick does, without ROS, for ``--seconds`` of cell time, three times,
and prints the median CPU seconds (``time.process_time``, this process only):

* ``mems-demo``: the demo scene's array (its squeeze, quadratic, combined program; 5e-4 s), likewise.
* ``mems``: the cell scene's array (``feeder_cell/scenes/cell.yaml``: the plus, seed 7, ideal model,
  ``time_step`` 2.5e-3 s, drag 1) under the reference controller's program (one combined field, delta 0.2),
  ticked at 20 Hz in whole steps; a new batch every ``--cycle`` s (``reset_parts``, as ``~/place_parts``
  with ``reset: true`` does), so a cycle is a settle and then the part at rest while the others work.
* ``fixture``: the cell's fixture (built-in assembly, default parameters) ticked at 20 Hz, each tick the
  stability verdict at the table's true gravity (what ``~/stability`` publishes); per cycle one tilt to
  the cell scene's ``fixture_route`` and back, the table still the rest of the cycle.

Usage: ``python tools/measure_ticks.py [--seconds 120] [--cycle 30] [--repeats 3]``.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from feeder_planner.assembly import check_result, prepare
from feeder_planner.assembly.parameters import load_assembly_parameter
from feeder_planner.fields_io import load_yaml_mapping
from feeder_planner.mems import CombinedField, ProgramStep, program_from_mapping
from feeder_planner.parts import load_part
from feeder_sim.fixture.table import Table
from feeder_sim.mems import Body, Scene, random_poses
from feeder_sim.mems.placing import reset_parts

try:  # the cache this measurement was written for; before it, every tick solves the LP
    from feeder_sim.fixture.stability import stability_result as _stability
except ImportError:  # pragma: no cover - the "before" tree
    _stability = check_result

ROOT = Path(__file__).resolve().parents[1]
TICK = 0.05  # s: both devices' default publish_rate, 20 Hz
MEMS_STEP = 2.5e-3  # s: the cell scene's time_step
ROUTE = np.array([-0.5, 0.0, -0.8660254037844386])  # the cell scene's fixture_route


def mems_run(seconds: float, cycle: float) -> dict[str, Any]:
    """Tick the cell scene's array for ``seconds`` of cell time; return what it did."""
    program = (ProgramStep(CombinedField(0.2), math.inf),)
    return _mems(program, random_poses(1, 1e-3, 7), MEMS_STEP, seconds, cycle)


def mems_demo_run(seconds: float, cycle: float) -> dict[str, Any]:
    """The demo scene's array (its program file, seed 0, time_step 5e-4 s), a new part every cycle."""
    document = load_yaml_mapping(str(ROOT / "examples" / "mems" / "program_squeeze_then_orient.yaml"))
    return _mems(program_from_mapping(document), random_poses(1, 1e-3, 0), 5e-4, seconds, cycle)


def _mems(
    program: tuple[ProgramStep, ...], initial: np.ndarray, step: float, seconds: float, cycle: float
) -> dict[str, Any]:
    part = load_part(str(ROOT / "examples" / "mems" / "plus.yaml"))
    scene = Scene([Body(part, initial[0].copy())], program, "ideal")
    step_ns, owed, ticks = round(step * 1e9), 0, round(seconds / TICK)
    per_cycle = round(cycle / TICK)
    for tick in range(ticks):
        if tick % per_cycle == 0:
            reset_parts(scene, initial)
            scene.set_program(program)  # the controller's ~/run_program installs its program each cycle
        owed += round(TICK * 1e9)
        steps, owed = divmod(owed, step_ns)
        for _ in range(steps):
            scene.step(step)
    return {
        "pose": scene.bodies[0].pose.tolist(),
        "evaluations": getattr(getattr(scene, "stepper", None), "evaluations", None),
        "stiff_steps": scene.stiff_steps,
    }


def fixture_run(seconds: float, cycle: float) -> dict[str, Any]:
    """Tick the cell's fixture for ``seconds``: one tilt out and back per cycle, the verdict every tick."""
    prepared = prepare(load_assembly_parameter(""))
    from feeder_sim.fixture.parameters import FixtureParameters, table_limits

    table = Table(np.zeros(2), table_limits(FixtureParameters()))
    home = table.gravity()
    ticks, per_cycle, stable = round(seconds / TICK), round(cycle / TICK), 0
    for tick in range(ticks):
        if tick % per_cycle == 0:
            table.start(table.plan(np.array([home, ROUTE / np.linalg.norm(ROUTE)])))
        elif tick % per_cycle == per_cycle // 2 and not table.moving:
            table.start(table.plan(np.array([table.gravity(), home])))
        table.advance(TICK)
        stable += bool(_stability(prepared, table.gravity()).stable)
    return {"stable_ticks": stable, "ticks": ticks}


def cpu(run: Callable[[float, float], dict[str, Any]], seconds: float, cycle: float) -> tuple[float, Any]:
    """Return the CPU seconds of one run and its report."""
    start = time.process_time()
    report = run(seconds, cycle)
    return time.process_time() - start, report


def main() -> None:
    """Print the median CPU time of each model over the repeats."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=120.0, help="cell time simulated per run (s)")
    parser.add_argument("--cycle", type=float, default=30.0, help="cell time of one production cycle (s)")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    for name, run in (("mems", mems_run), ("mems-demo", mems_demo_run), ("fixture", fixture_run)):
        times, report = [], None
        for _ in range(args.repeats):
            seconds, report = cpu(run, args.seconds, args.cycle)
            times.append(seconds)
        median = statistics.median(times)
        print(
            f"{name:9s} {args.seconds:g} s of cell time: CPU median {median:.3f} s "
            f"({median / args.seconds * 1e3:.2f} ms per simulated s; "
            f"runs {', '.join(f'{t:.3f}' for t in times)}) "
            f"{report}"
        )


if __name__ == "__main__":
    main()
