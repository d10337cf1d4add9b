"""Replay a rosbag2 bag onto live topics (raw CDR bytes) as a node with ros2 bag play's controls.

The node (``rosbag2_player`` by default) serves ``~/pause``, ``~/resume``, ``~/toggle_paused``,
``~/is_paused``, ``~/play_next``, ``~/seek``, ``~/set_rate``, ``~/get_rate`` and ``~/burst`` with the
feeder_msgs types that have rosbag2_interfaces' names and fields, and with ``clock_hz`` publishes
``/clock`` from the bag's time. The timing and the controls themselves are in
:mod:`feeder_cell.bag.playback` (no rclpy); this module reads the bag and adapts it to ROS.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator

from rclpy.node import Node
from rosbags.rosbag2 import Reader, ReaderError

from feeder_cell.bag.controls import serve_pause_controls
from feeder_cell.bag.playback import Item, Playback, check_rate, playback_window
from feeder_cell.bag.qos import from_bag_qos
from feeder_cell.bag.recorder import SERVICE_EVENT_SUFFIX
from feeder_cell.bag.reindex import FileReport, _scan, is_complete
from feeder_cell.bag.types import message_class
from feeder_planner.errors import InputError
from feeder_planner.node_kit.qos import request_qos

__all__ = [
    "SERVICE_EVENT_SUFFIX",
    "BackgroundSpin",
    "PlayOptions",
    "Player",
    "check_integrity",
    "open_bag",
    "parse_remap",
    "play",
]


def _reindex_hint(path: Path) -> str:
    return f"`feeder bag-reindex {path}` recovers it up to its last complete chunk"


def _one_line(text: str) -> str:
    """Collapse a multi-line library message (a YAML parser's caret drawing) into one line."""
    return " ".join(text.split())


def check_metadata_yaml(path: Path) -> None:
    """Parse the bag's ``metadata.yaml``; a damaged one is refused in one line naming its line and column.

    rosbags' own error repeats the YAML parser's multi-line message with a caret drawing; here the file,
    the line and column (1-based) and the parser's problem come on one line, with the fix.
    """
    from ruamel.yaml import YAML
    from ruamel.yaml.error import MarkedYAMLError, YAMLError

    metapath = path / "metadata.yaml"
    fix = f"`feeder bag-reindex {path}` writes it again from the MCAP files"
    try:
        text = metapath.read_bytes().decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError("bag", f"{metapath}: not UTF-8 text (byte {exc.start}); {fix}") from None
    except OSError as exc:
        raise InputError("bag", f"{metapath} cannot be read: {exc.strerror}") from None
    try:
        document = YAML(typ="safe").load(text)
    except MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = f"line {mark.line + 1} column {mark.column + 1}" if mark is not None else "somewhere"
        problem = _one_line(" ".join(p for p in (exc.context, exc.problem) if p)) or "not valid YAML"
        raise InputError("bag", f"{metapath}: {where}: {problem}; {fix}") from None
    except YAMLError as exc:
        raise InputError("bag", f"{metapath}: {_one_line(str(exc))}; {fix}") from None
    if not isinstance(document, dict) or not isinstance(document.get("rosbag2_bagfile_information"), dict):
        raise InputError("bag", f"{metapath}: line 1 column 1: no rosbag2_bagfile_information mapping; {fix}")


def open_bag(path: Path) -> Reader:
    """Open a rosbag2 MCAP bag for reading; errors name the bag, and bag-reindex where it helps.

    A bag whose recording was killed has no ``metadata.yaml``, and an MCAP file cut short (killed,
    truncated copy) has no summary: both are refused with what is wrong, never read half-way. A damaged
    ``metadata.yaml`` is refused in one line naming the YAML line and column.
    """
    if path.is_dir() and not (path / "metadata.yaml").exists() and any(path.glob("*.mcap")):
        raise InputError(
            "bag",
            f"{path} has no metadata.yaml (its recording did not end cleanly); {_reindex_hint(path)}",
        )
    incomplete = sorted(p.name for p in path.glob("*.mcap") if not is_complete(p)) if path.is_dir() else []
    if incomplete:
        raise InputError(
            "bag",
            f"{path}: {', '.join(incomplete)} ends without its MCAP summary (cut short while recording "
            f"or copying); {_reindex_hint(path)}",
        )
    if path.is_dir() and (path / "metadata.yaml").is_file():
        check_metadata_yaml(path)
    try:
        reader = Reader(path)
        reader.open()
    except Exception as exc:  # rosbags raises several error types for unreadable bags
        hint = f"; {_reindex_hint(path)}" if path.is_dir() and any(path.glob("*.mcap")) else ""
        raise InputError(
            "bag", f"{path} is not a readable rosbag2 bag: {_one_line(str(exc))}{hint}"
        ) from None
    return reader


def _first_damage(path: Path) -> tuple[Path, FileReport] | None:
    """Scan every MCAP file of the bag; return the first one that does not read to its end, and why."""
    for mcap_file in sorted(path.glob("*.mcap")) if path.is_dir() else []:
        size = mcap_file.stat().st_size
        report = FileReport(mcap_file.name, size, 0)
        try:
            with mcap_file.open("rb") as stream:
                for _ in _scan(stream, size, report):
                    pass
        except OSError as exc:
            raise InputError("bag", f"{mcap_file} cannot be read: {exc.strerror}") from None
        if not report.complete:
            return mcap_file, report
    return None


def check_integrity(path: Path) -> None:
    """Read every record of the bag's MCAP files; a damaged one is refused naming file and byte offset.

    A bag whose summary is intact can still hold a damaged chunk (a bad copy, a disk error). rosbags
    would fail only on reaching it, after part of the bag was played: reading it all first means play
    is never a silent or unannounced partial replay. Chunks are CRC-checked where the writer set one.
    A bag that :func:`open_bag` refuses (no ``metadata.yaml``, a file without its summary) is refused
    with its reason and, where a file is cut, the byte offset where the intact part ends.

    Raises
    ------
    InputError
        (field ``bag``) naming the file, the byte offset where the damage starts and bag-reindex.
    """
    damage = _first_damage(path)
    where = ""
    if damage is not None:
        mcap_file, report = damage
        where = (
            f"{mcap_file} is intact up to byte {report.recovered_bytes} of {report.size} "
            f"({report.stopped_by})"
        )
    try:
        open_bag(path).close()
    except InputError as error:
        raise InputError("bag", f"{error.problem}; {where}" if where else error.problem) from None
    if damage is not None:
        raise InputError("bag", f"{where}: it is damaged; {_reindex_hint(path)}")


def parse_remap(rule: str) -> tuple[str, str]:
    """Return (from, to) topic names of a ``--remap FROM:=TO`` rule (names made absolute)."""
    from rclpy.validate_full_topic_name import validate_full_topic_name

    source, sep, target = rule.partition(":=")
    if not sep or not source or not target:
        raise InputError("--remap", f"expected FROM:=TO, got {rule!r:.80}")
    names = tuple(name if name.startswith("/") else f"/{name}" for name in (source, target))
    for name in names:
        try:
            validate_full_topic_name(name)
        except Exception as exc:  # rclpy raises its own InvalidTopicNameException
            raise InputError("--remap", f"{name!r:.80} is not a valid topic name: {exc}") from None
    return names[0], names[1]


@dataclass
class PlayOptions:
    """What ``feeder play`` was asked for (see its --help for each field)."""

    rate: float = 1.0
    topics: tuple[str, ...] = ()
    wait_for_subscribers: float = 0.0
    clock_hz: float | None = None  # None: no /clock
    loop: bool = False
    start_offset: float = 0.0
    playback_duration: float | None = None
    playback_until: float | None = None
    delay: float = 0.0
    remaps: dict[str, str] = field(default_factory=dict)
    start_paused: bool = False
    read_ahead_queue_size: int = 1000

    def check(self) -> None:
        """Raise InputError naming the flag of the first bad value."""
        check_rate(self.rate, "--rate")
        for flag, value in (("--wait-for-subscribers", self.wait_for_subscribers), ("--delay", self.delay)):
            if not (math.isfinite(value) and value >= 0):
                raise InputError(flag, f"must be a finite number >= 0 seconds, got {value}")
        if self.clock_hz is not None and not (math.isfinite(self.clock_hz) and 0 < self.clock_hz <= 10_000):
            raise InputError("--clock", f"must be a rate in Hz, > 0 and <= 10000, got {self.clock_hz}")
        if self.read_ahead_queue_size < 1:
            raise InputError("--read-ahead-queue-size", f"must be >= 1, got {self.read_ahead_queue_size}")


class Player:
    """A bag opened for playback on ``node``: publishers, control services and (optionally) ``/clock``.

    Call :meth:`run` from one thread while the node's executor spins on another (the services and the
    clock timer are executor callbacks); :meth:`close` releases the bag. ``verify``: read the whole bag
    first (:func:`check_integrity`); False only when the caller has just done so.
    """

    def __init__(self, node: Node, path: Path, options: PlayOptions, verify: bool = True) -> None:
        options.check()
        if verify:
            check_integrity(path)
        self.node, self.path, self.options = node, path, options
        self.reader = open_bag(path)
        try:
            self._setup()
        except BaseException:
            self.reader.close()
            raise

    def _setup(self) -> None:
        options, reader, node = self.options, self.reader, self.node
        wanted = set(options.topics)
        unknown = sorted(wanted - {c.topic for c in reader.connections})
        if unknown:
            raise InputError("--topics", f"not in {self.path}: {', '.join(unknown)}")
        chosen = [c for c in reader.connections if not wanted or c.topic in wanted]
        # Topics of service introspection: replaying them would look like commands, so play never does.
        self.skipped: dict[str, int] = {
            c.topic: c.msgcount for c in chosen if c.topic.endswith(SERVICE_EVENT_SUFFIX)
        }
        self.connections = [c for c in chosen if not c.topic.endswith(SERVICE_EVENT_SUFFIX)]
        unused = sorted(set(options.remaps) - {c.topic for c in self.connections})
        if unused:
            raise InputError("--remap", f"no played topic is named {', '.join(unused)}")
        self.topic_of = {c.id: options.remaps.get(c.topic, c.topic) for c in self.connections}
        self.counts = {c.topic: 0 for c in self.connections}
        self._topic_by_id = {c.id: c.topic for c in self.connections}
        self.publishers: dict[int, Any] = {}
        for connection in self.connections:
            qos = from_bag_qos(getattr(connection.ext, "offered_qos_profiles", ()))
            # Two connections of one topic (re-subscribed with another profile) share a publisher.
            self.publishers[connection.id] = node.create_publisher(
                message_class(connection.msgtype), self.topic_of[connection.id], qos
            )
        empty = reader.message_count == 0
        bag_start = 0 if empty else reader.start_time
        bag_end = 0 if empty else reader.end_time - 1
        window = playback_window(
            bag_start, bag_end, options.start_offset, options.playback_duration, options.playback_until
        )
        self.playback = Playback(
            self._messages,
            window,
            self._publish,
            rate=options.rate,
            start_paused=options.start_paused,
            loop=options.loop,
            delay=options.delay,
            read_ahead=options.read_ahead_queue_size,
        )
        self._services()
        self.clock_pub = None
        self._started = False
        if options.clock_hz is not None:
            from rclpy.qos import QoSProfile, ReliabilityPolicy
            from rosgraph_msgs.msg import Clock

            self._clock_msg = Clock
            self.clock_pub = node.create_publisher(
                Clock, "/clock", QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
            )
            node.create_timer(1.0 / options.clock_hz, self.publish_clock)

    def _messages(self, start: int) -> Iterator[Item[int]]:
        if not self.connections:
            return
        try:
            for connection, stamp, data in self.reader.messages(connections=self.connections, start=start):
                yield Item(connection.id, stamp, data)
        except ReaderError as exc:
            raise InputError(
                "bag",
                f"{self.path} is damaged after {self.playback.published} messages: {exc}; "
                f"{_reindex_hint(self.path)}",
            ) from None

    def _publish(self, item: Item[int]) -> None:
        self.publishers[item.key].publish(bytes(item.data))
        self.counts[self._topic_by_id[item.key]] += 1

    def publish_clock(self) -> None:
        """Publish the bag time reached on /clock (a timer at ``clock_hz``; also before playback)."""
        if self.clock_pub is None:
            return
        # Until playback starts (the discovery wait) the clock holds at the window's start: it must
        # not run ahead and then jump back when playback begins.
        now = self.playback.now() if self._started else self.playback.window.start
        msg = self._clock_msg()
        msg.clock.sec, msg.clock.nanosec = divmod(now, 1_000_000_000)
        self.clock_pub.publish(msg)

    def _services(self) -> None:
        from feeder_msgs.srv import Burst, GetRate, PlayNext, Seek, SetRate

        playback, logger = self.playback, self.node.get_logger()
        # A burst of control calls (a script stepping with play_next) must not lose requests.
        qos = request_qos()

        self._controls = serve_pause_controls(
            self.node, playback.pause, playback.resume, playback.toggle_paused, playback.is_paused
        )

        def play_next(_req: Any, res: Any) -> Any:
            res.success = playback.play_next()
            return res

        def seek(req: Any, res: Any) -> Any:
            target = req.time.sec * 1_000_000_000 + req.time.nanosec
            res.success = playback.seek(target)
            if not res.success:
                window = playback.window
                logger.warning(
                    f"seek: time {target / 1e9:.9f} is outside the playback window "
                    f"{window.start / 1e9:.9f} .. {window.end / 1e9:.9f} (bag time, s); playback goes on"
                )
            return res

        def set_rate(req: Any, res: Any) -> Any:
            res.success = playback.set_rate(req.rate)
            if not res.success:
                logger.warning(f"set_rate: rate must be a finite number > 0, got {req.rate}; rate stays")
            return res

        def get_rate(_req: Any, res: Any) -> Any:
            res.rate = playback.rate()
            return res

        def burst(req: Any, res: Any) -> Any:
            res.actually_burst = playback.burst(req.num_messages)
            return res

        for srv_type, name, callback in (
            (PlayNext, "play_next", play_next),
            (Seek, "seek", seek),
            (SetRate, "set_rate", set_rate),
            (GetRate, "get_rate", get_rate),
            (Burst, "burst", burst),
        ):
            self.node.create_service(srv_type, f"~/{name}", callback, qos_profile=qos)

    def key_action(self, action: str) -> None:
        """Apply a keyboard action (see :mod:`feeder_cell.bag.keyboard`) and log what it did."""
        from feeder_cell.bag.keyboard import FASTER, SLOWER

        playback, logger = self.playback, self.node.get_logger()
        if action == "toggle_paused":
            logger.info("paused" if playback.toggle_paused() else "resumed")
        elif action == "play_next":
            if not playback.play_next():
                logger.info("play next: only while paused, and while messages are left")
        elif action in ("faster", "slower"):
            playback.set_rate(playback.rate() * (FASTER if action == "faster" else SLOWER))
            logger.info(f"rate {playback.rate():.3f}")

    def wait_for_subscribers(self, keep_going: Callable[[], bool]) -> None:
        """Wait (bounded by the option) until every publisher and /clock are matched."""
        seconds = self.options.wait_for_subscribers
        if seconds <= 0:
            time.sleep(0.5)  # DDS discovery is not instant; give existing subscribers a moment to match
            return
        # With --clock, /clock counts too: a sim-time node that has not matched it yet would sit at its
        # clock's origin through the first part of the replay and miss what happened there.
        publishers = [*self.publishers.values(), *([self.clock_pub] if self.clock_pub is not None else [])]
        deadline = time.monotonic() + seconds
        while (
            keep_going()
            and time.monotonic() < deadline
            and any(p.get_subscription_count() == 0 for p in publishers)
        ):
            time.sleep(0.05)

    def run(self, keep_going: Callable[[], bool] = lambda: True, wait: bool = True) -> dict[str, int]:
        """Play the window (every loop of it); return messages published per recorded topic.

        ``wait``: first :meth:`wait_for_subscribers` (False when the caller has just done so).
        """
        if wait:
            self.wait_for_subscribers(keep_going)
        # The start delay and the discovery wait are not part of the played time.
        self.playback.clock.jump(self.playback.window.start, self.options.delay)
        self._started = True
        # The start time on /clock before the first message: a sim-time node then never receives a
        # replayed message while its clock reads no time at all.
        self.publish_clock()
        self.playback.run(keep_going)
        return dict(self.counts)

    def close(self) -> None:
        """Release the bag."""
        self.reader.close()


def play(
    node: Node,
    path: Path,
    rate: float = 1.0,
    topics: tuple[str, ...] = (),
    keep_going: Callable[[], bool] = lambda: True,
    wait_for_subscribers: float = 0.0,
) -> dict[str, int]:
    """Publish every message of the bag once at its pace over ``rate``; returns messages per topic.

    The whole-bag form without controls, for callers that spin nothing else; ``feeder play`` uses
    :class:`Player`. ``wait_for_subscribers`` > 0: before the first message, wait up to that many seconds
    until every topic has a matched subscriber (volatile messages published earlier would reach nobody).
    """
    player = Player(
        node, path, PlayOptions(rate=rate, topics=topics, wait_for_subscribers=wait_for_subscribers)
    )
    try:
        return player.run(keep_going)
    finally:
        player.close()


class BackgroundSpin:
    """Spin an executor on a thread until :meth:`stop` (which joins it: no thread outlives the node)."""

    def __init__(self, executor: Any) -> None:
        self._executor = executor
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._spin, name="player-executor", daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        while not self._stop.is_set():
            self._executor.spin_once(timeout_sec=0.05)

    def stop(self) -> None:
        """End the spinning and wait for the thread (bounded)."""
        self._stop.set()
        self._thread.join(timeout=5.0)
