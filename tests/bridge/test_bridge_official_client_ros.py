"""Over DDS: `feeder bridge` driven by the official Foxglove client, under both subprotocol names.

The client is @foxglove/ws-protocol (the Foxglove WebSocket protocol's own TypeScript client, pinned in
tests/js/package-lock.json and installed there by `make setup` with npm ci) on Node.js, with the `ws`
package as its WebSocket. tests/js/foxglove_client.js drives it one JSON line at a time; the payloads come
back as base64 and are decoded here with rclpy. Every test runs once offering ``foxglove.websocket.v1``
(the published specification's name, which ws-protocol, Lichtblick and the ROS foxglove_bridge's clients
offer) and once offering ``foxglove.sdk.v1`` (the Foxglove SDK's name for the same messages).

One throwing arm for the module, under /fox, active and at rest with its sensor under the part (the bit
reads true), and one bridge process; the read-only bridge has a module of its own below.
"""

from __future__ import annotations

import base64
import itertools
import json
import queue
import shutil
import subprocess
import tempfile
import threading
import time
from pathlib import Path
from typing import Any, Callable, Iterator

import pytest
import ros_harness
from bridge_process import BridgeProcess

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]
JS = ROOT / "tests" / "js"
EXAMPLES = ROOT / "examples"
TRIANGLE = EXAMPLES / "throwing" / "triangle.yaml"
EDGE, RADIUS = 1, 0.12  # at rest there, a sensor at x = R reads true
NS = "/fox"
ARM = f"{NS}/throwing_arm"
STATION_COMMAND = f"{NS}/station/command"  # a command topic: in the default client-publish allow-list
SUBPROTOCOLS = ("foxglove.websocket.v1", "foxglove.sdk.v1")
TIMEOUT = 30.0  # s: generous, for a loaded two-core CI machine
FAULT_MOTOR, IDLE, FAULT = 101, 1, 4


# --- the official client ------------------------------------------------------------------------------
def require_official_client() -> None:
    """Fail, naming the cause, unless Node.js and the pinned @foxglove/ws-protocol are installed."""
    pinned = json.loads((JS / "package.json").read_text())["dependencies"]["@foxglove/ws-protocol"]
    if shutil.which("node") is None:
        raise AssertionError("Node.js (node) is not on PATH: the official Foxglove client runs on it")
    installed = JS / "node_modules" / "@foxglove" / "ws-protocol" / "package.json"
    if installed.is_file() and json.loads(installed.read_text())["version"] == pinned:
        return
    log = JS / "npm-ci.log"
    said = (
        npm_reason(log.read_text()) if log.is_file() else "(no tests/js/npm-ci.log: make setup did not run)"
    )
    registry = subprocess.run(
        ["npm", "config", "get", "registry"], capture_output=True, text=True, timeout=60, check=False
    ).stdout.strip()
    ping = subprocess.run(["npm", "ping"], capture_output=True, text=True, timeout=120, check=False, cwd=JS)
    reach = (
        "reachable" if ping.returncode == 0 else f"NOT reachable ({npm_reason(ping.stderr + ping.stdout)})"
    )
    raise AssertionError(
        f"@foxglove/ws-protocol {pinned} is not installed in tests/js (make setup installs it with npm ci): "
        f"the npm registry {registry} is {reach}; npm ci said: {said}"
    )


def npm_reason(text: str) -> str:
    """Return the line of npm's error output that says why (the failed request, else the error code)."""
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    for marker in ("FetchError", "request to", "error code", "ERR!"):
        found = [line for line in lines if marker in line]
        if found:
            return found[0]
    return lines[-1] if lines else "(nothing)"


