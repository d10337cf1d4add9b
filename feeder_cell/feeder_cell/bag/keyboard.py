"""Keyboard controls of ``feeder play`` on a terminal (the keys ``ros2 bag play`` uses).

Space pauses and resumes, the right arrow plays the next message, the up and down arrows multiply the
rate by 1.1 and 0.9.

Only a terminal gets them, and only in the foreground: with stdin a pipe, a file or /dev/null, or run as
a background job, nothing is read, so a scripted ``feeder play`` never blocks on or consumes its input.
"""

from __future__ import annotations

import os
import select
import sys
import threading
from typing import Callable, TextIO

__all__ = ["KEYS", "KeyDecoder", "KeyboardControls"]

# Key sequence -> action name (what KeyboardControls does with it).
KEYS = {
    b" ": "toggle_paused",
    b"\x1b[C": "play_next",  # right arrow
    b"\x1b[A": "faster",  # up arrow: rate x 1.1
    b"\x1b[B": "slower",  # down arrow: rate x 0.9
}
FASTER, SLOWER = 1.1, 0.9


class KeyDecoder:
    """Turn the bytes a terminal sends into action names; escape sequences may arrive in pieces."""

    def __init__(self) -> None:
        self._pending = b""

    def feed(self, data: bytes) -> list[str]:
        """Return the actions of the complete key sequences seen so far (others are ignored)."""
        actions: list[str] = []
        self._pending += data
        while self._pending:
            if self._pending[:1] != b"\x1b":
                action = KEYS.get(self._pending[:1])
                if action:
                    actions.append(action)
                self._pending = self._pending[1:]
                continue
            if len(self._pending) < 2:
                break  # wait for the rest of the sequence
            if self._pending[1:2] != b"[":
                self._pending = self._pending[1:]  # a lone escape, then another key
                continue
            if len(self._pending) < 3:
                break
            sequence, self._pending = self._pending[:3], self._pending[3:]
            action = KEYS.get(sequence)
            if action:
                actions.append(action)
        return actions


class KeyboardControls:
    """Read keys from a terminal on a thread and call ``act(action)``; does nothing for a non-terminal.

    Used as a context manager: the terminal is put in non-canonical, no-echo mode for the playback and
    restored on exit (also after an error).
    """

    def __init__(
        self, act: Callable[[str], None], stream: TextIO | None = None, enabled: bool = True
    ) -> None:
        self._act = act
        self._stream = stream if stream is not None else sys.stdin
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._saved: list | None = None
        try:
            # A background job (`feeder play ... &`) that changed its terminal's mode would be stopped
            # by SIGTTOU: only the foreground process group of a terminal reads keys.
            is_tty = self._stream.isatty() and os.tcgetpgrp(self._stream.fileno()) == os.getpgrp()
        except (AttributeError, ValueError, OSError):  # a closed or fake stream
            is_tty = False
        self.active = enabled and is_tty

    def __enter__(self) -> KeyboardControls:
        if not self.active:
            return self
        import termios
        import tty

        fd = self._stream.fileno()
        try:
            self._saved = termios.tcgetattr(fd)
            tty.setcbreak(fd)
        except termios.error:
            self.active = False  # not a real terminal after all (e.g. a pty closed under us)
            return self
        self._thread = threading.Thread(target=self._read, args=(fd,), name="play-keyboard", daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=1.0)
        if self._saved is not None:
            import termios

            termios.tcsetattr(self._stream.fileno(), termios.TCSADRAIN, self._saved)

    def _read(self, fd: int) -> None:
        decoder = KeyDecoder()
        while not self._stop.is_set():
            ready, _, _ = select.select([fd], [], [], 0.1)
            if not ready:
                continue
            data = os.read(fd, 64)
            if not data:
                return  # the terminal went away
            for action in decoder.feed(data):
                self._act(action)
