"""The reference cell controller's cycle rate, at real time and as fast as the cell still holds its rates.

Runs the cell scene (`feeder_cell/scenes/cell.yaml`: the three devices, their planners and the cell
controller) with `feeder launch` on its own ROS domain; the launch ends when the controller has run its
cycles (on_exit: shutdown). Read over DDS while it runs: the controller's own status (cycles, cycle
times, parts per minute) and every device's figures on /diagnostics (achieved against configured rate
and real-time factor, the devices' own 5 s windows), as bench_cell.py reads them. First at real-time
factor 1, then on the cell clock at rising factors: the highest factor at which the controller still
completes its cycles with every device within 2 % of its configured rates.
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import yaml
from benchlib import holds_rate, row

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "feeder_cell" / "scenes" / "cell.yaml"
FEEDER = [sys.executable, "-m", "feeder_cell.cli.main"]
CONTROLLER_STATUS = "/cell/cell_controller/status"
# Device figures are judged from this long after the first cycle started (wall s): each device measures
# over a 5 s window of its node clock, and the first windows include configure and start-up.
WINDOW_WALL_S = 5.0
RUN_WALL_LIMIT_S = 240.0


def _scene_with(cycles: int, folder: Path) -> Path:
    """Write the cell scene with the controller's cycle count set (paths made absolute)."""
    document = yaml.safe_load(SCENE.read_text())
    for node in document["nodes"]:
        parameters = node.get("parameters", {})
        for key, value in list(parameters.items()):
            if key.endswith("_file") and isinstance(value, str) and value:
                parameters[key] = str((SCENE.parent / value).resolve())
            elif key.endswith("_files") and isinstance(value, list):
                parameters[key] = [str((SCENE.parent / v).resolve()) for v in value]
        if node["executable"] == "cell_controller":
            parameters["cycles"] = cycles
    path = folder / "cell.yaml"
    path.write_text(yaml.safe_dump(document))
    return path


class _Listener:
    """Diagnostics of every device and the controller's status, on a thread, for one run."""

    def __init__(self) -> None:
        self.devices: dict[str, list[tuple[float, dict[str, float]]]] = {}
        self.status: list[tuple[float, Any]] = []
        self.lock = threading.Lock()
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._spin, daemon=True)
        self.thread.start()

    def _spin(self) -> None:
        import rclpy
        from diagnostic_msgs.msg import DiagnosticArray
        from rclpy.executors import SingleThreadedExecutor

        from feeder_msgs.msg import CellStatus
        from feeder_planner.node_kit import LATCHED

        context = rclpy.Context()
        rclpy.init(context=context)
        node = rclpy.create_node("bench_controller_listener", context=context)
        node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diagnostics, 50)
        node.create_subscription(CellStatus, CONTROLLER_STATUS, self._on_status, LATCHED)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        while not self.stop.is_set():
            executor.spin_once(timeout_sec=0.1)
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=context)

    def _on_diagnostics(self, msg: Any) -> None:
        now = time.monotonic()
        for status in msg.status:
            values = {kv.key: kv.value for kv in status.values}
            if "achieved_rate_hz" not in values:
                continue  # the controller's own entry
            figures = {
                key: float(values[key])
                for key in (
                    "configured_rate_hz",
                    "achieved_rate_hz",
                    "configured_real_time_factor",
                    "achieved_real_time_factor",
                )
            }
            with self.lock:
                self.devices.setdefault(status.name, []).append((now, figures))

    def _on_status(self, msg: Any) -> None:
        with self.lock:
            self.status.append((time.monotonic(), msg))

    def close(self) -> None:
        self.stop.set()
        self.thread.join(timeout=10.0)


