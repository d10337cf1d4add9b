"""Over DDS: the simulators' ~/markers and frames, and `feeder bridge` as a Foxglove WebSocket client sees it.

One of each device for the whole module, under the namespace /viz. The array and the fixture are left
configured but inactive (``lifecycle: inactive``), so their physics is frozen and every drawn vertex is an
exact number of the model: the part at its initial pose, the table at its initial tilt. The arm is active,
at rest, with its sensor under the part (the bit reads true).

The bridge test speaks the published Foxglove WebSocket protocol with a plain ``websockets`` client
(serverInfo, advertise, subscribe, binary message data) and decodes the CDR it receives with rclpy.
"""

from __future__ import annotations

import asyncio
import json
import math
import struct
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import ros_harness
from bridge_process import BridgeProcess

from feeder_planner.node_kit.msg_markers import STYLES
from feeder_planner.node_kit.tf import TFMessage, quaternion_from_matrix, quaternion_from_rpy
from feeder_planner.parts import load_part
from feeder_planner.throwing import ThrowParams, arm_part
from feeder_sim.fixture.drawing import table_rotation
from feeder_sim.throwing import ThrowingArm

pytestmark = pytest.mark.ros

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
WASHER = EXAMPLES / "mems" / "washer.yaml"
PART_POSE = [0.4e-3, -0.3e-3, 0.7]
ARRAY_POSE = [0.5, 0.25, 0.0, 0.0, 0.0, 0.3]  # the array's place in the cell
TILT = (0.2, -0.1)
TRIANGLE = EXAMPLES / "throwing" / "triangle.yaml"
PAPER = {"offset": -0.005, "release_speed": math.radians(320), "gravity": -9.66, "mu": 0.5}
EDGE, RADIUS = 1, 0.12  # at rest there, a sensor at x = R reads true
NS = "/viz"
# The bridge serves the same v1 messages under both names and picks foxglove.sdk.v1 when a client offers
# both, as current Foxglove does (tests/bridge drives it with the official client under each name alone).
SUBPROTOCOLS = ["foxglove.sdk.v1", "foxglove.websocket.v1"]
SERVED_SUBPROTOCOL = "foxglove.sdk.v1"
ARRAY, ARM, FIXTURE = f"{NS}/mems_field_array", f"{NS}/throwing_arm", f"{NS}/assembly_fixture"
PLANNER = f"{NS}/stable_region_planner"
CUBE = EXAMPLES / "assembly" / "cube_in_corner.yaml"  # a 2-D stable region
SPHERE_RADIUS = 0.2


@pytest.fixture(scope="module")
def devices(launch_module_node: Any) -> None:
    launch_module_node(
        "feeder_sim",
        "mems_field_array",
        {
            "part_files": [str(WASHER)],
            "initial_poses": PART_POSE,
            "fidelity": "ideal",
            "cell_pose": ARRAY_POSE,
            "marker_rate": 10.0,
        },
        namespace=NS,
        lifecycle="inactive",
        wait_topics=(f"{ARRAY}/markers",),
    )
    launch_module_node(
        "feeder_sim",
        "throwing_arm",
        {
            "part_file": str(TRIANGLE),
            **PAPER,
            "initial_edge": EDGE,
            "initial_radius": RADIUS,
            "sensor_radius": RADIUS,
            "sensing_height": 0.001,
            "marker_rate": 10.0,
        },
        namespace=NS,
        wait_topics=(f"{ARM}/markers", f"{ARM}/sensor"),
    )
    launch_module_node(
        "feeder_sim",
        "assembly_fixture",
        {
            "initial_tilt_x": TILT[0],
            "initial_tilt_y": TILT[1],
            "marker_rate": 10.0,
        },
        namespace=NS,
        lifecycle="inactive",
        wait_topics=(f"{FIXTURE}/markers",),
    )
    launch_module_node(
        "feeder_planner",
        "stable_region_planner",
        {"assembly_file": str(CUBE), "sphere_radius": SPHERE_RADIUS},
        namespace=NS,
        wait_topics=(f"{PLANNER}/markers",),
        wait_services=(f"{PLANNER}/safe_path",),
    )


def first_of(listener: Any, accept: Any, timeout: float = 30.0) -> Any:
    """Return the first message the listener ever received that ``accept`` takes, waiting for one."""
    deadline = time.monotonic() + timeout
    with listener.arrived:
        index = 0
        while True:
            for msg in listener.messages[index:]:
                if accept(msg):
                    return msg
            index = len(listener.messages)
            remaining = deadline - time.monotonic()
            assert remaining > 0, f"nothing accepted on {listener.topic} within {timeout} s"
            listener.arrived.wait(remaining)


