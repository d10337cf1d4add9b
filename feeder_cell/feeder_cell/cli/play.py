"""``feeder play``: replay a rosbag2 MCAP bag onto live topics, with ros2 bag play's flags and services."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

from feeder_cell.cli.common import add_json_flag, emit, finite_float
from feeder_cell.ros_session import with_node
from feeder_planner.errors import InputError

if TYPE_CHECKING:
    from feeder_cell.bag.player import PlayOptions

DEFAULT_NODE_NAME = "rosbag2_player"  # as ros2 bag play names its node
DEFAULT_CLOCK_HZ = 40.0  # ros2 bag play's default --clock rate


def _summary(result: dict[str, Any]) -> str:
    lines = [f"{result['path']}: {sum(t['count'] for t in result['topics'].values())} messages"]
    lines += [f"  {name}  {t['type']}  {t['count']}" for name, t in result["topics"].items()]
    if result.get("skipped_service_events"):
        skipped = result["skipped_service_events"]
        lines.append(
            f"  skipped {len(skipped)} service-event topics ({sum(skipped.values())} messages): "
            "recorded commands are not re-issued"
        )
    return "\n".join(lines)


def _options(args: argparse.Namespace) -> PlayOptions:
    from feeder_cell.bag.player import PlayOptions, parse_remap

    remaps: dict[str, str] = {}
    for rule in args.remap or ():
        source, target = parse_remap(rule)
        if source in remaps:
            raise InputError("--remap", f"{source} is remapped twice")
        remaps[source] = target
    return PlayOptions(
        rate=args.rate,
        topics=tuple(args.topics or ()),
        wait_for_subscribers=args.wait_for_subscribers,
        clock_hz=args.clock,
        loop=args.loop,
        start_offset=args.start_offset,
        playback_duration=args.playback_duration,
        playback_until=args.playback_until,
        delay=args.delay,
        remaps=remaps,
        start_paused=args.start_paused,
        read_ahead_queue_size=args.read_ahead_queue_size,
    )


def _play(args: argparse.Namespace) -> int:
    from rclpy.validate_node_name import validate_node_name

    from feeder_cell.bag.keyboard import KeyboardControls
    from feeder_cell.bag.player import BackgroundSpin, Player, check_integrity

    path = Path(args.bag)
    if args.linger < 0:
        raise InputError("--linger", f"must be >= 0 seconds, got {args.linger}")
    try:
        validate_node_name(args.node_name)
    except Exception:  # rclpy raises its own InvalidNodeNameException, with a multi-line message
        raise InputError(
            "--node-name",
            f"{args.node_name!r:.80} is not a valid node name (letters, digits and _, no leading digit)",
        ) from None
    if not path.exists():
        raise InputError("BAG", f"{path} does not exist")
    options = _options(args)
    options.check()
    check_integrity(path)  # before any node starts: a damaged bag is one line, nothing played

    def work(node: Any, executor: Any, keep_going: Callable[[], bool]) -> dict[str, Any]:
        player = Player(node, path, options, verify=False)  # verified above
        spinning: BackgroundSpin | None = None
        try:
            if player.skipped:
                print(
                    f"feeder play: skipping {len(player.skipped)} service-event topics "
                    f"({sum(player.skipped.values())} messages; commands are not re-issued): "
                    f"{', '.join(sorted(player.skipped))}",
                    file=sys.stderr,
                )
            # The controls answer once playback is ready: a play_next sent at once then reaches the
            # subscribers --wait-for-subscribers waited for (a request sent earlier waits in the queue).
            player.wait_for_subscribers(keep_going)
            spinning = BackgroundSpin(executor)
            keyboard = KeyboardControls(player.key_action, enabled=not args.disable_keyboard_controls)
            if keyboard.active:
                print(
                    "feeder play: space pause/resume, right arrow play next (paused), up/down rate x1.1/x0.9",
                    file=sys.stderr,
                )
            with keyboard:
                counts = player.run(keep_going, wait=False)
                deadline = time.monotonic() + args.linger
                while keep_going() and time.monotonic() < deadline:
                    time.sleep(0.05)  # latched topics stay available to late subscribers for a while
            types = {c.topic: c.msgtype for c in player.connections}
            return {
                "path": str(path.resolve()),
                "topics": {t: {"type": types[t], "count": n} for t, n in sorted(counts.items())},
                "remapped": dict(options.remaps),
                "skipped_service_events": dict(sorted(player.skipped.items())),
                "loops": player.playback.loops,
            }
        finally:
            if spinning is not None:
                spinning.stop()
            player.close()

    emit(args, with_node(args.node_name, work), _summary)
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``feeder play`` to the ``feeder`` parser."""
    player = _add_parser(subparsers)
    player.add_argument("bag")
    _add_pacing_flags(player)
    _add_window_flags(player)
    _add_control_flags(player)
    add_json_flag(player)
    player.set_defaults(handler=_play)