class OfficialClient:
    """tests/js/foxglove_client.js in a Node.js process: one request line, one answer line."""

    def __init__(
        self,
        url: str,
        subprotocol: str,
        wrap: Callable[[list[str]], list[str]] = list,
        env: dict[str, str] | None = None,
        timeout: float = TIMEOUT,
    ) -> None:
        """Connect; ``wrap`` runs Node.js elsewhere (``netns.Host.command``: another host) with ``env``."""
        self.log = tempfile.NamedTemporaryFile("w+", prefix="foxglove-client-", suffix=".log")  # noqa: SIM115
        self.process = subprocess.Popen(
            wrap(["node", str(JS / "foxglove_client.js")]),
            cwd=JS,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=self.log,
            text=True,
            env=env,
        )
        self.answers: queue.Queue[dict[str, Any]] = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()
        self.ids = itertools.count(1)
        try:
            connected = self.request("connect", timeout=timeout, url=url, subprotocol=subprotocol)
        except AssertionError:
            self.close()  # a refused connection leaves no Node.js process behind
            raise
        self.server_info, self.protocol = connected["serverInfo"], connected["protocol"]

    def _read(self) -> None:
        for line in self.process.stdout or []:
            self.answers.put(json.loads(line))

    def request(self, cmd: str, timeout: float = TIMEOUT, **fields: Any) -> dict[str, Any]:
        """Send one command; return its answer, or fail with what the client said."""
        request_id = next(self.ids)
        assert self.process.stdin is not None
        self.process.stdin.write(
            json.dumps({"id": request_id, "cmd": cmd, "timeout": timeout, **fields}) + "\n"
        )
        self.process.stdin.flush()
        try:
            answer = self.answers.get(timeout=timeout + 10.0)
        except queue.Empty:
            self.log.seek(0)
            raise AssertionError(
                f"the client did not answer {cmd}; its log: {self.log.read()[-2000:]}"
            ) from None
        assert answer["id"] == request_id, answer
        if not answer["ok"]:
            raise AssertionError(f"{cmd}: {answer['error']}")
        return answer

    def close(self) -> None:
        if self.process.poll() is None:
            assert self.process.stdin is not None
            self.process.stdin.close()  # the driver closes the connection and exits
            try:
                self.process.wait(timeout=10.0)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(timeout=10.0)

    # Conveniences over request().
    def subscribe(self, topic: str) -> int:
        return int(self.request("subscribe", topic=topic)["subscription"])

    def messages(self, subscription: int, count: int, since: int = 0) -> list[bytes]:
        answer = self.request("messages", subscription=subscription, count=count, since=since)
        return [base64.b64decode(m["data"]) for m in answer["messages"]]

    def stamps(self, subscription: int, count: int, since: int = 0) -> list[int]:
        answer = self.request("messages", subscription=subscription, count=count, since=since)
        return [int(m["timestamp"]) for m in answer["messages"]]

    def statuses(self, since: int, contains: str) -> list[str]:
        return [s["message"] for s in self.request("statuses", since=since, contains=contains)["statuses"]]

    def mark(self) -> dict[str, int]:
        return self.request("mark")


def cdr(message: Any) -> str:
    from rclpy.serialization import serialize_message

    return base64.b64encode(serialize_message(message)).decode()


def decoded(data: bytes | str, msg_type: Any) -> Any:
    from rclpy.serialization import deserialize_message

    return deserialize_message(base64.b64decode(data) if isinstance(data, str) else data, msg_type)


@pytest.fixture(scope="module")
def arm(launch_module_node: Any) -> None:
    launch_module_node(
        "feeder_sim",
        "throwing_arm",
        {
            "part_file": str(TRIANGLE),
            "offset": -0.005,
            "release_speed": 5.585,
            "gravity": -9.66,
            "mu": 0.5,
            "initial_edge": EDGE,
            "initial_radius": RADIUS,
            "sensor_radius": RADIUS,
            "sensing_height": 0.001,
            "marker_rate": 10.0,
        },
        namespace=NS,
        wait_topics=(f"{ARM}/markers", f"{ARM}/sensor", f"{ARM}/status"),
        wait_services=(f"{ARM}/inject_fault", f"{ARM}/set_parameters"),
    )


@pytest.fixture(scope="module")
def bridge(arm: None) -> Iterator[BridgeProcess]:
    require_official_client()
    process = BridgeProcess()
    yield process
    assert process.stop() == 0, process.output()  # Ctrl-C ends it cleanly


