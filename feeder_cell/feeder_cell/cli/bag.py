"""``feeder record``, ``feeder bag-info`` and ``feeder bag-reindex`` (``feeder play`` is in cli.play)."""

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
    if args.flush_interval <= 0:
        raise InputError("--flush-interval", f"must be > 0 seconds, got {args.flush_interval}")
    output = Path(args.output)
    if output.exists():
        raise InputError("output", f"{output} already exists; bags are never overwritten")

    def work(node: Any, executor: Any, keep_going: Any) -> dict[str, Any]:
        recorder = Recorder(node, output, tuple(args.topics or ()), flush_interval=args.flush_interval)
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


def _info(args: argparse.Namespace) -> int:
    from feeder_cell.bag.player import open_bag

    reader = open_bag(Path(args.bag))
    try:
        topics = {c.topic: {"type": c.msgtype, "count": c.msgcount} for c in reader.connections}
        empty = reader.message_count == 0  # rosbags reports the "no message yet" sentinel as the start
        result = {
            "path": str(Path(args.bag).resolve()),
            "duration": 0.0 if empty else reader.duration / 1e9,
            "start_time": None if empty else reader.start_time / 1e9,
            "topics": dict(sorted(topics.items())),
        }
    finally:
        reader.close()
    emit(args, result, _summary)
    return 0


def _reindex(args: argparse.Namespace) -> int:
    from feeder_cell.bag.reindex import reindex

    report = reindex(Path(args.bag))
    result = {
        "path": str(report.path.resolve()),
        "files": [
            {
                "name": f.name,
                "size": f.size,
                "recovered_bytes": f.recovered_bytes,
                "chunks": f.chunks,
                "messages": f.messages,
                "complete": f.complete,
                "stopped_by": f.stopped_by,
            }
            for f in report.files
        ],
        "topics": dict(sorted(report.topics.items())),
    }
    emit(args, result, _reindex_summary)
    return 0


def _reindex_summary(result: dict[str, Any]) -> str:
    lines = [_summary(result)]
    for f in result["files"]:
        state = (
            "complete" if f["complete"] else f"recovered up to byte {f['recovered_bytes']}: {f['stopped_by']}"
        )
        lines.append(
            f"  {f['name']}: {f['size']} bytes, {f['chunks']} chunks, {f['messages']} messages, {state}"
        )
    return "\n".join(lines)


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add this module's subcommands to the ``feeder`` parser."""
    record = subparsers.add_parser(
        "record",
        help="record live topics into a rosbag2 MCAP bag",
        description="Subscribe to topics as they appear (raw CDR) and write them to a new rosbag2 bag (MCAP "
        "storage) at OUTPUT. A topic is subscribed once it has a publisher, with its publishers' "
        "reliability and durability (latched topics are recorded, and marked, latched), and again when a "
        "new publisher needs another profile. Stops after --duration seconds, on Ctrl-C, SIGTERM or SIGHUP "
        "(each closes the bag cleanly). Data reaches the disk at least every --flush-interval seconds: "
        "after a SIGKILL or power loss at most that much is lost, and `feeder bag-reindex OUTPUT` makes the "
        "rest readable. Timestamps are receive times, nanoseconds since the epoch.",
    )
    record.add_argument("output", help="bag directory to create (never overwritten), e.g. bags/run1")
    record.add_argument(
        "--topics", nargs="+", help="topics to record (default: all but /rosout, /parameter_events)"
    )
    record.add_argument(
        "--duration", type=finite_float, help="seconds to record (default: until Ctrl-C, SIGTERM or SIGHUP)"
    )
    record.add_argument(
        "--flush-interval",
        type=finite_float,
        default=1.0,
        metavar="SECONDS",
        help="close the current MCAP chunk and flush it to disk at least this often, whatever the data "
        "rate (> 0, default 1): the most a killed recorder loses",
    )
    add_json_flag(record)
    record.set_defaults(handler=_record)

    info = subparsers.add_parser(
        "bag-info",
        help="topics, types, counts and duration of a bag",
        description="Print a bag's topics, types, counts and duration. A bag whose recording did not end "
        "cleanly (no metadata.yaml, or an MCAP file without its summary) is refused naming bag-reindex.",
    )
    info.add_argument("bag")
    add_json_flag(info)
    info.set_defaults(handler=_info)

    reindex = subparsers.add_parser(
        "bag-reindex",
        help="recover a bag whose recording was killed or cut short (as ros2 bag reindex)",
        description="Scan BAG's MCAP files record by record, keep everything up to the last complete chunk "
        "and write the bag again with its MCAP summary and metadata.yaml, so that bag-info, play and other "
        "readers accept it. A complete bag is rebuilt unchanged. Prints what was kept per file and topic.",
    )
    reindex.add_argument("bag")
    add_json_flag(reindex)
    reindex.set_defaults(handler=_reindex)
