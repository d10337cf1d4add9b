"""`feeder experiment` on the ROS-free loop: the file's checks, common random numbers, the table, the report.

No ROS here (the loop imports no rclpy); the equivalence with the ROS cell is
tests/experiment/test_loop_equivalence_ros.py, the Dask runs tests/experiment/test_experiment_dask.py.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
import yaml

from feeder_cell.experiment import experiment as ex
from feeder_cell.experiment.loop import read_scene, scene_loop
from feeder_cell.launcher import scene_copy
from feeder_planner.errors import InputError

ROOT = Path(__file__).resolve().parents[2]
SCENE = str(ROOT / "feeder_cell/scenes/cell.yaml")
ARRIVALS = {
    "mems": {"orientation": "uniform", "feed_area": {"x": [-0.001, 0.001], "y": [-0.001, 0.001]}},
    "arm": {"drop": "quasi_static", "radius": [0.115, 0.125]},
}


def _file(tmp_path: Path, **fields: Any) -> Path:
    document = {"scene": SCENE, "seed": 3, "arrivals": ARRIVALS, "replications": 2, "horizon": {"cycles": 2}}
    document.update(fields)
    document = {key: value for key, value in document.items() if value is not None}  # None: left out
    path = tmp_path / "exp.yaml"
    path.write_text(yaml.safe_dump(document))
    return path


def _run(path: Path, results: Path) -> ex.Results:
    experiment = ex.load_experiment(path)
    table = ex.Results(results, experiment)
    ex.run_local(experiment, table)
    return table


@pytest.mark.parametrize(
    ("fields", "field", "words"),
    [
        ({"factors": {"welder.speed": [1]}}, "factors.welder.speed", "names no node"),
        ({"factors": {"throwing_arm.speed": [1]}}, "factors.throwing_arm.speed", "no parameter 'speed'"),
        ({"factors": {"throwing_arm.period": []}}, "factors.throwing_arm.period", "non-empty list"),
        ({"factors": {"throwing_arm.period": [0.5, -1.0]}}, "factors.throwing_arm.period[1]", "period"),
        ({"factors": {"cell_controller.cycles": ["two"]}}, "factors.cell_controller.cycles[0]", "like 1"),
        (
            {"faults": {"throwing_arm": {"fault": "part_lost", "mtbf": -5, "mttr": 1}}},
            "faults.throwing_arm.mtbf",
            ">",
        ),
        # the squeeze gripper as orienter has no model in the loop: refused naming the parameter
        (
            {"factors": {"cell_controller.orienter": ["squeeze"]}},
            "factors.cell_controller.orienter",
            "orienter",
        ),
        ({"replications": 0}, "replications", "integer in [1"),
        ({"horizon": {"cycles": 2, "time": 5}}, "horizon", "{cycles: N} or {time: S}"),
        ({"warmup": {"time": -1}}, "warmup.time", "in [0"),
        ({"speed": 3}, "speed", "is not a field"),
        ({"scene": "nowhere.yaml"}, "scene", "no such file"),
        (
            {"factors": {"throwing_arm.period": [0.5]}, "baseline": {"throwing_arm.period": 0.3}},
            "baseline",
            "levels",
        ),
    ],
)
def test_bad_input_names_its_field(tmp_path: Path, fields: dict[str, Any], field: str, words: str) -> None:
    """Each bad value is an InputError naming the field (and the file), before anything runs."""
    with pytest.raises(InputError) as caught:
        ex.load_experiment(_file(tmp_path, **fields))
    assert caught.value.field.startswith(field), str(caught.value)
    assert words in str(caught.value), str(caught.value)
    assert "exp.yaml" in str(caught.value)


def test_the_command_refuses_bad_input_in_one_line(tmp_path: Path) -> None:
    """`feeder experiment` with an unknown factor: one line on stderr naming it, exit 2, no table."""
    path = _file(tmp_path, factors={"throwing_arm.speed": [1.0]})
    result = subprocess.run(
        [sys.executable, "-m", "feeder_cell.cli.main", "experiment", str(path)],
        capture_output=True,
        text=True,
        timeout=120,
        env=dict(os.environ),
    )
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "factors.throwing_arm.speed" in lines[0], result.stderr
    assert not (tmp_path / "exp.results.csv").exists()


def test_a_row_is_the_loop_run_after_the_warm_up(tmp_path: Path) -> None:
    """Warm-up 1 cycle, horizon 2: the row's cycle times are cycles 2 and 3 of the loop's own run."""
    path = _file(tmp_path, replications=1, warmup={"cycles": 1})
    table = _run(path, tmp_path / "r.csv")
    (row,) = table.rows.values()
    scene_file = scene_copy(Path(SCENE), tmp_path, {})  # its part paths made absolute
    document = yaml.safe_load(scene_file.read_text())
    scene_file.write_text(yaml.safe_dump({**document, "seed": 3, "arrivals": ARRIVALS}))
    loop = scene_loop(read_scene(scene_file), 0, {"cell_controller": {"cycles": 3}}).run()
    times = [f"{c.time:.3f}" for c in loop.cycles[1:]]
    assert row["status"] == "ok" and row["cycle_times"].split(";") == times
    assert int(row["good"]) == 2 and int(row["cycles"]) == 2
    assert math.isclose(float(row["window_s"]), sum(c.time for c in loop.cycles[1:]), abs_tol=1e-6)
    shares = json.loads(row["shares"])
    for device in ("mems_field_array", "throwing_arm", "assembly_fixture"):
        assert math.isclose(sum(shares[device].values()), 1.0, abs_tol=1e-9)
    # Throughput is 3600 good parts over the window.
    assert math.isclose(ex._throughput(row), 3600 * 2 / float(row["window_s"]))


def test_common_random_numbers_make_a_factor_without_effect_a_zero_difference(tmp_path: Path) -> None:
    """A factor that changes nothing (a longer step bound): each replication's rows agree exactly, the
    paired difference is 0 with a 0 interval, while the replications themselves differ (random parts)."""
    path = _file(tmp_path, factors={"cell_controller.step_timeout": [120.0, 130.0]}, replications=3)
    table = _run(path, tmp_path / "r.csv")
    experiment = ex.load_experiment(path)
    for r in range(3):
        a, b = table.rows[(0, r)], table.rows[(1, r)]
        assert a["cycle_times"] == b["cycle_times"] and a["good"] == b["good"]
    assert len({table.rows[(0, r)]["cycle_times"] for r in range(3)}) > 1
    levels = ex.report(experiment, table)
    assert levels[1].difference is not None
    mean, half, n = levels[1].difference
    assert (mean, half, n) == (0.0, 0.0, 3)
    assert levels[0].difference is None and math.isfinite(levels[0].throughput[1])


def test_an_interrupted_experiment_resumes_where_it_stopped(tmp_path: Path) -> None:
    """Rows of a finished run, cut to the first: run again, the missing rows come back the same."""
    path = _file(tmp_path, replications=3)
    full = _run(path, tmp_path / "full.csv")
    lines = (tmp_path / "full.csv").read_text().splitlines(keepends=True)
    (tmp_path / "cut.csv").write_text("".join(lines[:2]))
    resumed = _run(path, tmp_path / "cut.csv")
    assert ex.sorted_rows_text(resumed) == ex.sorted_rows_text(full)
    assert len((tmp_path / "cut.csv").read_text().splitlines()) == 4  # header and three rows, none twice
    # a table of another experiment is refused naming --results
    other = _file(tmp_path, replications=3, seed=4)
    with pytest.raises(InputError) as caught:
        ex.Results(tmp_path / "full.csv", ex.load_experiment(other))
    assert caught.value.field == "--results"


def test_a_replication_that_raises_is_recorded_and_the_experiment_goes_on(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Replication 1 raises: its row says failed with the seed and the reason; 0 and 2 are ok."""
    real = ex.run_replication

    def flaky(*arguments: Any) -> dict[str, Any]:
        if arguments[3] == 1:
            raise ZeroDivisionError("a bug in replication 1")
        return real(*arguments)

    monkeypatch.setattr(ex, "run_replication", flaky)
    path = _file(tmp_path, replications=3)
    table = _run(path, tmp_path / "r.csv")
    assert [table.rows[(0, r)]["status"] for r in range(3)] == ["ok", "failed", "ok"]
    failed = table.rows[(0, 1)]
    assert "ZeroDivisionError: a bug in replication 1" in failed["reason"] and failed["seed"] == "3"
    (level,) = ex.report(ex.load_experiment(path), table)
    assert level.replications == 2 and "replication 1 (seed 3)" in level.failed[0]