@pytest.fixture(params=SUBPROTOCOLS)
def client(request: pytest.FixtureRequest, bridge: BridgeProcess) -> Iterator[OfficialClient]:
    official = OfficialClient(bridge.url, request.param)
    try:
        assert official.protocol == request.param  # the bridge accepted the name the client offered
        yield official
    finally:
        errors = official.request("errors")
        official.close()
        assert bridge.process.poll() is None, f"the bridge ended: {bridge.output()}"
        assert errors["errors"] == [], errors  # the client could parse everything the bridge sent


# --- topics ---------------------------------------------------------------------------------------------
def test_client_decodes_the_arm_markers_and_the_sensor_bit(client: OfficialClient) -> None:
    from std_msgs.msg import Bool
    from visualization_msgs.msg import MarkerArray

    from feeder_planner.node_kit.msg_markers import STYLES

    info = client.server_info
    assert set(info["capabilities"]) == {
        "parameters",
        "parametersSubscribe",
        "connectionGraph",
        "services",
        "clientPublish",
    }  # no time: no cell clock runs
    assert info["supportedEncodings"] == ["cdr"] and info["metadata"]["ROS_DISTRO"] == "jazzy"
    markers = client.request("subscribe", topic=f"{ARM}/markers")
    assert markers["channel"]["schemaName"] == "visualization_msgs/msg/MarkerArray"
    assert (markers["channel"]["encoding"], markers["channel"]["schemaEncoding"]) == ("cdr", "ros2msg")
    sensor = client.subscribe(f"{ARM}/sensor")
    bits = [decoded(m, Bool).data for m in client.messages(sensor, 3)]
    assert bits and all(bits)
    # A late subscriber first gets the two latched arrays (static, and the last update drawn), and the arm
    # draws nothing while nobody watches (a566821), so that update may predate the first sensor reading
    # (drawn as off); the arrays after them are drawn now, at marker_rate.
    arrays = [decoded(m, MarkerArray) for m in client.messages(markers["subscription"], 5)]
    drawn = [m for a in arrays for m in a.markers if m.ns == "sensor" and m.action == m.ADD]
    assert drawn and all(m.header.frame_id == "fox/arm_pivot" for m in drawn)
    color = drawn[-1].color
    assert (color.r, color.g, color.b, color.a) == pytest.approx(STYLES["sensor_on"])
    # Wall-clock receive stamps (no cell clock): within this test's lifetime.
    stamps = client.stamps(sensor, 3)
    assert all(abs(s - time.time_ns()) < 60 * 10**9 for s in stamps)


# --- services -------------------------------------------------------------------------------------------
def test_client_injects_a_fault_and_sees_it_in_the_status(client: OfficialClient) -> None:
    from feeder_msgs.srv import InjectFault

    services = client.request("services", names=[f"{ARM}/inject_fault", f"{ARM}/reset"])["services"]
    inject = services[f"{ARM}/inject_fault"]
    assert inject["type"] == "feeder_msgs/srv/InjectFault"
    assert inject["request"]["schemaName"] == "feeder_msgs/srv/InjectFault_Request"
    assert (
        inject["request"]["schemaEncoding"] == "ros2msg" and "string fault\n" in inject["request"]["schema"]
    )
    assert "string[] active_faults" in inject["response"]["schema"]
    status = client.subscribe(f"{ARM}/status")
    seen = len(client.messages(status, 1))  # the latched status first
    answer = client.request(
        "call", name=f"{ARM}/inject_fault", request=cdr(InjectFault.Request(fault="motor_fault"))
    )
    response = decoded(answer["response"], InjectFault.Response)
    try:
        assert response.ok and "motor_fault" in " ".join(response.active_faults), response
        faulted = wait_status(client, status, seen, lambda s: s.state == FAULT)
        assert faulted.fault_code == FAULT_MOTOR and "motor_fault" in faulted.fault_text
    finally:
        cleared = client.request(
            "call",
            name=f"{ARM}/inject_fault",
            request=cdr(InjectFault.Request(fault="motor_fault", clear=True)),
        )
        assert decoded(cleared["response"], InjectFault.Response).ok
    wait_status(client, status, seen, lambda s: s.state == IDLE and ros_harness.unfaulted(s.fault_code))
    # A request that is not the service's CDR is answered with a failure naming the payload.
    failure = client.request(
        "call", name=f"{ARM}/inject_fault", request=base64.b64encode(b"\x00\x01").decode()
    )
    assert "payload: not a CDR feeder_msgs/srv/InjectFault_Request" in failure["failure"], failure