def _add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the ``play`` subparser with its help line and the description of what replay does and serves."""
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "play",
        help="replay a bag onto live topics (as ros2 bag play)",
        description="Publish the messages of BAG at the recorded pace times --rate, with the QoS the "
        "recorded publishers offered (latched topics are replayed latched). The player is a node "
        f"(--node-name, default {DEFAULT_NODE_NAME}) serving ~/pause, ~/resume, ~/toggle_paused, "
        "~/is_paused, ~/play_next, ~/seek, ~/set_rate, ~/get_rate and ~/burst (feeder_msgs/srv types with "
        "the names and fields of rosbag2_interfaces). On a terminal: space pauses/resumes, the right arrow "
        "plays the next message while paused, up/down multiply the rate by 1.1/0.9. Service-event topics "
        "(*/_service_event) are never replayed: recorded commands are not re-issued. The whole bag is "
        "checked first: a damaged or cut one is refused naming the file, the byte offset and bag-reindex.",
    )
    return parser


def _add_pacing_flags(player: argparse.ArgumentParser) -> None:
    """Add the flags that set how fast and what is played.

    --rate, --topics, --wait-for-subscribers, --clock, --loop, in the order --help lists them.
    """
    player.add_argument(
        "--rate", type=finite_float, default=1.0, help="playback speed factor (> 0, default 1)"
    )
    player.add_argument("--topics", nargs="+", help="only these topics")
    player.add_argument(
        "--wait-for-subscribers",
        type=finite_float,
        default=0.0,
        metavar="SECONDS",
        help="before playing, wait up to SECONDS until every topic's publisher has matched a subscriber "
        "(the publisher's side: a subscriber may match a moment later; for a lossless start use "
        "--start-paused and ~/resume, docs/bags.md) (default 0: wait 0.5 s for discovery and start)",
    )
    player.add_argument(
        "--clock",
        type=finite_float,
        nargs="?",
        const=DEFAULT_CLOCK_HZ,
        metavar="HZ",
        help="publish /clock from the bag's time at HZ (default 40 when given without a value), so nodes "
        "with use_sim_time follow the replay (paused, sought, faster or slower)",
    )
    player.add_argument("--loop", action="store_true", help="play the window again and again until stopped")


def _add_window_flags(player: argparse.ArgumentParser) -> None:
    """Add the flags that cut the bag's time window and delay its start.

    --start-offset, --playback-duration, --playback-until, --delay, in the order --help lists them.
    """
    player.add_argument(
        "--start-offset",
        type=finite_float,
        default=0.0,
        metavar="SECONDS",
        help="start this many seconds after the bag's first message (>= 0)",
    )
    player.add_argument(
        "--playback-duration",
        type=finite_float,
        metavar="SECONDS",
        help="play only this many seconds of bag time from the start (> 0)",
    )
    player.add_argument(
        "--playback-until",
        type=finite_float,
        metavar="TIMESTAMP",
        help="stop at this bag time, seconds since the epoch (with --playback-duration the earlier end wins)",
    )
    player.add_argument(
        "--delay",
        type=finite_float,
        default=0.0,
        metavar="SECONDS",
        help="wait this long before playing (and before each loop), >= 0",
    )


def _add_control_flags(player: argparse.ArgumentParser) -> None:
    """Add the flags for topic names, the player node and its lifetime.

    --remap, --start-paused, --read-ahead-queue-size, --node-name, --disable-keyboard-controls,
    --linger, in the order --help lists them.
    """
    player.add_argument(
        "--remap",
        action="append",
        metavar="FROM:=TO",
        help="publish the bag's topic FROM on TO (repeat for several)",
    )
    player.add_argument(
        "--start-paused",
        action="store_true",
        help="start paused (resume with ~/resume, ~/toggle_paused or the space key)",
    )
    player.add_argument(
        "--read-ahead-queue-size",
        type=int,
        default=1000,
        metavar="N",
        help="messages read ahead of the one being played (>= 1, default 1000)",
    )
    player.add_argument(
        "--node-name",
        default=DEFAULT_NODE_NAME,
        help=f"name of the player node whose services control playback (default {DEFAULT_NODE_NAME})",
    )
    player.add_argument(
        "--disable-keyboard-controls",
        action="store_true",
        help="do not read keys even on a terminal (they are off anyway when stdin is not a terminal)",
    )
    player.add_argument(
        "--linger", type=finite_float, default=1.0, help="seconds to stay up after the last message"
    )
