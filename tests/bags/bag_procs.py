"""Shared pieces of the bag tests: processes ended by pid, graph waits, MCAP reads."""

from __future__ import annotations

import json
import os
import select
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any, Callable

from mcap.exceptions import EndOfFile
from mcap.reader import make_reader
from mcap.records import Channel, Message
from mcap.stream_reader import StreamReader

FEEDER = [sys.executable, "-m", "feeder_cell.cli.main"]
SCRIPTS = Path(__file__).with_name("scripts")


def start_script(name: str, *args: str) -> subprocess.Popen:
    """Start one of this directory's test publishers or subscribers (stdout piped, stderr discarded)."""
    return subprocess.Popen(
        [sys.executable, str(SCRIPTS / name), *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )


def wait_for_line(process: subprocess.Popen, line: str, timeout: float) -> None:
    """Wait (bounded) until the process prints ``line`` on stdout."""
    assert process.stdout is not None
    deadline = time.monotonic() + timeout
    while True:
        remaining = deadline - time.monotonic()
        assert remaining > 0, f"timed out after {timeout} s waiting for {line!r}"
        ready, _, _ = select.select([process.stdout], [], [], remaining)
        if ready:
            text = process.stdout.readline()
            assert text, f"the process ended (code {process.poll()}) before printing {line!r}"
            if text.strip() == line:
                return


def _start_feeder(
    command: str, bag: Path, args: tuple[str, ...], env: dict[str, str] | None = None
) -> subprocess.Popen:
    """Start ``feeder COMMAND BAG ARGS --json`` with stdout and stderr piped (``env``: this process's)."""
    return subprocess.Popen(
        [*FEEDER, command, str(bag), *args, "--json"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )


def start_recorder(bag: Path, *args: str, env: dict[str, str] | None = None) -> subprocess.Popen:
    """Start ``feeder record BAG ARGS --json``."""
    return _start_feeder("record", bag, args, env)


def start_player(bag: Path, *args: str) -> subprocess.Popen:
    """Start ``feeder play BAG ARGS --json``."""
    return _start_feeder("play", bag, args)


def end(process: subprocess.Popen, sig: int = signal.SIGKILL) -> None:
    """End a process by pid (a no-op if it has ended) and reap it."""
    if process.poll() is None:
        os.kill(process.pid, sig)
    try:
        process.wait(timeout=30)
    except subprocess.TimeoutExpired:
        os.kill(process.pid, signal.SIGKILL)
        process.wait()


def finish(process: subprocess.Popen, sig: int, timeout: float = 60.0) -> dict[str, Any]:
    """Send ``sig`` to a ``feeder`` process and return its JSON result; it must exit 0."""
    os.kill(process.pid, sig)
    try:
        out, err = process.communicate(timeout=timeout)
    finally:
        end(process)
    assert process.returncode == 0, err
    assert "Traceback" not in err, err
    return json.loads(out)


def wait_until(condition: Callable[[], bool], timeout: float, what: str) -> None:
    """Poll ``condition`` until it holds; fail naming ``what`` after ``timeout`` seconds."""
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, f"timed out after {timeout} s waiting for {what}"
        time.sleep(0.05)


def subscribed(client: Any, topic: str, node_name: str) -> list[Any]:
    """The subscriptions ``node_name`` has on ``topic`` (as the graph shows them, with their QoS)."""
    return [s for s in client.get_subscriptions_info_by_topic(topic) if s.node_name == node_name]


def in_graph(client: Any, node_name: str) -> bool:
    """Whether a node of that name is in the graph."""
    return node_name in client.get_node_names()


def mcap_file(bag: Path) -> Path:
    """The bag's one MCAP file."""
    files = list(bag.glob("*.mcap"))
    assert len(files) == 1, files
    return files[0]


def read_messages(bag: Path, topic: str) -> list[tuple[int, bytes]]:
    """(log time, raw CDR) of every message on ``topic``, read with the mcap package's reader."""
    with mcap_file(bag).open("rb") as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None, "the MCAP file has no summary"
        messages = [(m.log_time, m.data) for _, c, m in reader.iter_messages() if c.topic == topic]
        assert summary.statistics.message_count >= len(messages)
        return messages


def flushed_messages(bag: Path, topic: str) -> list[bytes]:
    """Raw CDR of the messages on ``topic`` already on disk in a bag still being recorded."""
    found: list[bytes] = []
    channels: dict[int, str] = {}
    if not list(bag.glob("*.mcap")):
        return found  # the recorder has not created the bag yet
    try:
        with mcap_file(bag).open("rb") as stream:
            for record in StreamReader(stream).records:
                if isinstance(record, Channel):
                    channels[record.id] = record.topic
                elif isinstance(record, Message) and channels.get(record.channel_id) == topic:
                    found.append(record.data)
    except EndOfFile:
        pass  # the end of what is on disk so far: the recording goes on
    return found


def string_data(cdr: bytes) -> str:
    """Decode a std_msgs/String from its CDR bytes."""
    length = int.from_bytes(cdr[4:8], "little")
    return cdr[8 : 8 + length - 1].decode()


def seq_and_sent(cdr: bytes) -> tuple[int, int]:
    """Decode a bag_seq_talker message (std_msgs/String "SEQ SENT_NS") from its CDR bytes."""
    seq, sent = string_data(cdr).split()
    return int(seq), int(sent)


def run_feeder(*args: str, timeout: float = 120.0) -> subprocess.CompletedProcess:
    """Run a ``feeder`` subcommand to its end."""
    return subprocess.run([*FEEDER, *args], capture_output=True, text=True, timeout=timeout)