def wait_status(client: OfficialClient, subscription: int, since: int, accept: Any) -> Any:
    """Return the first DeviceStatus from message ``since`` on that ``accept`` takes, waiting for it."""
    from feeder_msgs.msg import DeviceStatus

    deadline = time.monotonic() + TIMEOUT
    index = since
    while time.monotonic() < deadline:
        for data in client.messages(subscription, 1, since=index):
            index += 1
            status = decoded(data, DeviceStatus)
            if accept(status):
                return status
    raise AssertionError(f"no accepted status within {TIMEOUT} s")


def test_service_call_answers_the_nodes_own_refusal(client: OfficialClient) -> None:
    from lifecycle_msgs.srv import GetState

    from feeder_msgs.srv import ArmCommand

    # A command the arm refuses: the node's response, ok false and its reason, travels back unchanged.
    answer = client.request("call", name=f"{ARM}/command", request=cdr(ArmCommand.Request(command="juggle")))
    response = decoded(answer["response"], ArmCommand.Response)
    assert not response.ok and "juggle" in response.error, response
    # Lifecycle and parameter services are services of the cell too.
    state = client.request("call", name=f"{ARM}/get_state", request=cdr(GetState.Request()))
    assert decoded(state["response"], GetState.Response).current_state.label == "active"


# --- parameters -----------------------------------------------------------------------------------------
def test_client_sets_a_runtime_parameter_and_reads_it_back(client: OfficialClient) -> None:
    name = f"{ARM}.marker_rate"
    before = client.request("getParameters", names=[name], requestId="before")["parameters"]
    assert before == [{"name": name, "value": 10.0, "type": "float64"}]
    client.request("subscribeParameterUpdates", names=[name])
    mark = client.mark()
    try:
        # A JSON 7 (what a JavaScript client sends for 7.0) is set as the double the node declared.
        after = client.request("setParameters", parameters=[{"name": name, "value": 7}], requestId="set")
        assert after["parameters"] == [{"name": name, "value": 7.0, "type": "float64"}]
        again = client.request("getParameters", names=[name], requestId="again")["parameters"]
        assert again == [{"name": name, "value": 7.0, "type": "float64"}]
        updates = client.request("parameterUpdates", since=mark["parameterValues"], name=name)["parameters"]
        assert {"name": name, "value": 7.0, "type": "float64"} in updates
        # Refusals in the node's own words, one line each; the values stay.
        refused = client.request(
            "setParameters",
            parameters=[{"name": f"{ARM}.gravity", "value": -1.0}, {"name": name, "value": -3.0}],
            requestId="refused",
        )["parameters"]
        assert {p["name"]: p["value"] for p in refused} == {f"{ARM}.gravity": -9.66, name: 7.0}
        lines = client.statuses(mark["statuses"], "Trying to set a read-only parameter: gravity")
        assert any(line.startswith(f"setParameters: {ARM}.marker_rate: ") for line in lines), lines
        assert all("\n" not in line for line in lines)
        # A value of the wrong type names the field, the parameter and its declared type.
        client.request("setParameters", parameters=[{"name": name, "value": "fast"}], requestId="typed")
        lines = client.statuses(mark["statuses"], "parameters[0].value")
        assert any(f"{name} is a double: must be a number" in line for line in lines), lines
    finally:
        restored = client.request(
            "setParameters", parameters=[{"name": name, "value": 10.0}], requestId="restore"
        )
        assert restored["parameters"] == [{"name": name, "value": 10.0, "type": "float64"}]


