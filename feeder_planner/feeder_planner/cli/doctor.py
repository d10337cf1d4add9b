"""``feeder doctor``: checks that ROS 2, the RMW, the interfaces and DDS discovery work here."""

from __future__ import annotations

import argparse
import os
import random
import subprocess
import sys
import time
from dataclasses import dataclass
from typing import Callable

FIX_SETUP = "run 'make setup', then 'source env.sh'"


@dataclass
class Check:
    name: str
    ok: bool
    detail: str
    hint: str = ""

    def line(self) -> str:
        status = "OK  " if self.ok else "FAIL"
        hint = f" -- fix: {self.hint}" if not self.ok and self.hint else ""
        return f"{status} {self.name}: {self.detail}{hint}"


def check_rclpy() -> Check:
    try:
        import rclpy  # noqa: F401
        from importlib.metadata import version
        return Check("rclpy import", True, f"rclpy {version('ros-rclpy')} from {os.path.dirname(rclpy.__file__)}")
    except Exception as exc:  # any import failure is the finding itself
        return Check("rclpy import", False, f"{type(exc).__name__}: {exc}", FIX_SETUP)


def check_rmw() -> Check:
    try:
        from rclpy.utilities import get_rmw_implementation_identifier
        identifier = get_rmw_implementation_identifier()
    except Exception as exc:
        return Check("RMW implementation", False, f"{type(exc).__name__}: {exc}", FIX_SETUP)
    wanted = os.environ.get("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
    if identifier != wanted:
        return Check("RMW implementation", False, f"{identifier} in use, {wanted} requested",
                     "unset RMW_IMPLEMENTATION or install that RMW")
    return Check("RMW implementation", True, identifier)


def check_interfaces() -> Check:
    try:
        import feeder_msgs.msg as messages
        names = sorted(n for n in dir(messages) if n[:1].isupper())
        if not names:
            return Check("feeder_msgs types", False, "package imports but defines no message", FIX_SETUP)
        message = getattr(messages, names[0])()
        return Check("feeder_msgs types", True, f"{len(names)} messages import ({', '.join(names[:4])}...), "
                                                f"{type(message).__name__} instantiates")
    except Exception as exc:
        return Check("feeder_msgs types", False, f"{type(exc).__name__}: {exc}", FIX_SETUP)


def check_dds_round_trip(timeout_s: float = 20.0) -> Check:
    """Publish to an echo process on a private domain and wait for the echo to come back."""
    name = "DDS round trip"
    try:
        import rclpy
        from rclpy.node import Node
        from std_msgs.msg import String
    except Exception as exc:
        return Check(name, False, f"{type(exc).__name__}: {exc}", FIX_SETUP)
    domain = random.randint(150, 200)
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    token = f"feeder-doctor-{os.getpid()}-{random.getrandbits(32):08x}"
    request, reply = f"/feeder_doctor/request_{domain}", f"/feeder_doctor/reply_{domain}"
    echo = subprocess.Popen([sys.executable, "-m", "feeder_planner.cli.dds_echo", request, reply, str(timeout_s + 5)],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    context = rclpy.Context()
    try:
        rclpy.init(context=context, domain_id=domain)
        node = Node("feeder_doctor", context=context)
        received: list[str] = []
        node.create_subscription(String, reply, lambda m: received.append(m.data), 10)
        publisher = node.create_publisher(String, request, 10)
        executor = rclpy.executors.SingleThreadedExecutor(context=context)
        executor.add_node(node)
        started = time.monotonic()
        while time.monotonic() - started < timeout_s and token not in received:
            if echo.poll() is not None:
                return Check(name, False, f"echo process exited early: {echo.stderr.read().strip()[-300:]}", FIX_SETUP)
            publisher.publish(String(data=token))
            executor.spin_once(timeout_sec=0.2)
        elapsed = time.monotonic() - started
        if token in received:
            return Check(name, True, f"two processes on domain {domain}, echo after {elapsed:.2f} s")
        return Check(name, False, f"no echo within {timeout_s:.0f} s on domain {domain}",
                     "check that loopback multicast/shared memory is allowed and no firewall blocks UDP on lo")
    finally:
        echo.terminate()
        try:
            echo.wait(timeout=5)
        except subprocess.TimeoutExpired:
            echo.kill()
            echo.wait()
        rclpy.try_shutdown(context=context)


CHECKS: tuple[Callable[[], Check], ...] = (check_rclpy, check_rmw, check_interfaces, check_dds_round_trip)


def _doctor(args: argparse.Namespace) -> int:
    failed = False
    for check in CHECKS:
        result = check()
        print(result.line(), flush=True)
        failed |= not result.ok
    return 1 if failed else 0


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "doctor", help="check the ROS 2 environment (rclpy, RMW, feeder_msgs, a DDS round trip)",
        description="Run each check and print one line per check with OK or FAIL and a fix hint. "
                    "Exit status 1 if any check fails.")
    parser.set_defaults(handler=_doctor)
