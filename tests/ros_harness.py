"""Real-process ROS 2 test harness: domain allocation, node processes, a client node in the test process."""

from __future__ import annotations

import fcntl
import random
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any, Callable, Iterable

from feeder_cell import launcher
from feeder_cell.launcher import NodeProcess
from feeder_cell.lifecycle_client import LifecycleClient, LifecycleError

DOMAIN_RANGE = range(1, 102)  # Fast DDS ports for domains above ~101 can collide with ephemeral ports


# A busy loop that dies with the test process, even when pytest itself is killed (SIGTERM or SIGKILL skip
# fixture teardown): prctl(PR_SET_PDEATHSIG = 1, SIGKILL = 9), then a check that the parent had not
# already gone before the request took effect.
_BURNER = (
    "import ctypes, os, sys\n"
    "ctypes.CDLL(None).prctl(1, 9)\n"
    "if os.getppid() != int(sys.argv[1]): os._exit(0)\n"
    "while True: pass\n"
)


def cpu_burners(count: int) -> list[subprocess.Popen[bytes]]:
    """Start ``count`` busy processes (load for a test under load); each ends with the test process."""
    import os

    return [subprocess.Popen([sys.executable, "-c", _BURNER, str(os.getpid())]) for _ in range(count)]


class DomainLease:
    """An exclusive ROS_DOMAIN_ID on this machine, held by a file lock for the lease's lifetime."""

    def __init__(self) -> None:
        candidates = list(DOMAIN_RANGE)
        random.shuffle(candidates)
        for domain in candidates:
            handle = open(Path(tempfile.gettempdir()) / f"feeder-ros-domain-{domain}.lock", "w")
            try:
                fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                handle.close()
                continue
            self.domain, self._handle = domain, handle
            return
        raise RuntimeError(f"every ROS_DOMAIN_ID in {DOMAIN_RANGE} is leased by another test run")

    def release(self) -> None:
        fcntl.flock(self._handle, fcntl.LOCK_UN)
        self._handle.close()


def start_node(
    package: str,
    executable: str,
    parameters: dict[str, Any] | None,
    log_dir: Path,
    extra_args: Iterable[str] = (),
    namespace: str = "",
    name: str = "",
) -> NodeProcess:
    spec = launcher.NodeSpec(package, executable, parameters or {}, name=name, namespace=namespace)
    return launcher.start_node(spec, log_dir, tuple(extra_args))


def bring_to(client: Any, node: NodeProcess, target: str) -> str:
    """Bring a managed node to a lifecycle state; an unmanaged node is left as it is ("unmanaged")."""
    name = node.spec.fully_qualified_name
    lifecycle = LifecycleClient(client, None, name)
    # Every node serves its parameter services; once they are discovered, a managed node's lifecycle
    # services follow within a moment, so an unmanaged node costs a second here rather than a timeout.
    try:
        wait_for_graph(client, node, services=[f"{name}/list_parameters"])
        if not lifecycle.is_managed(timeout=1.0):
            return "unmanaged"
        return lifecycle.bring_to(target)
    except LifecycleError as error:
        raise AssertionError(f"{error}. Node log:\n{node.output()[-4000:]}") from None
    finally:
        # The session's one client node must not collect two clients per node started.
        lifecycle.close()


def wait_for_graph(
    client: Any,
    node: NodeProcess | None,
    topics: Iterable[str] = (),
    services: Iterable[str] = (),
    timeout: float = 30.0,
) -> None:
    """Wait until the topics and services are discovered; fail with what was seen and the node's log."""
    wanted_topics, wanted_services = set(topics), set(services)
    deadline = time.monotonic() + timeout
    while True:
        seen_topics = {name for name, _ in client.get_topic_names_and_types()}
        seen_services = {name for name, _ in client.get_service_names_and_types()}
        missing = sorted((wanted_topics - seen_topics) | (wanted_services - seen_services))
        if not missing:
            return
        if node is not None and not node.alive():
            raise AssertionError(
                f"{node.package}/{node.executable} exited with code {node.process.returncode} "
                f"before {missing} appeared. Its log:\n{node.output()[-4000:]}"
            )
        if time.monotonic() > deadline:
            log = node.output()[-4000:] if node is not None else ""
            raise AssertionError(
                f"not discovered within {timeout:.0f} s: {missing}. Seen topics: {sorted(seen_topics)}; "
                f"services: {sorted(seen_services)}. Node log:\n{log}"
            )
        time.sleep(0.1)