def test_all_parameters_of_every_node_are_listed(client: OfficialClient) -> None:
    everything = client.request("getParameters", names=[], requestId="all")["parameters"]
    names = {p["name"] for p in everything}
    assert {f"{ARM}.part_file", f"{ARM}.fidelity", f"{ARM}.marker_rate", f"{ARM}.use_sim_time"} <= names
    assert not any(n.startswith("/feeder_bridge.") for n in names)  # the bridge's own are not the cell's
    by_name = {p["name"]: p for p in everything}
    assert by_name[f"{ARM}.part_file"]["value"] == str(TRIANGLE)
    assert by_name[f"{ARM}.use_sim_time"]["value"] is False


# --- publishing -----------------------------------------------------------------------------------------
def test_client_publishes_on_a_command_topic_and_is_refused_a_sensor(
    client: OfficialClient, ros_client: Any, listen: Any
) -> None:
    from std_msgs.msg import Bool, String

    commands = listen(String, STATION_COMMAND)
    text = f"hello over {client.protocol}"
    channel = client.request("advertise", topic=STATION_COMMAND, schemaName="std_msgs/msg/String")[
        "channelId"
    ]
    # Counted before the publish: the message can arrive before the request returns (ci14 saw it there,
    # and a wait "from now on" then missed it for 30 s).
    before = commands.count()
    client.request("publish", channelId=channel, data=cdr(String(data=text)))
    assert commands.wait(lambda m: m.data == text, TIMEOUT, after=before).data == text
    client.request("unadvertise", channelId=channel)
    # The arm's sensor bit is no command: a viewer may not forge it.
    mark = client.mark()
    forged = client.request("advertise", topic=f"{ARM}/sensor", schemaName="std_msgs/msg/Bool")["channelId"]
    lines = client.statuses(mark["statuses"], "allow-list")
    assert any(
        line.startswith("advertise: channels[0].topic: /fox/throwing_arm/sensor is not in the client-publish")
        for line in lines
    ), lines
    client.request("publish", channelId=forged, data=cdr(Bool(data=False)))
    lines = client.statuses(mark["statuses"], f"channel {forged}")
    assert any("it was not advertised, or was refused" in line for line in lines), lines
    writers = {i.node_name for i in ros_client.get_publishers_info_by_topic(f"{ARM}/sensor")}
    assert writers == {"throwing_arm"}


# --- the graph and the clock ----------------------------------------------------------------------------
def test_connection_graph_names_the_arm(client: OfficialClient) -> None:
    client.request("subscribeConnectionGraph")
    update = client.request("graph")["updates"][0]
    published = {t["name"]: t["publisherIds"] for t in update["publishedTopics"]}
    assert published[f"{ARM}/sensor"] == [ARM]
    services = {s["name"]: s["providerIds"] for s in update["advertisedServices"]}
    assert services[f"{ARM}/inject_fault"] == [ARM]
    assert update["removedTopics"] == [] and update["removedServices"] == []


def test_a_client_that_connects_while_a_cell_clock_runs_follows_it(
    bridge: BridgeProcess, ros_client: Any
) -> None:
    from rosgraph_msgs.msg import Clock

    base = 1000 * 10**9
    publisher = ros_client.create_publisher(Clock, "/clock", 10)
    ticking = threading.Event()
    sent: list[int] = []

    def tick() -> None:
        step = 0
        while not ticking.is_set():
            stamp = base + step * 10**7  # 10 ms of cell time per 20 ms of wall time
            publisher.publish(Clock(clock=_time_msg(stamp)))
            sent.append(stamp)
            step += 1
            time.sleep(0.02)

    thread = threading.Thread(target=tick, daemon=True)
    thread.start()
    try:
        for subprotocol in SUBPROTOCOLS:
            official = connect_when(bridge.url, subprotocol, lambda info: "time" in info["capabilities"])
            try:
                times = [int(t) for t in official.request("times", count=5)["times"]]
                assert all(base <= t <= sent[-1] for t in times) and times == sorted(times)
                sensor = official.subscribe(f"{ARM}/sensor")
                stamps = official.stamps(sensor, 3)
                assert all(base <= s <= sent[-1] for s in stamps), stamps  # cell time, not wall time
            finally:
                official.close()
    finally:
        ticking.set()
        thread.join()
        ros_client.destroy_publisher(publisher)
    # Once the clock is gone, a new client keeps wall time again.
    official = connect_when(bridge.url, SUBPROTOCOLS[0], lambda info: "time" not in info["capabilities"])
    official.close()


