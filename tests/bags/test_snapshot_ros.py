"""Snapshot mode and the flight recorder, with real processes: a throwing arm, ``feeder record``, this client.

The flight recorder (``--snapshot-on-fault``) keeps a throwing arm's joint states in its cache; the test
injects ``motor_fault`` into the running arm and finds, in the bag the recorder writes by itself, the
samples the test saw before the fault (by their stamps) and those of the post-fault seconds, the FAULT
status, and a name made of the device, the fault code and the fault's time. ``~/snapshot``
(``--snapshot-mode``) writes the newest messages within ``--max-cache-size`` and empties the cache. Every
bag is read with the independent ``mcap`` reader and carries what rosbag2_storage_mcap writes.
"""

from __future__ import annotations

import re
import signal
import time
from pathlib import Path
from typing import Any, Callable

import bag_procs as bp
import pytest
import ros_harness
import rosbag2_fields
from mcap.reader import make_reader
from rclpy.serialization import deserialize_message

from feeder_cell.bag.snapshot import ENTRY_OVERHEAD

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "throwing"
ARM = "/flight/throwing_arm"
WAIT = 60.0


def _arm_parameters() -> dict[str, Any]:
    return {
        "part_file": str(EXAMPLES / "triangle.yaml"),
        "offset": -0.005,
        "release_speed": 5.585,
        "gravity": -9.66,
        "mu": 0.5,
        "initial_edge": 1,
        "initial_radius": 0.12,
        "sensor_rate": 50.0,
        "period": 0.2,
        "autostart": True,
    }


def _stamp(msg: Any) -> int:
    return int(msg.header.stamp.sec) * 1_000_000_000 + int(msg.header.stamp.nanosec)


def _bag_messages(bag: Path) -> dict[str, list[tuple[int, bytes]]]:
    """Per topic (log time, CDR) of the bag's one file, read with the mcap reader."""
    found: dict[str, list[tuple[int, bytes]]] = {}
    with bp.mcap_file(bag).open("rb") as stream:
        for _, channel, message in make_reader(stream).iter_messages():
            found.setdefault(channel.topic, []).append((message.log_time, message.data))
    return found


def _wait_for_bag(directory: Path, pattern: str, timeout: float) -> Path:
    """Wait until a complete bag (its metadata.yaml in place) whose name matches ``pattern`` appears."""
    found: list[Path] = []

    def complete() -> bool:
        found[:] = [
            p for p in directory.iterdir() if re.fullmatch(pattern, p.name) and (p / "metadata.yaml").exists()
        ]
        return bool(found)

    try:
        bp.wait_until(complete, timeout, f"a bag named {pattern}")
    except AssertionError as error:
        listing = sorted(p.name for p in directory.iterdir()) if directory.is_dir() else "no directory"
        raise AssertionError(f"{error}; {directory} holds {listing}") from None
    assert len(found) == 1, found
    return found[0]