def test_student_t_intervals() -> None:
    """t(0.975) for 1 and 9 degrees of freedom, and an interval computed by hand."""
    assert math.isclose(ex.t_quantile_975(1), 12.7062047, rel_tol=1e-7)
    assert math.isclose(ex.t_quantile_975(9), 2.2621572, rel_tol=1e-7)
    mean, half, n = ex.interval([1.0, 2.0, 3.0, 4.0])
    assert (mean, n) == (2.5, 4)
    assert math.isclose(half, ex.t_quantile_975(3) * math.sqrt(5 / 3) / 2)
    assert math.isnan(ex.interval([1.0])[1])


def test_a_time_horizon_ends_at_the_first_cycle_end_after_it(tmp_path: Path) -> None:
    """horizon {time: 30}: the measured window is at least 30 s, and less than 30 s plus one cycle."""
    path = _file(tmp_path, replications=1, horizon={"time": 30.0})
    (row,) = _run(path, tmp_path / "r.csv").rows.values()
    times = [float(t) for t in row["cycle_times"].split(";")]
    window = float(row["window_s"])
    assert window >= 30.0 and window - times[-1] < 30.0


def test_ctrl_c_keeps_every_finished_replication(tmp_path: Path) -> None:
    """SIGINT once two rows are in the table: exit 130, one line, the rows kept whole; a rerun resumes."""
    import signal
    import time

    path = _file(tmp_path, replications=40)
    command = [sys.executable, "-m", "feeder_cell.cli.main", "experiment", str(path), "--quiet"]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    table = tmp_path / "exp.results.csv"
    try:
        deadline = time.monotonic() + 240
        while time.monotonic() < deadline:
            if table.exists() and len(table.read_text().splitlines()) >= 3:
                break
            time.sleep(0.2)
        process.send_signal(signal.SIGINT)
        _, stderr = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    assert process.returncode == 130, stderr
    assert "interrupted" in stderr and "run again to resume" in stderr
    experiment = ex.load_experiment(path)
    kept = ex.Results(table, experiment)  # parses: every row whole
    assert 2 <= len(kept.rows) < 40
    assert all(row["status"] == "ok" for row in kept.rows.values())
    assert sorted(kept.rows) == [(0, r) for r in range(len(kept.rows))]


