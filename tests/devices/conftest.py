"""Fixtures of the device conformance suite: node processes started together, a device's client side.

Everything here is device-agnostic; what a device is (its parameters, services, action, faults) is the
table in ``test_device_conformance_ros.py``.
"""

from __future__ import annotations

import threading
import time
from typing import Any, Callable, Iterator, Sequence

import pytest
import ros_harness

from feeder_cell import launcher

# Many node processes import rclpy, numpy and scipy at once on two shared cores: generous, never waited out.
STARTUP = 120.0
# A reply can be lost when a server answers before it has matched the caller's reply reader (Fast DDS,
# "client will not receive response"); an unanswered request is sent again after this long. Every request
# the suite sends is idempotent (refused, or a harmless command), so a second copy changes nothing.
RESEND_S = 3.0


def _stop_together(processes: Sequence[launcher.NodeProcess]) -> None:
    """End processes by pid, all at once (SIGINT, then SIGKILL after the grace period), not one by one."""
    stoppers = [threading.Thread(target=process.stop) for process in processes]
    for stopper in stoppers:
        stopper.start()
    for stopper in stoppers:
        stopper.join()


@pytest.fixture(scope="module")
def stop_together() -> Callable[[Sequence[launcher.NodeProcess]], None]:
    """Return ``stop(processes)``: end them by pid, all at once."""
    return _stop_together


@pytest.fixture(scope="module")
def start_together(
    ros_client: Any, started_processes: list, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[Callable[[Sequence[launcher.NodeSpec]], list[launcher.NodeProcess]]]:
    """Return ``start(specs)``: start every node at once, then bring each to its spec's lifecycle target.

    The imports of all the processes overlap (most of a node's start-up). Every process is ended by pid when
    the module ends, together.
    """
    log_dir = tmp_path_factory.mktemp("devices")
    mine: list[launcher.NodeProcess] = []

    def start(specs: Sequence[launcher.NodeSpec], host: str = "") -> list[launcher.NodeProcess]:
        """Start ``specs`` each alone, or (``host``) all in one cell host of that name."""
        if host:
            processes = launcher.start_host(host, [(spec, {}) for spec in specs], log_dir)
        else:
            processes = [launcher.start_node(spec, log_dir) for spec in specs]
        for process in processes:
            started_processes.append(process)
            mine.append(process)
        for process in processes:
            _wait_for_node(ros_client, process)
            if process.spec.lifecycle != "unconfigured":
                ros_harness.bring_to(ros_client, process, process.spec.lifecycle)
        return processes

    yield start
    _stop_together(mine)


def _wait_for_node(client: Any, process: launcher.NodeProcess) -> None:
    """Wait until the node itself is in the graph (a service name alone can be a client's, not the node's)."""
    wanted = (process.spec.node_name, process.spec.namespace or "/")
    deadline = time.monotonic() + STARTUP
    while wanted not in client.get_node_names_and_namespaces():
        if not process.alive():
            raise AssertionError(
                f"{process.spec.fully_qualified_name} exited with code {process.process.returncode}:\n"
                f"{process.output()[-4000:]}"
            )
        if time.monotonic() > deadline:
            raise AssertionError(
                f"{process.spec.fully_qualified_name} not in the graph within {STARTUP:.0f} s. Its log:\n"
                f"{process.output()[-4000:]}"
            )
        time.sleep(0.1)


class Caller:
    """Service and action clients of one client node, made once per name and kept for the node's life."""

    def __init__(self, node: Any) -> None:
        self.node = node
        self.services: dict[tuple[Any, str], Any] = {}
        self.actions: dict[tuple[Any, str], Any] = {}

    def prepare(self, srv_type: Any, name: str) -> Any:
        """Make the client of a service now: made before its server starts, no first reply is lost."""
        key = (srv_type, name)
        if key not in self.services:
            self.services[key] = self.node.create_client(srv_type, name)
        return self.services[key]

    def prepare_action(self, action_type: Any, name: str) -> Any:
        """Make the client of an action now (rclpy's, without its goal-registration race)."""
        from feeder_planner.node_kit.action_client import ActionClient

        key = (action_type, name)
        if key not in self.actions:
            self.actions[key] = ActionClient(self.node, action_type, name)
        return self.actions[key]

    def call(self, srv_type: Any, name: str, request: Any, timeout: float = 30.0) -> Any:
        """Call a service; an unanswered request is sent again every RESEND_S (see RESEND_S)."""
        client = self.prepare(srv_type, name)
        if not client.wait_for_service(timeout_sec=timeout):
            raise AssertionError(f"service {name} not available within {timeout:.0f} s")
        return _first_answer(lambda: client.call_async(request), timeout, f"service {name}")

    def action(self, action_type: Any, name: str, timeout: float = 30.0) -> Any:
        """Return the action client of ``name``, its server discovered."""
        client = self.prepare_action(action_type, name)
        if not client.wait_for_server(timeout_sec=timeout):
            raise AssertionError(f"action {name} not available within {timeout:.0f} s")
        return client

    def send_goal(
        self, action_type: Any, name: str, goal: Any, resend: bool = False, timeout: float = 30.0
    ) -> Any:
        """Send a goal and return its handle (``accepted`` says whether the server took it).

        ``resend`` sends it again while no answer comes: only for a goal the server rejects, which changes
        nothing however often it arrives (a rejected goal warms a new client up).
        """
        client = self.action(action_type, name)
        if resend:
            return _first_answer(lambda: client.send_goal_async(goal), timeout, f"a goal of {name}")
        return wait_future(client.send_goal_async(goal), timeout, f"the goal response of {name}")

    def close(self) -> None:
        """Destroy every client made here."""
        for client in self.services.values():
            self.node.destroy_client(client)
        for action in self.actions.values():
            action.destroy()
        self.services.clear()
        self.actions.clear()


def wait_future(future: Any, timeout: float, what: str) -> Any:
    """Return a future's result, waiting at most ``timeout`` s (the client's executor runs elsewhere)."""
    done = threading.Event()
    future.add_done_callback(lambda _: done.set())
    if not done.wait(timeout):
        raise AssertionError(f"no {what} within {timeout:.0f} s")
    return future.result()


def _first_answer(send: Callable[[], Any], timeout: float, what: str) -> Any:
    """Send, and send again every RESEND_S while none of the sends is answered; return the first answer."""
    answered = threading.Event()
    futures: list[Any] = []
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        future = send()
        future.add_done_callback(lambda _: answered.set())
        futures.append(future)
        if answered.wait(min(RESEND_S, max(0.0, deadline - time.monotonic()))):
            return next(f for f in futures if f.done()).result()
    raise AssertionError(f"{what} did not answer within {timeout:.0f} s ({len(futures)} sends)")


@pytest.fixture(scope="module")
def caller(ros_client: Any) -> Iterator[Caller]:
    """The module client node's service and action clients."""
    made = Caller(ros_client)
    yield made
    made.close()


@pytest.fixture
def side_caller(ros_domain: int) -> Iterator[Caller]:
    """Clients on a client node of their own for one test: its endpoints leave the graph with it."""
    node = ros_harness.ClientNode("feeder_conformance_side")
    made = Caller(node.node)
    yield made
    made.close()
    node.close()
