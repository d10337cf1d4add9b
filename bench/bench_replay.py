"""Replay timing: how closely ``feeder play`` reproduces a bag's recorded gaps, at rate 1 and 4.

A bag is written here (no recorder, so the gaps are known exactly): std_msgs/String messages carrying
their index, with gaps drawn uniformly between 1 and 19 ms (seeded; a 100 Hz stream with jitter, mean
10 ms). ``feeder play --rate R`` replays it on a ROS domain of its own, and a subscriber in this process
takes each message's arrival time (time.monotonic in the callback). The error of message i is its
arrival gap minus the recorded gap over the rate, (t_i - t_{i-1}) - (s_i - s_{i-1}) / R; the table gives
the median and the 99th percentile of its absolute value. The figure includes DDS delivery and the
subscriber's executor (Python), not only the player's timing: it is what a node under test sees.
"""

from __future__ import annotations

import os
import random
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

from benchlib import lease_domain, row

FEEDER = [sys.executable, "-m", "feeder_cell.cli.main"]
TOPIC = "/bench_replay"
TARGET_P99_MS = 5.0  # half the mean gap: the replayed stream keeps its recorded rhythm
START_NS = 1_700_000_000_000_000_000


def _cdr(text: str) -> bytes:
    raw = text.encode() + b"\0"
    return b"\0\1\0\0" + len(raw).to_bytes(4, "little") + raw


def _index(cdr: bytes) -> int:
    length = int.from_bytes(cdr[4:8], "little")
    return int(cdr[8 : 8 + length - 1])


def write_bag(bag: Path, count: int, seed: int = 12) -> list[int]:
    """Write ``count`` messages with jittered gaps; return their stamps (ns)."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    from feeder_cell.bag.qos import to_bag_qos
    from feeder_cell.bag.types import typestore

    rng = random.Random(seed)
    stamps, stamp = [], START_NS
    for _ in range(count):
        stamps.append(stamp)
        stamp += rng.randint(1_000_000, 19_000_000)
    writer = Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.open()
    connection = writer.add_connection(
        TOPIC, "std_msgs/msg/String", typestore=typestore(), offered_qos_profiles=[to_bag_qos(True, False)]
    )
    for i, stamp in enumerate(stamps):
        writer.write(connection, stamp, _cdr(str(i)))
    writer.close()
    return stamps


def _percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(round(q * (len(ordered) - 1))))]


def measure(bag: Path, stamps: list[int], rate: float) -> dict[str, float]:
    """Replay ``bag`` at ``rate`` and return the gap errors' p50 and p99 (ms) and the messages received."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from std_msgs.msg import String

    arrivals: dict[int, float] = {}
    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node("bench_replay_listener", context=context)
    node.create_subscription(
        String, TOPIC, lambda data: arrivals.setdefault(_index(data), time.monotonic()), 1000, raw=True
    )
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    stop = threading.Event()

    def spin() -> None:
        while not stop.is_set():
            executor.spin_once(timeout_sec=0.05)

    thread = threading.Thread(target=spin, daemon=True)
    thread.start()
    try:
        play = subprocess.run(
            [*FEEDER, "play", str(bag), "--rate", str(rate), "--wait-for-subscribers", "30", "--linger", "0"],
            capture_output=True,
            text=True,
            timeout=120 + (stamps[-1] - stamps[0]) / 1e9 / rate,
        )
        if play.returncode != 0:
            raise RuntimeError(f"feeder play failed: {play.stderr.strip()}")
        deadline = time.monotonic() + 5.0
        while len(arrivals) < len(stamps) and time.monotonic() < deadline:
            time.sleep(0.05)
    finally:
        stop.set()
        thread.join(timeout=5.0)
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=context)
    errors = [
        abs((arrivals[i] - arrivals[i - 1]) - (stamps[i] - stamps[i - 1]) / 1e9 / rate) * 1e3
        for i in range(1, len(stamps))
        if i in arrivals and i - 1 in arrivals
    ]
    if not errors:
        raise RuntimeError("no consecutive messages arrived")
    return {
        "p50": statistics.median(errors),
        "p99": _percentile(errors, 0.99),
        "received": len(arrivals),
    }


def run(out_dir: Path, quick: bool = False) -> list[dict]:
    """Return the table rows of the replay timing benchmark."""
    count = 300 if quick else 1500
    domain, lock = lease_domain("replay")
    previous = {key: os.environ.get(key) for key in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE")}
    os.environ["ROS_DOMAIN_ID"] = str(domain)
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    rows = []
    try:
        with tempfile.TemporaryDirectory() as tmp:
            bag = Path(tmp) / "bag"
            stamps = write_bag(bag, count)
            for rate in (1.0, 4.0):
                figures = measure(bag, stamps, rate)
                for q in ("p50", "p99"):
                    rows.append(
                        row(
                            "replay timing",
                            f"gap error {q}, rate {rate:g} ({figures['received']:.0f}/{count} msgs)",
                            figures[q],
                            "ms",
                            f"p99 < {TARGET_P99_MS:g} ms",
                            "recorded gaps 1-19 ms",
                            figures["p99"] < TARGET_P99_MS and figures["received"] == count,
                        )
                    )
    finally:
        for key, value in previous.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value
        lock.close()
    return rows


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    for line in run(Path(tempfile.gettempdir()), "--quick" in sys.argv):
        print(line)
