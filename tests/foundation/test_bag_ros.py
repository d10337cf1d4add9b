"""Bags: record live topics over DDS, decode them with an independent MCAP reader, replay and re-record."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

FEEDER = [sys.executable, "-m", "feeder_cell.cli.main"]
TALKER = Path(__file__).with_name("scripts") / "talker.py"


def _record(bag: Path, duration: float, topics: list[str]) -> subprocess.Popen:
    return subprocess.Popen(
        [*FEEDER, "record", str(bag), "--duration", str(duration), "--topics", *topics, "--json"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _finish(process: subprocess.Popen, timeout: float = 60.0) -> dict:
    try:
        out, err = process.communicate(timeout=timeout)
    finally:
        if process.poll() is None:
            os.kill(process.pid, signal.SIGKILL)
            process.wait()
    assert process.returncode == 0, err
    return json.loads(out)


def _decoded_strings(bag: Path, topic: str) -> list[str]:
    mcap_files = list(bag.glob("*.mcap"))
    assert len(mcap_files) == 1
    with open(mcap_files[0], "rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        return [message.data for _, channel, _, message in reader.iter_decoded_messages(topics=[topic])]


@pytest.mark.ros
def test_record_decode_replay_rerecord(ros_domain: int, tmp_path: Path) -> None:
    original, replayed = tmp_path / "original", tmp_path / "replayed"
    recorder = _record(original, 6.0, ["/talk", "/latched"])
    talker = subprocess.Popen(
        [sys.executable, str(TALKER), "30", "0.05"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        talker.wait(timeout=60)
    finally:
        if talker.poll() is None:
            os.kill(talker.pid, signal.SIGKILL)
            talker.wait()
    summary = _finish(recorder)
    assert summary["topics"]["/talk"]["count"] == 30
    assert summary["topics"]["/latched"]["count"] == 1
    assert (original / "metadata.yaml").is_file()
    # An independent reader decodes every message with the schema the bag carries.
    assert _decoded_strings(original, "/talk") == [f"msg-{i}" for i in range(30)]
    assert _decoded_strings(original, "/latched") == ["latched-hello"]

    rerecorder = _record(replayed, 8.0, ["/talk", "/latched"])
    player = subprocess.run(
        [*FEEDER, "play", str(original), "--rate", "2", "--wait-for-subscribers", "30", "--json"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert player.returncode == 0, player.stderr
    assert json.loads(player.stdout)["topics"]["/talk"]["count"] == 30
    _finish(rerecorder)
    assert _decoded_strings(replayed, "/talk") == [f"msg-{i}" for i in range(30)]
    assert _decoded_strings(replayed, "/latched") == ["latched-hello"]


def test_record_refuses_to_overwrite_and_play_names_a_bad_bag(tmp_path: Path) -> None:
    existing = tmp_path / "exists"
    existing.mkdir()
    result = subprocess.run(
        [*FEEDER, "record", str(existing), "--duration", "1"], capture_output=True, text=True, timeout=60
    )
    assert result.returncode == 2 and "already exists" in result.stderr
    result = subprocess.run([*FEEDER, "play", str(existing)], capture_output=True, text=True, timeout=60)
    assert result.returncode == 2 and "bag" in result.stderr and "Traceback" not in result.stderr
    result = subprocess.run(
        [*FEEDER, "record", str(tmp_path / "new"), "--duration", "-1"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 2 and "--duration" in result.stderr