def wait_for_graph_node(client: Any, node: NodeProcess, node_name: str, timeout: float = 30.0) -> None:
    """Wait until a node of that name is in the graph; fail with the node's log if it dies or never shows."""
    deadline = time.monotonic() + timeout
    while node_name not in client.get_node_names():
        if not node.alive():
            raise AssertionError(
                f"{node.executable} exited with code {node.process.returncode}:\n{node.output()[-4000:]}"
            )
        if time.monotonic() > deadline:
            raise AssertionError(
                f"node {node_name} not in the graph within {timeout:.0f} s; "
                f"seen {client.get_node_names()}. Log:\n{node.output()[-4000:]}"
            )
        time.sleep(0.1)


class ClientNode:
    """An rclpy node in the test process, spun by an executor on a background thread."""

    def __init__(self, name: str = "feeder_test_client") -> None:
        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.task import Future

        self._rclpy = rclpy
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node(name, context=self.context)
        # Single-threaded: with rclpy 7.1's MultiThreadedExecutor (two threads) this client stopped taking
        # messages for 1-3 s at a time (the replay test's /clock and data arrived in floods, 1 run in 6,
        # while a subscriber in another process got the same stream without a gap); single-threaded, 12
        # of 12 runs got every message on time. Nothing in the tests waits inside a callback.
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        # Completed by close(): the spin waits on it, with no timeout. A loop of spin_once(timeout_sec)
        # makes rclpy 7.1 create a timeout timer per call that it never destroys.
        self._stop = Future()
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        # A subscription or client destroyed from the test thread can race the executor's wait set
        # (InvalidHandle); that one wait is lost, not the client: keep spinning until shutdown.
        from rclpy.executors import ExternalShutdownException

        while self.context.ok() and not self._stop.done():
            try:
                self.executor.spin_until_future_complete(self._stop)
            except (ExternalShutdownException, KeyboardInterrupt):
                return
            except Exception as error:  # noqa: BLE001 - reported, then the client keeps serving
                if not self.context.ok():
                    return
                if type(error).__name__ != "InvalidHandle":
                    print(f"ros_harness: client executor: {type(error).__name__}: {error}", file=sys.stderr)

    def close(self) -> None:
        self._stop.set_result(True)
        self._thread.join(timeout=5.0)
        self.executor.shutdown(timeout_sec=2.0)
        # destroy_node leaves waitables (action clients) alive, and they keep the node and its DDS
        # participant in the graph: the next module would see their topics as strays.
        for waitable in list(self.node.waitables):
            destroy = getattr(waitable, "destroy", None)
            if destroy is not None:
                destroy()
        self.node.destroy_node()
        self._rclpy.try_shutdown(context=self.context)


def call_service(client: Any, srv_type: Any, name: str, request: Any, timeout: float = 30.0) -> Any:
    """Call a service from the client node (whose executor runs elsewhere) and return the response."""
    # One client per service for the client node's life: a new client's reply reader must be discovered
    # by the server before it can answer, and a server that answers first drops the reply.
    clients = client.__dict__.setdefault("_feeder_service_clients", {})
    key = (srv_type, name)
    if key not in clients:
        clients[key] = client.create_client(srv_type, name)
    service_client = clients[key]
    if not service_client.wait_for_service(timeout_sec=timeout):
        raise AssertionError(f"service {name} not available within {timeout:.0f} s")
    future = service_client.call_async(request)
    done = threading.Event()
    future.add_done_callback(lambda _: done.set())
    if not done.wait(timeout):
        raise AssertionError(f"service {name} did not answer within {timeout:.0f} s")
    return future.result()


