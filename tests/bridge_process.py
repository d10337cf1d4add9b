"""`feeder bridge` as a child process for the bridge tests: started on a free port, ended by pid."""

from __future__ import annotations

import os
import queue
import signal
import subprocess
import sys
import tempfile
import threading
from typing import Callable

STARTUP_TIMEOUT = 30.0


class BridgeProcess:
    """`feeder bridge --port 0 ARGS` as a child process; its first stdout line says where it serves.

    ``serving`` is the start of that line's URL (loopback ws:// unless told); ``wrap`` runs the command
    elsewhere (``netns.Host.command``: another network namespace) with ``env``.
    """

    def __init__(
        self,
        *args: str,
        serving: str = "ws://127.0.0.1:",
        wrap: Callable[[list[str]], list[str]] = list,
        env: dict[str, str] | None = None,
    ) -> None:
        command = wrap([sys.executable, "-m", "feeder_cell.cli.main", "bridge", "--port", "0", *args])
        self.log = tempfile.NamedTemporaryFile("w+", prefix="feeder-bridge-", suffix=".log")  # noqa: SIM115
        self.process = subprocess.Popen(
            command, stdout=subprocess.PIPE, stderr=self.log, text=True, env=env or dict(os.environ)
        )
        lines: queue.Queue[str] = queue.Queue()
        threading.Thread(
            target=lambda: [lines.put(x) for x in self.process.stdout or []], daemon=True
        ).start()
        try:
            line = lines.get(timeout=STARTUP_TIMEOUT)
        except queue.Empty:
            self.stop()
            raise AssertionError(
                f"feeder bridge printed nothing in {STARTUP_TIMEOUT:g} s: {self.output()}"
            ) from None
        assert line.startswith(f"feeder bridge: serving {serving}"), line
        self.url = line.split()[3]

    def output(self) -> str:
        self.log.seek(0)
        return self.log.read()[-4000:]

    def stop(self) -> int:
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
            try:
                return self.process.wait(timeout=10.0)
            except subprocess.TimeoutExpired:
                self.process.kill()
        return self.process.wait(timeout=10.0)
