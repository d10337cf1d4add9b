"""Lifecycle transitions and parameters: configure validates, activate starts the tick, cleanup releases.

Each transition calls the device's hook (``configure_device``, ``activate_device``, ...) between what the kit
does, and publishes the status at once. Every path out of a configured state (cleanup, a failed configure,
error, shutdown) releases the model, the streams and the counts the same way (``_release``). The
transitions publish their ``~/transition_event`` with a stamp and the transition, which rcl_lifecycle's own
notification lacks; parameters are validated at configure and at every runtime change.
"""

from __future__ import annotations

import dataclasses
import time
import traceback
from typing import Any

from lifecycle_msgs.msg import State, Transition, TransitionEvent
from rcl_interfaces.msg import SetParametersResult
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.lifecycle import LifecycleNodeMixin, LifecycleState, TransitionCallbackReturn
from rclpy.parameter import Parameter

from feeder_device.core import P
from feeder_device.faults import FaultServices
from feeder_planner.errors import FeederError, InputError
from feeder_planner.node_kit.parameters import check_value
from feeder_planner.parameter_specs import from_values

__all__ = ["LifecycleTransitions"]

RCLError = _rclpy.RCLError


class LifecycleTransitions(FaultServices[P]):
    """The lifecycle transitions, their events, the node's destruction and the parameters."""

    # --- transitions -----------------------------------------------------------------------------
    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Validate every parameter and build the model; a bad one fails the transition, naming it."""
        try:
            values = {name: self.get_parameter(name).value for name in self.specs}
            for name, spec in self.specs.items():
                check_value(spec, values[name])
            self.p = from_values(self.parameters, values)
            self.count.reset()
            self.configure_device(self.p)
            self._inject_configured_faults()
        except FeederError as error:
            self.configuration_error = f"configure failed: {error}"
            self.get_logger().error(self.configuration_error)
            self.faults.clear()
            self._release()
            self.publish_status()
            return TransitionCallbackReturn.FAILURE
        self.configuration_error = ""
        self.internal_error = ""  # a model built again: a former tick's error is gone with its model
        self.lifecycle = "inactive"
        self.publish_status()
        return TransitionCallbackReturn.SUCCESS

    def _release(self) -> None:
        """Release the device's model, then the kit's streams and counts: one path for every exit."""
        try:
            self.cleanup_device()
        finally:
            self._streams.destroy_all()
            self.count.reset()

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Start the simulation and the lifecycle publishers."""
        result = super().on_activate(state)
        self.monitor.reset()
        self.last_advance_ns = self.get_clock().now().nanoseconds  # a paused span is not simulated
        self.activate_device()
        self.lifecycle = "active"
        self._start_ticks()
        self.publish_status()
        return result

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Freeze the physics where it is; latched descriptions stay with their late-joining subscribers.

        After a tick raised (``fail_tick``) the transition ends in ERROR: rcl_lifecycle then runs the error
        path (ErrorProcessing, ``on_error``), which releases the model.
        """
        self._stop_ticks()
        self.deactivate_device()
        self.lifecycle = "inactive"
        self._wake_tick_waiters()  # a goal must not outlive the device's activity
        result = super().on_deactivate(state)
        if self.internal_error:
            return TransitionCallbackReturn.ERROR
        self.publish_status()
        return result

    def fail_tick(self, error: Exception) -> None:
        """Take the lifecycle's error path after the device's own tick raised, and say FAULT_INTERNAL.

        Like a ros2_control hardware component whose read fails: the device leaves Active through its error
        path (Deactivating, then ErrorProcessing: the model released, lifecycle Unconfigured) and its status
        says FAULT with the error, until it is configured again. Its goals end; the rest of the cell (the
        other nodes of a cell host, the clock) goes on. The traceback is logged for whoever fixes the bug.
        """
        self.internal_error = (
            f"internal error in the tick: {type(error).__name__}: {error} (the model was released; "
            "configure the device again)"
        )
        self.get_logger().error(self.internal_error)
        self.get_logger().error("".join(traceback.format_exception(error)).rstrip())
        if self.lifecycle == "active":
            self.trigger_deactivate()
        self.publish_status()

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Release the model; the node is unconfigured again."""
        self._release()
        self.faults.clear()
        self.model_fault = None
        self.stopped = False
        self.lifecycle = "unconfigured"
        self.publish_status()
        return TransitionCallbackReturn.SUCCESS

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Release everything before the node is finalized."""
        if self.lifecycle == "active":
            self._stop_ticks()
            self.deactivate_device()
        if self.lifecycle in ("active", "inactive"):
            self._release()
        self.lifecycle = "finalized"
        self._wake_tick_waiters()
        self.publish_status()
        return TransitionCallbackReturn.SUCCESS

    def on_error(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Recover from a transition that raised: log, release, back to unconfigured (the node lives on)."""
        self.get_logger().error(f"error in lifecycle state {state.label}; cleaning up")
        try:
            self._stop_ticks()
            self._release()
        finally:
            self.lifecycle = "unconfigured"
            self._wake_tick_waiters()
            self.publish_status()
        return TransitionCallbackReturn.SUCCESS

    def destroy_node(self) -> None:
        """Destroy the node with its action servers and state machine, which rclpy's destroy_node leaves.

        An action server keeps its rcl node and its DDS endpoints alive, even past ``rclpy.shutdown``: a
        device destroyed in a process that goes on would still show its actions in the graph.
        """
        if self.lockstep is not None:
            self.lockstep.leave()
        for server in self.action_servers:
            server.destroy()
        self.action_servers.clear()
        super().destroy_node()
        # Likewise the lifecycle state machine and its ~/transition_event publisher (rclpy keeps them).
        self._state_machine.destroy_when_not_in_use()

    # --- rclpy's transition machinery, with stamped events ----------------------------------------
    def _LifecycleNodeMixin__change_state(self, transition_id: int) -> TransitionCallbackReturn:  # noqa: N802
        """Run a transition as rclpy does, publishing each step's TransitionEvent with stamp and transition.

        rcl_lifecycle's notification on ``~/transition_event`` carries only the start and goal states
        (``timestamp`` 0, ``transition`` {0, ""}), so a recorded bring-up said neither when nor which
        transition. The steps are the same as rclpy's (the transition, the callback, its outcome, and on
        ERROR the error processing), each triggered without rcl's notification and published here.
        """
        callbacks = LifecycleNodeMixin._LifecycleNodeMixin__execute_callback
        initial = self._state_machine.current_state
        initial_state = LifecycleState(state_id=initial[0], label=initial[1])
        self._transition_step(transition_id=transition_id)
        code = callbacks(self, self._state_machine.current_state[0], initial_state)
        self._transition_step(label=code.to_label())
        if code == TransitionCallbackReturn.ERROR:
            error_code = callbacks(self, self._state_machine.current_state[0], initial_state)
            self._transition_step(label=error_code.to_label())
        return code

    def _transition_step(self, transition_id: int | None = None, label: str = "") -> None:
        """Trigger one transition of the state machine (by id or by label) and publish its event."""
        machine = self._state_machine
        start = machine.current_state
        taken = next(
            (
                t
                for t in machine.available_transitions
                if (t[0] == transition_id if label == "" else t[1] == label)
            ),
            None,
        )
        if transition_id is not None:
            machine.trigger_transition_by_id(transition_id, False)
        else:
            machine.trigger_transition_by_label(label, False)
        goal = machine.current_state
        event = TransitionEvent()
        # The node clock (cell time on the cell clock); wall time while a sim-time node has no /clock yet.
        now = self.get_clock().now().nanoseconds
        event.timestamp = now if now > 0 else time.time_ns()
        event.transition = Transition(
            id=taken[0] if taken else (transition_id or 0), label=taken[1] if taken else label
        )
        event.start_state = State(id=start[0], label=start[1])
        event.goal_state = State(id=goal[0], label=goal[1])
        self._transition_events.publish(event)

    def _LifecycleNodeMixin__on_change_state(self, request: Any, response: Any) -> Any:  # noqa: N802
        """Refuse a transition the present state does not have, instead of dying of it.

        rclpy's lifecycle node raises out of its ~/change_state callback for a transition id that is not
        registered in the present state (ros2/rclpy#1209, fixed upstream after the pinned Jazzy wheel),
        which ends the device's process: a controller sending ``activate`` to an unconfigured device would
        kill it. Overriding the name-mangled callback is the one place to catch it; the answer is
        ``success: false``, as for a transition named by an unknown label.
        """
        try:
            return LifecycleNodeMixin._LifecycleNodeMixin__on_change_state(self, request, response)
        except RCLError as error:
            self.get_logger().warning(
                f"change_state refused: transition {request.transition.id} "
                f"{request.transition.label!r} is not available in state {self.lifecycle}: {error}"
            )
            response.success = False
            return response

    # --- parameters ------------------------------------------------------------------------------
    def _on_set_parameters(self, changes: list[Parameter]) -> SetParametersResult:
        # Read-only parameters never reach here (rclpy refuses them by their descriptor). A runtime
        # parameter is validated, then applied at once when the device is configured; never ignored.
        for change in changes:
            spec = self.specs.get(change.name)
            if spec is None:
                continue  # rclpy's own (use_sim_time) and anything undeclared: rclpy decides
            try:
                check_value(spec, change.value)
            except InputError as error:
                return SetParametersResult(successful=False, reason=str(error))
        if self.lifecycle in ("active", "inactive"):
            for change in changes:
                if change.name in self.specs:
                    changed = self.p
                    if change.name in self.p.__dataclass_fields__:
                        changed = dataclasses.replace(self.p, **{change.name: change.value})
                    try:
                        self.apply_parameter(change.name, changed)
                    except FeederError as error:
                        return SetParametersResult(successful=False, reason=str(error))
                    self.p = changed
        return SetParametersResult(successful=True)
