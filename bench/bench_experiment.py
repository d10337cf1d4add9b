"""Production experiments (docs/experiments.md): the ROS-free cell loop's speed and Dask's scaling.

Issue 38 item 8's rows, on the cell scene at its default fidelity (the ideal array at a 2.5 ms step, the
paper model on the arm), with arrivals and a part_lost process on the arm:

- cell time per CPU second of one process (target: at least 100x real time per worker);
- two Dask workers (a LocalCluster) against one process on the same replications (target: 1.7x), the
  wall time of the work, the cluster's start not counted;
- the wall time of 1,000 cycles with arrivals and faults on two workers (target: at most 3 minutes);
  with --quick 100 cycles, the row scaled to 1,000 and saying so.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import yaml
from benchlib import row

from feeder_cell.experiment import experiment as ex
from feeder_cell.experiment.loop import read_scene, scene_loop

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "feeder_cell" / "scenes" / "cell.yaml"
ARRIVALS = {
    "mems": {"orientation": "uniform", "feed_area": {"x": [-1.0e-3, 1.0e-3], "y": [-1.0e-3, 1.0e-3]}},
    "arm": {"drop": "quasi_static", "radius": [0.115, 0.125]},
}
FAULTS = {"throwing_arm": {"fault": "part_lost", "mtbf": 120.0, "mttr": 5.0}}


def _experiment(folder: Path, replications: int, cycles: int) -> ex.Experiment:
    document = {
        "scene": str(SCENE),
        "seed": 5,
        "arrivals": ARRIVALS,
        "faults": FAULTS,
        "replications": replications,
        "horizon": {"cycles": cycles},
    }
    path = folder / "bench.yaml"
    path.write_text(yaml.safe_dump(document))
    return ex.load_experiment(path)


def run(out_dir: Path, quick: bool) -> list[dict]:
    """Return the benchmark's rows (out_dir unused: no plots)."""
    rows: list[dict] = []
    scene = read_scene(SCENE)
    cycles = 4 if quick else 10
    started = time.process_time()
    result = scene_loop(scene, 0, {"cell_controller": {"cycles": cycles}}).run()
    cpu = time.process_time() - started
    factor = result.cell_time / cpu
    rows.append(
        row(
            "experiment loop",
            f"cell time per CPU second, one process ({cycles} cycles)",
            factor,
            "x real time",
            ">= 100",
            f"ROS lockstep at max: about 3x; {result.cell_time:.0f} s in {cpu:.1f} CPU s",
            factor >= 100.0,
        )
    )
    # The same replications in one process and on two workers: 8 replications of 10 cycles (2 x 5 quick).
    replications, per = (4, 5) if quick else (8, 10)
    with tempfile.TemporaryDirectory() as folder:
        experiment = _experiment(Path(folder), replications, per)
        one = ex.Results(Path(folder) / "one.csv", experiment)
        started = time.perf_counter()
        ex.run_local(experiment, one)
        single = time.perf_counter() - started
        two = ex.Results(Path(folder) / "two.csv", experiment)
        timings: list[float] = []
        _run_on_two(experiment, two, timings)
        double = timings[0]
        same = ex.sorted_rows_text(one) == ex.sorted_rows_text(two)
    speedup = single / double
    rows.append(
        row(
            "experiment dask",
            f"two workers against one process ({replications} replications x {per} cycles)",
            speedup,
            "x",
            ">= 1.7 (rows identical)",
            f"one process {single:.1f} s, two workers {double:.1f} s; rows identical: {same}",
            speedup >= 1.7 and same,
        )
    )
    # 1,000 cycles with arrivals and faults on two workers (100 quick, scaled), as 10 replications.
    total = 100 if quick else 1000
    with tempfile.TemporaryDirectory() as folder:
        experiment = _experiment(Path(folder), 10, total // 10)
        timings = []
        _run_on_two(experiment, ex.Results(Path(folder) / "t.csv", experiment), timings)
    wall = timings[0] * 1000 / total
    rows.append(
        row(
            "experiment 1000 cycles",
            "wall time on two workers, arrivals and faults" + (" (100 cycles x 10)" if quick else ""),
            wall,
            "s",
            "<= 180",
            "",
            wall <= 180.0,
        )
    )
    return rows


def _run_on_two(experiment: ex.Experiment, results: ex.Results, timings: list[float]) -> None:
    """Run on a LocalCluster of two workers; append the work's wall time (submission to the last row)."""
    _, work = ex.run_dask(experiment, results, 2, None)
    timings.append(work)
