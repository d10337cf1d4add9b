"""``feeder record``, ``bag-info``, ``bag-reindex`` and ``bag-convert`` (``feeder play`` is in cli.play)."""

from __future__ import annotations

import argparse
import re
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

from feeder_cell.cli.common import add_json_flag, emit, finite_float, output_directory
from feeder_cell.ros_session import with_node
from feeder_planner.errors import InputError

if TYPE_CHECKING:
    from rclpy.executors import Executor
    from rclpy.node import Node
    from rclpy.service import Service

    from feeder_cell.bag.recorder import Recorder, Selection


def _selection(args: argparse.Namespace) -> Selection:
    from feeder_cell.bag.recorder import Selection

    selective = args.topics or args.regex is not None or args.services is not None or args.actions is not None
    return Selection(
        topics=tuple(args.topics or ()),
        all_topics=args.all or not selective,
        regex=args.regex,
        exclude=args.exclude,
        topic_types=tuple(args.topic_types or ()),
        include_hidden=args.include_hidden_topics,
        services=() if args.all and args.services is None else _names(args.services),
        actions=() if args.all and args.actions is None else _names(args.actions),
    )


def _names(values: list[str] | None) -> tuple[str, ...] | None:
    return None if values is None else tuple(values)


def _compression(args: argparse.Namespace) -> str:
    """Return the MCAP chunk compression the flags ask for (rosbag2's file and message modes map to it)."""
    if args.compression is not None:
        if args.compression_mode not in (None, "none") or args.compression_format is not None:
            raise InputError(
                "--compression", "give either --compression or --compression-mode/--compression-format"
            )
        return str(args.compression)
    mode = args.compression_mode or "none"
    if mode == "none":
        if args.compression_format is not None:
            raise InputError("--compression-format", "needs --compression-mode file or message")
        return "none"
    return str(args.compression_format or "zstd")


@dataclass(frozen=True)
class _RecordPlan:
    """A recording's checked flags and what they decide, all known before its node starts."""

    args: argparse.Namespace
    snapshot: bool
    selection: Selection
    compression: str
    overrides: dict[str, Any]  # QoS profiles by topic
    output: Path


def _record(args: argparse.Namespace) -> int:
    plan = _plan_record(args)

    def work(node: Node, executor: Executor, keep_going: Callable[[], bool]) -> dict[str, Any]:
        return _run_recording(plan, node, executor, keep_going)

    result = with_node(args.node_name, work)
    emit(args, result, _summary)
    return 0


def _plan_record(args: argparse.Namespace) -> _RecordPlan:
    """Check the flags, in this order (a user sees the first mistake), before any node starts."""
    from feeder_cell.bag.qos import load_qos_overrides

    if args.duration is not None and args.duration <= 0:
        raise InputError("--duration", f"must be > 0 seconds, got {args.duration}")
    if args.flush_interval <= 0:
        raise InputError("--flush-interval", f"must be > 0 seconds, got {args.flush_interval}")
    if args.max_bag_size < 0:
        raise InputError("--max-bag-size", f"must be >= 0 bytes (0: no splitting), got {args.max_bag_size}")
    if args.max_bag_duration < 0:
        raise InputError(
            "--max-bag-duration", f"must be >= 0 seconds (0: no splitting), got {args.max_bag_duration}"
        )
    snapshot = _snapshot_options(args)
    if not _NODE_NAME.fullmatch(args.node_name):
        raise InputError(
            "--node-name", f"must be a ROS node name (letters, digits, _), got {args.node_name!r}"
        )
    selection = _selection(args)
    compression = _compression(args)
    overrides = (
        load_qos_overrides(Path(args.qos_profile_overrides_path)) if args.qos_profile_overrides_path else {}
    )
    # Before any node starts: an existing bag, or a parent that is a file, is refused by name. Snapshot
    # bags go into OUTPUT as a directory of bags, which may exist already (each bag's name is new).
    output = output_directory(args.output, "output", must_be_new=not snapshot)
    return _RecordPlan(args, snapshot, selection, compression, overrides, output)


