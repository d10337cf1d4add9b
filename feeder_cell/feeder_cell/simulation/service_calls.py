"""Service calls from a request's coroutine: bounded waits, reads sent again, a one-line error on silence.

A request of the simulation node awaits the clock's and the devices' answers without holding the
executor (the answer arrives through the client's callback while the request is suspended), and never
waits forever: no answer within the timeout fails with a message naming the service. Separate from
``cell_link``, which says what is called; this says how a call waits.
"""

from __future__ import annotations

import time
from typing import Any

from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.task import Future

from feeder_cell.simulation.results import OPERATION_FAILED, SimulationError

__all__ = ["READ_RESEND_S", "ServiceCalls"]

# Wall seconds a request without effect waits before it is sent again (docs/cell.md, "A fresh client's
# first request is never answered": 0.5-2 s).
READ_RESEND_S = 1.0
# Wall seconds between looks at whether a server not yet discovered has been.
DISCOVERY_LOOK_S = 0.05


class ServiceCalls:
    """Waiting on service answers and wall time, with the node's timers (steady clock) in ``group``."""

    def __init__(self, node: Node, group: ReentrantCallbackGroup, timeout_s: float) -> None:
        self.node = node
        self.group = group
        self.timeout_s = timeout_s
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)

    async def call(
        self, client: Any, request: Any, what: str, patient: bool = False, read: bool = False
    ) -> Any:
        """Call a service; raise OPERATION_FAILED naming it when it is not there or does not answer.

        ``patient``: wait as long as the server is still there (checked every ``timeout_s``), for a call
        that takes as long as the cell needs (a step of many quanta; the clock's own lockstep timeout drops
        a participant that stops answering, so the step ends).
        ``read``: the request has no effect, so it is sent again every READ_RESEND_S while unanswered, up to
        ``timeout_s``: a fresh client's first request can be answered into the void (docs/cell.md,
        Troubleshooting; measured: GetSimulationState said LOADING_WORLD 30 s after the join in 2 of 20
        launches with one process per node, a first is_paused or get_parameters to the clock unanswered).
        """
        await self._discovered(client, what)
        if read:
            deadline = time.monotonic() + self.timeout_s
            while time.monotonic() < deadline:
                future = client.call_async(request)
                if await self._within(future, READ_RESEND_S):
                    return future.result()
                client.remove_pending_request(future)
            raise SimulationError(
                OPERATION_FAILED, f"{what}: {client.srv_name} did not answer within {self.timeout_s:g} s"
            )
        future = client.call_async(request)
        while not future.done():
            if not await self._within(future, self.timeout_s) and not (patient and client.service_is_ready()):
                client.remove_pending_request(future)
                gone = " (its server went away)" if patient else ""
                raise SimulationError(
                    OPERATION_FAILED,
                    f"{what}: {client.srv_name} did not answer within {self.timeout_s:g} s{gone}",
                )
        return future.result()

    async def _discovered(self, client: Any, what: str) -> None:
        """Wait until this node has discovered the client's server, up to ``timeout_s``; else name it.

        A server that is up may not be discovered yet: on a loaded machine discovery of a new process's
        services takes seconds (ci41: a reset right after a launch with one process per node found the
        fixture's get_state undiscovered and failed at once). A server that never appears fails as late
        as one that never answers, with the same one line naming the service.
        """
        deadline = time.monotonic() + self.timeout_s
        while not client.service_is_ready():
            if time.monotonic() >= deadline:
                raise SimulationError(
                    OPERATION_FAILED,
                    f"{what}: the service {client.srv_name} is not available "
                    f"(not discovered within {self.timeout_s:g} s)",
                )
            await self.sleep(DISCOVERY_LOOK_S)

    async def sleep(self, seconds: float) -> None:
        """Wait ``seconds`` wall seconds without holding the executor."""
        await self._within(Future(), seconds)

    async def _within(self, future: Future, timeout_s: float) -> bool:
        """Wait until ``future`` is done or ``timeout_s`` wall seconds have passed; return whether done."""
        wake = Future()
        future.add_done_callback(lambda _: wake.done() or wake.set_result(True))
        timer = self.node.create_timer(
            timeout_s,
            lambda: wake.done() or wake.set_result(False),
            clock=self._steady,
            callback_group=self.group,
        )
        try:
            return bool(await wake)
        finally:
            self.node.destroy_timer(timer)