def _time_msg(stamp_ns: int) -> Any:
    from builtin_interfaces.msg import Time

    return Time(sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9)


def connect_when(url: str, subprotocol: str, accept: Any) -> OfficialClient:
    """Connect until the server info is what ``accept`` wants (the bridge looks at the graph each second)."""
    deadline = time.monotonic() + TIMEOUT
    while True:
        official = OfficialClient(url, subprotocol)
        if accept(official.server_info):
            return official
        official.close()
        assert time.monotonic() < deadline, f"server info never accepted: {official.server_info}"
        time.sleep(0.5)


def wait_until_parameters_known(official: OfficialClient, name: str) -> None:
    """Wait until the bridge's discovery knows the node of ``name`` takes parameter requests."""
    deadline = time.monotonic() + TIMEOUT
    while not official.request("getParameters", names=[name], requestId="known")["parameters"]:
        assert time.monotonic() < deadline, f"the bridge never knew {name}'s node takes parameter requests"
        time.sleep(0.2)


# --- read-only ------------------------------------------------------------------------------------------
def test_a_read_only_bridge_refuses_everything_that_acts(arm: None, ros_client: Any) -> None:
    from feeder_msgs.srv import InjectFault

    require_official_client()
    read_only = BridgeProcess("--read-only")
    try:
        for subprotocol in SUBPROTOCOLS:
            official = OfficialClient(read_only.url, subprotocol)
            try:
                capabilities = set(official.server_info["capabilities"])
                assert capabilities == {"parameters", "parametersSubscribe", "connectionGraph"}
                sensor = official.subscribe(f"{ARM}/sensor")  # reading still works
                assert official.messages(sensor, 1)  # at least one sample arrives
                name = f"{ARM}.marker_rate"
                # A bridge just started may have seen the arm's topics and not yet its parameter services
                # (discovery is incremental; it looks again each second): it would then answer "no node
                # takes parameter requests" and [], which is right but not what this test is about.
                wait_until_parameters_known(official, name)
                mark = official.mark()
                values = official.request(
                    "setParameters", parameters=[{"name": name, "value": 3.0}], requestId="ro"
                )["parameters"]
                assert values == [{"name": name, "value": 10.0, "type": "float64"}]
                official.statuses(mark["statuses"], "setParameters: refused: the bridge is read-only")
                official.request("advertise", topic=STATION_COMMAND, schemaName="std_msgs/msg/String")
                official.statuses(mark["statuses"], "advertise: refused: the bridge is read-only")
                failure = official.request(
                    "callById", serviceId=1, request=cdr(InjectFault.Request(fault="motor_fault"))
                )
                assert failure["failure"] == "service call: refused: the bridge is read-only (--read-only)"
            finally:
                official.close()
    finally:
        assert read_only.stop() == 0, read_only.output()


