"""`feeder experiment` on Dask: a real `dask scheduler` and two `dask worker` processes on this machine.

Issue 38 item 4. The same small experiment (two scenarios, two replications, arrivals and a fault
process) runs in this process, through `--scheduler` on the started cluster, and through `--workers 2`
(a LocalCluster): the tables' rows, in (scenario, replication) order and without the CPU seconds, are the
same, and so is the report (but for its CPU seconds). An unreachable scheduler is one line naming
--scheduler, exit 2.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path
from typing import Iterator

import pytest
import yaml

from feeder_cell.experiment import experiment as ex

ROOT = Path(__file__).resolve().parents[2]
EXPERIMENT = {
    "scene": str(ROOT / "feeder_cell/scenes/cell.yaml"),
    "seed": 11,
    "arrivals": {"arm": {"drop": "quasi_static", "radius": [0.115, 0.125]}},
    "faults": {"throwing_arm": {"fault": "part_lost", "mtbf": 20.0, "mttr": 2.0}},
    "factors": {"throwing_arm.period": [0.5, 0.4]},
    "replications": 2,
    "horizon": {"cycles": 2},
}


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.fixture(scope="module")
def scheduler() -> Iterator[str]:
    """Start `dask scheduler` and two single-threaded `dask worker`s; end each by its pid."""
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    dask = str(Path(sys.executable).parent / "dask")
    quiet = dict(os.environ, DASK_LOGGING__DISTRIBUTED="error")
    processes = [
        subprocess.Popen(
            [dask, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            env=quiet,
        )
    ]
    try:
        for _ in range(2):
            processes.append(
                subprocess.Popen(
                    [dask, "worker", address, "--nthreads", "1", "--nworkers", "1", "--no-dashboard"],
                    stdout=subprocess.DEVNULL,
                    stderr=subprocess.DEVNULL,
                    env=quiet,
                )
            )
        from dask.distributed import Client

        with Client(address, timeout=60) as client:
            client.wait_for_workers(2, timeout=120)
            assert len(client.scheduler_info()["workers"]) == 2
        yield address
    finally:
        for process in reversed(processes):
            if process.poll() is None:
                os.kill(process.pid, signal.SIGTERM)
        for process in reversed(processes):
            try:
                process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                os.kill(process.pid, signal.SIGKILL)
                process.wait()


def _command(path: Path, *flags: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "feeder_cell.cli.main", "experiment", str(path), "--quiet", *flags],
        capture_output=True,
        text=True,
        timeout=600,
    )


def test_results_are_the_same_on_a_scheduler_with_two_workers_and_in_one_process(
    tmp_path: Path, scheduler: str
) -> None:
    """Rows and report equal in one process, on the started cluster, and on a LocalCluster of 2."""
    path = tmp_path / "exp.yaml"
    path.write_text(yaml.safe_dump(EXPERIMENT))
    experiment = ex.load_experiment(path)
    texts, reports = {}, {}
    for name, flags in (
        ("local", ()),
        ("scheduler", ("--scheduler", scheduler)),
        ("workers", ("--workers", "2")),
    ):
        results = tmp_path / f"{name}.csv"
        report = tmp_path / f"{name}.md"
        done = _command(path, "--results", str(results), "--report", str(report), *flags)
        assert done.returncode == 0, done.stderr[-2000:]
        table = ex.Results(results, experiment)
        assert len(table.rows) == 4 and all(r["status"] == "ok" for r in table.rows.values())
        texts[name] = ex.sorted_rows_text(table)
        # The report without its last column, the CPU seconds of a replication (timing, not a result).
        reports[name] = [line.rsplit("|", 2)[0] for line in report.read_text().splitlines()]
    assert texts["scheduler"] == texts["local"] and texts["workers"] == texts["local"]
    assert reports["scheduler"] == reports["local"] == reports["workers"]
    assert any("good parts/h" in line for line in reports["local"])


def test_an_unreachable_scheduler_is_one_line_naming_the_flag(tmp_path: Path) -> None:
    """Nothing listens on the port: one line on stderr naming --scheduler, exit 2."""
    path = tmp_path / "exp.yaml"
    path.write_text(yaml.safe_dump({**EXPERIMENT, "replications": 1}))
    begin = time.monotonic()
    done = _command(path, "--scheduler", f"tcp://127.0.0.1:{_free_port()}")
    assert done.returncode == 2, done.stderr[-2000:]
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "--scheduler" in lines[0], done.stderr
    assert time.monotonic() - begin < 120
