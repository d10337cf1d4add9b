"""DDS across hosts: simulators on one network namespace, planners and a controller on another.

The test makes both namespaces and their veth pair itself (as root), runs Fast DDS over UDP only on
that pair (each namespace has its own loopback, and shared memory is off), and removes them at
teardown. Where namespaces cannot be made, it fails and says why.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path
from typing import Iterator

import netns
import pytest

from feeder_cell.launcher import NodeSpec, resolve_executable

ROOT = Path(__file__).resolve().parents[2]
CLIENT = Path(__file__).resolve().parent / "scripts" / "remote_client.py"


@pytest.fixture
def two_hosts() -> Iterator[netns.TwoHosts]:
    reason = netns.can_make_namespaces()
    if reason:
        pytest.fail(f"cannot run the across-hosts test: {reason}")
    hosts = netns.make_two_hosts(str(os.getpid()))
    try:
        yield hosts
    finally:
        hosts.close()
    listed = subprocess.run(["ip", "netns", "list"], capture_output=True, text=True).stdout
    assert hosts.a.namespace not in listed and hosts.b.namespace not in listed


def start_on(host: netns.Host, spec: NodeSpec, env: dict[str, str], log: Path) -> subprocess.Popen[bytes]:
    command = [str(resolve_executable(spec.package, spec.executable)), "--ros-args"]
    for name, value in spec.parameters.items():
        command += ["-p", f"{name}:={value}"]
    with open(log, "w") as out:
        return subprocess.Popen(host.command(command), env=env, stdout=out, stderr=subprocess.STDOUT)


@pytest.mark.ros
def test_topics_services_and_lifecycle_cross_hosts(
    two_hosts: netns.TwoHosts, ros_domain: int, tmp_path: Path
) -> None:
    env = two_hosts.environment(ros_domain)
    sim, planners = two_hosts.a, two_hosts.b
    part = ROOT / "examples/throwing/triangle.yaml"
    specs = [
        (
            sim,
            NodeSpec(
                "feeder_sim",
                "throwing_arm",
                {"part_file": str(part), "gravity": -9.66, "offset": -0.005, "period": 0.3},
            ),
        ),
        (
            sim,
            NodeSpec(
                "feeder_sim", "mems_field_array", {"part_files": f"['{ROOT / 'examples/mems/bracket.yaml'}']"}
            ),
        ),
        (planners, NodeSpec("feeder_planner", "field_equilibria_planner")),
        (planners, NodeSpec("feeder_planner", "throw_planner")),
    ]
    rx_before = planners.rx_bytes()
    processes = [start_on(host, spec, env, tmp_path / f"{spec.executable}.log") for host, spec in specs]
    try:
        client = subprocess.run(
            planners.command([sys.executable, str(CLIENT)]),
            env=env,
            capture_output=True,
            text=True,
            timeout=240,
        )
    finally:
        for process in processes:
            if process.poll() is None:
                process.send_signal(signal.SIGINT)
        for process in processes:
            try:
                process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait(timeout=10)
    logs = "\n".join(f"--- {p.name}\n{p.read_text()[-1500:]}" for p in tmp_path.glob("*.log"))
    assert client.returncode == 0, client.stderr + logs
    result = json.loads(client.stdout.strip().splitlines()[-1])
    assert "error" not in result, f"{result}\n{logs}"
    assert result["throwing_arm_managed"] and result["mems_field_array_managed"]
    assert result["throwing_arm_before"] == "unconfigured" and result["throwing_arm_after"] == "active"
    assert result["mems_field_array_after"] == "active" and result["statuses_seen"]
    assert result["command_ok"] and result["throw_events"] >= 2
    assert result["predictions"] == ["bracket"]
    assert result["throwing_arm_deactivated"] == "inactive"
    # All of it crossed the veth pair: the planner host received the streams of the simulator host.
    assert planners.rx_bytes() - rx_before > 100_000
