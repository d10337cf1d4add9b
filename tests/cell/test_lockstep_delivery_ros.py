"""A lockstep answer waits until every reader has a delivered publisher's samples (``Participant.delivered``).

Over DDS, with a reader in a process of its own. DDS orders what one writer sends, not what two writers of
one process send to a third: a status published just before an answer could reach the recorder after the
clock's next announcement, which the answer lets out (CI saw the hosted controller's status logged one
quantum late). So the controller marks its status publisher delivered, and an answer is held until every
reader has acknowledged the status. The reader here is stopped (SIGSTOP) while the status is published:
the answer must wait for it, and go out once it is continued and has acknowledged. A reader that never
acknowledges holds an answer for ``DELIVERY_S`` only.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any, Callable, Iterator

import pytest
from std_msgs.msg import String

from feeder_planner.node_kit import LATCHED
from feeder_planner.node_kit.lockstep import DELIVERY_S, NANOSECONDS, Participant

pytestmark = pytest.mark.ros

TOPIC = "/delivery_probe/status"
T_NS = 1_000 * NANOSECONDS
STOPPED_S = 0.8  # how long the reader stays stopped: the answer must not go out meanwhile

READER = """
import sys
from pathlib import Path
import rclpy
from std_msgs.msg import String
from feeder_planner.node_kit import LATCHED

rclpy.init()
node = rclpy.create_node("delivery_reader")
out = Path(sys.argv[1])


def take(msg: String) -> None:
    out.write_text(out.read_text() + msg.data + "\\n")


node.create_subscription(String, sys.argv[2], take, LATCHED)
out.write_text("")
rclpy.spin(node)
"""


@pytest.fixture()
def reader(ros_client: Any, tmp_path: Path) -> Iterator[tuple[subprocess.Popen[bytes], Path]]:
    """A subscriber of TOPIC in a process of its own, writing each sample's data to a file; ended by pid."""
    received = tmp_path / "received.txt"
    process = subprocess.Popen([sys.executable, "-c", READER, str(received), TOPIC])
    try:
        yield process, received
    finally:
        os.kill(process.pid, signal.SIGCONT)
        process.kill()
        process.wait(timeout=10)


def _stop(pid: int) -> None:
    """SIGSTOP ``pid`` and wait until it is stopped (the signal lands when the process is next scheduled)."""
    os.kill(pid, signal.SIGSTOP)
    deadline = time.monotonic() + 10.0
    while Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "T":
        assert time.monotonic() < deadline, f"process {pid} did not stop"
        time.sleep(0.01)


def _until(ready: Callable[[], bool], what: str, deadline: float) -> None:
    while not ready():
        assert time.monotonic() < deadline, what
        time.sleep(0.05)


def _answer_with_the_reader_stopped(
    participant: Participant, status: Any, data: str, pid: int, now_ns: int
) -> threading.Thread:
    """Stop the reader, publish ``data`` on the delivered ``status``, answer ``now_ns`` on a thread."""
    _stop(pid)
    status.publish(String(data=data))
    participant.delivered(status)
    thread = threading.Thread(target=participant.release, args=(now_ns,), daemon=True)
    thread.start()
    return thread


@pytest.fixture()
def holding(
    ros_client: Any, reader: tuple[subprocess.Popen[bytes], Path]
) -> Iterator[tuple[Participant, Any]]:
    """A holding react participant and a latched status publisher that the reader has matched."""
    _, received = reader
    participant = Participant(ros_client, "react", hold=True)
    status = ros_client.create_publisher(String, TOPIC, LATCHED)
    try:
        deadline = time.monotonic() + 60.0
        _until(lambda: status.get_subscription_count() >= 1 and received.exists(), "no match", deadline)
        yield participant, status
    finally:
        participant.leave()
        ros_client.destroy_publisher(status)


def test_an_answer_waits_until_every_reader_has_acknowledged_the_delivered_status(
    reader: tuple[subprocess.Popen[bytes], Path], holding: tuple[Participant, Any]
) -> None:
    process, received = reader
    participant, status = holding
    deadline = time.monotonic() + 60.0
    status.publish(String(data="warm-up"))
    _until(lambda: "warm-up" in received.read_text(), "the reader never took the first sample", deadline)

    answering = _answer_with_the_reader_stopped(participant, status, "FEED", process.pid, T_NS)
    answering.join(STOPPED_S)
    assert answering.is_alive(), "the answer went out while a reader had not acknowledged the status"
    assert participant.answered_ns < T_NS

    os.kill(process.pid, signal.SIGCONT)
    answering.join(DELIVERY_S + 5.0)
    assert not answering.is_alive() and participant.answered_ns == T_NS
    _until(lambda: "FEED" in received.read_text(), "the continued reader never took the status", deadline)

    # A reader that never acknowledges holds an answer for DELIVERY_S, then the clock goes on.
    started = time.monotonic()
    answering = _answer_with_the_reader_stopped(
        participant, status, "FINISHED", process.pid, T_NS + NANOSECONDS
    )
    answering.join(DELIVERY_S + 5.0)
    assert not answering.is_alive(), f"an answer held by a stopped reader past {DELIVERY_S + 5.0} s"
    assert time.monotonic() - started >= DELIVERY_S * 0.9
    assert participant.answered_ns == T_NS + NANOSECONDS
    # Nothing new published: the next answer does not wait again for the stopped reader.
    started = time.monotonic()
    participant.release(T_NS + 2 * NANOSECONDS)
    assert time.monotonic() - started < DELIVERY_S * 0.5


def test_an_answer_waits_while_the_participants_other_thread_waits_for_the_delivery(
    reader: tuple[subprocess.Popen[bytes], Path], holding: tuple[Participant, Any]
) -> None:
    """ci41: the join timer (the executor's thread) took the delivered status and waited for it, and the
    holding thread's answer, finding nothing left to deliver, went out at once. Made certain here: the
    join's send takes the status first, then the answer is released."""
    process, received = reader
    participant, status = holding
    deadline = time.monotonic() + 60.0
    _stop(process.pid)
    status.publish(String(data="FEED"))
    participant.delivered(status)
    joining = threading.Thread(target=participant.send, args=(0,), daemon=True)  # as the join timer
    joining.start()
    _until(lambda: not participant._undelivered, "the join never took the status", deadline)
    answering = threading.Thread(target=participant.release, args=(T_NS,), daemon=True)
    answering.start()
    answering.join(STOPPED_S)
    assert answering.is_alive(), "the answer went out while the join still waited for the reader"
    os.kill(process.pid, signal.SIGCONT)
    answering.join(DELIVERY_S + 5.0)
    joining.join(DELIVERY_S + 5.0)
    assert not answering.is_alive() and participant.answered_ns == T_NS
    _until(lambda: "FEED" in received.read_text(), "the continued reader never took the status", deadline)
