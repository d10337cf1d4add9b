"""The bag a ``feeder launch --record`` writes: its recorder, in lockstep its observer, its discovery."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any, Callable

from feeder_cell.cli.launch_plan import LaunchPlan

# Before a node's first transition the recorder's new readers must have matched their writers: a
# transition event (volatile) published before the match is lost. The most it waits (wall s), and the
# settle after the readers' side matched, for the writers' side (as the lockstep observer's).
RECORDER_MATCH_TIMEOUT_S = 2.0
RECORDER_MATCH_SETTLE_S = 0.2
# A node that ends the scene (the controller done with its cycles) published its last status just before
# it exited: the launch sees the exit while those messages may still be on their way to the recorder (a
# CI run under load lost the squeeze cell's FINISHED status so). Before the bag is closed the launch
# spins this long (wall s). Not "until quiet": the devices' markers, statuses and /diagnostics beat on
# the wall clock, so a cell never falls quiet. In lockstep the clock is held meanwhile (the recorder does
# not answer the quantum), so little newer than the end comes in.
RECORDER_DRAIN_S = 0.5


def open_recording(node: Any, plan: LaunchPlan) -> tuple[Any, Any]:
    """Return the launch's recorder and lockstep observer, each None when the launch has no use for it."""
    from feeder_cell.bag.recorder import Recorder
    from feeder_cell.lockstep_observer import RecordingObserver

    args = plan.args
    if args.record and plan.sim_time:
        # Recording in lockstep, the recorder holds each quantum until it has taken in all of it,
        # and logs each message at the cell time of its quantum.
        observer = RecordingObserver(node, int(round(args.quantum * 1e9)))
        recorder = Recorder(node, Path(args.record), clock=observer.log_time_ns, wait_for_clock=True)
        observer.recorder = recorder
        return recorder, observer
    if args.record:
        return Recorder(node, Path(args.record)), None
    return None, None


def drain(executor: Any) -> None:
    """Spin for RECORDER_DRAIN_S: the recorder takes in what an ended node sent just before it exited."""
    end = time.monotonic() + RECORDER_DRAIN_S
    while time.monotonic() < end:
        executor.spin_once(timeout_sec=0.02)


def discover_matched(recorder: Any, node: Any, executor: Any, keep_going: Callable[[], bool]) -> None:
    """Subscribe the recorder to the topics there are now and wait until its new readers have matched."""
    if not recorder.discover():
        return
    deadline = time.monotonic() + RECORDER_MATCH_TIMEOUT_S
    while keep_going() and time.monotonic() < deadline:
        subscriptions = recorder.subscriptions()
        if all(s.get_publisher_count() >= node.count_publishers(n) for n, s in subscriptions.items()):
            settled = time.monotonic() + RECORDER_MATCH_SETTLE_S
            while keep_going() and time.monotonic() < settled:
                executor.spin_once(timeout_sec=0.02)
            return
        executor.spin_once(timeout_sec=0.02)
