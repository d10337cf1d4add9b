"""Test fixtures: a private ROS domain per session, node processes ended by pid, a client node."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Callable, Iterator

import process_tree
import pytest
import ros_harness


@pytest.fixture(scope="session")
def ros_domain() -> Iterator[int]:
    """A ROS_DOMAIN_ID no other test run on this machine holds, exported for this process and its children."""
    lease = ros_harness.DomainLease()
    previous = {key: os.environ.get(key) for key in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE")}
    os.environ["ROS_DOMAIN_ID"] = str(lease.domain)
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    yield lease.domain
    for key, value in previous.items():
        if value is None:
            os.environ.pop(key, None)
        else:
            os.environ[key] = value
    lease.release()


@pytest.fixture(scope="session", autouse=True)
def no_leftover_processes() -> Iterator[None]:
    """At the end of the session (of each worker's, under pytest-xdist): no process it started is alive.

    Set up first, so torn down last: after every other fixture has ended what it started.
    """
    yield
    left = process_tree.descendants(os.getpid())
    assert left == [], f"processes the tests started are still running (pid, name): {left}"


@pytest.fixture(scope="session")
def started_processes() -> Iterator[list[ros_harness.NodeProcess]]:
    """Every node process the session started; at the end, none may still be running."""
    processes: list[ros_harness.NodeProcess] = []
    yield processes
    for process in processes:
        process.stop()
    survivors = [p for p in processes if p.alive()]
    assert not survivors, f"node processes left running: {[(p.executable, p.pid) for p in survivors]}"


@pytest.fixture(scope="module")
def ros_client(ros_domain: int) -> Iterator[Any]:
    """An rclpy node in the test process on the session's domain, spun on a background thread.

    One per test module: every subscription and client the tests make is an endpoint each node started
    later must discover before it can answer; a session-long client collects hundreds, and late in a
    run a new node then answers a service before it has matched the caller ("client will not receive
    response").
    """
    client = ros_harness.ClientNode()
    yield client.node
    client.close()


def _launcher(
    ros_client: Any, started: list[ros_harness.NodeProcess], log_dir: Path
) -> tuple[Callable[..., ros_harness.NodeProcess], list[ros_harness.NodeProcess]]:
    mine: list[ros_harness.NodeProcess] = []

    def launch(
        package: str,
        executable: str,
        parameters: dict[str, Any] | None = None,
        wait_topics: tuple[str, ...] = (),
        wait_services: tuple[str, ...] = (),
        timeout: float = 30.0,
        extra_args: tuple[str, ...] = (),
        namespace: str = "",
        name: str = "",
        lifecycle: str = "active",
    ) -> ros_harness.NodeProcess:
        """Start a node; a managed one is brought to ``lifecycle`` (as `feeder launch` does), then wait."""
        node = ros_harness.start_node(package, executable, parameters, log_dir, extra_args, namespace, name)
        started.append(node)
        mine.append(node)
        ros_harness.wait_for_graph_node(ros_client, node, node.spec.node_name, timeout)
        ros_harness.bring_to(ros_client, node, lifecycle)
        ros_harness.wait_for_graph(ros_client, node, wait_topics, wait_services, timeout)
        return node

    return launch, mine


@pytest.fixture
def launch_node(
    ros_client: Any, started_processes: list, tmp_path: Path
) -> Iterator[Callable[..., ros_harness.NodeProcess]]:
    """Start a node process for one test; it is ended by pid (SIGINT, then SIGKILL) when the test ends."""
    launch, mine = _launcher(ros_client, started_processes, tmp_path)
    yield launch
    for node in mine:
        node.stop()


@pytest.fixture(scope="module")
def launch_module_node(
    ros_client: Any, started_processes: list, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[Callable[..., ros_harness.NodeProcess]]:
    """Like launch_node, but the node lives for the whole test module (for tests that share one node)."""
    launch, mine = _launcher(ros_client, started_processes, tmp_path_factory.mktemp("nodes"))
    yield launch
    for node in mine:
        node.stop()


@pytest.fixture(scope="module")
def listen(ros_client: Any) -> Callable[..., ros_harness.Listener]:
    """Return the module's listener of a topic (created at first use, gone with the module's client)."""
    from feeder_planner.node_kit import LATCHED

    listeners: dict[tuple[Any, str, bool], ros_harness.Listener] = {}

    def get(msg_type: Any, topic: str, latched: bool = False) -> ros_harness.Listener:
        key = (msg_type, topic, latched)
        if key not in listeners:
            listeners[key] = ros_harness.Listener(ros_client, msg_type, topic, LATCHED if latched else 200)
        return listeners[key]

    return get
