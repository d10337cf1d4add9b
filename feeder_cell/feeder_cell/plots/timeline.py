"""The timeline of a recorded run: device states, throws and the sensor bit, MEMS part angles, fixture."""

from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from feeder_cell.plots.common import HIGHLIGHT_COLOUR, STABLE_COLOUR, edge_colour, new_figure

__all__ = [
    "STATE_NAMES",
    "PANELS",
    "Series",
    "Timeline",
    "read_timeline",
    "timeline_figure",
]

# DeviceStatus.state values (feeder_msgs/msg/DeviceStatus) and their colours in the states panel.
STATE_NAMES = ("UNCONFIGURED", "IDLE", "RUNNING", "PAUSED", "FAULT", "STOPPED")
STATE_COLOURS = ("0.8", "#56B4E9", "#009E73", "#E69F00", "#D55E00", "#000000")
THROW_KIND_COLOURS = {"jog": "#0072B2", "flip": "#CC79A7", "fault": "#D55E00"}
# Panel title -> what the bag must hold for it (said in the panel when it is missing).
PANELS = {
    "device states": "feeder_msgs/msg/DeviceStatus on */status",
    "throwing arm": "feeder_msgs/msg/ThrowEvent on */throw_events, std_msgs/msg/Bool on */sensor",
    "MEMS part angles": "feeder_msgs/msg/MemsPartStates on */part_states",
    "fixture": "sensor_msgs/msg/JointState on *fixture*/joint_states, feeder_msgs/msg/StabilityStatus",
}


@dataclass
class Series:
    """Samples of one quantity: times (s since the bag's start) and values."""

    t: list[float] = field(default_factory=list)
    v: list[float] = field(default_factory=list)

    def add(self, t: float, v: float) -> None:
        """Append one sample."""
        self.t.append(t)
        self.v.append(v)


@dataclass
class Timeline:
    """What a bag says over time, per panel; empty dicts are panels the bag has no topic for.

    Times are seconds of the recorder's clock since the bag's first message; angles are radians.
    """

    duration: float = 0.0
    states: dict[str, Series] = field(default_factory=dict)  # device -> DeviceStatus.state
    sensor: dict[str, Series] = field(default_factory=dict)  # topic -> sensor bit (0/1)
    throws: dict[str, list[tuple[float, str]]] = field(default_factory=dict)  # topic -> (time, kind)
    part_angles: dict[str, Series] = field(default_factory=dict)  # MEMS part name -> theta
    fixture_angles: dict[str, Series] = field(default_factory=dict)  # joint name -> position
    margin: dict[str, Series] = field(default_factory=dict)  # topic -> StabilityStatus.margin
    undecodable: list[str] = field(default_factory=list)  # topics recorded with another message layout


def _device(topic: str) -> str:
    """Return the node name of a device topic (/cell/throwing_arm/status -> throwing_arm)."""
    parts = [p for p in topic.split("/") if p]
    return parts[-2] if len(parts) >= 2 else topic


def read_timeline(path: Path) -> Timeline:
    """Read the timeline's topics of a rosbag2 bag (others are skipped unread).

    Raises
    ------
    InputError
        (field ``bag``) when the bag cannot be read (``open_bag`` says why, and when bag-reindex helps).
    """
    from rclpy.serialization import deserialize_message

    from feeder_cell.bag.player import open_bag
    from feeder_cell.bag.types import message_class

    wanted = {
        "feeder_msgs/msg/DeviceStatus",
        "feeder_msgs/msg/ThrowEvent",
        "feeder_msgs/msg/MemsPartStates",
        "feeder_msgs/msg/StabilityStatus",
    }
    timeline = Timeline()
    reader = open_bag(Path(path))
    try:
        connections = [
            c
            for c in reader.connections
            if c.msgtype in wanted
            or (c.msgtype == "std_msgs/msg/Bool" and c.topic.endswith("/sensor"))
            or (c.msgtype == "sensor_msgs/msg/JointState" and "fixture" in _device(c.topic))
        ]
        start = reader.start_time if reader.message_count else 0
        timeline.duration = (reader.end_time - start) / 1e9 if reader.message_count else 0.0
        series: dict[str, dict[str, Series]] = defaultdict(lambda: defaultdict(Series))
        throws: dict[str, list[tuple[float, str]]] = defaultdict(list)
        bad: set[str] = set()
        for connection, stamp, raw in reader.messages(connections=connections):
            if connection.topic in bad:
                continue
            t = (stamp - start) / 1e9
            # rclpy's own decoder: the bytes are what rclpy published (rosbags' stricter CDR reader refuses
            # some of them, e.g. trailing padding after an empty array).
            try:
                msg = deserialize_message(raw, message_class(connection.msgtype))
            except Exception:  # a bag recorded before the message changed: skip the topic, say so
                bad.add(connection.topic)
                continue
            kind = connection.msgtype
            if kind == "feeder_msgs/msg/DeviceStatus":
                series["states"][_device(connection.topic)].add(t, msg.state)
            elif kind == "feeder_msgs/msg/ThrowEvent":
                throws[connection.topic].append((t, msg.kind))
            elif kind == "std_msgs/msg/Bool":
                series["sensor"][connection.topic].add(t, float(msg.data))
            elif kind == "feeder_msgs/msg/MemsPartStates":
                for part in msg.parts:
                    series["part_angles"][part.name].add(t, part.theta)
            elif kind == "feeder_msgs/msg/StabilityStatus":
                series["margin"][connection.topic].add(t, msg.margin)
            else:
                for name, position in zip(msg.name, msg.position, strict=False):
                    series["fixture_angles"][name].add(t, position)
    finally:
        reader.close()
    for name in ("states", "sensor", "part_angles", "fixture_angles", "margin"):
        setattr(timeline, name, dict(series[name]))
    timeline.throws = dict(throws)
    timeline.undecodable = sorted(bad)
    return timeline


