"""The lifecycle client when a node's transition reply is lost: the node's state settles it, not a timeout.

A node that answers before it has matched the caller's reply reader loses the reply (ci29: a bad
configuration's refused configure came back as "configure not answered within 30 s"). The node here
(scripts/lossy_lifecycle_node.py, a real process over DDS) loses its first transition reply for certain.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any, Callable, Iterator

import pytest

from feeder_cell.lifecycle_client import CALL_TIMEOUT_S, LifecycleClient, LifecycleError

pytestmark = pytest.mark.ros

SCRIPT = Path(__file__).resolve().parent / "scripts" / "lossy_lifecycle_node.py"
NODE = "/lossy_lifecycle"


class LossyNode:
    """The lossy node's process, ended by pid; its printed transition requests counted."""

    def __init__(self, mode: str) -> None:
        self.process = subprocess.Popen(
            [sys.executable, str(SCRIPT), mode], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
        )

    def stop(self) -> str:
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
        try:
            out, _ = self.process.communicate(timeout=20)
        except subprocess.TimeoutExpired:
            self.process.kill()
            out, _ = self.process.communicate()
        return out

    @staticmethod
    def requests(output: str) -> int:
        """How many transition requests the node took, from its printed output."""
        return sum(line.startswith("change_state ") for line in output.splitlines())


Start = Callable[[str], tuple[LifecycleClient, "LossyNode"]]


@pytest.fixture
def lossy(ros_client: Any) -> Iterator[Start]:
    nodes: list[LossyNode] = []
    clients: list[LifecycleClient] = []

    def start(mode: str) -> tuple[LifecycleClient, LossyNode]:
        node = LossyNode(mode)
        nodes.append(node)
        client = LifecycleClient(ros_client, None, NODE)
        clients.append(client)
        assert client.is_managed(timeout=30.0), f"{NODE} not discovered: {node.stop()[-2000:]}"
        return client, node

    yield start
    for client in clients:
        client.close()
    for node in nodes:
        node.stop()


def test_a_refused_transition_whose_reply_is_lost_is_reported_refused(lossy: Start) -> None:
    client, node = lossy("refuse")
    started = time.monotonic()
    with pytest.raises(LifecycleError, match="configure refused") as refused:
        client.change("configure")
    took = time.monotonic() - started
    output = node.stop()
    # Still unconfigured after the lost reply: sent once more, and that reply says refused.
    assert node.requests(output) == 2, output
    assert "unconfigured" in str(refused.value)
    assert took < CALL_TIMEOUT_S, f"settled after {took:.1f} s: the client waited the lost reply out"


def test_a_transition_that_ran_but_whose_reply_is_lost_returns_its_result_without_resending(
    lossy: Start,
) -> None:
    client, node = lossy("accept")
    started = time.monotonic()
    assert client.change("configure") == "inactive"
    took = time.monotonic() - started
    output = node.stop()
    assert node.requests(output) == 1, output
    assert took < CALL_TIMEOUT_S, f"settled after {took:.1f} s: the client waited the lost reply out"


def test_a_transition_still_running_is_not_sent_again(lossy: Start) -> None:
    # Its configure takes longer than the client's RESEND_S, in the state "configuring".
    client, node = lossy("slow")
    assert client.change("configure") == "inactive"
    output = node.stop()
    assert node.requests(output) == 1, output
