"""``feeder bag-plot BAG``: a picture of a recorded run's timeline (device states, throws, angles)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from feeder_cell.cli.common import add_json_flag, emit
from feeder_cell.plots.flag import plot_path
from feeder_cell.plots.paths import check_plot_path

__all__ = ["register"]

HELP = """Draw the timeline of a recorded bag into a PNG or SVG file: the devices' states (from their
~/status DeviceStatus), the throwing arm's throws (by kind) and sensor bit, the MEMS parts' angles and
the fixture's joint angles with its stability margin. Times are seconds since the recording started on
the recorder's clock; angles are degrees. A panel whose topics are not in the bag says so. Exit 2 when
the bag cannot be read (an unclosed bag: run bag-reindex) or the output name is not .png/.svg."""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add bag-plot to the feeder parser."""
    parser = subparsers.add_parser(
        "bag-plot",
        help="draw a recorded run's timeline (states, throws, sensor, angles, margin)",
        description=HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("bag", metavar="BAG", help="rosbag2 bag folder (as feeder record writes it)")
    parser.add_argument(
        "--output",
        type=plot_path,
        default=None,
        metavar="FILE",
        help="picture to write, .png or .svg (default: BAG-timeline.png beside the bag)",
    )
    add_json_flag(parser)
    parser.set_defaults(handler=_bag_plot)


def default_output(bag: Path) -> Path:
    """Return the default picture of a bag: ``<bag>-timeline.png`` beside it (the bag folder is untouched)."""
    bag = bag.resolve()
    return bag.with_name(f"{bag.name}-timeline.png")


def _bag_plot(args: argparse.Namespace) -> int:
    from feeder_cell.plots.common import write_figure
    from feeder_cell.plots.timeline import read_timeline, timeline_figure

    bag = Path(args.bag)
    timeline = read_timeline(bag)  # first: a bag that cannot be read is named before its default output
    output = args.output if args.output is not None else check_plot_path(default_output(bag), "--output")
    path = write_figure(timeline_figure(timeline, bag.resolve().name), output, "--output")
    result: dict[str, Any] = {
        "path": str(path.resolve()),
        "duration": timeline.duration,
        "panels": {
            "device states": sorted(timeline.states),
            "throwing arm": sorted({*timeline.sensor, *timeline.throws}),
            "MEMS part angles": sorted(timeline.part_angles),
            "fixture": sorted({*timeline.fixture_angles, *timeline.margin}),
        },
        "undecodable": timeline.undecodable,
    }
    emit(args, result, _summary)
    return 0


def _summary(result: dict[str, Any]) -> str:
    lines = [f"plot: {result['path']} ({result['duration']:.1f} s recorded)"]
    for panel, names in result["panels"].items():
        lines.append(f"  {panel}: {', '.join(names) if names else 'not in the bag'}")
    if result["undecodable"]:
        lines.append(f"  not decodable (another message definition): {', '.join(result['undecodable'])}")
    return "\n".join(lines)
