"""The OPC UA gateway's update latency: from a device's DDS sample to the OPC UA data-change notification.

Runs a throwing arm (throwing every 0.1 s) and the gateway with `feeder launch` on a ROS domain of its own,
and subscribes with an asyncua client at a publishing interval of 10 ms (the figure includes up to that
much waiting for the next publish cycle; a PLC's usual 50-100 ms adds its own interval instead).
Each notification's latency is the client's wall time at arrival minus the value's SourceTimestamp, the
DDS sample's stamp (the arm's status header, or the sensor sample's DDS source timestamp; both wall
clock on this host). Samples: every change of the arm's throw counter (one ~/status per throw) and of its
sensor bit.
"""

from __future__ import annotations

import asyncio
import os
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import yaml
from benchlib import lease_domain, row

ROOT = Path(__file__).resolve().parents[1]
FEEDER = [sys.executable, "-m", "feeder_cell.cli.main"]
# The client's health probe times out after this long (asyncua's default, 1 s, is shorter than a reply
# of a starved server on a loaded 2-core host).
WATCHDOG_S = 10.0
SETTLE_S = 8.0
PUBLISHING_INTERVAL_MS = 10
TARGET_P99_MS = 100.0  # a PLC's usual publishing interval: the gateway must not be the slow part


def _port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def _percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(round(q * (len(ordered) - 1))))]


async def _measure(url: str, seconds: float) -> dict[str, list[float]]:
    from asyncua import Client, ua

    from feeder_cell.gateway import layout

    latencies: dict[str, list[float]] = {"status": [], "sensor": []}
    skip: set[str] = set()  # the first notification of an item is its current value, not a change

    class Handler:
        def __init__(self, ids: dict[Any, str]) -> None:
            self.ids = ids

        def datachange_notification(self, node: Any, value: Any, data: Any) -> None:
            arrived = time.time()
            which = self.ids[node.nodeid]
            if which not in skip:
                skip.add(which)
                return
            stamp = data.monitored_item.Value.SourceTimestamp
            latencies[which].append((arrived - stamp.timestamp()) * 1e3)

    deadline = time.monotonic() + 60
    client = Client(url, timeout=10, watchdog_intervall=WATCHDOG_S)
    while True:
        try:
            await client.connect()
            break
        except Exception:  # noqa: BLE001 - not listening yet
            if time.monotonic() > deadline:
                raise
            await asyncio.sleep(0.5)
    try:
        idx = await client.get_namespace_index(layout.NAMESPACE_URI)
        key = "bench.throwing_arm"
        nodes = {
            "status": client.get_node(ua.NodeId(layout.variable_id(key, "Status.Counters.throws"), idx)),
            "sensor": client.get_node(ua.NodeId(layout.variable_id(key, "Signals.Sensor"), idx)),
        }
        subscription = await client.create_subscription(
            PUBLISHING_INTERVAL_MS, Handler({n.nodeid: k for k, n in nodes.items()})
        )
        await subscription.subscribe_data_change(list(nodes.values()), queuesize=100)
        await asyncio.sleep(seconds)
        await subscription.delete()
    finally:
        await client.disconnect()
    return latencies


def run(out_dir: Path, quick: bool) -> list[dict]:
    """Return the gateway rows: update latency p50 and p99 for the arm's status and sensor."""
    seconds = 20.0 if quick else 60.0
    domain, lease = lease_domain("gateway")
    url = f"opc.tcp://127.0.0.1:{_port()}"
    scene = {
        "name": "bench_gateway",
        "nodes": [
            {
                "package": "feeder_sim",
                "executable": "throwing_arm",
                "namespace": "/bench",
                "parameters": {
                    "part_file": str(ROOT / "examples/throwing/triangle.yaml"),
                    "autostart": True,
                    "period": 0.1,
                },
            },
            {
                "package": "feeder_cell",
                "executable": "opcua_gateway",
                "parameters": {"endpoint": url, "devices": ["/bench/throwing_arm"]},
            },
        ],
    }
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    try:
        with tempfile.TemporaryDirectory() as logs:
            scene_path = Path(logs) / "scene.yaml"
            scene_path.write_text(yaml.safe_dump(scene))
            launch = subprocess.Popen(
                [*FEEDER, "launch", str(scene_path), "--log-dir", logs],
                env=env,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.PIPE,
                text=True,
            )
            try:
                time.sleep(SETTLE_S)
                latencies = asyncio.run(_measure(url, seconds))
            finally:
                launch.send_signal(signal.SIGINT)
                launch.communicate(timeout=60)
    finally:
        lease.close()
    rows = []
    for which, what in (("status", "~/status (throw counter)"), ("sensor", "~/sensor bit")):
        values = latencies[which]
        if len(values) < 20:
            raise RuntimeError(f"only {len(values)} {which} notifications in {seconds:.0f} s")
        p50, p99 = statistics.median(values), _percentile(values, 0.99)
        for name, value in (("p50", p50), ("p99", p99)):
            rows.append(
                row(
                    "gateway",
                    f"OPC UA update latency, DDS sample to data-change notification, {what}, {name} "
                    f"({len(values)} samples, publishing interval {PUBLISHING_INTERVAL_MS} ms)",
                    value,
                    "ms",
                    f"p99 < {TARGET_P99_MS:g} ms",
                    "a PLC publishing interval of 100 ms",
                    p99 < TARGET_P99_MS,
                )
            )
    return rows
