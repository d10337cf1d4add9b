"""The hand-off from the asyncio loop to the rclpy executor's thread, and back, bounded by call_timeout.

Its own module because every method call of the gateway crosses it and nothing else does: rclpy's
objects are touched only in the executor's thread (its action client is not thread-safe), so a coroutine
on the loop hands its work to the executor (``Executor.create_task`` is thread-safe) and awaits the
result, which comes back by ``call_soon_threadsafe``. It holds no lock and no state but its settings.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from typing import Coroutine, TypeVar

from rclpy.executors import Executor
from rclpy.task import Task

__all__ = ["InRos"]

T = TypeVar("T")


class InRos:
    """Runs functions and coroutines in the rclpy executor's thread for a coroutine on the loop."""

    def __init__(self, executor: Executor, call_timeout: float) -> None:
        self.executor = executor
        self.call_timeout = call_timeout

    async def answer(self, work: Coroutine[object, None, tuple[str, str]]) -> tuple[str, str]:
        """Run a coroutine in the rclpy executor's thread; its result, or BadTimeout after call_timeout."""
        try:
            return await self.value(work)
        except asyncio.TimeoutError:
            return "BadTimeout", f"the device did not answer within {self.call_timeout:g} s"

    async def value(self, work: Callable[[], T] | Coroutine[object, None, T]) -> T:
        """Run a function or coroutine in the executor's thread; asyncio.TimeoutError after call_timeout.

        rclpy's objects are touched only there: its action client is not thread-safe.
        """
        loop = asyncio.get_running_loop()
        done: asyncio.Future[T] = loop.create_future()

        def finished(task: Task) -> None:
            def settle() -> None:
                if done.done():
                    return
                error = task.exception()
                if error is not None:
                    done.set_exception(error)
                else:
                    done.set_result(task.result())

            loop.call_soon_threadsafe(settle)

        self.executor.create_task(work).add_done_callback(finished)
        return await asyncio.wait_for(done, self.call_timeout)