def _run(cycles: int, factor: float, domain: int) -> dict[str, Any]:
    """Run the cell scene for ``cycles`` at ``factor``; return the controller's end and device figures."""
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    os.environ.update(ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    with tempfile.TemporaryDirectory() as folder:
        scene = _scene_with(cycles, Path(folder))
        listener = _Listener()
        started = time.monotonic()
        try:
            launch = subprocess.run(
                [*FEEDER, "launch", str(scene), "--log-dir", folder, "--real-time-factor", f"{factor:g}"],
                env=env,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.PIPE,
                text=True,
                timeout=RUN_WALL_LIMIT_S,
            )
        finally:
            listener.close()
        wall = time.monotonic() - started
    statuses = [m for _, m in listener.status]
    final = statuses[-1] if statuses else None
    first_cycle = next((t for t, m in listener.status if m.cycle >= 1), None)
    judged_from = (first_cycle or started) + WINDOW_WALL_S
    devices = {
        name: {
            key: statistics.median(f[key] for t, f in samples if t >= judged_from) for key in samples[0][1]
        }
        for name, samples in listener.devices.items()
        if any(t >= judged_from for t, _ in samples)
    }
    return {
        "factor": factor,
        "exit_code": launch.returncode,
        "error": launch.stderr.strip().splitlines()[-1:] if launch.returncode else [],
        "finished": final is not None and final.state == "FINISHED",
        "stop_reason": final.stop_reason if final else "no status from the controller",
        "cycles": final.cycles_completed if final else 0,
        "mean_cycle_time": final.mean_cycle_time if final else float("nan"),
        "parts_per_minute": final.parts_per_minute if final else float("nan"),
        "wall": wall,
        "devices": devices,
        "holds": len(devices) == 3 and all(holds_rate(f) for f in devices.values()),
    }


def run(out_dir: Path, quick: bool) -> list[dict]:
    """Return the controller rows: cycle rate at factor 1, the highest factor the cell sustains."""
    domain = 80 + os.getpid() % 10
    real_time = _run(1 if quick else 2, 1.0, domain)
    rate = 60.0 / real_time["mean_cycle_time"] if real_time["finished"] else 0.0
    rows = [
        row(
            "controller",
            f"cycle rate at real-time factor 1 ({real_time['cycles']} cycles of the cell scene)",
            rate,
            "cycles/min",
            "cycles complete (reported)",
            f"mean cycle {real_time['mean_cycle_time']:.1f} s, {real_time['parts_per_minute']:.2f} parts/min",
            real_time["finished"],
        ),
        row(
            "controller",
            "devices within 2 % of their rates at real-time factor 1 during the cycles",
            sum(holds_rate(f) for f in real_time["devices"].values()),
            "of 3",
            "3",
            ", ".join(
                f"{name.rsplit('/', 1)[1]} {f['achieved_rate_hz']:.4g}/{f['configured_rate_hz']:.4g} Hz"
                for name, f in sorted(real_time["devices"].items())
            ),
            real_time["holds"],
        ),
    ]
    sustained, best = (1.0, real_time) if real_time["finished"] and real_time["holds"] else (0.0, None)
    for factor in (2.0, 4.0, 8.0) if quick else (2.0, 4.0, 8.0, 16.0):
        result = _run(2 if quick else 3, factor, domain)
        if not (result["finished"] and result["holds"]):
            why = (
                f"did not finish ({result['stop_reason']})"
                if not result["finished"]
                else "a device below 2 %"
            )
            print(f"bench_controller: factor {factor:g}: {why}: {result['devices']}", flush=True)
            break
        sustained, best = factor, result
    wall_rate = 60.0 * best["cycles"] / best["wall"] if best else 0.0
    rows.append(
        row(
            "controller",
            "highest real-time factor at which the cell completes cycles, every device within 2 %",
            sustained,
            "x",
            ">= 1 (reported)",
            f"factors 2, 4, 8{'' if quick else ', 16'} tried in turn; at the highest "
            f"{wall_rate:.2f} cycles per wall minute (start-up included)",
            sustained >= 1.0,
        )
    )
    return rows