def _run_recording(
    plan: _RecordPlan, node: Node, executor: Executor, keep_going: Callable[[], bool]
) -> dict[str, Any]:
    """Record until the duration is up or a stop signal; the bag is closed whatever ends it."""
    from feeder_cell.bag.controls import serve_pause_controls

    recorder = _open_recorder(plan, node)
    # ~/pause, ~/resume, ~/toggle_paused and ~/is_paused on the recorder node, as rosbag2 serves them.
    services = serve_pause_controls(
        node, recorder.pause, recorder.resume, recorder.toggle_paused, lambda: recorder.paused
    )
    if plan.snapshot:
        services.append(_serve_snapshot(node, recorder))
    started = time.monotonic()
    try:
        _record_until_the_end(plan.args.duration, recorder, executor, keep_going, started)
    finally:
        stats = recorder.close()
        for service in services:
            node.destroy_service(service)
    return _record_result(plan, recorder, stats, started)


def _open_recorder(plan: _RecordPlan, node: Node) -> Recorder:
    """Return the recorder the flags ask for, on the wall clock or (--use-sim-time) on /clock."""
    from feeder_cell.bag.recorder import Recorder

    args = plan.args
    clock: Callable[[], int] = time.time_ns
    stamp: Callable[[dict[str, int]], int] | None = None
    if args.use_sim_time:
        from rclpy.parameter import Parameter

        from feeder_cell.bag.receipt_clock import CellTimeAtReceipt

        # The node's clock follows /clock from here; it reads 0 until the first message.
        node.set_parameters([Parameter("use_sim_time", Parameter.Type.BOOL, True)])
        clock = lambda: node.get_clock().now().nanoseconds  # noqa: E731
        stamp = CellTimeAtReceipt(node).stamp
        node.get_logger().info("use_sim_time: waiting for /clock before recording")
    return Recorder(
        node,
        plan.output,
        flush_interval=args.flush_interval,
        selection=plan.selection,
        compression=plan.compression,
        max_bag_size=args.max_bag_size,
        max_bag_duration=args.max_bag_duration,
        qos_overrides=plan.overrides,
        paused=args.start_paused,
        clock=clock,
        wait_for_clock=args.use_sim_time,
        stamp=stamp,
        snapshot=plan.snapshot,
        max_cache_size=args.max_cache_size or 0,
        max_cache_duration=args.max_cache_duration or 0.0,
        snapshot_on_fault=args.snapshot_on_fault,
        post_fault=DEFAULT_POST_FAULT if args.post_fault is None else args.post_fault,
    )


def _record_until_the_end(
    duration: float | None,
    recorder: Recorder,
    executor: Executor,
    keep_going: Callable[[], bool],
    started: float,
) -> None:
    """Spin, subscribing to new topics every half second, until ``duration`` is up or a stop signal."""
    next_discovery = 0.0
    while keep_going() and (duration is None or time.monotonic() - started < duration):
        if time.monotonic() >= next_discovery:
            recorder.discover()
            next_discovery = time.monotonic() + 0.5
        executor.spin_once(timeout_sec=0.05)


def _record_result(
    plan: _RecordPlan, recorder: Recorder, stats: dict[str, Any], started: float
) -> dict[str, Any]:
    """Return the recording's JSON result (in snapshot mode with its snapshots and cache)."""
    from feeder_cell.bag.recorder import missing_topics

    result = {
        "path": str(plan.output.resolve()),
        "duration": time.monotonic() - started,
        "files": [f.name for f in recorder.files],
        "compression": plan.compression,
        "use_sim_time": plan.args.use_sim_time,
        "dropped_while_paused": recorder.dropped_paused,
        "topics": {name: {"type": s.type_name, "count": s.count} for name, s in sorted(stats.items())},
        "missing": missing_topics(stats, plan.args.topics or ()),
    }
    if plan.snapshot:
        result["snapshots"] = [bag.to_json() for bag in recorder.written]
        result["skipped_faults"] = recorder.skipped_faults
        result["cache"] = recorder.cache_stats
    return result