def collect(
    client: Any,
    msg_type: Any,
    topic: str,
    count: int | None = None,
    duration: float | None = None,
    qos: Any = 10,
    timeout: float = 30.0,
    stop: Callable[[Any], bool] | None = None,
) -> list[Any]:
    """Collect messages on a topic until ``count`` arrived, ``stop`` accepts one, or ``duration`` is up."""
    if count is None and duration is None:
        raise ValueError("give count or duration")
    messages: list[Any] = []
    enough = threading.Event()
    lock = threading.Lock()

    def on_message(message: Any) -> None:
        with lock:
            messages.append(message)
            if (count is not None and len(messages) >= count) or (stop is not None and stop(message)):
                enough.set()

    subscription = client.create_subscription(msg_type, topic, on_message, qos)
    try:
        limit = min(duration, timeout) if duration is not None else timeout
        enough.wait(limit)
        with lock:
            result = list(messages)
    finally:
        client.destroy_subscription(subscription)
    if count is not None and duration is None and len(result) < count:
        raise AssertionError(f"got {len(result)} of {count} messages on {topic} within {timeout:.0f} s")
    return result


class Listener:
    """One subscription of the test client for the whole session, with every message it received.

    Tests that wait on streams use these rather than a subscription per wait: a subscription destroyed
    from the test thread races the client's executor (the wait in flight is lost).
    """

    def __init__(self, client: Any, msg_type: Any, topic: str, qos: Any) -> None:
        self.topic = topic
        self.messages: list[Any] = []
        self.arrived = threading.Condition()
        client.create_subscription(msg_type, topic, self._on_message, qos)

    def _on_message(self, msg: Any) -> None:
        with self.arrived:
            self.messages.append(msg)
            self.arrived.notify_all()

    def count(self) -> int:
        """Return how many messages arrived so far (a mark for ``since``)."""
        with self.arrived:
            return len(self.messages)

    def since(self, mark: int) -> list[Any]:
        """Return the messages that arrived after ``mark``."""
        with self.arrived:
            return self.messages[mark:]

    def wait(
        self,
        accept: Callable[[Any], bool] = lambda m: True,
        timeout: float = 30.0,
        current: bool = False,
        after: int | None = None,
    ) -> Any:
        """Return the first message from now on that ``accept`` takes.

        ``current``: the latest counts too; ``after``: every message since that mark (``count``) counts,
        for a wait on what a call caused that may have arrived before the call returned.
        """
        deadline = time.monotonic() + timeout
        with self.arrived:
            if after is not None:
                index = after
            else:
                index = max(0, len(self.messages) - 1) if current else len(self.messages)
            while True:
                while index < len(self.messages):
                    msg = self.messages[index]
                    index += 1
                    if accept(msg):
                        return msg
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    last = self.messages[-1] if self.messages else None
                    raise AssertionError(
                        f"no accepted message on {self.topic} within {timeout} s; last: {last}"
                    )
                self.arrived.wait(remaining)

    def next(self, count: int = 1, timeout: float = 30.0) -> list[Any]:
        """Return the next ``count`` messages from now on."""
        seen: list[Any] = []

        def take(msg: Any) -> bool:
            seen.append(msg)
            return len(seen) >= count

        self.wait(take, timeout)
        return seen


# --- what every device test asks of a managed device ------------------------------------------------


def counters(status: Any) -> dict[str, int]:
    """Return a DeviceStatus's counters as a mapping."""
    return dict(zip(status.counter_names, status.counter_values, strict=True))


def stamp_ns(msg: Any) -> int:
    """Return a stamped message's header time in integer nanoseconds."""
    return int(msg.header.stamp.sec) * 10**9 + int(msg.header.stamp.nanosec)


def inject_fault(client: Any, device: str, fault: str, **fields: Any) -> Any:
    """Call ``device``'s ~/inject_fault with the given InjectFault fields; return the response."""
    from feeder_msgs.srv import InjectFault

    request = InjectFault.Request(fault=fault, **fields)
    return call_service(client, InjectFault, f"{device}/inject_fault", request)


def trigger(client: Any, device: str, service: str) -> Any:
    """Call a std_srvs/Trigger service of ``device`` (``stop``, ``reset``)."""
    from std_srvs.srv import Trigger

    return call_service(client, Trigger, f"{device}/{service}", Trigger.Request())


def set_parameter(client: Any, node: str, name: str, value: Any) -> Any:
    """Set one parameter of ``node`` over its parameter service; return the SetParametersResult."""
    from rcl_interfaces.srv import SetParameters
    from rclpy.parameter import Parameter

    request = SetParameters.Request(parameters=[Parameter(name, value=value).to_parameter_msg()])
    return call_service(client, SetParameters, f"{node}/set_parameters", request).results[0]