@pytest.mark.ros
def test_a_fault_mid_run_writes_the_samples_before_it_and_after_it(
    ros_client: Any,
    launch_node: Callable[..., Any],
    listen: Callable[..., ros_harness.Listener],
    tmp_path: Path,
) -> None:
    from sensor_msgs.msg import JointState

    from feeder_msgs.msg import DeviceStatus

    launch_node("feeder_sim", "throwing_arm", _arm_parameters(), namespace="/flight")
    joints = listen(JointState, f"{ARM}/joint_states")
    # Listening from before the fault: the first FAULT status is the one the recorder names its bag by.
    status = listen(DeviceStatus, f"{ARM}/status", latched=True)
    joints.next(10, WAIT)
    out = tmp_path / "flight"
    recorder = bp.start_recorder(
        out,
        "--snapshot-on-fault",
        "--max-cache-duration",
        "4",
        "--post-fault",
        "1.5",
        "--topics",
        f"{ARM}/joint_states",
        f"{ARM}/status",
        "--node-name",
        "flight_recorder",
    )
    try:
        # The recorder has the joint states and watches the status (a second subscription of its own).
        bp.wait_until(
            lambda: (
                bool(bp.subscribed(ros_client, f"{ARM}/joint_states", "flight_recorder"))
                and len(bp.subscribed(ros_client, f"{ARM}/status", "flight_recorder")) == 2
            ),
            WAIT,
            "the flight recorder subscribed to the arm",
        )
        time.sleep(3.0)  # three seconds of samples in the cache
        seen_before = [_stamp(m) for m in joints.since(0)]
        response = ros_harness.inject_fault(ros_client, ARM, "motor_fault")
        assert response.ok, response.error
        bp.wait_until(
            lambda: any(s.state == DeviceStatus.FAULT for s in status.since(0)), WAIT, "the arm in FAULT"
        )
        seen_fault = next(s for s in status.since(0) if s.state == DeviceStatus.FAULT)
        assert seen_fault.fault_code == DeviceStatus.FAULT_MOTOR
        # Written by the recorder itself, 1.5 s after the fault: named by device, code and the fault's time.
        bag = _wait_for_bag(out, r"flight-throwing_arm_fault101_t\d+\.\d{3}", 30.0)
        assert not list(out.glob(".*.partial")), "a complete bag leaves no partial directory"
        result = bp.finish(recorder, signal.SIGINT)
    finally:
        bp.end(recorder)
    [written] = result["snapshots"]
    assert written["path"] == str(bag.resolve()) and written["reason"] == "fault"
    assert written["device"] == ARM and written["fault_code"] == 101

    messages = _bag_messages(bag)
    statuses = [deserialize_message(data, DeviceStatus) for _, data in messages[f"{ARM}/status"]]
    # The first FAULT status in the bag is the one that triggered it, and the bag is named by its time.
    fault = next(s for s in statuses if s.state == DeviceStatus.FAULT)
    assert fault.fault_code == 101 and _stamp(fault) <= _stamp(seen_fault)
    seconds, rest = divmod(_stamp(fault), 1_000_000_000)
    assert bag.name == f"flight-throwing_arm_fault101_t{seconds}.{rest // 1_000_000:03d}"
    stamps = [_stamp(deserialize_message(data, JointState)) for _, data in messages[f"{ARM}/joint_states"]]
    fault_ns = _stamp(fault)
    before = [s for s in stamps if s < fault_ns]
    after = [s for s in stamps if s > fault_ns]
    # The samples the test saw in the last two seconds before the fault are all in the bag.
    recent = [s for s in seen_before if s >= seen_before[-1] - 2_000_000_000]
    assert len(recent) >= 50 and set(recent) <= set(before), (len(recent), len(set(recent) - set(before)))
    # Bounded by --max-cache-duration (4 s of log time, plus the executor's lag) ...
    log_times = [t for t, _ in messages[f"{ARM}/joint_states"]]
    assert (max(log_times) - min(log_times)) / 1e9 <= 4.0 + 1.5 + 1.0
    # ... and with the post-fault seconds: about 1.5 s of samples at 50 Hz after the fault.
    assert len(after) >= 40, len(after)
    assert any(s.state != DeviceStatus.FAULT for s in statuses), "the status before the fault too"
    rosbag2_fields.check_bag(bag)


@pytest.mark.ros
def test_snapshot_service_writes_the_newest_messages_within_the_cache_size(
    ros_client: Any, tmp_path: Path
) -> None:
    from feeder_msgs.srv import Snapshot

    out = tmp_path / "snaps"
    limit = 20_000
    talker = bp.start_script("bag_seq_talker.py", "200")
    recorder = bp.start_recorder(
        out,
        "--snapshot-mode",
        "--max-cache-size",
        str(limit),
        "--topics",
        "/bag_seq",
        "--node-name",
        "snap_rec",
    )
    try:
        bp.wait_for_line(talker, "matched", 90)
        time.sleep(2.0)  # 400 messages sent; the cache holds the newest that fit
        reply = ros_harness.call_service(ros_client, Snapshot, "/snap_rec/snapshot", Snapshot.Request())
        assert reply.success
        bag = _wait_for_bag(out, r"snapshot_1_t\d+\.\d{3}", 30.0)
        result = bp.finish(recorder, signal.SIGINT)
    finally:
        bp.end(recorder)
        bp.end(talker, signal.SIGINT)
    seqs = [bp.seq_and_sent(data)[0] for _, data in _bag_messages(bag)["/bag_seq"]]
    # The newest run of messages, none missing, and no more than the bound lets the cache hold.
    assert seqs == list(range(seqs[0], seqs[0] + len(seqs))), "a contiguous run"
    size = len(_bag_messages(bag)["/bag_seq"][0][1]) + ENTRY_OVERHEAD
    assert 10 <= len(seqs) <= limit // size + 1, (len(seqs), limit // size)
    assert seqs[0] > 100, "the oldest messages were dropped from the cache"
    assert result["snapshots"][0]["messages"] == len(seqs)
    rosbag2_fields.check_bag(bag)