def test_the_picture_and_the_main_effects(tmp_path: Path) -> None:
    """One factor: each level's main effect is that scenario's throughput and interval; the PNG is written."""
    from feeder_cell.experiment.plot import cost_points, experiment_figure, main_effects
    from feeder_cell.plots.common import write_figure

    path = _file(tmp_path, factors={"throwing_arm.period": [0.5, 0.4]})
    table = _run(path, tmp_path / "r.csv")
    experiment = ex.load_experiment(path)
    levels = ex.report(experiment, table)
    effects = main_effects(experiment, table)["throwing_arm.period"]
    for (level, mean, half), report in zip(effects, levels, strict=True):
        assert level == report.scenario.levels["throwing_arm.period"]
        assert math.isclose(mean, report.throughput[0]) and math.isclose(half, report.throughput[1])
    # The estimate-against-cost panel: each scenario's throughput beside its CPU per replication.
    points = cost_points(levels)
    assert [label for label, *_ in points] == [level.scenario.label() for level in levels]
    for (_, cpu, mean, half), level in zip(points, levels, strict=True):
        assert cpu == level.cpu and cpu > 0 and (mean, half) == level.throughput[:2]
    picture = write_figure(experiment_figure(experiment, table, levels), tmp_path / "exp.png")
    assert picture.stat().st_size > 10_000 and picture.read_bytes()[:4] == b"\x89PNG"


def test_a_cell_that_stops_ends_its_replication_with_the_time_lost(tmp_path: Path) -> None:
    """power_loss on the array at +20 s (fixed): cycle 2's ORIENT meets it, the policy stops the cell; the
    row says why, counts cycle 1's part good and none rejected, and keeps cycle 2's time as lost."""
    faults = {"mems_field_array": {"fault": "power_loss", "mtbf": 20.0, "mttr": 1.0, "distribution": "fixed"}}
    path = _file(tmp_path, replications=1, faults=faults, horizon={"cycles": 3}, arrivals=None)
    (row,) = _run(path, tmp_path / "r.csv").rows.values()
    assert row["status"] == "ok" and row["end_state"].startswith("STOPPED: ORIENT: FAULT 201"), row
    assert (row["cycles"], row["good"], row["rejected"]) == ("1", "1", "0")
    assert row["cycle_times"] == "17.100"
    assert 20.0 <= float(row["window_s"]) <= 20.5, row["window_s"]
    (level,) = ex.report(ex.load_experiment(path), ex.Results(tmp_path / "r.csv", ex.load_experiment(path)))
    assert math.isclose(level.performance * (float(row["window_s"]) - float(row["down_s"])), 17.1)