def _missing(ax: Axes, panel: str) -> None:
    """Say in the panel that the bag has nothing for it."""
    ax.text(
        0.5,
        0.5,
        f"no {panel} in this bag (needs {PANELS[panel]})",
        ha="center",
        va="center",
        transform=ax.transAxes,
        color="0.35",
        fontsize="small",
        gid="missing",
    )
    ax.set_yticks([])


def _states(ax: Axes, timeline: Timeline) -> None:
    """One row per device, coloured by its state from each status message to the next."""
    devices = sorted(timeline.states)
    for row, device in enumerate(devices):
        s = timeline.states[device]
        ends = [*s.t[1:], max(timeline.duration, s.t[-1])]
        bars = [(t0, max(t1 - t0, 0.0)) for t0, t1 in zip(s.t, ends, strict=True)]
        colours = [STATE_COLOURS[int(v)] if 0 <= int(v) < len(STATE_COLOURS) else "w" for v in s.v]
        ax.broken_barh(bars, (row - 0.4, 0.8), facecolors=colours, gid=f"states {device}")
    ax.set_yticks(range(len(devices)), devices)
    ax.set_ylim(-0.6, len(devices) - 0.4)
    handles = [ax.bar(0, 0, color=c, label=n) for n, c in zip(STATE_NAMES, STATE_COLOURS, strict=True)]
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize="x-small")


def _throwing(ax: Axes, timeline: Timeline) -> None:
    """Draw the sensor bit as a step line, and each throw as a tick coloured by its kind."""
    for index, (topic, s) in enumerate(sorted(timeline.sensor.items())):
        ax.step(s.t, s.v, where="post", color=edge_colour(index), lw=1, label=f"sensor {_device(topic)}")
    for events in timeline.throws.values():
        for kind, colour in THROW_KIND_COLOURS.items():
            times = [t for t, k in events if k == kind]
            if times:
                ax.plot(
                    times,
                    [1.25] * len(times),
                    ls="none",
                    marker="v",
                    color=colour,
                    label=f"{kind} ({len(times)})",
                )
    ax.set_ylim(-0.15, 1.45)
    ax.set_yticks([0, 1], ["0", "1"])
    ax.set_ylabel("sensor bit")
    ax.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize="x-small")


def _lines(ax: Axes, data: dict[str, Series], degrees: bool, label: str) -> None:
    """One line per series (angles drawn in degrees)."""
    for index, (name, s) in enumerate(sorted(data.items())):
        values = np.degrees(s.v) if degrees else np.asarray(s.v)
        ax.plot(s.t, values, color=edge_colour(index), lw=1, label=name)
    ax.set_ylabel(label)


def timeline_figure(timeline: Timeline, title: str = "recorded run") -> Figure:
    """Return the timeline of a recorded run, one panel per device kind, on a shared time axis.

    Parameters
    ----------
    timeline
        What ``read_timeline`` returned.
    title
        The figure's title (e.g. the bag's name).

    Returns
    -------
    Figure
        Four panels, titled by PANELS' keys: device states (one bar row per device, gid ``states NAME``),
        the throwing arm (sensor bit, throws by kind), the MEMS part angles (deg), the fixture's joint angles
        (deg) with the stability margin (deg, right axis). A panel whose topics are not in the bag says so
        (a text with gid ``missing``).
    """
    figure = new_figure((9.0, 9.0))
    axes = figure.subplots(4, 1, sharex=True)
    note = f"\nnot decodable (recorded with another message definition): {', '.join(timeline.undecodable)}"
    figure.suptitle(f"{title}: {timeline.duration:.1f} s recorded" + (note if timeline.undecodable else ""))
    for ax, panel in zip(axes, PANELS, strict=True):
        ax.set_title(panel, fontsize="medium", loc="left")
    if timeline.states:
        _states(axes[0], timeline)
    else:
        _missing(axes[0], "device states")
    if timeline.sensor or timeline.throws:
        _throwing(axes[1], timeline)
    else:
        _missing(axes[1], "throwing arm")
    if timeline.part_angles:
        _lines(axes[2], timeline.part_angles, True, "theta (deg)")
        axes[2].legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize="x-small")
    else:
        _missing(axes[2], "MEMS part angles")
    if timeline.fixture_angles or timeline.margin:
        _lines(axes[3], timeline.fixture_angles, True, "joint angle (deg)")
        handles, labels = axes[3].get_legend_handles_labels()
        if timeline.margin:
            right = axes[3].twinx()
            for s in timeline.margin.values():
                right.plot(
                    s.t, np.degrees(s.v), color=HIGHLIGHT_COLOUR, lw=1, ls="--", label="stability margin"
                )
            right.axhline(0.0, color=STABLE_COLOUR, lw=0.6, ls=":")
            right.set_ylabel("margin (deg)")
            more, names = right.get_legend_handles_labels()
            handles, labels = handles + more, labels + names
        axes[3].legend(handles, labels, loc="upper left", bbox_to_anchor=(1.08, 1.0), fontsize="x-small")
    else:
        _missing(axes[3], "fixture")
    axes[-1].set_xlabel("time since the recording started (s, recorder's clock)")
    axes[-1].set_xlim(0, max(timeline.duration, math.ulp(1.0)))
    return figure