_NODE_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def _snapshot_options(args: argparse.Namespace) -> bool:
    """Check the snapshot flags; return whether the recording is in snapshot mode."""
    from feeder_cell.bag.snapshot import DEFAULT_MAX_CACHE_SIZE, check_cache_limits

    snapshot = bool(args.snapshot_mode or args.snapshot_on_fault)
    if not snapshot:
        for flag, value in (
            ("--max-cache-size", args.max_cache_size),
            ("--max-cache-duration", args.max_cache_duration),
            ("--post-fault", args.post_fault),
        ):
            if value is not None:
                raise InputError(
                    flag, "needs --snapshot-mode or --snapshot-on-fault (writes go to disk as they come)"
                )
        return False
    for flag, value in (("--max-bag-size", args.max_bag_size), ("--max-bag-duration", args.max_bag_duration)):
        if value:
            raise InputError(flag, "cannot split in snapshot mode: each snapshot is a bag of one file")
    if args.start_paused:
        raise InputError(
            "--start-paused", "has no meaning in snapshot mode: nothing is written until a snapshot"
        )
    if args.max_cache_size is None:
        args.max_cache_size = DEFAULT_MAX_CACHE_SIZE
    if args.max_cache_duration is None:
        args.max_cache_duration = 0.0
    if args.post_fault is None:
        args.post_fault = DEFAULT_POST_FAULT
    check_cache_limits(args.max_cache_size, args.max_cache_duration)
    if args.post_fault < 0:
        raise InputError("--post-fault", f"must be >= 0 seconds, got {args.post_fault}")
    return True


DEFAULT_POST_FAULT = 5.0


def _serve_snapshot(node: Node, recorder: Recorder) -> Service:
    """Serve ``~/snapshot`` (rosbag2_interfaces' Snapshot shape) on the recorder node."""
    from feeder_msgs.srv import Snapshot
    from feeder_planner.node_kit.qos import request_qos

    def callback(_request: Snapshot.Request, response: Snapshot.Response) -> Snapshot.Response:
        response.success = recorder.snapshot_now()
        return response

    return node.create_service(Snapshot, "~/snapshot", callback, qos_profile=request_qos())


def _summary(result: dict[str, Any]) -> str:
    lines = [
        f"{result['path']}: {sum(t['count'] for t in result['topics'].values())} messages"
        + (f" in {result['duration']:.1f} s" if "duration" in result else "")
    ]
    lines += [f"  {name}  {t['type']}  {t['count']}" for name, t in result["topics"].items()]
    if result.get("missing"):
        lines.append(f"  never seen: {', '.join(result['missing'])}")
    for bag in result.get("snapshots", []):
        why = f"{bag['device']} fault {bag['fault_code']}" if bag["reason"] == "fault" else "~/snapshot"
        lines.append(f"  snapshot ({why}): {bag['path']}  {bag['messages']} messages")
    return "\n".join(lines)


def _info(args: argparse.Namespace) -> int:
    from feeder_cell.bag.info import bag_info, info_text

    emit(args, bag_info(Path(args.bag)), info_text)
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
                "left_out": f.left_out,
                "kept_as": f.kept_as,
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
        if f["left_out"]:
            kept = f", renamed {f['kept_as']}" if f["kept_as"] else ", removed"
            lines.append(f"  {f['name']}: left out of metadata.yaml ({f['left_out']}){kept}")
            continue
        if f["kept_as"]:
            state += f"; its unreadable bytes kept as {f['kept_as']}"
        lines.append(
            f"  {f['name']}: {f['size']} bytes, {f['chunks']} chunks, {f['messages']} messages, {state}"
        )
    return "\n".join(lines)


def _convert(args: argparse.Namespace) -> int:
    from feeder_cell.bag.convert import convert, load_output_options

    inputs = [Path(p) for p in args.inputs or ()]
    for given in args.input or ():
        if len(given) > 2 or (len(given) == 2 and given[1] != "mcap"):
            raise InputError(
                "--input", f"takes URI [mcap] (the only storage read here), got {' '.join(given)!r:.80}"
            )
        inputs.append(Path(given[0]))
    outputs = load_output_options(Path(args.output_options))
    result = convert(inputs, outputs)
    emit(
        args,
        {"inputs": result.inputs, "outputs": result.outputs, "skipped_topics": result.skipped_topics},
        _convert_summary,
    )
    return 0


def _convert_summary(result: dict[str, Any]) -> str:
    lines = [f"read {sum(result['inputs'].values())} messages from {len(result['inputs'])} input(s)"]
    for output in result["outputs"]:
        lines.append(f"{output['uri']}: {output['messages']} messages in {', '.join(output['files'])}")
        lines += [f"  {name}  {t['type']}  {t['count']}" for name, t in output["topics"].items()]
    for name, types in result["skipped_topics"].items():
        lines.append(f"  left out {name}: more than one type among the inputs ({', '.join(types)})")
    return "\n".join(lines)


