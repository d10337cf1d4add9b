"""The simulation node's service calls over DDS: a server not discovered yet is waited for, up to the
call timeout, and one that never appears is named in one line (``feeder_cell.simulation.service_calls``).

CI (ci41) saw ResetSimulation fail with "the service /cell/assembly_fixture/get_state is not available"
right after a launch with one process per node: the fixture was up, but the simulation node had not
discovered its get_state yet, and the call gave up at once.
"""

from __future__ import annotations

import time
from typing import Any, Iterator

import pytest
import ros_harness
from rclpy.callback_groups import ReentrantCallbackGroup
from std_srvs.srv import Trigger

from feeder_cell.simulation.results import SimulationError
from feeder_cell.simulation.service_calls import ServiceCalls

pytestmark = pytest.mark.ros

TIMEOUT_S = 10.0


@pytest.fixture()
def caller(ros_domain: int) -> Iterator[ros_harness.ClientNode]:
    node = ros_harness.ClientNode("service_calls_caller")
    yield node
    node.close()


def _call(caller: ros_harness.ClientNode, service: str, timeout_s: float) -> Any:
    """Start ``ServiceCalls.call`` of ``service`` (a read) as a task on the caller's executor."""
    group = ReentrantCallbackGroup()
    calls = ServiceCalls(caller.node, group, timeout_s)
    client = caller.node.create_client(Trigger, service, callback_group=group)
    return caller.executor.create_task(calls.call(client, Trigger.Request(), f"{service} call", read=True))


def _wait_done(task: Any, seconds: float) -> None:
    deadline = time.monotonic() + seconds
    while not task.done():
        assert time.monotonic() < deadline, f"the call did not end within {seconds} s"
        time.sleep(0.01)


def test_a_server_that_appears_after_the_call_began_answers_it(caller: ros_harness.ClientNode) -> None:
    server = ros_harness.ClientNode("service_calls_server")
    try:
        task = _call(caller, "/late_server/trigger", TIMEOUT_S)
        time.sleep(1.0)
        assert not task.done(), f"the call ended before its server appeared: {task.exception()}"

        def answer(_request: Any, response: Any) -> Any:
            response.success, response.message = True, "here"
            return response

        server.node.create_service(Trigger, "/late_server/trigger", answer)
        _wait_done(task, TIMEOUT_S + 5.0)
        assert task.result().message == "here"
    finally:
        server.close()


def test_a_server_that_never_appears_is_named_after_the_timeout(caller: ros_harness.ClientNode) -> None:
    started = time.monotonic()
    task = _call(caller, "/absent_server/trigger", 1.0)
    _wait_done(task, 10.0)
    assert time.monotonic() - started >= 0.9
    error = task.exception()
    assert isinstance(error, SimulationError)
    assert "/absent_server/trigger is not available (not discovered within 1 s)" in str(error)