# --- bad frames -----------------------------------------------------------------------------------------
# Each bad frame is answered with one error line naming the operation and the field; the connection and
# the bridge keep serving. (frame, what the one line must contain)
BAD_FRAMES: list[tuple[str | bytes, str]] = [
    ("not json", "text message: not JSON"),
    ("[1, 2]", "text message: must be a JSON object with an op, got list"),
    ("[" * 100_000, "text message: not JSON"),
    ('{"foo": 1}', "op: missing"),
    ('{"op": "launch"}', "op: unknown operation 'launch' (known: subscribe, unsubscribe,"),
    ('{"op": "subscribe"}', "subscribe: subscriptions: missing"),
    ('{"op": "subscribe", "subscriptions": {}}', "subscribe: subscriptions: must be an array, got {}"),
    (
        '{"op": "subscribe", "subscriptions": [{"id": "a", "channelId": 1}]}',
        "subscribe: subscriptions[0].id: must be a whole number in [0, 4294967295], got 'a'",
    ),
    (
        '{"op": "subscribe", "subscriptions": [{"id": 1, "channelId": -1}]}',
        "subscribe: subscriptions[0].channelId: must be a whole number in [0, 4294967295], got -1",
    ),
    (
        '{"op": "subscribe", "subscriptions": [{"id": 1, "channelId": 999999}]}',
        "subscribe: subscriptions[0].channelId: no channel 999999 is advertised",
    ),
    ('{"op": "unsubscribe", "subscriptionIds": [42]}', "unsubscribe: subscriptionIds[0]: no subscription 42"),
    ('{"op": "unadvertise", "channelIds": [7]}', "unadvertise: channelIds[0]: channel 7 is not advertised"),
    (
        '{"op": "getParameters", "parameterNames": ["/nobody.x"], "id": "g"}',
        "getParameters: parameterNames[0]: no node /nobody takes parameter requests",
    ),
    (
        '{"op": "getParameters", "parameterNames": ["/fox/throwing_arm.no_such"], "id": "g"}',
        "getParameters: /fox/throwing_arm.no_such: the node has no such parameter",
    ),
    (
        '{"op": "setParameters", "parameters": [{"name": "nodot", "value": 1}], "id": "s"}',
        "setParameters: parameters[0].name: 'nodot' is not a parameter name (/node.name)",
    ),
    (
        '{"op": "setParameters", "parameters": [{"name": "/a.b", "value": 1, "type": "int8"}]}',
        "setParameters: parameters[0].type: must be one of byte_array, float64, float64_array, got 'int8'",
    ),
    (
        '{"op": "advertise", "channels": [{"id": 1, "topic": "/a/command", "encoding": "json",'
        ' "schemaName": "std_msgs/msg/String"}]}',
        "advertise: channels[0].encoding: 'json' is not supported (only cdr)",
    ),
    (
        '{"op": "advertise", "channels": [{"id": 2, "topic": "/a/command", "encoding": "cdr",'
        ' "schemaName": "no_pkg/msg/Nope"}]}',
        "advertise: channels[0].schemaName: 'no_pkg/msg/Nope' is not a ROS message type the bridge has",
    ),
    (
        '{"op": "advertise", "channels": [{"id": 3, "topic": "/9a/command", "encoding": "cdr",'
        ' "schemaName": "std_msgs/msg/String"}]}',
        "advertise: channels[0].topic: ",
    ),
    ('{"op": "advertise", "channels": [{"id": 4}]}', "advertise: channels[0].topic: missing"),
    (
        '{"op": "fetchAsset", "uri": "package://x/y.stl", "requestId": 1}',
        "fetchAsset: the bridge serves no assets",
    ),
    (b"", "binary message: empty"),
    (b"\x07abc", "binary message: opcode: unknown opcode 0x07"),
    (b"\x01\x00", "client message data: 2 byte(s), the header alone is 5"),
    (
        b"\x02" + bytes(8) + b"\xff\xff\x00\x00",
        "service call request: encoding length: 65535 runs past the end",
    ),
    (b"\x01\x63\x00\x00\x00abc", "client message data: channel 99: it was not advertised, or was refused"),
]


