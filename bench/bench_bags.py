"""Recording: throughput sustained without loss against the raw DDS receive rate, and memory over time.

Throughput: a publisher sends numbered 1 KiB std_msgs/String messages (reliable, depth 10000) on
/bench/data in steps of rising rate; in the same run a plain raw subscriber (another process, rclpy, no
disk) and ``feeder record`` receive them. Per step, what each got is counted by sequence number (the
recorder's from its bag, read with the mcap reader); a step is sustained when nothing of it was lost.
Twice: MCAP chunks uncompressed, then zstd. The raw subscriber is the ceiling a Python rclpy reader
reaches on this host; the recorder's figure is only comparable to it, not to rosbag2's C++.

Memory: ``feeder record --all`` of the demo scene (feeder_cell/scenes/demo.yaml, on a ROS domain of its
own), its RSS sampled every second with psutil: peak, and the median of the last tenth against the
first after start-up (flat: the recorder keeps no per-message state beyond its bounded dedup window).
Quick mode: 60 s; full: 10 minutes.

Flight recorder: the cell scene (feeder_cell/scenes/cell.yaml, its controller cycling without end) with
``feeder record --all --snapshot-on-fault`` (cache 32 MiB and 30 s, 3 s after each fault); every 30 s a
fault is injected into the throwing arm (motor_fault) or the MEMS array (power_loss), cleared and the
device reset 5 s later. The recorder's RSS is sampled every second: peak, the median of the last tenth
against the median of the first tenth once the cache is full (after 40 s: flat), and the peak's rise over
that against twice the cache bound (a fault's copy shares the cache's messages; the post-fault seconds and
the bag being written come on top); every fault must give one bag. Quick mode: 120 s; full: 10 minutes
(measured once: 19 faults, 19 bags, 171.7 MiB once full, 181.8 MiB peak; the README's row).
"""

from __future__ import annotations

import json
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from benchlib import lease_domain, row

ROOT = Path(__file__).resolve().parents[1]
FEEDER = [sys.executable, "-m", "feeder_cell.cli.main"]
SCENE = ROOT / "feeder_cell" / "scenes" / "demo.yaml"
TOPIC = "/bench/data"
PAYLOAD = 1024

PUBLISHER = r"""
import json, sys, time
import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_msgs.msg import String
rates, step_s = json.loads(sys.argv[1]), float(sys.argv[2])
payload, readers = int(sys.argv[3]), int(sys.argv[4])
rclpy.init()
node = rclpy.create_node("bench_bag_publisher")
qos = QoSProfile(depth=10000, reliability=ReliabilityPolicy.RELIABLE)
pub = node.create_publisher(String, "/bench/data", qos)
deadline = time.monotonic() + 60
while pub.get_subscription_count() < readers and time.monotonic() < deadline:
    time.sleep(0.05)
time.sleep(1.0)  # the readers' other matches (discovery is not symmetric at once)
pad = "x" * payload
seq, steps = 0, []
for rate in rates:
    first, start = seq, time.monotonic()
    while True:
        elapsed = time.monotonic() - start
        if elapsed >= step_s:
            break
        due = int(elapsed * rate) + 1
        while seq - first < due:
            pub.publish(String(data=f"{seq} " + pad))
            seq += 1
        time.sleep(0.0005)
    steps.append({"rate": rate, "first": first, "last": seq - 1, "seconds": time.monotonic() - start})
    time.sleep(0.5)  # let the readers drain between steps
time.sleep(2.0)
print(json.dumps(steps), flush=True)
node.destroy_node()
rclpy.try_shutdown()
"""

SUBSCRIBER = r"""
import json, signal
import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from std_msgs.msg import String
stop = []
rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
signal.signal(signal.SIGINT, lambda *_: stop.append(True))
node = rclpy.create_node("bench_bag_raw_subscriber")
seqs = []
node.create_subscription(String, "/bench/data", lambda data: seqs.append(int(data[8:24].split(b" ")[0])),
                         QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE), raw=True)
while not stop:
    rclpy.spin_once(node, timeout_sec=0.05)
print(json.dumps(seqs), flush=True)
node.destroy_node()
rclpy.try_shutdown()
"""


def _bag_seqs(bag: Path) -> list[int]:
    from mcap.reader import make_reader

    seqs = []
    for path in sorted(bag.glob("*.mcap")):
        with path.open("rb") as stream:
            for _, channel, message in make_reader(stream).iter_messages():
                if channel.topic == TOPIC:
                    seqs.append(int(message.data[8:24].split(b" ")[0]))
    return seqs


