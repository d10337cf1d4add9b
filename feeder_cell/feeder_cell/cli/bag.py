"""``feeder record``, ``feeder play`` and ``feeder bag-info``: rosbag2 MCAP bags without ros2bag."""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

from feeder_cell.cli.common import add_json_flag, emit, finite_float
from feeder_cell.ros_session import with_node
from feeder_planner.errors import InputError


def _record(args: argparse.Namespace) -> int:
    from feeder_cell.bag.recorder import Recorder, missing_topics

    if args.duration is not None and args.duration <= 0:
        raise InputError("--duration", f"must be > 0 seconds, got {args.duration}")
    output = Path(args.output)

    def work(node: Any, executor: Any, keep_going: Any) -> dict[str, Any]:
        recorder = Recorder(node, output, tuple(args.topics or ()))
        started = time.monotonic()
        next_discovery = 0.0
        try:
            while keep_going() and (args.duration is None or time.monotonic() - started < args.duration):
                if time.monotonic() >= next_discovery:
                    recorder.discover()
                    next_discovery = time.monotonic() + 0.5
                executor.spin_once(timeout_sec=0.05)
        finally:
            stats = recorder.close()
        return {
            "path": str(output.resolve()),
            "duration": time.monotonic() - started,
            "topics": {name: {"type": s.type_name, "count": s.count} for name, s in sorted(stats.items())},
            "missing": missing_topics(stats, args.topics or ()),
        }

    result = with_node("feeder_recorder", work)
    emit(args, result, _summary)
    return 0


def _summary(result: dict[str, Any]) -> str:
    lines = [
        f"{result['path']}: {sum(t['count'] for t in result['topics'].values())} messages"
        + (f" in {result['duration']:.1f} s" if "duration" in result else "")
    ]
    lines += [f"  {name}  {t['type']}  {t['count']}" for name, t in result["topics"].items()]
    if result.get("missing"):
        lines.append(f"  never seen: {', '.join(result['missing'])}")
    return "\n".join(lines)


def _play(args: argparse.Namespace) -> int:
    from feeder_cell.bag.player import play

    path = Path(args.bag)
    for flag, value in (("--wait-for-subscribers", args.wait_for_subscribers), ("--linger", args.linger)):
        if value < 0:
            raise InputError(flag, f"must be >= 0 seconds, got {value}")
    if not path.exists():
        raise InputError("BAG", f"{path} does not exist")

    def work(node: Any, executor: Any, keep_going: Any) -> dict[str, Any]:
        counts = play(node, path, args.rate, tuple(args.topics or ()), keep_going, args.wait_for_subscribers)
        executor.spin_once(timeout_sec=0.1)
        time.sleep(args.linger)  # latched topics stay available to late subscribers for a while
        return {
            "path": str(path.resolve()),
            "topics": {t: {"type": "", "count": n} for t, n in counts.items()},
        }

    emit(args, with_node("feeder_player", work), _summary)
    return 0


def _info(args: argparse.Namespace) -> int:
    from feeder_cell.bag.player import open_bag

    reader = open_bag(Path(args.bag))
    try:
        topics = {c.topic: {"type": c.msgtype, "count": c.msgcount} for c in reader.connections}
        result = {
            "path": str(Path(args.bag).resolve()),
            "duration": reader.duration / 1e9,
            "start_time": reader.start_time / 1e9,
            "topics": dict(sorted(topics.items())),
        }
    finally:
        reader.close()
    emit(args, result, _summary)
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add this module's subcommands to the ``feeder`` parser."""
    record = subparsers.add_parser(
        "record",
        help="record live topics into a rosbag2 MCAP bag",
        description="Subscribe to topics as they appear (raw CDR, matching each publisher's reliability and "
        "durability) and write them to a new rosbag2 bag (MCAP storage) at OUTPUT. Stops after "
        "--duration seconds or on Ctrl-C. Timestamps are receive times, nanoseconds since the epoch.",
    )
    record.add_argument("output", help="bag directory to create (never overwritten), e.g. bags/run1")
    record.add_argument(
        "--topics", nargs="+", help="topics to record (default: all but /rosout, /parameter_events)"
    )
    record.add_argument("--duration", type=finite_float, help="seconds to record (default: until Ctrl-C)")
    add_json_flag(record)
    record.set_defaults(handler=_record)

    player = subparsers.add_parser(
        "play",
        help="replay a bag onto live topics",
        description="Publish every message of BAG at the recorded pace divided by --rate, with the QoS the "
        "recorded publishers offered (latched topics are replayed latched).",
    )
    player.add_argument("bag")
    player.add_argument(
        "--rate", type=finite_float, default=1.0, help="playback speed factor (> 0, default 1)"
    )
    player.add_argument("--topics", nargs="+", help="only these topics")
    player.add_argument(
        "--wait-for-subscribers",
        type=finite_float,
        default=0.0,
        metavar="SECONDS",
        help="before playing, wait up to SECONDS until every topic has a subscriber (default 0: "
        "wait 0.5 s for discovery and start)",
    )
    player.add_argument(
        "--linger", type=finite_float, default=1.0, help="seconds to stay up after the last message"
    )
    add_json_flag(player)
    player.set_defaults(handler=_play)

    info = subparsers.add_parser("bag-info", help="topics, types, counts and duration of a bag")
    info.add_argument("bag")
    add_json_flag(info)
    info.set_defaults(handler=_info)