@pytest.fixture(scope="module")
def history(ros_client: Any) -> Any:
    """Return the module's transient-local listener of a topic, 20 deep.

    Several latched writers share these topics (the static geometry and the updates on ~/markers, every
    device on /tf_static); a reader one deep would keep only the last of what they deliver at once.
    """
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    qos = QoSProfile(
        depth=20, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
    )
    listeners: dict[str, ros_harness.Listener] = {}

    def get(msg_type: Any, topic: str) -> ros_harness.Listener:
        if topic not in listeners:
            listeners[topic] = ros_harness.Listener(ros_client, msg_type, topic, qos)
        return listeners[topic]

    return get


def markers_with(listen: Any, device: str, namespace: str, timeout: float = 30.0) -> Any:
    """Return the markers in ``namespace`` of the first MarkerArray of ``device`` that adds some.

    The latched geometry arrives once (at subscription), the updates after it: the whole history counts.
    """
    from visualization_msgs.msg import Marker, MarkerArray

    def has(msg: Any) -> bool:
        return any(m.ns == namespace and m.action == Marker.ADD for m in msg.markers)

    msg = first_of(listen(MarkerArray, f"{device}/markers"), has, timeout)
    return [m for m in msg.markers if m.ns == namespace and m.action == Marker.ADD]


def static_transform(listen: Any, child: str, timeout: float = 30.0) -> Any:
    """Return the transform to ``child`` that some node latched on /tf_static."""
    msg = first_of(
        listen(TFMessage, "/tf_static"),
        lambda m: any(t.child_frame_id == child for t in m.transforms),
        timeout,
    )
    return next(t for t in msg.transforms if t.child_frame_id == child)


def xy(marker: Any) -> np.ndarray:
    return np.array([[p.x, p.y] for p in marker.points])


def rgba(marker: Any) -> tuple[float, float, float, float]:
    return (marker.color.r, marker.color.g, marker.color.b, marker.color.a)


# --- markers ---------------------------------------------------------------------------------------
def test_array_markers_draw_the_part_at_its_pose_in_the_array_frame(
    devices: None, history: Any, listen: Any
) -> None:
    part = load_part(WASHER)
    outer, hole = part.placed(*PART_POSE)
    outlines = markers_with(history, ARRAY, "parts_outline")
    assert [m.header.frame_id for m in outlines] == ["viz/mems_array"] * 2
    assert xy(outlines[0])[:-1] == pytest.approx(outer, abs=1e-15)
    assert xy(outlines[1])[:-1] == pytest.approx(hole, abs=1e-15)
    (array,) = markers_with(history, ARRAY, "array_outline")
    half = 0.5 * 100 * 100e-6  # the default 100 x 100 cells of 100 um
    assert np.abs(xy(array)).max(axis=0) == pytest.approx([half, half])


def test_devices_are_placed_in_the_cell_frame(devices: None, history: Any, listen: Any) -> None:
    array = static_transform(history, "viz/mems_array")
    assert array.header.frame_id == "cell"
    t, r = array.transform.translation, array.transform.rotation
    assert (t.x, t.y, t.z) == pytest.approx(ARRAY_POSE[:3])
    assert (r.x, r.y, r.z, r.w) == pytest.approx(quaternion_from_rpy(*ARRAY_POSE[3:]))
    arm = static_transform(history, "viz/arm_pivot")  # by default rolled upright: the arm's -y is down
    r = arm.transform.rotation
    assert (r.x, r.y, r.z, r.w) == pytest.approx((math.sin(math.pi / 4), 0.0, 0.0, math.cos(math.pi / 4)))
    base = static_transform(history, "viz/fixture_base")
    assert base.header.frame_id == "cell"


def test_fixture_draws_bodies_and_tilts_its_frame(devices: None, history: Any, listen: Any) -> None:
    bodies = [m for m in markers_with(history, FIXTURE, "gravity")]
    assert bodies and bodies[0].header.frame_id == "viz/assembly"
    tilt = listen(TFMessage, "/tf").wait(
        lambda m: any(t.child_frame_id == "viz/assembly" for t in m.transforms), 30.0
    )
    (t,) = [t for t in tilt.transforms if t.child_frame_id == "viz/assembly"]
    assert t.header.frame_id == "viz/fixture_base"
    r = t.transform.rotation
    assert (r.x, r.y, r.z, r.w) == pytest.approx(quaternion_from_matrix(table_rotation(np.array(TILT))))