async def bad_frames_session(url: str) -> list[tuple[str, list[dict[str, Any]]]]:
    """Send each bad frame; return the statuses and failures each drew, then whether data still flows."""
    import asyncio

    import websockets

    answers = []
    async with websockets.connect(url, subprotocols=["foxglove.websocket.v1"], max_size=None) as ws:
        channels: dict[str, int] = {}

        async def drain(first: float, quiet: float) -> list[dict[str, Any]]:
            """Return statuses and failures: the first within ``first`` s, then any until ``quiet`` s pass."""
            got: list[dict[str, Any]] = []
            deadline = time.monotonic() + first
            while (remaining := deadline - time.monotonic()) > 0:
                try:
                    frame = await asyncio.wait_for(ws.recv(), remaining)
                except TimeoutError:
                    break
                if isinstance(frame, bytes):
                    continue
                message = json.loads(frame)
                if message["op"] == "advertise":
                    channels.update({c["topic"]: c["id"] for c in message["channels"]})
                elif message["op"] in ("status", "serviceCallFailure"):
                    got.append(message)
                    deadline = time.monotonic() + quiet  # a second line would follow at once
            return got

        await drain(1.0, 1.0)  # the greeting: server info and advertisements
        for frame, _ in BAD_FRAMES:
            await ws.send(frame)
            answers.append((repr(frame)[:60], await drain(TIMEOUT, 0.3)))
        # The same connection still serves: a subscription to the sensor delivers.
        await ws.send(
            json.dumps(
                {"op": "subscribe", "subscriptions": [{"id": 5, "channelId": channels[f"{ARM}/sensor"]}]}
            )
        )
        while not isinstance(frame := await asyncio.wait_for(ws.recv(), TIMEOUT), bytes):
            pass
        answers.append(("data after the bad frames", [{"opcode": frame[0], "subscription": frame[1]}]))
    return answers


def test_bad_frames_get_one_line_each_and_the_bridge_keeps_serving(bridge: BridgeProcess) -> None:
    import asyncio

    answers = asyncio.run(bad_frames_session(bridge.url))
    for (frame, expected), (_, got) in zip(BAD_FRAMES, answers, strict=False):
        lines = [m["message"] for m in got if m["op"] == "status" and m["level"] == 2]
        assert len(lines) == 1 and expected in lines[0] and "\n" not in lines[0], (frame, lines)
    assert answers[-1][1] == [{"opcode": 1, "subscription": 5}]
    assert bridge.process.poll() is None, bridge.output()


def test_bad_service_calls_are_answered_with_a_failure(bridge: BridgeProcess) -> None:
    import asyncio

    import websockets

    async def session() -> list[str]:
        async with websockets.connect(bridge.url, subprotocols=["foxglove.sdk.v1"]) as ws:
            services: dict[str, int] = {}
            while f"{ARM}/reset" not in services:
                frame = await asyncio.wait_for(ws.recv(), TIMEOUT)
                if isinstance(frame, str) and json.loads(frame)["op"] == "advertiseServices":
                    services.update({s["name"]: s["id"] for s in json.loads(frame)["services"]})
            calls = [
                struct_call(99999, 1, "cdr", b""),
                struct_call(services[f"{ARM}/reset"], 2, "json", b"{}"),
            ]
            failures = []
            for call in calls:
                await ws.send(call)
                while True:
                    frame = await asyncio.wait_for(ws.recv(), TIMEOUT)
                    if isinstance(frame, str) and json.loads(frame)["op"] == "serviceCallFailure":
                        failures.append(json.loads(frame))
                        break
            return [f"{f['callId']} {f['message']}" for f in failures]

    assert asyncio.run(session()) == [
        "1 service call request: serviceId: no service 99999 is advertised",
        "2 service call request: encoding: 'json' is not supported (only cdr)",
    ]


def struct_call(service: int, call: int, encoding: str, payload: bytes) -> bytes:
    """Return a Service Call Request frame."""
    import struct

    name = encoding.encode()
    return struct.pack("<BIII", 2, service, call, len(name)) + name + payload


@pytest.mark.parametrize(
    ("offered", "said"),
    [
        (None, "missing subprotocol"),
        (
            ["foxglove.websocket.v2"],
            "invalid subprotocol; expected one of foxglove.sdk.v1, foxglove.websocket.v1",
        ),
    ],
)
def test_a_client_without_either_subprotocol_is_told_which(
    bridge: BridgeProcess, offered: list[str] | None, said: str
) -> None:
    import asyncio

    import websockets
    from websockets.exceptions import InvalidStatus

    async def attempt() -> tuple[int, str]:
        try:
            async with websockets.connect(bridge.url, subprotocols=offered):  # type: ignore[arg-type]
                return 101, ""
        except InvalidStatus as refused:
            return refused.response.status_code, refused.response.body.decode()

    status, body = asyncio.run(attempt())
    assert status == 400 and said in body, (status, body)
