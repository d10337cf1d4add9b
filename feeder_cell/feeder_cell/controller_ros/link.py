"""The controller's link to the devices: their latest status, and every bounded wait and call to them.

Every wait is bounded twice: on the node clock (``step_timeout``, so a bound scales with the cell clock's
real-time factor) and on the wall clock (``wall_timeout``, so a held ``/clock`` cannot hang it). Every wait
looks at the stop request (``stopping``) and ends the cycle with ShutdownError. In lockstep a wait for a
result lets the clock go one quantum at a time and looks again once every device has ticked it; between
quanta it runs the ``between_quanta`` hook (the fault processes' injections).
"""

from __future__ import annotations

import threading
import time
from typing import Any, Callable

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.node import Node

from feeder_cell.controller import Outcome
from feeder_msgs.msg import DeviceStatus
from feeder_planner.errors import FeederError
from feeder_planner.node_kit import LATCHED
from feeder_planner.node_kit.action_client import ActionClient
from feeder_planner.node_kit.lockstep import Participant
from feeder_planner.node_kit.runner import StopRequest

__all__ = ["POLL_S", "DeviceLink", "ShutdownError"]

POLL_S = 0.02  # wall seconds between looks at a pending future


class ShutdownError(FeederError):
    """The node is shutting down (Ctrl-C): the cycle ends where it is."""