def _compare(args: argparse.Namespace) -> int:
    from feeder_cell.bag.compare import DEFAULT_EXCLUDED, compare_bags

    end = None if args.end is None else int(round(args.end * 1e9))
    difference, counts = compare_bags(
        Path(args.left),
        Path(args.right),
        int(round(args.start * 1e9)),
        end,
        (*DEFAULT_EXCLUDED, *args.exclude),
    )
    result = {
        "agree": difference is None,
        "difference": difference.describe() if difference else "",
        "messages": counts,
    }
    emit(
        args,
        result,
        lambda r: (
            f"the bags agree: {sum(counts.values())} messages on {len(counts)} topics"
            if r["agree"]
            else f"the bags differ: {r['difference']}"
        ),
    )
    return 0 if difference is None else 1


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add this module's subcommands to the ``feeder`` parser."""
    _register_record(subparsers)
    _register_info(subparsers)
    _register_reindex(subparsers)
    _register_compare(subparsers)
    _register_convert(subparsers)


def _register_record(subparsers: argparse._SubParsersAction) -> None:
    """Add ``feeder record``: its flags in the order its --help lists them."""
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
    _add_record_selection(record)
    _add_record_files(record)
    _add_record_behaviour(record)
    _add_record_snapshot(record)
    _add_record_run(record)
    add_json_flag(record)
    record.set_defaults(handler=_record)


def _add_record_selection(record: argparse.ArgumentParser) -> None:
    """Add the flags of what ``feeder record`` records: topics, services, actions (name, pattern, type)."""
    record.add_argument(
        "--topics",
        nargs="+",
        metavar="TOPIC",
        help="record these topics (default, when no other selection is given: every topic but /rosout, "
        "/parameter_events and hidden ones)",
    )
    record.add_argument(
        "-a",
        "--all",
        action="store_true",
        help="every topic (as the default), every service's calls (as --services) and every action's "
        "feedback and status (as --actions)",
    )
    record.add_argument(
        "-e",
        "--regex",
        metavar="REGEX",
        help="also record topics whose name matches REGEX (Python re.search)",
    )
    record.add_argument(
        "-x",
        "--exclude",
        "--exclude-regex",
        dest="exclude",
        metavar="REGEX",
        help="never record topics (service events and action topics included) whose name matches REGEX",
    )
    record.add_argument(
        "--topic-types",
        nargs="+",
        metavar="TYPE",
        help="record only topics of these types (pkg/msg/Type); service events are not affected",
    )
    record.add_argument(
        "--include-hidden-topics",
        action="store_true",
        help="let the default selection, --all and --regex take hidden topics (a name part starting with _)",
    )
    record.add_argument(
        "--services",
        nargs="*",
        metavar="SERVICE",
        help="record service calls: the <service>/_service_event topics of these services, every "
        "service's with no name (nodes publish their calls' requests and responses by default: parameter "
        "service_introspection); play never re-issues them",
    )
    record.add_argument(
        "--actions",
        nargs="*",
        metavar="ACTION",
        help="record these actions' <action>/_action/feedback and _action/status topics (goal states and "
        "feedback), every action's with no name; Jazzy cannot introspect actions' goal and result services",
    )


def _add_record_files(record: argparse.ArgumentParser) -> None:
    """Add the flags of how ``feeder record`` writes its files: splitting and compression."""
    record.add_argument(
        "--max-bag-size",
        type=int,
        default=0,
        metavar="BYTES",
        help="split: close the current file once it holds BYTES and continue in the next "
        "(<bag>_0.mcap, <bag>_1.mcap, ...; metadata.yaml lists them; default 0: no splitting)",
    )
    record.add_argument(
        "--max-bag-duration",
        type=finite_float,
        default=0.0,
        metavar="SECONDS",
        help="split: start the next file once the current one spans SECONDS (default 0: no splitting)",
    )
    record.add_argument(
        "--compression",
        choices=("none", "zstd", "lz4"),
        help="MCAP chunk compression (each chunk compressed; every MCAP reader decodes it, and crash safety "
        "is unchanged); the way rosbag2's MCAP storage compresses",
    )
    record.add_argument(
        "--compression-mode",
        choices=("none", "file", "message"),
        help="rosbag2's compression flags, mapped to MCAP chunk compression of --compression-format: a "
        "file compressed whole at close would lose a killed recording, and per-message compression "
        "leaves messages no MCAP reader decodes",
    )
    record.add_argument(
        "--compression-format", choices=("zstd", "lz4"), help="with --compression-mode (default zstd)"
    )


