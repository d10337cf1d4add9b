"""Play timing and controls without ROS: the window, the bag clock, the play loop's controls, keys, and
the refusal of a damaged bag by ``feeder play`` (in process: it refuses before any node starts)."""

from __future__ import annotations

import math
import shutil
import threading
import time
from pathlib import Path

import play_bags as pb
import pytest

from feeder_cell.bag.keyboard import KeyboardControls, KeyDecoder
from feeder_cell.bag.playback import NS, BagClock, Item, Playback, Window, playback_window
from feeder_cell.bag.player import check_integrity, parse_remap
from feeder_cell.cli.main import main
from feeder_planner.errors import InputError


class FakeWall:
    """A wall clock the test moves by hand."""

    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def _items(count: int, gap: int = NS // 10, start: int = NS) -> list[Item]:
    return [Item("k", start + i * gap, str(i).encode()) for i in range(count)]


def _playback(items: list[Item], **kwargs: object) -> tuple[Playback, list[Item]]:
    sent: list[Item] = []
    window = Window(items[0].stamp, items[-1].stamp)
    source = lambda start: iter([i for i in items if i.stamp >= start])  # noqa: E731
    return Playback(source, window, sent.append, **kwargs), sent  # type: ignore[arg-type]


def test_window_from_offset_duration_and_until() -> None:
    assert playback_window(NS, 11 * NS) == Window(NS, 11 * NS)
    assert playback_window(NS, 11 * NS, start_offset=2.5) == Window(NS + 25 * NS // 10, 11 * NS)
    assert playback_window(NS, 11 * NS, 2.0, duration=3.0) == Window(3 * NS, 6 * NS)
    # With both a duration and an until, the earlier end wins.
    assert playback_window(NS, 11 * NS, 0.0, duration=3.0, until=2.0) == Window(NS, 2 * NS)
    assert playback_window(NS, 11 * NS, 0.0, duration=3.0, until=9.0) == Window(NS, 4 * NS)
    for kwargs, flag in (
        ({"start_offset": -1.0}, "--start-offset"),
        ({"start_offset": math.nan}, "--start-offset"),
        ({"start_offset": 10.5}, "--start-offset"),
        ({"duration": 0.0}, "--playback-duration"),
        ({"duration": math.inf}, "--playback-duration"),
        ({"until": 0.5}, "--playback-until"),
    ):
        with pytest.raises(InputError, match=flag):
            playback_window(NS, 11 * NS, **kwargs)  # type: ignore[arg-type]


def test_bag_clock_pause_rate_and_delay_keep_their_anchor() -> None:
    wall = FakeWall()
    clock = BagClock(5 * NS, rate=2.0, wall=wall)
    wall.t += 1.0
    assert clock.now() == 7 * NS  # two bag seconds per wall second
    assert clock.wall_due(9 * NS) == pytest.approx(wall.t + 1.0)
    clock.pause()
    wall.t += 10.0
    assert clock.now() == 7 * NS and clock.wall_due(8 * NS) == math.inf
    clock.resume()
    clock.set_rate(0.5)
    wall.t += 2.0
    assert clock.now() == 8 * NS
    with pytest.raises(InputError, match="rate"):
        clock.set_rate(-1.0)
    assert clock.rate == 0.5
    clock.jump(20 * NS, delay=3.0)
    wall.t += 1.0
    assert clock.now() == 20 * NS  # still in its delay: standing at the start
    wall.t += 4.0
    assert clock.now() == 21 * NS


def test_controls_while_paused_and_bad_requests() -> None:
    items = _items(20)
    playback, sent = _playback(items, start_paused=True)
    assert playback.is_paused()
    assert playback.play_next() and sent == items[:1]
    assert playback.now() == items[0].stamp  # the clock holds at the message played
    assert playback.burst(3) == 3 and sent == items[:4]
    assert playback.now() == items[3].stamp
    for bad in (-1.0, 0.0, math.nan, math.inf):
        assert not playback.set_rate(bad)
    assert playback.rate() == 1.0 and playback.set_rate(4.0) and playback.rate() == 4.0
    assert not playback.seek(items[0].stamp - 1) and not playback.seek(items[-1].stamp + 1)
    assert playback.seek(items[10].stamp)
    assert playback.play_next() and sent[-1] == items[10]
    assert playback.burst(0) == 9 and sent[-1] == items[-1]  # 0: the rest of the window
    assert not playback.play_next() and playback.burst(5) == 0  # nothing is left
    assert not playback.toggle_paused()
    assert not playback.play_next() and playback.burst(1) == 0  # both only while paused


def test_run_plays_in_order_at_the_rate_and_obeys_pause_from_another_thread() -> None:
    items = _items(30, gap=NS // 100)  # 10 ms apart: 0.29 s at rate 1
    playback, sent = _playback(items, rate=2.0, read_ahead=4)
    done = threading.Event()
    thread = threading.Thread(target=lambda: (playback.run(), done.set()))
    began = time.monotonic()
    thread.start()
    assert done.wait(10.0)
    assert sent == items
    # Never early: the last message is due 0.145 s after the start at rate 2 (a slow machine may be late).
    assert time.monotonic() - began >= 0.14

    playback, sent = _playback(items, start_paused=True)
    thread = threading.Thread(target=playback.run)
    thread.start()
    time.sleep(0.3)
    assert sent == []  # paused: nothing goes out however long it waits
    playback.resume()
    thread.join(10.0)
    assert not thread.is_alive() and sent == items


def test_loop_replays_the_window_and_stops_when_asked() -> None:
    items = _items(5, gap=NS // 1000)
    playback, sent = _playback(items, loop=True)
    playback.run(keep_going=lambda: len(sent) < 12)
    assert [i.data for i in sent] == [i.data for i in (items * 3)[:12]] and playback.loops == 2


def test_bad_delay_and_queue_size_name_their_flags() -> None:
    with pytest.raises(InputError, match="--delay"):
        _playback(_items(2), delay=-1.0)
    with pytest.raises(InputError, match="--read-ahead-queue-size"):
        _playback(_items(2), read_ahead=0)


def test_remap_rules() -> None:
    assert parse_remap("/a:=/b") == ("/a", "/b")
    assert parse_remap("a:=ns/b") == ("/a", "/ns/b")
    for bad in ("/a", ":=/b", "/a:=", "/a:=/b c"):
        with pytest.raises(InputError, match="--remap"):
            parse_remap(bad)


def test_keys_decode_even_split_and_controls_stay_off_without_a_terminal() -> None:
    decoder = KeyDecoder()
    assert decoder.feed(b" x\x1b[A") == ["toggle_paused", "faster"]
    assert decoder.feed(b"\x1b[") == [] and decoder.feed(b"B\x1b[C") == ["slower", "play_next"]
    assert decoder.feed(b"\x1bq ") == ["toggle_paused"]  # a lone escape is dropped
    with open(__file__) as not_a_tty:
        controls = KeyboardControls(lambda action: None, stream=not_a_tty)  # type: ignore[arg-type]
        assert not controls.active
        with controls:
            pass  # nothing read, nothing to restore


def test_a_damaged_or_cut_bag_is_refused_naming_file_offset_and_reindex(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    intact = tmp_path / "intact"
    pb.write_seq_bag(intact, 200, NS // 100)
    check_integrity(intact)  # the intact bag passes
    data = next(intact.glob("*.mcap")).read_bytes()
    half = len(data) // 2
    cases = {
        "garbage in a chunk": data[:half] + b"\xff" * 64 + data[half + 64 :],
        "cut at half": data[:half],
    }
    bags = {}
    for case, damaged in cases.items():
        bag = tmp_path / case.replace(" ", "_")
        shutil.copytree(intact, bag)
        mcap = next(bag.glob("*.mcap"))
        mcap.write_bytes(damaged)
        with pytest.raises(InputError, match="bag-reindex") as error:
            check_integrity(bag)
        assert mcap.name in str(error.value) and "byte" in str(error.value), case
        bags[case] = bag
    # The command refuses each in one line before any node starts (exit 2, no traceback).
    for case, bag in bags.items():
        assert main(["play", str(bag)]) == 2, case
        lines = capsys.readouterr().err.strip().splitlines()
        assert len(lines) == 1, (case, lines)
        assert "byte" in lines[0] and "bag-reindex" in lines[0] and str(bag) in lines[0], case
