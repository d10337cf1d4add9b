"""The recorder's flush thread: one turn every period until stopped, a failing disk logged, not fatal.

A thread of its own so that a message waits at most a period plus one flush's duration before it is on
disk whatever the data rate (and, in snapshot mode, fault captures close on time with no new message);
the turn itself is the recorder's (``DiskBag.flush`` or ``SnapshotMode.tick``), which takes its locks.
"""

from __future__ import annotations

import threading
from typing import Callable

__all__ = ["Flusher"]


class Flusher:
    """A daemon thread ``bag-flusher`` running ``turn`` every ``period`` seconds until :meth:`stop`."""

    def __init__(self, period: float, turn: Callable[[], None], on_error: Callable[[OSError], None]) -> None:
        self.period = period
        self.turn = turn
        self.on_error = on_error
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name="bag-flusher", daemon=True)

    def start(self) -> None:
        """Start the thread."""
        self._thread.start()

    def stop(self, timeout: float = 10.0) -> None:
        """Stop the thread and wait for its turn in progress (at most ``timeout`` seconds)."""
        self._stop.set()
        self._thread.join(timeout=timeout)

    def _loop(self) -> None:
        while not self._stop.wait(self.period):
            try:
                self.turn()
            except OSError as exc:
                # A full or failing disk: logged at each failed turn, and the next one tries again (the data
                # stays in the writer's buffer), rather than the thread dying with a traceback.
                self.on_error(exc)
