"""Recording in cell time: ``feeder record --use-sim-time``, and ``feeder play --clock`` of that bag.

A test cell clock publishes ``/cell_time`` from the start but ``/clock`` (cell time from 1000 s, five
times faster than wall time) only after 3 s. The recorder on sim time subscribes to nothing before the
first ``/clock`` (as rosbag2), so no message of the first seconds is in the bag; every message's log
time is the cell time it was published at (within two clock ticks). Replaying the bag with ``--clock``
publishes ``/clock`` from those log times: a sim-time node sees the cell times again, each replayed
message arriving at the cell time it carries.
"""

from __future__ import annotations

import os
import signal
import threading
import time
from pathlib import Path
from typing import Any, Callable

import bag_procs as bp
import pytest
import ros_harness
import rosbag2_fields
from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.qos import QoSProfile, ReliabilityPolicy

START_S, FACTOR = 1000.0, 5.0
# A message's log time is the last /clock tick that reached the recorder before it: 20 ms of wall time
# between ticks is 0.1 s of cell time, and the middleware's receive path adds a tick or two on a loaded
# machine.
TOLERANCE_NS = 400_000_000
# Holds the recorder's executor once, for STALL_S, in its 30th write: the backlog a loaded machine makes.
STALLED_WRITE_SITE = """
import os, time
_stall = os.environ.get("FEEDER_TEST_STALL_S")
if _stall:
    from feeder_cell.bag import recorder as _recorder
    _write = _recorder.Recorder._write
    _calls = []
    def _stalled(self, topic, data, info):
        _calls.append(1)
        if len(_calls) == 30:
            time.sleep(float(_stall))
        return _write(self, topic, data, info)
    _recorder.Recorder._write = _stalled
"""
STALL_S = 1.0


