"""``feeder experiment``: replications of the cell on the ROS-free loop, a results table and a report.

docs/experiments.md, "Experiments", describes the file, the method (replications, warm-up, common random
numbers, Student-t intervals, OEE) and the output.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Callable

from feeder_cell.cli.ctrl_c import check_ctrl_c
from feeder_cell.cli.main import EXIT_INTERRUPTED
from feeder_cell.experiment.experiment import (
    Experiment,
    Results,
    format_report,
    load_experiment,
    replay_scene,
    report,
    run_dask,
    run_local,
    tasks,
)
from feeder_planner.errors import InputError

__all__ = ["register", "run"]

HELP = """\
Run a production experiment on the ROS-free cell loop (the same device models, goal machines and
controller machine as the ROS cell, in one process per replication): every scenario of the file's
factors, each with the same replications (common random numbers). One CSV row per replication is
appended as it ends; run the command again to resume an interrupted experiment. The report (Markdown)
gives per scenario throughput in good parts per hour with its 95 % interval, cycle-time p50/p95,
availability, performance, quality, OEE, device time shares, the bottleneck, faults, and the paired
difference against the baseline.

The file:

  scene: ../../feeder_cell/scenes/cell.yaml   # relative to this file
  seed: 7                                     # optional: replaces the scene's (also arrivals:, faults:)
  factors:                                    # NODE.PARAMETER: [levels]; the full factorial
    throwing_arm.period: [0.5, 0.4]
  baseline: {throwing_arm.period: 0.5}        # optional: each factor's first level
  replications: 10
  horizon: {cycles: 20}                       # or {time: 3600} (s of cell time)
  warmup: {cycles: 1}                         # or {time: 60}; default no warm-up
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``experiment`` to the feeder parser."""
    parser = subparsers.add_parser(
        "experiment",
        help="replications of the cell on the ROS-free loop: parts per hour with intervals, OEE",
        description=HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("experiment", metavar="EXPERIMENT", help="experiment file (YAML)")
    parser.add_argument(
        "--results", metavar="CSV", help="results table (default: EXPERIMENT's name with .results.csv)"
    )
    parser.add_argument("--report", metavar="MD", help="report (default: EXPERIMENT's name with .report.md)")
    parser.add_argument(
        "--workers", type=int, default=1, metavar="N", help="Dask LocalCluster worker processes (1: none)"
    )
    parser.add_argument("--scheduler", metavar="ADDRESS", help="run on the Dask scheduler at ADDRESS")
    parser.add_argument(
        "--plot",
        metavar="PNG",
        help="the picture: cycle-time histograms, utilisation bars, main effects (default: EXPERIMENT's "
        "name with .png)",
    )
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.add_argument(
        "--replay",
        type=int,
        metavar="K",
        help="run replication K as a full ROS scene (feeder launch --real-time-factor max) instead",
    )
    parser.add_argument(
        "--scenario",
        type=int,
        default=None,
        metavar="S",
        help="--replay: the scenario (default the baseline)",
    )
    parser.add_argument("--record", metavar="DIR", help="--replay: record the run into this new bag")
    parser.set_defaults(handler=run)


def _progress(quiet: bool) -> Callable[[int, int], None]:
    """Return a progress callback that draws one line on stderr (nothing when quiet)."""
    began = time.monotonic()

    def show(done: int, total: int) -> None:
        check_ctrl_c()
        if quiet:
            return
        width = 30
        filled = int(width * done / total) if total else width
        rate = done / max(time.monotonic() - began, 1e-9)
        left = (total - done) / rate if rate > 0 else 0.0
        bar = "#" * filled + "." * (width - filled)
        sys.stderr.write(f"\r[{bar}] {done}/{total} replications, ~{left:.0f} s left")
        if done == total:
            sys.stderr.write("\n")
        sys.stderr.flush()

    return show


def run(args: argparse.Namespace) -> int:
    """Run (or resume) the experiment, write the report, print it and the files' paths."""
    if args.workers < 1:
        raise InputError("--workers", f"must be an integer >= 1, got {args.workers}")
    experiment = load_experiment(args.experiment)
    if args.replay is not None:
        return replay(args, experiment)
    if args.record or args.scenario is not None:
        raise InputError("--record" if args.record else "--scenario", "applies to --replay only")
    if args.plot:
        from feeder_cell.plots.common import check_plot_path

        check_plot_path(args.plot, "--plot")  # before hours of replications, not after
    stem = Path(args.experiment)
    results_path = Path(args.results) if args.results else stem.with_suffix(".results.csv")
    report_path = Path(args.report) if args.report else stem.with_suffix(".report.md")
    results = Results(results_path, experiment)
    todo = len(tasks(experiment, results))
    total = len(experiment.scenarios) * experiment.replications
    if todo < total:
        sys.stderr.write(f"resuming: {total - todo} of {total} replications already in {results_path}\n")
    progress = _progress(args.quiet)
    try:
        if args.workers == 1 and args.scheduler is None:
            run_local(experiment, results, progress)
        else:
            run_dask(experiment, results, args.workers, args.scheduler, progress)
    except KeyboardInterrupt:
        sys.stderr.write(
            f"\nfeeder experiment: interrupted; {len(results.rows)} of {total} replications kept in "
            f"{results_path} (run again to resume)\n"
        )
        return EXIT_INTERRUPTED
    levels = report(experiment, results)
    text = format_report(experiment, levels)
    report_path.write_text(text)
    from feeder_cell.experiment.plot import experiment_figure
    from feeder_cell.plots.common import write_figure

    picture = write_figure(
        experiment_figure(experiment, results, levels),
        Path(args.plot) if args.plot else stem.with_suffix(".png"),
    )
    sys.stdout.write(text)
    sys.stdout.write(f"\nresults: {results_path}\nreport: {report_path}\npicture: {picture}\n")
    return 0


def replay(args: argparse.Namespace, experiment: Experiment) -> int:
    """Run one replication as a ROS scene (feeder launch in lockstep); say the loop's cycles first."""
    scenario = experiment.baseline if args.scenario is None else args.scenario
    folder = Path(tempfile.mkdtemp(prefix="feeder-replay-"))
    path, expected = replay_scene(experiment, scenario, args.replay, folder)
    sys.stderr.write(
        f"replaying scenario {scenario} ({experiment.scenarios[scenario].label()}), replication "
        f"{args.replay} as a ROS scene: {path}\nthe loop's cycles: {'; '.join(expected)}\n"
    )
    command = [sys.executable, "-m", "feeder_cell.cli.main", "launch", str(path), "--real-time-factor", "max"]
    command += ["--log-dir", str(folder / "logs")]
    if args.record:
        command += ["--record", args.record]
    try:
        return subprocess.call(command)
    except KeyboardInterrupt:
        return EXIT_INTERRUPTED
