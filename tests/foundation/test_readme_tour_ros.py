"""The README's tour, run as the README writes it: a command there that stops working fails here.

The tour's fenced blocks each follow a comment that says how to run them:

- ``<!-- tour: background expect="RE" -->``: start the block in the background (a scene); it is ended
  by ``<!-- tour: end -->`` or the next background with SIGINT, as Ctrl-C would, and must then exit 0
  with RE in its output;
- ``<!-- tour: meanwhile expect="RE" -->``: run while the background runs (its first command is retried
  until the scene is up), exit 0, RE in the output;
- ``<!-- tour: server expect="RE" -->``: start beside the background, wait until it prints RE (it
  serves), exit 0 on SIGINT;
- ``<!-- tour: run expect="RE" -->``: run to its end, exit 0, RE in the output.

The tour runs in a scratch directory that links the repository's scenes and examples, so its outputs
(``bags/tour``, ``tour.png``) land there, on this session's ROS domain.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
MARKER = re.compile(r'<!-- tour: (\w+)(?: expect="([^"]*)")? -->\n(?:```bash\n(.*?)```)?', re.S)
READY_TIMEOUT_S = 90.0  # a meanwhile block's first command, retried until the scene is up
RUN_TIMEOUT_S = 300.0

pytestmark = pytest.mark.ros


@dataclass
class Step:
    kind: str
    expect: str
    script: str


def tour_steps() -> list[Step]:
    """The marked blocks of the README's tour section, in order."""
    text = (ROOT / "README.md").read_text()
    section = text.split("## A tour", 1)[1].split("\n## ", 1)[0]
    steps = [Step(m.group(1), m.group(2) or "", m.group(3) or "") for m in MARKER.finditer(section)]
    assert steps, "the README's tour has no marked blocks"
    for step in steps:
        assert step.kind in ("background", "meanwhile", "server", "run", "end"), step.kind
        assert step.kind == "end" or step.script.strip(), f"a {step.kind} marker without a bash block"
    return steps


def _start(script: str, cwd: Path) -> subprocess.Popen[str]:
    return subprocess.Popen(
        ["bash", "-c", script],
        cwd=cwd,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        start_new_session=True,  # its own process group: SIGINT reaches it as Ctrl-C would
    )


SEEN: dict[int, list[str]] = {}  # a server's output lines read so far, by pid


def _wait_for_output(process: subprocess.Popen[str], expect: str) -> None:
    """Read a server's output until a line matches ``expect`` (it serves); the rest is kept for the end."""
    seen = SEEN.setdefault(process.pid, [])
    found = threading.Event()

    def read() -> None:
        assert process.stdout is not None
        for line in process.stdout:
            seen.append(line)
            if re.search(expect, line):
                found.set()

    threading.Thread(target=read, daemon=True).start()
    if not found.wait(READY_TIMEOUT_S):
        raise AssertionError(
            f"{expect!r} not printed within {READY_TIMEOUT_S:.0f} s:\n{''.join(seen)[-3000:]}"
        )


def _interrupt(process: subprocess.Popen[str]) -> tuple[int, str]:
    if process.poll() is None:
        os.killpg(process.pid, signal.SIGINT)
    if process.pid in SEEN:  # a server: its reader thread owns the pipe
        try:
            process.wait(timeout=60)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
        time.sleep(0.2)  # the reader takes the last lines
        return int(process.returncode), "".join(SEEN.pop(process.pid))
    try:
        output, _ = process.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        output, _ = process.communicate()
        raise AssertionError(f"did not end within 60 s of SIGINT:\n{output[-3000:]}") from None
    return int(process.returncode), output


def _run(script: str, cwd: Path, retry_first: bool) -> str:
    lines = [line for line in script.splitlines() if line.strip()]
    output = ""
    for index, line in enumerate(lines):
        deadline = time.monotonic() + (READY_TIMEOUT_S if retry_first and index == 0 else 0)
        while True:
            result = subprocess.run(
                ["bash", "-c", line], cwd=cwd, capture_output=True, text=True, timeout=RUN_TIMEOUT_S
            )
            if result.returncode == 0 or time.monotonic() > deadline:
                break
            time.sleep(2.0)
        output += result.stdout + result.stderr
        assert result.returncode == 0, f"{line!r} exited {result.returncode}:\n{output[-3000:]}"
    return output


def test_the_readme_tour_runs_as_written(ros_domain: int, tmp_path: Path) -> None:
    for name in ("feeder_cell", "examples"):
        (tmp_path / name).symlink_to(ROOT / name)
    background: tuple[Step, subprocess.Popen[str]] | None = None
    servers: list[subprocess.Popen[str]] = []

    def end_background() -> None:
        nonlocal background
        for server in servers:
            alive = server.poll() is None
            code, output = _interrupt(server)
            assert alive, f"a server of the tour ended early:\n{output[-3000:]}"
            assert code == 0, f"a server of the tour exited {code} on SIGINT:\n{output[-3000:]}"
        servers.clear()
        if background is not None:
            step, process = background
            background = None
            code, output = _interrupt(process)
            assert code == 0, f"{step.script.strip()} exited {code}:\n{output[-3000:]}"
            assert re.search(step.expect, output), f"{step.expect!r} not in:\n{output[-3000:]}"

    try:
        for step in tour_steps():
            if step.kind in ("background", "end"):
                end_background()
            if step.kind == "background":
                background = (step, _start(step.script, tmp_path))
            elif step.kind == "server":
                server = _start(step.script, tmp_path)
                servers.append(server)
                _wait_for_output(server, step.expect)
            elif step.kind in ("meanwhile", "run"):
                assert (step.kind == "meanwhile") == (background is not None), f"{step.kind} {step.script}"
                output = _run(step.script, tmp_path, retry_first=step.kind == "meanwhile")
                assert re.search(step.expect, output), f"{step.expect!r} not in:\n{output[-3000:]}"
        end_background()
    finally:
        for process in [*servers, *([background[1]] if background else [])]:
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGKILL)
                process.communicate()
    assert (tmp_path / "tour.png").stat().st_size > 10_000