@pytest.mark.ros
def test_record_in_cell_time_and_replay_it_with_the_clock(ros_client: Any, tmp_path: Path) -> None:
    from rosgraph_msgs.msg import Clock
    from std_msgs.msg import String

    from feeder_msgs.srv import Resume

    bag = tmp_path / "cell"
    recorded = _record_cell_time(ros_client, bag, "sim_rec", delay_s=3.0, record_s=3.0)  # 15 s of cell time
    first, last = recorded[0][0], recorded[-1][0]
    assert START_S * 1e9 <= first < last < (START_S + 60) * 1e9, "cell times, not wall times"
    rosbag2_fields.check_bag(bag)

    # Replay at 2x with /clock at 100 Hz: the clock a sim-time node sees is the recorded cell time.
    clocks: list[tuple[float, int]] = []
    replayed: list[tuple[float, int]] = []
    lock = threading.Lock()

    def on_clock(msg: Any) -> None:
        with lock:
            clocks.append((time.monotonic(), msg.clock.sec * 1_000_000_000 + msg.clock.nanosec))

    def on_data(msg: Any) -> None:
        with lock:
            replayed.append((time.monotonic(), int(msg.data)))

    # DDS matches the two ends of a topic independently: the player's publishers can count this client's
    # subscriptions while these subscriptions have not matched the player's publishers yet, and what a
    # volatile reader has not matched it never receives (the first 0.7 s of the replay went missing in
    # 1 run of 2, before this client waited for its own side). So the player starts paused, and resumes
    # once both subscriptions have matched its publishers (their own `matched` events).
    matched: dict[str, int] = {}

    def on_matched(topic: str) -> Callable[[Any], None]:
        return lambda status: matched.__setitem__(topic, status.current_count)

    reliable = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
    subscriptions = [
        ros_client.create_subscription(
            msg_type,
            topic,
            callback,
            reliable,
            event_callbacks=SubscriptionEventCallbacks(matched=on_matched(topic)),
        )
        for msg_type, topic, callback in ((Clock, "/clock", on_clock), (String, "/cell_time", on_data))
    ]
    player = bp.start_player(
        bag, "--clock", "100", "--rate", "2", "--start-paused", "--node-name", "sim_player"
    )
    try:
        bp.wait_until(
            lambda: matched.get("/clock", 0) > 0 and matched.get("/cell_time", 0) > 0, 30, "matched"
        )
        ros_harness.call_service(ros_client, Resume, "/sim_player/resume", Resume.Request())
        out, err = player.communicate(timeout=120)
        assert player.returncode == 0, err
        time.sleep(0.5)
    finally:
        bp.end(player)
        for subscription in subscriptions:
            ros_client.destroy_subscription(subscription)
    with lock:
        clocks_seen, data_seen = list(clocks), list(replayed)
    assert len(data_seen) == len(recorded), (len(data_seen), len(recorded))
    values = [c for _, c in clocks_seen]
    assert values == sorted(values), "the replayed clock runs forward"
    # While the bag plays, the clock reads the recorded cell times (after its end the player's clock runs
    # on until it exits, as rosbag2's does).
    playing = [c for t, c in clocks_seen if t <= data_seen[-1][0]]
    assert first - TOLERANCE_NS <= playing[0] and playing[-1] <= last + TOLERANCE_NS, (
        playing[0],
        playing[-1],
    )
    assert playing[-1] - playing[0] >= 0.8 * (last - first), "the clock covers the recorded cell times"
    # Each replayed message arrives when the replayed clock reads the cell time it was published at:
    # 100 Hz of /clock at rate 2 is 20 ms of cell time between ticks and the recording's offset adds up
    # to TOLERANCE_NS; this client's callbacks run up to a few hundred ms late on a loaded machine (the
    # median and the 95th percentile hold the clock to the cell times, the maximum catches a replay off).
    gaps = []
    for arrived, cell_ns in data_seen:
        before = [c for t, c in clocks_seen if t <= arrived]
        assert before, "the clock runs from before the first message"
        gaps.append(abs(before[-1] - cell_ns))
    gaps.sort()
    assert gaps[len(gaps) // 2] <= TOLERANCE_NS, gaps[len(gaps) // 2]
    assert gaps[int(len(gaps) * 0.95)] <= 2 * TOLERANCE_NS, gaps[int(len(gaps) * 0.95)]
    assert gaps[-1] <= 2_500_000_000, gaps[-1]


@pytest.mark.ros
def test_a_recorder_whose_executor_falls_behind_stamps_each_message_with_its_arrivals_cell_time(
    ros_client: Any, tmp_path: Path
) -> None:
    """ci50: a recorder held 0.3 s stamped its backlog with the newest /clock, 1.5 s of cell time late.

    The recorder's executor is held once for STALL_S (5 s of cell time) while both topics keep arriving;
    every message must still be stamped with the cell time of its arrival.
    """
    (tmp_path / "sitecustomize.py").write_text(STALLED_WRITE_SITE)
    env = dict(
        os.environ,
        PYTHONPATH=os.pathsep.join(p for p in (str(tmp_path), os.environ.get("PYTHONPATH", "")) if p),
        FEEDER_TEST_STALL_S=str(STALL_S),
    )
    recorded = _record_cell_time(
        ros_client, tmp_path / "stalled", "stalled_rec", delay_s=1.0, record_s=2.0 + STALL_S, env=env
    )
    # The stall happened: the 30th message's write waited STALL_S, so later messages queued behind it.
    assert len(recorded) > 30 + STALL_S / 0.02, len(recorded)


def _record_cell_time(
    ros_client: Any, bag: Path, name: str, delay_s: float, record_s: float, env: dict[str, str] | None = None
) -> list[tuple[int, bytes]]:
    """Record /cell_time on sim time for ``record_s`` once the test cell's /clock runs (after ``delay_s``).

    Return the recorded (log time, data) pairs, each checked to be from after the first /clock and stamped
    with the cell time it carries.
    """
    cell = bp.start_script("bag_cell_clock.py", str(delay_s), str(START_S), str(FACTOR))
    flags = ("--use-sim-time", "--topics", "/cell_time", "--node-name", name)
    recorder = bp.start_recorder(bag, *flags, env=env)
    try:
        bp.wait_until(lambda: bp.in_graph(ros_client, name), 60, "the recorder node")
        bp.wait_for_line(cell, "clock", 30)
        # Before the first /clock the recorder had not subscribed: it subscribes once the clock runs.
        bp.wait_until(lambda: bool(bp.subscribed(ros_client, "/cell_time", name)), 30, "subscribed")
        time.sleep(record_s)
        result = bp.finish(recorder, signal.SIGINT)
    finally:
        bp.end(recorder)
        bp.end(cell, signal.SIGINT)
    assert result["use_sim_time"] is True
    recorded = bp.read_messages(bag, "/cell_time")
    assert len(recorded) >= 100, len(recorded)
    assert all(bp.string_data(data) != "pre" for _, data in recorded), "nothing from before the first /clock"
    offsets = [log_time - int(bp.string_data(data)) for log_time, data in recorded]
    assert all(-TOLERANCE_NS <= d <= TOLERANCE_NS for d in offsets), (min(offsets), max(offsets))
    return recorded