def _stop(process: subprocess.Popen, timeout: float = 60.0) -> str:
    if process.poll() is None:
        os.kill(process.pid, signal.SIGINT)
    try:
        out, _ = process.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.kill(process.pid, signal.SIGKILL)
        out, _ = process.communicate()
    return out or ""


def _throughput(
    env: dict[str, str], work: Path, compression: str, rates: list[int], step_s: float
) -> list[dict]:
    """Per step: rate, what the raw subscriber and the recorder received of it."""
    bag = work / f"throughput_{compression}"
    subscriber = subprocess.Popen(
        [sys.executable, "-c", SUBSCRIBER],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    recorder = subprocess.Popen(
        [*FEEDER, "record", str(bag), "--topics", TOPIC, "--compression", compression, "--json"],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    try:
        publisher = subprocess.run(
            [sys.executable, "-c", PUBLISHER, json.dumps(rates), str(step_s), str(PAYLOAD), "2"],
            env=env,
            capture_output=True,
            text=True,
            timeout=120 + len(rates) * (step_s + 1),
        )
        if publisher.returncode != 0:
            raise RuntimeError(f"bench publisher failed: {publisher.stderr.strip().splitlines()[-1:]}")
        steps = json.loads(publisher.stdout)
    finally:
        raw = set(json.loads(_stop(subscriber) or "[]"))
        _stop(recorder)
    recorded = set(_bag_seqs(bag))
    size = sum(p.stat().st_size for p in bag.glob("*.mcap"))
    for step in steps:
        sent = range(step["first"], step["last"] + 1)
        step["sent"] = len(sent)
        step["raw"] = sum(1 for s in sent if s in raw)
        step["recorded"] = sum(1 for s in sent if s in recorded)
    steps.append({"bag_bytes": size, "messages": len(recorded)})
    return steps


def _sustained(steps: list[dict], key: str) -> float:
    """The highest step rate (msg/s) at which ``key`` received every message sent (0 if none)."""
    ok = [s["rate"] for s in steps if "rate" in s and s[key] == s["sent"]]
    return float(max(ok)) if ok else 0.0


def _memory(env: dict[str, str], work: Path, seconds: float) -> dict[str, Any]:
    import psutil

    logs = work / "logs"
    launch = subprocess.Popen(
        [*FEEDER, "launch", str(SCENE), "--log-dir", str(logs)],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    bag = work / "demo_long"
    recorder = None
    samples: list[tuple[float, int]] = []
    try:
        time.sleep(5.0)  # the scene's nodes up; the recorder subscribes to what appears later too
        recorder = subprocess.Popen(
            [*FEEDER, "record", str(bag), "--all", "--json"],
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
        )
        process = psutil.Process(recorder.pid)
        start = time.monotonic()
        while time.monotonic() - start < seconds and recorder.poll() is None:
            samples.append((time.monotonic() - start, process.memory_info().rss))
            time.sleep(1.0)
        summary = json.loads(_stop(recorder) or "{}")
    finally:
        if recorder is not None and recorder.poll() is None:
            _stop(recorder)
        _stop(launch)
    rss = [r for _, r in samples]
    tenth = max(1, len(rss) // 10)
    settled = [r for t, r in samples if t >= 5.0] or rss
    messages = sum(t["count"] for t in summary.get("topics", {}).values())
    return {
        "seconds": seconds,
        "samples": samples,
        "peak_mb": max(rss) / 2**20,
        "early_mb": statistics.median(settled[:tenth]) / 2**20,
        "late_mb": statistics.median(rss[-tenth:]) / 2**20,
        "messages": messages,
        "topics": len(summary.get("topics", {})),
    }


INJECTOR = r"""
import json, signal, sys, time
import rclpy
from rclpy.signals import SignalHandlerOptions
from std_srvs.srv import Trigger
from feeder_msgs.srv import InjectFault
period, hold = float(sys.argv[1]), float(sys.argv[2])
stop = []
rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
for sig in (signal.SIGINT, signal.SIGTERM):
    signal.signal(sig, lambda *_: stop.append(True))
node = rclpy.create_node("bench_fault_injector")
faults = [("/cell/throwing_arm", "motor_fault"), ("/cell/mems_field_array", "power_loss")]
def call(kind, name, request):
    client = node.create_client(kind, name)
    try:
        if not client.wait_for_service(timeout_sec=10.0):
            return None
        future = client.call_async(request)
        rclpy.spin_until_future_complete(node, future, timeout_sec=10.0)
        return future.result()
    finally:
        node.destroy_client(client)
injected = []
start = time.monotonic()
turn = 0
def wait(seconds):
    end = time.monotonic() + seconds
    while not stop and time.monotonic() < end:
        time.sleep(0.1)
wait(period)
while not stop:
    device, fault = faults[turn % len(faults)]
    reply = call(InjectFault, f"{device}/inject_fault", InjectFault.Request(fault=fault))
    if reply is not None and reply.ok:
        injected.append({"device": device, "fault": fault, "at": time.monotonic() - start})
    wait(hold)
    call(InjectFault, f"{device}/inject_fault", InjectFault.Request(fault=fault, clear=True))
    call(Trigger, f"{device}/reset", Trigger.Request())
    turn += 1
    wait(period - hold)
print(json.dumps(injected), flush=True)
node.destroy_node()
rclpy.try_shutdown()
"""

CACHE_BYTES = 32 * 2**20
CACHE_SECONDS = 30.0


def _endless_cell_scene(work: Path) -> Path:
    """The cell scene with its controller cycling without end (and the launch not ending with it)."""
    from ruamel.yaml import YAML

    source = ROOT / "feeder_cell" / "scenes" / "cell.yaml"
    yaml = YAML(typ="safe")
    scene = yaml.load(source.read_text())
    for node in scene["nodes"]:
        parameters = node.get("parameters", {})
        for key, value in list(parameters.items()):
            # The copy lives elsewhere: file parameters made absolute (they are relative to the scene).
            if key.endswith("_file"):
                parameters[key] = str((source.parent / value).resolve())
            elif key.endswith("_files"):
                parameters[key] = [str((source.parent / v).resolve()) for v in value]
        if node["executable"] == "cell_controller":
            node.pop("on_exit", None)
            parameters.update(cycles=100000, exit_when_done=False)
    path = work / "cell_endless.yaml"
    with path.open("w") as stream:
        yaml.dump(scene, stream)
    return path


def _flight_memory(env: dict[str, str], work: Path, seconds: float) -> dict[str, Any]:
    import psutil

    launch = subprocess.Popen(
        [*FEEDER, "launch", str(_endless_cell_scene(work)), "--log-dir", str(work / "cell_logs")],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    out = work / "flight"
    recorder = injector = None
    samples: list[tuple[float, int]] = []
    try:
        time.sleep(15.0)  # the scene's nodes up and active
        recorder = subprocess.Popen(
            [
                *FEEDER,
                "record",
                str(out),
                "--all",
                "--snapshot-on-fault",
                "--max-cache-size",
                str(CACHE_BYTES),
                "--max-cache-duration",
                str(CACHE_SECONDS),
                "--post-fault",
                "3",
                "--json",
            ],
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
        )
        injector = subprocess.Popen(
            [sys.executable, "-c", INJECTOR, "30", "5"],
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
        )
        process = psutil.Process(recorder.pid)
        start = time.monotonic()
        while time.monotonic() - start < seconds and recorder.poll() is None:
            samples.append((time.monotonic() - start, process.memory_info().rss))
            time.sleep(1.0)
        injected = json.loads(_stop(injector) or "[]")
        time.sleep(5.0)  # the last fault's post-fault seconds
        summary = json.loads(_stop(recorder) or "{}")
    finally:
        for process_ in (injector, recorder):
            if process_ is not None and process_.poll() is None:
                _stop(process_)
        _stop(launch)
    rss = [r for _, r in samples]
    tenth = max(1, len(rss) // 10)
    full = [r for t, r in samples if t >= CACHE_SECONDS + 10] or rss
    messages = sum(t["count"] for t in summary.get("topics", {}).values())
    return {
        "seconds": seconds,
        "samples": samples,
        "peak_mb": max(rss) / 2**20,
        "full_mb": statistics.median(full[:tenth]) / 2**20,
        "late_mb": statistics.median(rss[-tenth:]) / 2**20,
        "messages": messages,
        "faults": len(injected),
        "bags": len(summary.get("snapshots", [])),
        "bag_messages": [b["messages"] for b in summary.get("snapshots", [])],
        "cache_peak_mb": summary.get("cache", {}).get("peak_bytes", 0) / 2**20,
    }


def _plot(out: Path, runs: dict[str, list[dict]], memory: dict[str, Any]) -> None:
    import matplotlib.pyplot as plt

    figure, (left, right) = plt.subplots(1, 2, figsize=(11, 4))
    for compression, steps in runs.items():
        rates = [s["rate"] for s in steps if "rate" in s]
        left.plot(
            rates,
            [s["recorded"] / s["seconds"] for s in steps if "rate" in s],
            "o-",
            label=f"recorder ({compression})",
        )
        if compression == "none":
            left.plot(
                rates, [s["raw"] / s["seconds"] for s in steps if "rate" in s], "k--", label="raw subscriber"
            )
    left.plot(rates, rates, ":", color="grey", label="sent")
    left.set_xlabel("sent (msg/s, 1 KiB each)")
    left.set_ylabel("received (msg/s)")
    left.set_title("Record throughput vs raw DDS receive rate")
    left.legend()
    right.plot([t for t, _ in memory["samples"]], [r / 2**20 for _, r in memory["samples"]])
    right.set_xlabel("s since the recorder started")
    right.set_ylabel("recorder RSS (MiB)")
    right.set_title(f"feeder record --all of the demo scene ({memory['seconds']:.0f} s)")
    figure.tight_layout()
    figure.savefig(out / "bags_record.png", dpi=100)
    plt.close(figure)


def run(out: Path, quick: bool) -> list[dict]:
    """Record throughput (none and zstd) against the raw subscriber, and the recorder's RSS over time."""
    rates = [1000, 2000, 4000, 8000] if quick else [500, 1000, 2000, 4000, 6000, 8000, 12000, 16000]
    step_s = 2.0 if quick else 5.0
    seconds = 60.0 if quick else 600.0
    flight_seconds = 120.0 if quick else 600.0
    domain, handle = lease_domain("bag")
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain))
    rows = []
    try:
        with tempfile.TemporaryDirectory(prefix="feeder-bench-bags-") as scratch:
            work = Path(scratch)
            runs = {c: _throughput(env, work, c, rates, step_s) for c in ("none", "zstd")}
            memory = _memory(env, work, seconds)
            flight = _flight_memory(env, work, flight_seconds)
            (out / "bags_record.json").write_text(
                json.dumps({"throughput": runs, "memory": memory, "flight": flight}, indent=1)
            )
            _plot(out, runs, memory)
    finally:
        handle.close()
    mb = PAYLOAD / 1e6
    for compression, steps in runs.items():
        sustained, raw = _sustained(steps, "recorded"), _sustained(steps, "raw")
        rows.append(
            row(
                "bags",
                f"record sustained without loss ({compression} chunks), 1 KiB msgs",
                sustained,
                "msg/s",
                "the raw subscriber's of the same run",
                f"raw subscriber {raw:.0f} msg/s; steps {rates} x {step_s:.0f} s",
                sustained >= raw,
            )
        )
        rows.append(
            row(
                "bags",
                f"record sustained ({compression} chunks)",
                sustained * mb,
                "MB/s",
                "",
                f"raw subscriber {raw * mb:.3g} MB/s",
                True,
            )
        )
    ratio = memory["late_mb"] / memory["early_mb"] if memory["early_mb"] else float("nan")
    rows.append(
        row(
            "bags",
            f"recorder peak RSS, demo scene --all, {memory['seconds']:.0f} s ({memory['messages']} msgs)",
            memory["peak_mb"],
            "MiB",
            "flat: last tenth <= 1.1 x first",
            f"first {memory['early_mb']:.1f} MiB, last {memory['late_mb']:.1f} MiB",
            ratio <= 1.1,
        )
    )
    flat = flight["late_mb"] / flight["full_mb"] if flight["full_mb"] else float("nan")
    rise = flight["peak_mb"] - flight["full_mb"]
    bound = 2 * CACHE_BYTES / 2**20
    rows.append(
        row(
            "bags",
            "flight recorder peak RSS, cell scene --all --snapshot-on-fault "
            f"(cache {CACHE_BYTES // 2**20} MiB, {CACHE_SECONDS:.0f} s), {flight['seconds']:.0f} s, "
            f"{flight['faults']} faults "
            f"({flight['messages']} msgs)",
            flight["peak_mb"],
            "MiB",
            f"flat once the cache is full (last tenth <= 1.1 x), peak <= that + {bound:.0f} MiB, "
            "a bag per fault",
            f"cache full {flight['full_mb']:.1f}, "
            f"last {flight['late_mb']:.1f} MiB; cache peak {flight['cache_peak_mb']:.1f} MiB; "
            f"{flight['bags']} bags",
            flat <= 1.1 and rise <= bound and flight["bags"] == flight["faults"] > 0,
        )
    )
    return rows
