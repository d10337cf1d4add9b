"""``feeder play`` as a node over DDS: its rosbag2-shaped control services, /clock from the bag's time,
remapping, service-event topics never replayed, and keyboard controls on a terminal (a pty)."""

from __future__ import annotations

import fcntl
import json
import os
import pty
import subprocess
import termios
from pathlib import Path
from typing import Any, Iterator

import bag_procs as bp
import play_bags as pb
import pytest
import ros_harness
from builtin_interfaces.msg import Time
from rosgraph_msgs.msg import Clock
from std_msgs.msg import String

from feeder_msgs.srv import Burst, GetRate, IsPaused, PlayNext, Resume, Seek, SetRate, TogglePaused

COUNT, GAP_NS = 200, 20_000_000  # a 4 s bag
PLAYER = "test_player"
OUT = "/seq_out"


def _call(client: Any, srv: Any, name: str, node: str = PLAYER, **fields: Any) -> Any:
    return ros_harness.call_service(client, srv, f"/{node}/{name}", srv.Request(**fields))


def _time(ns: int) -> Time:
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def _clock_ns(msg: Clock) -> int:
    return msg.clock.sec * 1_000_000_000 + msg.clock.nanosec


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[int]]:
    path = tmp_path_factory.mktemp("play") / "bag"
    return path, pb.write_seq_bag(path, COUNT, GAP_NS, events=3)


@pytest.fixture(scope="module")
def player(ros_domain: int, listen: Any, bag: tuple[Path, list[int]]) -> Iterator[subprocess.Popen]:
    listen(String, OUT)  # subscribed before the player starts: it waits for this subscriber
    listen(Clock, "/clock")
    process = subprocess.Popen(
        [*bp.FEEDER, "play", str(bag[0]), "--start-paused", "--clock", "50", "--remap", f"/seq:={OUT}"]
        + ["--node-name", PLAYER, "--wait-for-subscribers", "30", "--linger", "0.2", "--json"],
        stdin=subprocess.DEVNULL,  # not a terminal: no keyboard, and nothing blocks on stdin
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    yield process
    bp.end(process)


@pytest.fixture(scope="module")
def key_player(ros_domain: int, bag: tuple[Path, list[int]]) -> Iterator[tuple[subprocess.Popen, int]]:
    """A player whose stdin is a terminal (a pty), started with the other so their start-ups overlap."""
    master, slave = pty.openpty()
    process = subprocess.Popen(
        [*bp.FEEDER, "play", str(bag[0]), "--start-paused", "--node-name", "key_player"]
        + ["--playback-duration", "0.5", "--linger", "0", "--json"],
        stdin=slave,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        # The pty becomes the player's controlling terminal, its process group the foreground one, as
        # in a shell: only then does it read keys.
        preexec_fn=lambda: fcntl.ioctl(0, termios.TIOCSCTTY, 0),
    )
    os.close(slave)
    yield process, master
    os.close(master)
    bp.end(process)


@pytest.mark.ros
def test_paused_start_play_next_and_burst(
    ros_client: Any, listen: Any, player: Any, key_player: Any, bag: Any
) -> None:
    stamps = bag[1]
    out = listen(String, OUT)
    assert _call(ros_client, IsPaused, "is_paused").paused
    assert out.count() == 0  # started paused: nothing played by itself
    mark = out.count()
    assert _call(ros_client, PlayNext, "play_next").success
    assert _call(ros_client, Burst, "burst", num_messages=4).actually_burst == 4
    out.wait(lambda m: m.data == "4", timeout=30, after=mark)  # the burst may be in before the call returns
    assert [m.data for m in out.since(mark)] == ["0", "1", "2", "3", "4"]
    # /clock holds the stamp of the last message played while paused.
    listen(Clock, "/clock").wait(lambda m: _clock_ns(m) == stamps[4], timeout=30)


@pytest.mark.ros
def test_bad_requests_answer_false_and_playback_goes_on(
    ros_client: Any, listen: Any, player: Any, bag: Any
) -> None:
    stamps = bag[1]
    for rate in (-1.0, 0.0, float("nan"), float("inf")):
        assert not _call(ros_client, SetRate, "set_rate", rate=rate).success, rate
    assert _call(ros_client, GetRate, "get_rate").rate == 1.0
    assert not _call(ros_client, Seek, "seek", time=_time(stamps[0] - 1)).success  # before the start
    assert not _call(ros_client, Seek, "seek", time=_time(stamps[-1] + 1)).success  # after the end
    assert _call(ros_client, IsPaused, "is_paused").paused
    out = listen(String, OUT)
    assert _call(ros_client, PlayNext, "play_next").success
    out.wait(lambda m: m.data == "5", timeout=30, current=True)
    assert player.poll() is None


@pytest.mark.ros
def test_seek_rate_and_resume_play_the_rest(ros_client: Any, listen: Any, player: Any, bag: Any) -> None:
    stamps = bag[1]
    out, clock = listen(String, OUT), listen(Clock, "/clock")
    assert _call(ros_client, Seek, "seek", time=_time(stamps[150])).success
    assert _call(ros_client, SetRate, "set_rate", rate=4.0).success
    assert _call(ros_client, GetRate, "get_rate").rate == 4.0
    mark = out.count()
    _call(ros_client, Resume, "resume")
    out.wait(lambda m: m.data == str(COUNT - 1), timeout=30)
    assert [m.data for m in out.since(mark)] == [str(i) for i in range(150, COUNT)]
    clock.wait(lambda m: _clock_ns(m) >= stamps[-1], timeout=30, current=True)
    out_json, err = player.communicate(timeout=60)
    assert player.returncode == 0, err
    result = json.loads(out_json)
    # 1 + 4 + 1 messages played while paused, then 150..199.
    assert result["topics"] == {"/seq": {"type": "std_msgs/msg/String", "count": 6 + COUNT - 150}}
    assert result["remapped"] == {"/seq": OUT}
    assert result["skipped_service_events"] == {pb.EVENT_TOPIC: 3}
    assert "skipping 1 service-event topics (3 messages" in err and "Traceback" not in err
    assert not [p for p in ros_client.get_publishers_info_by_topic(pb.EVENT_TOPIC) if p.node_name == PLAYER]


@pytest.mark.ros
def test_keyboard_on_a_terminal(ros_client: Any, key_player: Any) -> None:
    process, master = key_player
    assert _call(ros_client, IsPaused, "is_paused", node="key_player").paused
    os.write(master, b"\x1b[A")  # up arrow: rate x 1.1
    bp.wait_until(
        lambda: abs(_call(ros_client, GetRate, "get_rate", node="key_player").rate - 1.1) < 1e-9,
        30,
        "the up arrow to raise the rate",
    )
    # ~/toggle_paused is the space key's control as a service: toggled twice, paused again.
    _call(ros_client, TogglePaused, "toggle_paused", node="key_player")
    assert not _call(ros_client, IsPaused, "is_paused", node="key_player").paused
    _call(ros_client, TogglePaused, "toggle_paused", node="key_player")
    assert _call(ros_client, IsPaused, "is_paused", node="key_player").paused
    os.write(master, b" ")  # space: resume; 0.5 s of bag time later the player ends
    out, err = process.communicate(timeout=60)
    assert process.returncode == 0, err
    assert json.loads(out)["topics"]["/seq"]["count"] == 26  # stamps 0 .. 0.5 s, 20 ms apart
    assert "space pause/resume" in err
