"""Start-up of the cell in lockstep: launches in a row, each to its first step, never PLAYING too early.

Issue 37's done-when: 20 launches of the devices scene in a row (`feeder launch devices.yaml
--real-time-factor max`), each reaching its first step in under 10 s, and the simulation never said
PLAYING while a participant was still missing. Per launch, on a ROS domain of its own, a client node:

- times the first step: wall seconds from starting the launch to the first /clock past its start time
  (``--start-time``; the clock holds it while its participants join);
- asks /cell_simulation/get_simulation_state every POLL_S from the start and hears /lockstep/settled, the
  clock's first react announcement, which it sends only once every expected participant has joined: a
  PLAYING answer that arrives more than ORDER_S before that announcement is a PLAYING while a participant
  was missing (the answer is sent after cell_simulation heard the same announcement, so it can arrive a
  little before it only by taking another path through DDS).

Run alone (`python bench/bench_join.py --launches 20 [--one-process-per-node]`) it prints one line per
launch; `make bench` runs a few launches in each layout.
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from benchlib import lease_domain, row

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "feeder_cell" / "scenes" / "devices.yaml"
START_S = 1000
FIRST_STEP_TARGET_S = 10.0
LAUNCH_TIMEOUT_S = 60.0
POLL_S = 0.05
ORDER_S = 0.5
LOADING_WORLD, PLAYING = 5, 1  # simulation_interfaces/msg/SimulationState


@dataclass(frozen=True)
class Launch:
    """One launch's start-up, wall seconds from starting it."""

    first_step_s: float  # the first /clock past the start time (inf: none within LAUNCH_TIMEOUT_S)
    joined_s: float  # the first /lockstep/settled
    first_playing_s: float  # the first PLAYING answer
    answers: int  # GetSimulationState answers taken

    @property
    def playing_early(self) -> bool:
        """Whether PLAYING came before every participant had joined."""
        return self.first_playing_s < self.joined_s - ORDER_S


def one_launch(layout: list[str], domain: int) -> Launch:
    """Start the devices scene, watch its start-up to its first step, end it by its pid."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from rosgraph_msgs.msg import Clock
    from simulation_interfaces.srv import GetSimulationState
    from std_msgs.msg import Header

    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=domain)
    node = rclpy.create_node("bench_join", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    marks: dict[str, float] = {}
    answers = [0]
    started = time.monotonic()

    def mark(name: str) -> None:
        marks.setdefault(name, time.monotonic() - started)

    def on_clock(msg: Any) -> None:
        if msg.clock.sec * 1_000_000_000 + msg.clock.nanosec > START_S * 1_000_000_000:
            mark("first_step")

    reliable = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
    node.create_subscription(Clock, "/clock", on_clock, 10)
    node.create_subscription(Header, "/lockstep/settled", lambda _: mark("joined"), reliable)
    client = node.create_client(GetSimulationState, "/cell_simulation/get_simulation_state")
    with tempfile.TemporaryDirectory(prefix="bench-join-") as logs:
        process = subprocess.Popen(
            [sys.executable, "-m", "feeder_cell.cli.main", "launch", str(SCENE), "--real-time-factor", "max"]
            + ["--start-time", str(START_S), "--log-dir", logs, *layout],
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,  # the launch's own logs are in --log-dir
            text=True,
        )
        try:
            pending: Any = None
            while "first_step" not in marks or "joined" not in marks or "playing" not in marks:
                if process.poll() is not None or time.monotonic() - started > LAUNCH_TIMEOUT_S:
                    break
                if pending is None and client.service_is_ready():
                    pending = client.call_async(GetSimulationState.Request())
                if pending is not None and pending.done():
                    answers[0] += 1
                    if int(pending.result().state.state) == PLAYING:
                        mark("playing")
                    pending = None
                executor.spin_once(timeout_sec=POLL_S)
        finally:
            end_by_pid(process)
            executor.shutdown(timeout_sec=5)
            node.destroy_node()
            rclpy.shutdown(context=context)
    never = float("inf")
    return Launch(
        marks.get("first_step", never), marks.get("joined", never), marks.get("playing", never), answers[0]
    )


def end_by_pid(process: subprocess.Popen[str], grace_s: float = 30.0) -> None:
    """SIGINT (the launch ends its nodes); SIGKILL if it is still there after ``grace_s``."""
    process.send_signal(signal.SIGINT)
    deadline = time.monotonic() + grace_s
    while process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.1)
    if process.poll() is None:
        process.kill()
    process.communicate()


def launches(count: int, layout: list[str], report: bool = False) -> list[Launch]:
    """``count`` launches in a row, each on a domain of its own (leased, released after it)."""
    done = []
    for k in range(count):
        domain, handle = lease_domain("join")
        try:
            launch = one_launch(layout, domain)
        finally:
            handle.close()
        done.append(launch)
        if report:
            print(
                f"launch {k + 1}: first step {launch.first_step_s:.2f} s, joined {launch.joined_s:.2f} s, "
                f"first PLAYING {launch.first_playing_s:.2f} s ({launch.answers} answers)"
                + (" PLAYING EARLY" if launch.playing_early else ""),
                flush=True,
            )
    return done


def rows_of(name: str, done: list[Launch]) -> list[dict]:
    """The table's rows: the slowest first step, and how many launches said PLAYING early."""
    slowest = max(launch.first_step_s for launch in done)
    early = sum(launch.playing_early for launch in done)
    return [
        row(
            "join",
            f"{name}: slowest first step of {len(done)} launches",
            slowest,
            "s",
            f"< {FIRST_STEP_TARGET_S:g} s",
            "issue 37: 1 in 8 launches held 60 s",
            slowest < FIRST_STEP_TARGET_S,
        ),
        row("join", f"{name}: launches PLAYING before joined", early, "", "0", "", early == 0),
    ]


def run(out_dir: Path, quick: bool) -> list[dict]:
    """`make bench`: a few launches in each layout (the stress count is `python bench/bench_join.py`)."""
    count = 2 if quick else 5
    return rows_of("hosted", launches(count, [])) + rows_of(
        "one process per node", launches(count, ["--one-process-per-node"])
    )


def main() -> int:
    """Print each launch's figures and the summary; exit 1 if a target is not met."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--launches", type=int, default=20)
    parser.add_argument("--one-process-per-node", action="store_true")
    args = parser.parse_args()
    layout = ["--one-process-per-node"] if args.one_process_per_node else []
    done = launches(args.launches, layout, report=True)
    rows = rows_of("one process per node" if layout else "hosted", done)
    for r in rows:
        verdict = "met" if r["met"] else "NOT met"
        print(f"{r['measure']}: {r['value']:g} {r['unit']} (target {r['target']}): {verdict}")
    return 0 if all(r["met"] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
