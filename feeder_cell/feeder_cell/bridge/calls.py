"""Service requests in flight, never blocking the ROS thread: sent once matched, resent, failed when late.

A request waits (at most ``SERVER_WAIT``) until its server is matched, an idempotent one is sent again
every ``RESEND_S`` while unanswered, and one with no answer by its deadline fails with why. Both the
bridge's service calls (``bridge.services``) and its parameter requests (``bridge.node_parameters``)
go through here; the bridge's timer calls :meth:`ServiceCalls.check`. Everything runs on the ROS thread
(the executor's callbacks), so nothing is locked. Its own module: the call machinery assumes nothing of
what is called.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Callable

from rclpy.client import Client

__all__ = ["Done", "ServiceCalls", "SERVER_WAIT", "RESEND_S"]

SERVER_WAIT = 5.0  # s a call waits for its service's server to be matched before it fails
# s after which an idempotent request with no answer is sent again: a server drops the reply to a client
# whose reply reader it has not matched yet (DDS matches the two ends apart), so a new client's first
# request can go unanswered (a CI run: the bridge's first parameter set on a node came back empty).
RESEND_S = 1.0

# A service's answer: (its response, None) or (None, why there is none). The call machinery assumes
# nothing of the response; each caller's callback takes its own service's response type.
Done = Callable[[object, str | None], None]


@dataclass
class _Call:
    """A service request in flight: sent once its server is matched, failed at its deadline."""

    client: Client
    request: Any
    done: Done
    timeout: float
    server_deadline: float
    deadline: float
    future: Any = None
    finished: bool = False
    resend: bool = False  # an idempotent request (a parameter read, or a set of the same values)
    sent_at: float = 0.0
    sent: list[Any] = field(default_factory=list)  # every request's future, the earlier ones too


class ServiceCalls:
    """The requests in flight; :meth:`check` (on a timer) sends, resends and fails them."""

    def __init__(self) -> None:
        self._calls: list[_Call] = []

    def call(self, client: Client, request: Any, done: Done, timeout: float, resend: bool = False) -> None:
        """Call a service without blocking: ``done(response, None)`` or ``done(None, why)`` later.

        ``resend``: the request is idempotent and is sent again every RESEND_S until an answer comes.
        """
        now = time.monotonic()
        call = _Call(
            client, request, done, timeout, now + min(SERVER_WAIT, timeout), now + timeout, resend=resend
        )
        self._calls.append(call)
        self._send(call)

    def _send(self, call: _Call) -> None:
        if call.client.service_is_ready():
            call.sent_at = time.monotonic()
            future = call.client.call_async(call.request)
            call.future = future
            call.sent.append(future)
            future.add_done_callback(lambda _: self._finish(call, answered=future))

    def _finish(self, call: _Call, error: str | None = None, answered: Any = None) -> None:
        if call.finished:
            return
        if answered is not None and answered is not call.future:
            call.future = answered  # an earlier send was answered after all: its answer is as good
        for future in call.sent:  # the requests not answered are no longer waited for
            if future is not call.future or error is not None:
                call.client.remove_pending_request(future)
        call.finished = True
        self._calls.remove(call)
        if error is not None:
            call.done(None, error)
            return
        try:
            response = call.future.result()
        except Exception as failure:  # noqa: BLE001 -- whatever rclpy raised is the answer's reason
            call.done(None, f"{type(failure).__name__}: {failure}")
        else:
            call.done(response, None)

    def check(self, now: float) -> None:
        """Send the calls whose server came, resend the unanswered idempotent ones, fail the late ones."""
        for call in list(self._calls):
            if call.future is None:
                self._send(call)
                if call.future is None and now > call.server_deadline:
                    self._finish(call, f"no server of {call.client.srv_name} within {SERVER_WAIT:g} s")
            elif now > call.deadline:
                self._finish(call, f"{call.client.srv_name} did not answer within {call.timeout:g} s")
            elif call.resend and not call.future.done() and now - call.sent_at > RESEND_S:
                self._send(call)  # the earlier request stays pending: whichever is answered first counts
