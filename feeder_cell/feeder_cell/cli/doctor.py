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
    """One doctor check: what was checked, whether it passed, and the detail."""

    name: str
    ok: bool
    detail: str
    hint: str = ""

    def line(self) -> str:
        """Return the check's report line."""
        status = "OK  " if self.ok else "FAIL"
        hint = f" -- fix: {self.hint}" if not self.ok and self.hint else ""
        return f"{status} {self.name}: {self.detail}{hint}"


def _probe(code: str, timeout_s: float = 60.0) -> tuple[bool, str]:
    """Run ``code`` in a child Python: rcl exits the whole process on some failures (a wrong RMW)."""
    try:
        child = subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, timeout=timeout_s
        )
    except subprocess.TimeoutExpired:
        return False, f"no answer within {timeout_s:.0f} s"
    if child.returncode != 0:
        last = (child.stderr.strip().splitlines() or [f"exit status {child.returncode}"])[-1]
        return False, last[:300]
    return True, child.stdout.strip()


def check_rclpy() -> Check:
    """Check that rclpy imports and initialises."""
    ok, detail = _probe(
        "import os, rclpy\nfrom importlib.metadata import version\n"
        "print(f\"rclpy {version('ros-rclpy')} from {os.path.dirname(rclpy.__file__)}\")"
    )
    return Check("rclpy import", ok, detail, FIX_SETUP)


def check_rmw() -> Check:
    """Check which RMW implementation is in use."""
    wanted = os.environ.get("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
    ok, detail = _probe(
        "import rclpy\nfrom rclpy.utilities import get_rmw_implementation_identifier\n"
        "print(get_rmw_implementation_identifier())"
    )
    if ok and detail != wanted:
        ok, detail = False, f"{detail} in use, {wanted} requested"
    return Check(
        "RMW implementation",
        ok,
        detail,
        "unset RMW_IMPLEMENTATION (rmw_fastrtps_cpp is the one installed) or install the RMW you named",
    )


def check_interfaces() -> Check:
    """Check that the feeder_msgs types import and build."""
    ok, detail = _probe(
        "import feeder_msgs.msg as m\nnames = sorted(n for n in dir(m) if n[:1].isupper())\n"
        "assert names, 'feeder_msgs defines no message'\ngetattr(m, names[0])()\n"
        "print(f\"{len(names)} messages import ({', '.join(names[:4])}...), {names[0]} instantiates\")"
    )
    return Check("feeder_msgs types", ok, detail, FIX_SETUP)


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
    echo = subprocess.Popen(
        [sys.executable, "-m", "feeder_cell.cli.dds_echo", request, reply, str(timeout_s + 5)],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
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
                said = echo.stderr.read() if echo.stderr is not None else ""
                return Check(name, False, f"echo process exited early: {said.strip()[-300:]}", FIX_SETUP)
            publisher.publish(String(data=token))
            executor.spin_once(timeout_sec=0.2)
        elapsed = time.monotonic() - started
        if token in received:
            return Check(name, True, f"two processes on domain {domain}, echo after {elapsed:.2f} s")
        return Check(
            name,
            False,
            f"no echo within {timeout_s:.0f} s on domain {domain}",
            "check that loopback multicast/shared memory is allowed and no firewall blocks UDP on lo",
        )
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
    results: list[Check] = []
    for check in CHECKS:
        if check is check_dds_round_trip and not all(r.ok for r in results):
            # rclpy in this process would abort it on the same fault the earlier checks found.
            result = Check(
                "DDS round trip", False, "not attempted: an earlier check failed", "fix that first"
            )
        else:
            result = check()
        results.append(result)
        print(result.line(), flush=True)
    return 0 if all(r.ok for r in results) else 1


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add this module's subcommands to the ``feeder`` parser."""
    parser = subparsers.add_parser(
        "doctor",
        help="check the ROS 2 environment (rclpy, RMW, feeder_msgs, a DDS round trip)",
        description="Run each check and print one line per check with OK or FAIL and a fix hint. "
        "Exit status 1 if any check fails.",
    )
    parser.set_defaults(handler=_doctor)
