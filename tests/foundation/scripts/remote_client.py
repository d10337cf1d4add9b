"""A cell controller on the planner host: drives the simulators on the other host, prints one JSON object."""

from __future__ import annotations

import json
import sys
import time

import rclpy
from rclpy.executors import SingleThreadedExecutor

from feeder_cell.lifecycle_client import LifecycleClient
from feeder_msgs.msg import DeviceStatus, EquilibriaPrediction, ThrowEvent
from feeder_msgs.srv import ArmCommand
from feeder_planner.node_kit import LATCHED

DEADLINE_S = 90.0


def spin_until(executor: SingleThreadedExecutor, done, timeout: float) -> bool:
    end = time.monotonic() + timeout
    while not done() and time.monotonic() < end:
        executor.spin_once(timeout_sec=0.05)
    return bool(done())


def main() -> int:
    rclpy.init()
    node = rclpy.create_node("remote_controller")
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    result: dict = {}
    statuses: dict[str, DeviceStatus] = {}
    events: list[ThrowEvent] = []
    predictions: list[EquilibriaPrediction] = []
    for device in ("throwing_arm", "mems_field_array"):
        node.create_subscription(
            DeviceStatus, f"/{device}/status", lambda m, d=device: statuses.__setitem__(d, m), LATCHED
        )
    node.create_subscription(ThrowEvent, "/throwing_arm/throw_events", events.append, 50)
    node.create_subscription(
        EquilibriaPrediction, "/field_equilibria_planner/predicted_poses", predictions.append, LATCHED
    )
    try:
        for device in ("throwing_arm", "mems_field_array"):
            client = LifecycleClient(node, executor, f"/{device}")
            result[f"{device}_managed"] = client.is_managed(timeout=DEADLINE_S / 3)
            result[f"{device}_before"] = client.get_state()
            result[f"{device}_after"] = client.bring_to("active")
        result["statuses_seen"] = spin_until(
            executor,
            lambda: all(
                statuses.get(d) and statuses[d].state_name in ("IDLE", "RUNNING")
                for d in ("throwing_arm", "mems_field_array")
            ),
            30.0,
        )
        command = node.create_client(ArmCommand, "/throwing_arm/command")
        command.wait_for_service(timeout_sec=30.0)
        future = command.call_async(ArmCommand.Request(command="throw", count=2))
        spin_until(executor, future.done, 30.0)
        response = future.result()
        result["command_ok"] = bool(response and response.ok)
        result["throw_events"] = spin_until(executor, lambda: len(events) >= 2, 30.0) and len(events)
        result["predictions"] = spin_until(executor, lambda: bool(predictions), 30.0) and list(
            predictions[-1].names
        )
        client = LifecycleClient(node, executor, "/throwing_arm")
        result["throwing_arm_deactivated"] = client.change("deactivate")
    except Exception as error:  # the test reads the reason from the JSON
        result["error"] = f"{type(error).__name__}: {error}"
    sys.stdout.write(json.dumps(result) + "\n")
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
