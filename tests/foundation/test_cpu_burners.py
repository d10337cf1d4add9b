"""The load a test makes ends with the test process, even when that process is killed.

A killed pytest runs no fixture teardown: its busy loops used to outlive it and load every later run on
the machine (two of them, found at 100 % CPU ten minutes after the stress run they belonged to was
killed).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

START_TWO_AND_WAIT = """
import sys, time
sys.path.insert(0, sys.argv[1])
import ros_harness
burners = ros_harness.cpu_burners(2)
print(" ".join(str(b.pid) for b in burners), flush=True)
time.sleep(120)
"""


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().split(")")[-1].split()[0] != "Z"  # a zombie has ended
    except FileNotFoundError:
        return False


def test_burners_end_when_the_process_that_started_them_is_killed() -> None:
    tests = str(Path(__file__).resolve().parents[1])
    parent = subprocess.Popen(
        [sys.executable, "-c", START_TWO_AND_WAIT, tests], stdout=subprocess.PIPE, text=True
    )
    try:
        assert parent.stdout is not None
        pids = [int(p) for p in parent.stdout.readline().split()]
        assert len(pids) == 2 and all(_alive(pid) for pid in pids)
        os.kill(parent.pid, signal.SIGKILL)
        parent.wait(timeout=10)
        deadline = time.monotonic() + 5.0
        while any(_alive(pid) for pid in pids) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not any(_alive(pid) for pid in pids), f"burners outlived their parent: {pids}"
    finally:
        if parent.poll() is None:
            parent.kill()
            parent.wait(timeout=10)