def lifecycle_of(client: Any, node: str) -> LifecycleClient:
    """Return a lifecycle client of ``node`` on the (background-spun) test client node."""
    return LifecycleClient(client, None, node)


def wait_heard_clock(client: Any, device: str, clock_ns: int, timeout: float = 30.0) -> None:
    """Wait until a device's status is stamped ``clock_ns``: it has heard the held cell clock.

    The first /clock reading a device hears is its origin, where it does not tick; a step sent before the
    device heard the held clock would become its origin instead of a step it simulates.
    """
    from feeder_msgs.msg import DeviceStatus
    from feeder_planner.node_kit import LATCHED

    heard = collect(
        client,
        DeviceStatus,
        f"{device}/status",
        duration=timeout,
        qos=LATCHED,
        stop=lambda m: stamp_ns(m) == clock_ns,
    )
    assert heard and stamp_ns(heard[-1]) == clock_ns, f"{device} never heard the clock at {clock_ns}"


def step_clock(client: Any, seconds: float, clock: str = "/cell_clock") -> int:
    """Advance a paused cell clock by ``seconds``; return the clock's time after the step (ns)."""
    from builtin_interfaces.msg import Duration

    from feeder_msgs.srv import StepClock

    ns = int(round(seconds * 1e9))
    request = StepClock.Request(duration=Duration(sec=ns // 10**9, nanosec=ns % 10**9))
    response = call_service(client, StepClock, f"{clock}/step", request)
    assert response.ok, response.error
    return int(response.now.sec) * 10**9 + int(response.now.nanosec)


def launched_node_pids(parent: int) -> list[int]:
    """Pids of the node processes a launcher started: its children that run with --ros-args (from /proc)."""
    pids = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            ppid = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
            cmdline = (entry / "cmdline").read_bytes().decode(errors="replace")
        except (OSError, IndexError, ValueError):
            continue
        if ppid == parent and "--ros-args" in cmdline:
            pids.append(int(entry.name))
    return pids


def end_launch(process: subprocess.Popen[str], timeout: float = 30.0) -> tuple[str, str]:
    """End a launch by its pid: SIGINT (it ends its nodes), SIGKILL if it has not ended within ``timeout``."""
    process.send_signal(signal.SIGINT)
    try:
        return process.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        process.kill()
        return process.communicate()


def unfaulted(code: int) -> bool:
    """Whether a device status's ``fault_code`` says "no fault": none, or only that it is behind real time.

    FAULT_BEHIND_REAL_TIME is the one warning that load alone raises: a free-running device on a busy
    machine (two test workers on two cores) cannot always hold its rate, and says so, as it must. A test
    that checks a fault is gone or was never there must not fail on it.
    """
    from feeder_msgs.msg import DeviceStatus

    return code in (DeviceStatus.FAULT_NONE, DeviceStatus.FAULT_BEHIND_REAL_TIME)


class ActionFeedback:
    """The feedback an action server publishes, read on the action's own feedback topic.

    rclpy's ActionClient forgets a goal's feedback callback once it has handled the goal's result, so a
    feedback that arrives with the result or after it never reaches the callback (fresh-clone CI runs under
    load: 9 of 10 reached it, and 1 of 3). A check of what the server sends reads the topic instead.
    """

    def __init__(self, client: Any, action_type: Any, action: str) -> None:
        self.listener = Listener(client, action_type.Impl.FeedbackMessage, f"{action}/_action/feedback", 100)
        time.sleep(0.5)  # the server's feedback writer matches the new reader

    def mark(self) -> int:
        """Return a mark to take before sending a goal (``of``'s ``after``)."""
        return self.listener.count()

    def of(self, goal_id: Any, count: int, after: int, timeout: float = 5.0) -> list[Any]:
        """Return goal ``goal_id``'s feedback since ``after``, once ``count`` came or ``timeout`` passed."""
        uuid = bytes(goal_id.uuid)
        deadline = time.monotonic() + timeout
        while True:
            mine = [m.feedback for m in self.listener.since(after) if bytes(m.goal_id.uuid) == uuid]
            if len(mine) >= count or time.monotonic() > deadline:
                return mine
            time.sleep(0.02)
