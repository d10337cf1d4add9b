"""``feeder play``: replay a rosbag2 MCAP bag onto live topics."""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

from feeder_cell.cli.common import add_json_flag, emit, finite_float
from feeder_cell.ros_session import with_node
from feeder_planner.errors import InputError


def _summary(result: dict[str, Any]) -> str:
    lines = [f"{result['path']}: {sum(t['count'] for t in result['topics'].values())} messages"]
    lines += [f"  {name}  {t['type']}  {t['count']}" for name, t in result["topics"].items()]
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


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``feeder play`` to the ``feeder`` parser."""
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
