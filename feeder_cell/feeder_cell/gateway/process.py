"""The gateway process's set-up around its asyncio loop: the loop's thread calls and the log lines.

ROS-free; ``nodes/opcua_gateway.py`` installs both before it serves.
"""

from __future__ import annotations

import concurrent.futures
import logging
import threading
from collections.abc import Callable
from typing import Any, TypeVar

T = TypeVar("T")


class AbandonedCalls(concurrent.futures.ThreadPoolExecutor):
    """The loop's default executor: each call in a daemon thread that no close or exit waits for.

    A ThreadPoolExecutor only because asyncio accepts nothing else; its pool is never used.

    asyncua builds its address space with ``asyncio.to_thread``. With the default thread pool, a stop
    during the build waited for it twice over: ``asyncio.Runner.close`` joins the pool
    (``loop.shutdown_default_executor``), and so does the interpreter's exit.
    """

    def submit(self, fn: Callable[..., T], /, *args: Any, **kwargs: Any) -> concurrent.futures.Future[T]:
        """Start ``fn(*args, **kwargs)`` in a daemon thread of its own; the future gets its result."""
        future: concurrent.futures.Future[T] = concurrent.futures.Future()

        def call() -> None:
            if future.set_running_or_notify_cancel():
                try:
                    future.set_result(fn(*args, **kwargs))
                except BaseException as error:  # noqa: BLE001 - the caller's await raises it
                    future.set_exception(error)

        threading.Thread(target=call, name="asyncio-call", daemon=True).start()
        return future


class OneLine(logging.Filter):
    """Log asyncua's errors as their one-line message: a refused client is not a gateway traceback."""

    def filter(self, record: logging.LogRecord) -> bool:
        """Keep the record, without its traceback or stack."""
        record.exc_info, record.exc_text, record.stack_info = None, None, None
        return True


def log_to_stderr(node_name: str) -> None:
    """Python logging to stderr in ROS's line format: asyncua's errors only, the gateway's own from INFO."""
    handler = logging.StreamHandler()
    handler.setFormatter(logging.Formatter("[%(levelname)s] [%(name)s]: %(message)s"))
    handler.addFilter(OneLine())
    logging.basicConfig(level=logging.WARNING, handlers=[handler])
    # asyncua's per-request INFO and WARNING lines would flood the log; its errors stay (a refused
    # certificate, a bad login).
    for name in ("asyncua", "asyncuagds"):
        logging.getLogger(name).setLevel(logging.ERROR)
    # Every login, accepted too, is a line of the gateway's own (logins.LoginGuard).
    logging.getLogger(node_name).setLevel(logging.INFO)