def test_arm_markers_draw_the_part_at_rest_and_the_sensor_by_its_bit(
    devices: None, history: Any, listen: Any
) -> None:
    params = ThrowParams(PAPER["offset"], PAPER["release_speed"], PAPER["gravity"], PAPER["mu"])
    arm = ThrowingArm(arm_part(load_part(TRIANGLE)), params, EDGE, RADIUS)
    (outline,) = markers_with(history, ARM, "part_outline")
    assert outline.header.frame_id == "viz/arm_pivot"
    assert xy(outline)[:-1] == pytest.approx(arm.part.part.placed(*arm.rest_pose())[0], abs=1e-12)
    (sensor,) = markers_with(history, ARM, "sensor")
    assert rgba(sensor) == pytest.approx(STYLES["sensor_on"])
    assert xy(sensor) == pytest.approx(
        np.array([[RADIUS, PAPER["offset"]], [RADIUS, PAPER["offset"] + 0.001]])
    )


def test_region_planner_draws_its_region_and_the_path_it_planned(
    devices: None, ros_client: Any, history: Any
) -> None:
    from geometry_msgs.msg import Vector3

    from feeder_msgs.srv import StablePath
    from feeder_planner.assembly import load_assembly, prepare

    region = prepare(load_assembly(CUBE)).region
    (boundary,) = markers_with(history, PLANNER, "region")
    assert boundary.header.frame_id == "viz/assembly"  # the fixture's frame beside it: drawn on the table
    points = np.array([[p.x, p.y, p.z] for p in boundary.points])
    assert np.linalg.norm(points, axis=1) == pytest.approx(SPHERE_RADIUS)
    assert all(
        region.contains(g, tolerance=1e-6) and abs(region.margin(g)) < 1e-6 for g in points / SPHERE_RADIUS
    )
    (center,) = markers_with(history, PLANNER, "center")
    c = center.pose.position
    assert (c.x, c.y, c.z) == pytest.approx(np.asarray(region.center) * SPHERE_RADIUS)
    request = StablePath.Request(start=Vector3(x=-0.5, y=-0.6, z=-0.6), goal=Vector3(x=-0.6, y=-0.5, z=-0.6))
    response = ros_harness.call_service(ros_client, StablePath, f"{PLANNER}/safe_path", request)
    (path,) = markers_with(history, PLANNER, "safe_path")
    drawn = np.array([[p.x, p.y, p.z] for p in path.points])
    planned = np.array([[g.x, g.y, g.z] for g in response.path])
    assert len(planned) > 2 and drawn == pytest.approx(
        planned / np.linalg.norm(planned, axis=1)[:, None] * SPHERE_RADIUS
    )


def test_marker_rate_refuses_bad_values_and_zero_stops_the_updates(
    devices: None, ros_client: Any, history: Any, listen: Any
) -> None:
    from visualization_msgs.msg import MarkerArray

    for bad in (-1.0, 31.0, math.nan):
        result = ros_harness.set_parameter(ros_client, ARM, "marker_rate", bad)
        assert not result.successful and "parameter marker_rate" in result.reason, result.reason
    updates = history(MarkerArray, f"{ARM}/markers")
    updates.next(2, timeout=10.0)  # still at 10 Hz after the refusals
    assert ros_harness.set_parameter(ros_client, ARM, "marker_rate", 0.0).successful
    try:
        # The deletions of what was drawn may still be on their way; then nothing for a second.
        updates.wait(lambda m: m.markers and all(x.action == x.DELETE for x in m.markers), 10.0, current=True)
        mark = updates.count()
        time.sleep(1.0)  # a bound, not a wait for an event: at 10 Hz this would hold ten updates
        assert updates.since(mark) == []
    finally:
        assert ros_harness.set_parameter(ros_client, ARM, "marker_rate", 10.0).successful
    # Back at 10 Hz: a new update arrives (from now on, not from the history).
    updates.wait(lambda m: any(x.ns == "sensor" and x.action == x.ADD for x in m.markers), 10.0)


# --- the bridge --------------------------------------------------------------------------------------


async def foxglove_session(url: str, topics: dict[str, int], timeout: float) -> dict[str, Any]:
    """Connect, wait for ``topics`` to be advertised, subscribe, return the channels and a payload of each.

    ``topics`` maps a topic to the number of messages wanted from it.
    """
    import websockets

    channels: dict[str, dict[str, Any]] = {}
    payloads: dict[str, list[bytes]] = {t: [] for t in topics}
    others: list[Any] = []
    deadline = time.monotonic() + timeout
    async with websockets.connect(url, subprotocols=SUBPROTOCOLS) as ws:
        assert ws.subprotocol == SERVED_SUBPROTOCOL
        first = json.loads(await asyncio.wait_for(ws.recv(), timeout))
        assert first["op"] == "serverInfo" and "supportedEncodings" in first
        subscribed: dict[int, str] = {}
        while any(len(payloads[t]) < n for t, n in topics.items()):
            try:
                frame = await asyncio.wait_for(ws.recv(), max(deadline - time.monotonic(), 0.0))
            except TimeoutError:
                counts = {t: len(p) for t, p in payloads.items()}
                raise AssertionError(f"within {timeout} s: got {counts}; other ops {others}") from None
            if isinstance(frame, bytes):
                assert frame[0] == 0x01  # message data
                subscription, _received = struct.unpack_from("<IQ", frame, 1)
                payloads[subscribed[subscription]].append(frame[13:])
                continue
            message = json.loads(frame)
            if message["op"] not in ("advertise",):
                others.append(message)
            if message["op"] == "advertise":
                new = []
                for channel in message["channels"]:
                    channels[channel["topic"]] = channel
                    if channel["topic"] in topics:
                        sid = len(subscribed) + 1
                        subscribed[sid] = channel["topic"]
                        new.append({"id": sid, "channelId": channel["id"]})
                if new:
                    await ws.send(json.dumps({"op": "subscribe", "subscriptions": new}))
    return {"channels": channels, "payloads": payloads}


