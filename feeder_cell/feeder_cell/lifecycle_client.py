"""Drive a managed node through its lifecycle over the standard lifecycle_msgs services.

What `ros2 lifecycle` does on a full install, for `feeder lifecycle` and `feeder launch`: every call is
bounded in time, and a refused transition says which node refused it and why (the node's own status
text when it publishes one).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Callable, Literal

from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState, GetState

from feeder_planner.errors import FeederError, InputError

__all__ = [
    "TRANSITIONS",
    "TransitionName",
    "LifecycleClient",
    "LifecycleError",
    "LifecycleInterruptedError",
    "path_to",
]

TransitionName = Literal["configure", "activate", "deactivate", "cleanup", "shutdown"]

TRANSITIONS: dict[str, int] = {
    "configure": Transition.TRANSITION_CONFIGURE,
    "activate": Transition.TRANSITION_ACTIVATE,
    "deactivate": Transition.TRANSITION_DEACTIVATE,
    "cleanup": Transition.TRANSITION_CLEANUP,
    # shutdown has one transition id per primary state; the node picks by its state
    "shutdown": Transition.TRANSITION_UNCONFIGURED_SHUTDOWN,
}
SHUTDOWN_FROM = {
    "unconfigured": Transition.TRANSITION_UNCONFIGURED_SHUTDOWN,
    "inactive": Transition.TRANSITION_INACTIVE_SHUTDOWN,
    "active": Transition.TRANSITION_ACTIVE_SHUTDOWN,
}

# A lifecycle service call: configure may load and check files (an assembly region takes about a second
# on this machine); anything slower than this is a node that does not answer.
CALL_TIMEOUT_S = 30.0

# A reply can be lost when a node answers before it has discovered the caller's reply reader (Fast DDS:
# "client will not receive response"), which a loaded machine makes likely. get_state is idempotent and
# is sent again after this long without a reply. A transition is not idempotent: after this long without
# a reply the node's state decides (``change``).
RESEND_S = 2.0

# After get_state has shown no transition ran, this long for a reply already on its way before resending.
REPLY_GRACE_S = 0.5

# The labels of the states a node is in while it runs a transition (lifecycle_msgs/State 10-15).
TRANSITION_STATES = {
    "configuring",
    "cleaningup",
    "shuttingdown",
    "activating",
    "deactivating",
    "errorprocessing",
}

# The primary state each transition leads to when it succeeds.
RESULT_OF = {
    "configure": "inactive",
    "activate": "active",
    "deactivate": "inactive",
    "cleanup": "unconfigured",
    "shutdown": "finalized",
}

# Transitions from each primary state towards a target primary state, as `feeder launch` walks them.
_FORWARD = {
    ("unconfigured", "inactive"): ["configure"],
    ("unconfigured", "active"): ["configure", "activate"],
    ("inactive", "active"): ["activate"],
    ("active", "inactive"): ["deactivate"],
    ("inactive", "unconfigured"): ["cleanup"],
    ("active", "unconfigured"): ["deactivate", "cleanup"],
}


class LifecycleError(FeederError):
    """A node refused a transition or did not answer in time."""


class LifecycleInterruptedError(LifecycleError):
    """The caller's ``keep_going`` turned false while waiting (a stop signal, the node's process gone)."""


def path_to(current: str, target: str) -> list[str]:
    """Return the transitions that take a node from primary state ``current`` to ``target``."""
    if current == target:
        return []
    try:
        return list(_FORWARD[(current, target)])
    except KeyError:
        raise InputError("lifecycle", f"no transition path from {current} to {target}") from None


@dataclass
class LifecycleClient:
    """Lifecycle services of one node, by its fully qualified name (e.g. ``/cell/feeder_a/throwing_arm``)."""

    node: Any  # the rclpy node the clients live on
    executor: Any  # spun here while waiting; None when another thread already spins the node
    target: str
    # Checked while waiting: false ends the wait at once (LifecycleInterruptedError; `feeder launch` passes
    # "no stop signal and the node's process alive", so a dead node or Ctrl-C never costs CALL_TIMEOUT_S).
    keep_going: Callable[[], bool] = field(default=lambda: True)

    def __post_init__(self) -> None:
        self._get = self.node.create_client(GetState, f"{self.target}/get_state")
        self._change = self.node.create_client(ChangeState, f"{self.target}/change_state")

    def close(self) -> None:
        """Destroy the two service clients (a long-lived node must not collect them)."""
        self.node.destroy_client(self._get)
        self.node.destroy_client(self._change)

    def is_managed(self, timeout: float = 2.0) -> bool:
        """Whether the node serves the lifecycle services (waits up to ``timeout`` for discovery)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self._get.service_is_ready():
                return True
            self._wait(0.05)
        return self._get.service_is_ready()

    def _wait(self, seconds: float) -> None:
        if not self.keep_going():
            raise LifecycleInterruptedError(
                f"{self.target}: interrupted while waiting for its lifecycle services"
            )
        if self.executor is None:
            time.sleep(seconds)
        else:
            self.executor.spin_once(timeout_sec=seconds)

    def _wait_for_service(self, client: Any, what: str) -> None:
        deadline = time.monotonic() + CALL_TIMEOUT_S
        while not client.service_is_ready():
            if time.monotonic() > deadline:
                raise LifecycleError(
                    f"{self.target}: no lifecycle service ({what}) after {CALL_TIMEOUT_S:.0f} s"
                )
            self._wait(0.05)

    def _call(self, client: Any, request: Any, what: str, resend: bool) -> Any:
        """Call and wait (bounded); with ``resend``, send again every RESEND_S until one reply arrives."""
        self._wait_for_service(client, what)
        futures = [client.call_async(request)]
        deadline = time.monotonic() + CALL_TIMEOUT_S
        next_send = time.monotonic() + RESEND_S
        while not any(f.done() for f in futures):
            now = time.monotonic()
            if now > deadline:
                raise LifecycleError(f"{self.target}: {what} not answered within {CALL_TIMEOUT_S:.0f} s")
            if resend and now > next_send:
                futures.append(client.call_async(request))
                next_send = now + RESEND_S
            self._wait(0.02)
        return next(f for f in futures if f.done()).result()

    def get_state(self) -> str:
        """Return the node's primary state label (unconfigured, inactive, active, finalized)."""
        return str(self._call(self._get, GetState.Request(), "get_state", resend=True).current_state.label)

    def change(self, transition: str) -> str:
        """Run one transition; return the new state, or raise LifecycleError saying why it was refused."""
        if transition not in TRANSITIONS:
            raise InputError("transition", f"must be one of {', '.join(TRANSITIONS)}, got {transition!r}")
        request = ChangeState.Request()
        if transition == "shutdown":
            state = self.get_state()
            request.transition.id = SHUTDOWN_FROM.get(state, Transition.TRANSITION_UNCONFIGURED_SHUTDOWN)
        else:
            request.transition.id = TRANSITIONS[transition]
        response, state = self._transition(request, transition)
        if response is None or (not response.success and state == RESULT_OF[transition]):
            # No reply, or the refusal of a copy sent again after the first had run (see _transition).
            return state
        if not response.success:
            raise LifecycleError(f"{self.target}: {transition} refused (state {state})")
        return state

    def _transition(self, request: Any, transition: str) -> tuple[Any, str]:
        """Send ``request`` until a reply or the node's state settles it; return (reply or None, state).

        A transition may not be sent twice blindly, so a reply missing after RESEND_S is settled by the
        node's state: the transition's result means it ran (the reply was lost: None is returned); a
        transition state (``configuring``) means it still runs; any other state means it has not run or
        it was refused and its reply was lost, and the request is sent again. Each lost-reply case ends in
        a reply or in the result state well within CALL_TIMEOUT_S instead of waiting it out.
        """
        self._wait_for_service(self._change, transition)
        futures = [self._change.call_async(request)]
        deadline = time.monotonic() + CALL_TIMEOUT_S
        next_check = time.monotonic() + RESEND_S
        resend_at: float | None = None
        while not any(f.done() for f in futures):
            now = time.monotonic()
            if now > deadline:
                raise LifecycleError(
                    f"{self.target}: {transition} not answered within {CALL_TIMEOUT_S:.0f} s"
                )
            if resend_at is not None and now >= resend_at:
                futures.append(self._change.call_async(request))
                resend_at, next_check = None, now + RESEND_S
            elif resend_at is None and now > next_check:
                state = self.get_state()
                if any(f.done() for f in futures):
                    break  # the node answered while get_state waited: its reply, not its state, decides
                if state == RESULT_OF[transition]:
                    return None, state
                if state in TRANSITION_STATES:
                    next_check = time.monotonic() + RESEND_S
                else:
                    # A reply sent just before get_state's may still be on its way (two writers: no order).
                    resend_at = time.monotonic() + REPLY_GRACE_S
            self._wait(0.02)
        return next(f for f in futures if f.done()).result(), self.get_state()

    def bring_to(self, target: str) -> str:
        """Walk the transitions from the present state to ``target``; return the state reached."""
        state = self.get_state()
        for transition in path_to(state, target):
            state = self.change(transition)
        return state