def _add_record_behaviour(record: argparse.ArgumentParser) -> None:
    """Add the flags of how ``feeder record`` starts, subscribes and stamps."""
    record.add_argument(
        "--start-paused",
        action="store_true",
        help="start paused: nothing is written until the recorder's ~/resume (or ~/toggle_paused) service "
        "is called; ~/pause pauses again, ~/is_paused tells (rosbag2_interfaces-shaped, feeder_msgs/srv)",
    )
    record.add_argument(
        "--qos-profile-overrides-path",
        metavar="YAML",
        help="subscribe to these topics with these QoS profiles instead of the publishers' (rosbag2's "
        "format: {topic: {history, depth, reliability, durability, deadline, lifespan, liveliness, "
        "liveliness_lease_duration, avoid_ros_namespace_conventions}})",
    )
    record.add_argument(
        "--use-sim-time",
        action="store_true",
        help="stamp messages with the time on /clock (cell time, as `feeder launch --real-time-factor` "
        "publishes it) instead of wall time; nothing is recorded before the first /clock message "
        "(rosbag2's --use-sim-time)",
    )


def _add_record_snapshot(record: argparse.ArgumentParser) -> None:
    """Add the flags of ``feeder record``'s snapshot mode and flight recorder."""
    record.add_argument(
        "--snapshot-mode",
        action="store_true",
        help="keep messages in a memory cache bounded by --max-cache-size and --max-cache-duration instead "
        "of writing them; the recorder's ~/snapshot service (rosbag2_interfaces' Snapshot shape, "
        "feeder_msgs/srv/Snapshot) writes the cache as a complete bag OUTPUT/snapshot_N_tSEC.MSEC and "
        "empties it. OUTPUT is then a directory of bags",
    )
    record.add_argument(
        "--max-cache-size",
        type=int,
        metavar="BYTES",
        help="snapshot cache bound: messages' bytes plus 200 bytes each of bookkeeping, so the bound holds "
        "for memory (default 104857600, rosbag2's; 0: no size bound)",
    )
    record.add_argument(
        "--max-cache-duration",
        type=finite_float,
        metavar="SECONDS",
        help="snapshot cache bound: keep only messages this much older than the newest, in log time (cell "
        "time with --use-sim-time; default 0: no time bound)",
    )
    record.add_argument(
        "--snapshot-on-fault",
        action="store_true",
        help="flight recorder (implies --snapshot-mode): when any device's ~/status "
        "(feeder_msgs/DeviceStatus) enters FAULT, write the cache before the fault and the --post-fault "
        "seconds after it as one bag, OUTPUT/<device>_fault<CODE>_t<SEC.MSEC> (the fault's cell time)",
    )
    record.add_argument(
        "--post-fault",
        type=finite_float,
        metavar="SECONDS",
        help="with --snapshot-on-fault: seconds after the fault (on the recorder's clock) kept in its bag "
        f"(default {DEFAULT_POST_FAULT:g})",
    )


