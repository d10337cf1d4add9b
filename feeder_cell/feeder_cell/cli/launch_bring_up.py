"""The start-up of ``feeder launch``'s nodes: wait until all are in the graph, bring each to its target."""

from __future__ import annotations

import time
from typing import Any, Callable

from feeder_cell.launcher import NodeProcess, NodeSpec
from feeder_cell.lifecycle_client import LifecycleClient, LifecycleError, LifecycleInterruptedError
from feeder_cell.node_modules import node_class
from feeder_planner.errors import FeederError

STARTUP_TIMEOUT_S = 30.0
# Primary lifecycle states in the order `feeder launch` walks them (anything else is a transition state).
RANK = {"unconfigured": 0, "inactive": 1, "active": 2}


def _graph_names(node: Any) -> set[str]:
    return {f"{ns.rstrip('/')}/{name}" for name, ns in node.get_node_names_and_namespaces()}


def _process_name(process: NodeProcess, processes: list[NodeProcess]) -> str:
    """Name a process as a user knows it: its node's executable, or the cell host with all its nodes."""
    if not process.host:
        return f"{process.package}/{process.executable}"
    nodes = [p.spec.fully_qualified_name for p in processes if p.host == process.host]
    return f"cell host {process.host} (pid {process.pid}; nodes {', '.join(nodes)})"


def wait_until_in_graph(
    node: Any, executor: Any, processes: list[NodeProcess], keep_going: Callable[[], bool]
) -> None:
    """Spin until every started node is in the graph; a process that exits before its node is seen fails.

    A node seen in the graph and gone since is left to the bring-up and the launch's loop, as a node that
    dies mid-run is (in lockstep the clock drops a device and the cell goes on): the cell clock runs once
    its participants have joined, which can be well before the slowest node of a large scene is up (ci32:
    a device killed after 4 s of cell time ended the launch "at start-up" while a planner was coming up).
    """
    deadline = time.monotonic() + STARTUP_TIMEOUT_S
    wanted = {p.spec.fully_qualified_name for p in processes}
    seen: set[str] = set()
    while keep_going():
        executor.spin_once(timeout_sec=0.1)
        seen |= _graph_names(node) & wanted
        unseen = [p for p in processes if p.spec.fully_qualified_name not in seen]
        dead = [p for p in unseen if not p.alive()]
        if dead:
            p = dead[0]
            raise FeederError(
                f"{_process_name(p, processes)} exited with code {p.process.returncode} at start-up; "
                f"last log line: {(p.output().strip().splitlines() or ['(none)'])[-1]}"
            )
        if not unseen:
            return
        if time.monotonic() > deadline:
            missing = sorted(p.spec.fully_qualified_name for p in unseen)
            raise FeederError(f"nodes not in the graph after {STARTUP_TIMEOUT_S:.0f} s: {', '.join(missing)}")


def _configuration_error(node: Any, executor: Any, target: str) -> str:
    """Return the fault text a device published on its latched status (why configure failed), if any."""
    from feeder_msgs.msg import DeviceStatus
    from feeder_planner.node_kit import LATCHED

    seen: list[DeviceStatus] = []
    subscription = node.create_subscription(DeviceStatus, f"{target}/status", seen.append, LATCHED)
    deadline = time.monotonic() + 2.0
    while not seen and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.05)
    node.destroy_subscription(subscription)
    return seen[-1].fault_text if seen else ""


def _while_alive(process: NodeProcess, keep_going: Callable[[], bool]) -> Callable[[], bool]:
    return lambda: keep_going() and process.alive()


def is_managed_node(spec: NodeSpec) -> bool | None:
    """Whether the node is a lifecycle node, from the class its module offers (``NODE``); None: unknown.

    Asking the graph instead means waiting for lifecycle services that an unmanaged node never offers: two
    seconds for each planner of a scene, while a recording launch holds the cell clock for the bring-up.
    """
    from rclpy.lifecycle import LifecycleNode

    offered = node_class(spec.package, spec.executable)
    return None if offered is None else issubclass(offered, LifecycleNode)


def bring_up(
    node: Any,
    executor: Any,
    processes: list[NodeProcess],
    between: Callable[[], object] | None = None,
    keep_going: Callable[[], bool] = lambda: True,
) -> dict[str, str]:
    """Bring every managed node to its scene's lifecycle target, in scene order; return the states.

    A node without lifecycle services is left as it is ("unmanaged"), and so is one already at or past
    its target, or in a transition (another client of the scene is moving it). A refused transition
    stops the launch with the node's own reason. A stop signal (``keep_going`` false) ends the bring-up
    at once, and a node whose process has ended is left ("exited") at once too, never waited for: the
    launch's loop decides what its death means (in lockstep the clock drops it and the cell goes on).
    """
    states: dict[str, str] = {}
    for process in processes:
        if not keep_going():
            break
        if between is not None:
            between()  # e.g. the recorder's discovery: the scene is running while it is brought up
        target = process.spec.fully_qualified_name
        if is_managed_node(process.spec) is False:
            states[target] = "unmanaged"  # known from its class: no wait for services that never come
            continue
        client = LifecycleClient(node, executor, target, keep_going=_while_alive(process, keep_going))
        try:
            if not client.is_managed():
                states[target] = "unmanaged"
                continue
            state = client.get_state()
            if RANK.get(state, len(RANK)) >= RANK[process.spec.lifecycle]:
                # Forward only: a node already at or past its target (a controller of the scene brought
                # it up, or is doing so now) is left to it, never taken back.
                states[target] = state
                continue
            states[target] = client.bring_to(process.spec.lifecycle)
        except LifecycleInterruptedError:
            if not keep_going():
                break
            states[target] = "exited"
        except LifecycleError as error:
            reason = _configuration_error(node, executor, target)
            raise FeederError(f"{error}{': ' + reason if reason else ''}") from None
        finally:
            client.close()
    return states