@pytest.fixture(scope="module")
def bridge(devices: None) -> Any:
    process = BridgeProcess()
    yield process
    assert process.stop() == 0  # Ctrl-C ends it cleanly


def test_bridge_serves_markers_and_the_sensor_bit_as_cdr(bridge: BridgeProcess) -> None:
    from rclpy.serialization import deserialize_message
    from std_msgs.msg import Bool
    from visualization_msgs.msg import MarkerArray

    from feeder_cell.bag.types import typestore

    topics = {f"{ARM}/markers": 2, f"{ARM}/sensor": 3, f"{ARRAY}/markers": 1}
    try:
        session = asyncio.run(foxglove_session(bridge.url, topics, 20.0))
    except AssertionError:
        print(bridge.output())  # the bridge's log, for the failure report
        raise
    channels, payloads = session["channels"], session["payloads"]
    markers_channel = channels[f"{ARM}/markers"]
    assert (markers_channel["encoding"], markers_channel["schemaEncoding"]) == ("cdr", "ros2msg")
    assert markers_channel["schemaName"] == "visualization_msgs/msg/MarkerArray"
    # The schema is the definition rosbag2 writes: the type's text, then each nested type after "MSG:".
    expected, _ = typestore().generate_msgdef("visualization_msgs/msg/MarkerArray", ros_version=2)
    assert markers_channel["schema"] == expected and "MSG: visualization_msgs/Marker\n" in expected
    assert channels["/tf_static"]["schemaName"] == "tf2_msgs/msg/TFMessage"  # whichever type carries it
    bits = [deserialize_message(p, Bool).data for p in payloads[f"{ARM}/sensor"]]
    assert bits == [True] * len(bits)
    arm_markers = [deserialize_message(p, MarkerArray) for p in payloads[f"{ARM}/markers"]]
    sensors = [m for a in arm_markers for m in a.markers if m.ns == "sensor"]
    assert sensors and rgba(sensors[0]) == pytest.approx(STYLES["sensor_on"])
    array = deserialize_message(payloads[f"{ARRAY}/markers"][0], MarkerArray)
    assert {m.header.frame_id for m in array.markers} == {"viz/mems_array"}


async def watch_topic_come_and_go(
    url: str, topic: str, create: Any, destroy: Any, timeout: float
) -> list[str]:
    """Connect; create a publisher of ``topic``, see it advertised; destroy it, see it unadvertised."""
    import websockets

    events = []
    deadline = time.monotonic() + timeout
    async with websockets.connect(url, subprotocols=SUBPROTOCOLS) as ws:
        channel_id = None
        await asyncio.to_thread(create)
        while True:
            remaining = deadline - time.monotonic()
            assert remaining > 0, f"events so far: {events}"
            frame = await asyncio.wait_for(ws.recv(), remaining)
            if isinstance(frame, bytes):
                continue
            message = json.loads(frame)
            if message["op"] == "advertise" and channel_id is None:
                for channel in message["channels"]:
                    if channel["topic"] == topic:
                        channel_id = channel["id"]
                        events.append(f"advertise {channel['schemaName']}")
                        await asyncio.to_thread(destroy)
            elif message["op"] == "unadvertise" and channel_id in message["channelIds"]:
                events.append("unadvertise")
                return events


def test_bridge_advertises_new_topics_and_removes_vanished_ones(
    bridge: BridgeProcess, ros_client: Any
) -> None:
    from std_msgs.msg import String

    topic = f"{NS}/appears_later"
    publishers: list[Any] = []
    events = asyncio.run(
        watch_topic_come_and_go(
            bridge.url,
            topic,
            lambda: publishers.append(ros_client.create_publisher(String, topic, 10)),
            lambda: ros_client.destroy_publisher(publishers[0]),
            30.0,
        )
    )
    assert events == ["advertise std_msgs/msg/String", "unadvertise"]