def _add_record_run(record: argparse.ArgumentParser) -> None:
    """Add ``feeder record``'s node name, duration and flush interval flags."""
    record.add_argument(
        "--node-name",
        default="feeder_recorder",
        help="name of the recorder node (default feeder_recorder): its services are <name>/pause etc.",
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


def _register_info(subparsers: argparse._SubParsersAction) -> None:
    """Add ``feeder bag-info``."""
    info = subparsers.add_parser(
        "bag-info",
        help="what a bag holds, as ros2 bag info prints it",
        description="Print a bag's files, size, storage id, duration, start and end (wall time, to the "
        "nanosecond), message count, compression, and per topic its type, count, serialization format and "
        "offered QoS; service calls (<service>/_service_event topics) are listed as services with their "
        "request and response counts. A bag whose recording did not end cleanly (no metadata.yaml, or an "
        "MCAP file without its summary) is refused naming bag-reindex.",
    )
    info.add_argument("bag")
    add_json_flag(info)
    info.set_defaults(handler=_info)


def _register_reindex(subparsers: argparse._SubParsersAction) -> None:
    """Add ``feeder bag-reindex``."""
    reindex = subparsers.add_parser(
        "bag-reindex",
        help="recover a bag whose recording was killed or cut short (as ros2 bag reindex)",
        description="Scan BAG's MCAP files record by record, keep everything up to the last complete chunk "
        "and write the bag again with its MCAP summary and metadata.yaml, so that bag-info, play and other "
        "readers accept it. A complete bag is rebuilt unchanged. A split bag keeps its files (<bag>_0.mcap, "
        "<bag>_1.mcap...), each recovered on its own and listed in order; a file with nothing to recover is "
        "left out of metadata.yaml (an empty one removed, any other renamed NAME.left-out). Prints what was "
        "kept per file and topic.",
    )
    reindex.add_argument("bag")
    add_json_flag(reindex)
    reindex.set_defaults(handler=_reindex)


def _register_compare(subparsers: argparse._SubParsersAction) -> None:
    """Add ``feeder bag-compare``."""
    compare = subparsers.add_parser(
        "bag-compare",
        help="compare two bags message by message (the same lockstep run at two paces must agree)",
        description="Compare LEFT and RIGHT on every topic either recorded, message by message in log-time "
        "order and field by field (log times included), over --start..--end seconds of log time. Wall-clock "
        "topics (/rosout, /diagnostics, /parameter_events, /clock, /lockstep/*, transition events, "
        "markers and /tf, /tf_static, drawn on a wall-clock timer), a "
        "status's heartbeat copies and its wall-clock figures are left out (docs/cell.md). Exit 0 when "
        "they agree, 1 naming the first difference (topic, message, log time, field).",
    )
    compare.add_argument("left")
    compare.add_argument("right")
    compare.add_argument(
        "--start", type=finite_float, default=0.0, help="log time to start at (s, default 0)"
    )
    compare.add_argument(
        "--end", type=finite_float, help="log time to end at (s, inclusive; default: the end)"
    )
    compare.add_argument(
        "--exclude", action="append", default=[], metavar="REGEX", help="more topics to leave out"
    )
    add_json_flag(compare)
    compare.set_defaults(handler=_compare)


def _register_convert(subparsers: argparse._SubParsersAction) -> None:
    """Add ``feeder bag-convert``."""
    bag_convert = subparsers.add_parser(
        "bag-convert",
        help="merge, split, filter, cut or recompress bags (as ros2 bag convert)",
        description="Read the INPUT bags (bag directories, or single .mcap files) merged in log-time "
        "order and write each output bag of OUTPUT_OPTIONS.yaml, rosbag2's convert options: a"
        " top-level output_bags list, each with uri (required, relative to the current "
        "directory), storage_id (mcap), topic selection (all, all_topics, all_services, "
        "topics, topic_types, services, regex, exclude_topics, exclude_topic_types, "
        "exclude_services, exclude_regex or its older name exclude, include_hidden_topics), "
        "start_time_ns/end_time_ns (log time, inclusive), max_bagfile_size (bytes) and "
        "max_bagfile_duration (s) to split, compression_mode/compression_format or "
        "storage_preset_profile (MCAP chunk compression) and custom_data. Messages are copied"
        " byte for byte with their log and publish times. An unknown or mistyped option is "
        "refused naming it; outputs are never overwritten, and a failed conversion leaves "
        "none of them.",
    )
    bag_convert.add_argument(
        "inputs", nargs="*", metavar="INPUT", help="input bags (directories or .mcap files)"
    )
    bag_convert.add_argument(
        "-i",
        "--input",
        action="append",
        nargs="+",
        metavar="URI",
        help="an input as ros2 bag convert takes it (URI, then optionally its storage id mcap); repeatable",
    )
    bag_convert.add_argument(
        "-o",
        "--output-options",
        required=True,
        metavar="OUTPUT_OPTIONS.yaml",
        help="rosbag2's convert YAML (output_bags: [...])",
    )
    add_json_flag(bag_convert)
    bag_convert.set_defaults(handler=_convert)