class DeviceLink:
    """The devices as the controller sees them (``devices``: key -> node name) and its waits for them.

    Holds the node's parameters, the stop request, the lockstep participant (None unless ``lockstep``,
    attached by the node once made) and the cell time whose decisions are being made (``settled_ns``).
    """

    def __init__(
        self,
        node: Node,
        p: dict[str, Any],
        devices: dict[str, str],
        stop: StopRequest | None,
        between_quanta: Callable[[], None],
    ) -> None:
        self.node = node
        self.p = p
        self.devices = devices
        self.stop_request = stop
        self.between_quanta = between_quanta
        self.lockstep: Participant | None = None
        self.settled_ns = -1  # the last /lockstep/settled taken in
        # Latest status per device (latched: the current one arrives at once) and diagnostics values.
        self.status: dict[str, DeviceStatus] = {}
        self.diagnostics: dict[str, dict[str, str]] = {}
        for key, name in devices.items():
            node.create_subscription(DeviceStatus, f"{name}/status", self._status_callback(key), LATCHED)
        node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diagnostics, 10)

    # --- the clock and the stop request -----------------------------------------------------------
    def now(self) -> float:
        """Node-clock seconds (the cell clock under use_sim_time)."""
        return self.node.get_clock().now().nanoseconds * 1e-9

    def stopping(self) -> bool:
        """Whether a stop was requested (a signal), or the context ended under the node."""
        requested = self.stop_request is not None and self.stop_request.requested
        return requested or not rclpy.ok(context=self.node.context)

    def check_stop(self) -> None:
        """Raise ShutdownError if the node is stopping."""
        if self.stopping():
            raise ShutdownError("shutdown")

    def join_clock(self) -> bool:
        """In lockstep, wait (``wall_timeout``) for the first settled cell time; False if none came."""
        if self.lockstep is None:
            return True
        self.settled_ns = self.lockstep.wait_announcement(-1, self.p["wall_timeout"], self.stopping)
        self.check_stop()
        return self.settled_ns >= 0

    # --- bounded waits ------------------------------------------------------------------------------
    def sleep(self, seconds: float) -> None:
        """Sleep ``seconds`` of wall time, looking at the stop request every POLL_S."""
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self.check_stop()
            time.sleep(min(POLL_S, max(deadline - time.monotonic(), 0.0)))

    def wait_until(self, ready: Callable[[], bool]) -> bool:
        """Wait (``answer_timeout`` wall s) until ``ready()``, looking at the stop request every POLL_S.

        Not rclpy's wait_for_service / wait_for_server: they look only at the context, which a stop
        request leaves valid, so Ctrl-C would wait out the whole timeout.
        """
        deadline = time.monotonic() + self.p["answer_timeout"]
        while not ready():
            self.check_stop()
            if time.monotonic() > deadline:
                return ready()
            time.sleep(POLL_S)
        return True

    def wait(self, future: Any, sim_timeout: float) -> bool:
        """Wait for a future: at most ``sim_timeout`` s of node clock and ``wall_timeout`` s of wall clock.

        In lockstep the clock moves only while this waits: one quantum at a time, the future looked at
        after each (every device has ticked it by then, so the answer is seen at a defined cell time).
        """
        sim_deadline = self.now() + sim_timeout
        wall_deadline = time.monotonic() + self.p["wall_timeout"]
        while not future.done():
            self.check_stop()
            if time.monotonic() > wall_deadline or self.now() > sim_deadline:
                return False
            if self.lockstep is None:
                time.sleep(POLL_S)
                self.between_quanta()
                continue
            self.lockstep.release(self.settled_ns)
            settled = self.lockstep.wait_announcement(
                self.settled_ns, wall_deadline - time.monotonic(), self.stopping
            )
            self.check_stop()
            if settled < 0:
                return False
            self.settled_ns = settled
            self.between_quanta()
        return True

    def wait_wall(self, future: Any) -> bool:
        """Wait for a server's answer: at most ``answer_timeout`` wall s (in lockstep, within the quantum)."""
        done = threading.Event()
        future.add_done_callback(lambda _: done.set())
        deadline = time.monotonic() + self.p["answer_timeout"]
        while not done.wait(POLL_S):
            self.check_stop()
            if time.monotonic() > deadline:
                return future.done()
        return True

    # --- calls --------------------------------------------------------------------------------------
    def call(self, key: str, client: Any, request: Any) -> Any:
        """Call a device service; an answer with ok false or none in time becomes an Outcome."""
        if not self.wait_until(client.service_is_ready):
            return Outcome("NO_ANSWER", 0, f"service {client.srv_name} not available")
        future = client.call_async(request)
        if not self.wait_wall(future):
            return Outcome(
                "NO_ANSWER", 0, f"{client.srv_name} did not answer in {self.p['answer_timeout']:g} s"
            )
        response = future.result()
        if getattr(response, "ok", True):
            return response
        return self._refusal(key, f"{client.srv_name}: {response.error}")

    def action(self, key: str, client: ActionClient, action: str, goal: Any, goal_timeout: float) -> Any:
        """Send a goal and wait for its result (bounded); a rejection or no result becomes an Outcome."""
        name = f"{self.devices[key]}/{action}"
        if not self.wait_until(client.server_is_ready):
            return Outcome("NO_ANSWER", 0, f"action {name} not available")
        sent = client.send_goal_async(goal)
        if not self.wait_wall(sent):
            return Outcome("NO_ANSWER", 0, f"{name}: goal not answered in {self.p['answer_timeout']:g} s")
        handle = sent.result()
        if not handle.accepted:
            why = self.diagnostics.get(self._qualified(self.devices[key]), {}).get("last_goal_rejection", "")
            return self._refusal(key, f"{name}: goal rejected{': ' + why if why else ''}")
        result = handle.get_result_async()
        if not self.wait(result, goal_timeout + self.p["step_timeout"]):
            handle.cancel_goal_async()  # not waited on: the step has failed either way
            return Outcome("NO_ANSWER", 0, f"{name}: no result within the step's bound; goal canceled")
        return result.result().result

    def _refusal(self, key: str, message: str) -> Outcome:
        """Return a refusal as FAULT with the device's code when its status says FAULT, else as ERROR."""
        status = self.status.get(key)
        if status is not None and status.state == DeviceStatus.FAULT:
            return Outcome("FAULT", status.fault_code, f"{status.fault_text} ({message})")
        return Outcome("ERROR", 0, message)

    # --- readiness ----------------------------------------------------------------------------------
    def ready(self, key: str) -> Outcome:
        """Wait (answer_timeout, wall) until the device's status says ready; else say its state."""
        if self.wait_until(lambda: (s := self.status.get(key)) is not None and s.ready):
            return Outcome("DONE")
        status = self.status.get(key)
        if status is None:
            return Outcome("NO_ANSWER", 0, f"no status from {self.devices[key]}")
        if status.state == DeviceStatus.FAULT:
            return Outcome("FAULT", status.fault_code, f"{self.devices[key]}: {status.fault_text}")
        return Outcome(
            "ERROR", status.fault_code, f"{self.devices[key]} is {status.state_name}: {status.fault_text}"
        )

    def all_ready(self) -> Outcome:
        """Wait until every device says ready and the node clock runs; else the first problem."""
        for key in self.devices:
            outcome = self.ready(key)
            if outcome.event != "DONE":
                return outcome
        # Under use_sim_time the node clock reads 0 until the first /clock: cycle times start after.
        if not self.wait_until(lambda: self.now() > 0.0):
            return Outcome("NO_ANSWER", 0, "no /clock (use_sim_time is set)")
        return Outcome("DONE")

    # --- what the devices say -------------------------------------------------------------------------
    def _qualified(self, name: str) -> str:
        namespace = self.node.get_namespace().rstrip("/")
        return name if name.startswith("/") else f"{namespace}/{name}"

    def _status_callback(self, key: str) -> Callable[[DeviceStatus], None]:
        def on_status(msg: DeviceStatus) -> None:
            self.status[key] = msg

        return on_status

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        for status in msg.status:
            self.diagnostics[status.name] = {kv.key: kv.value for kv in status.values}
