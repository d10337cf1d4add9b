"""The one goal runner of managed devices: goals checked at goal time, one at a time, advanced by the ticks.

A device's long operations (feed a part, run a field program, follow a path) are ROS 2 actions beside the
services that start them without feedback. The goal itself is a ROS-free state machine in the device's
model package (``feeder_sim.throwing.feeding``, ``feeder_sim.mems.program_goal``,
``feeder_sim.fixture.path_goal``); the node wraps it in a ``DeviceGoal`` (messages in, messages out) and
this runner drives it. The conventions every device keeps, in one place:

- **Checked at goal time.** The goal callback asks the device whether it is ready (not FAULT, STOPPED or
  inactive) and validates the goal with the device's own check, which raises a ``FeederError`` naming the
  field. A refused goal is REJECTED at once (the client's ``accepted`` is false, nothing moved); ROS 2 has
  no field for the reason, so the device logs it at WARN on ``/rosout`` and shows the last one in its
  ``/diagnostics`` (``last_goal_rejection``).
- **One goal at a time** per action: a second goal while one executes is rejected naming the first. A
  controller that wants to preempt cancels first (hardware does not queue motion goals silently).
- **Advanced by the device's ticks.** The kit's tick calls ``advance(now_ns)`` on every executing goal
  right after the device's own ``tick``, before the tick is counted: a goal moves with the node clock (a
  held ``/clock`` holds it, lockstep runs are deterministic) and never blocks the executor. The
  ``execute`` coroutine only wakes after each tick to send feedback and the result.
- **One cancel rule.** Cancel is always accepted. The runner tells the goal (``cancel``) at its next wake:
  a tick, or a steady-clock poll every ``CANCEL_POLL`` s, so a cancel is heard under a held clock too;
  the goal ends where the device can safely stop: at once when it stands at such a point, else after
  what is in flight (the throw, the move to the next certified sample), at a later tick.
- **One timeout rule.** A goal's timeout is node-clock time from acceptance, judged by the goal's machine
  at the ticks (``declarations.deadline_ns``), never by wall time: the same run at any speed.
- **The device leaves active** (deactivate, shutdown): the runner calls ``interrupt`` so no goal outlives
  the device's activity.
- **One guard.** An exception inside a goal (its start, ``advance``, feedback or result) ends it ABORTED
  with the action's FAULT outcome and the reason in ``message``, logged at ERROR with its traceback; the
  goal's ``halt`` leaves the device safe (motion stopped), the node keeps serving, and the next goal is
  accepted.
"""

from __future__ import annotations

import traceback
from typing import TYPE_CHECKING, Any, Callable, Protocol, Sequence

from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.clock import Clock, ClockType
from rclpy.task import Future
from rclpy.timer import Timer

from feeder_planner.errors import FeederError
from feeder_planner.node_kit.qos import request_qos
from feeder_planner.node_kit.services import request_queue_depth

if TYPE_CHECKING:
    from feeder_device.device import ManagedDevice

__all__ = ["CANCEL_POLL", "DeviceGoal", "RunningGoal", "serve_goal"]

# Steady-clock period (s) at which a goal notices a cancel while the node clock is held (no ticks).
CANCEL_POLL = 0.05


class DeviceGoal(Protocol):
    """A goal in progress as the runner drives it: the node's adapter around its ROS-free machine.

    ``terminal`` is one of ``succeed``, ``canceled``, ``abort`` (the goal handle's end) with the result.
    """

    @property
    def done(self) -> bool:
        """Whether the goal has ended (its result is ready)."""
        ...

    def advance(self, now_ns: int) -> None:
        """Take in the tick at ``now_ns`` that just happened (judge, end, ask the device for more)."""
        ...

    def cancel(self, reason: str) -> None:
        """End where the device can safely stop: now if it stands at such a point, else after what flies."""
        ...

    def interrupt(self, reason: str) -> None:
        """End now: the device is no longer active (the physics is frozen)."""
        ...

    def feedback(self) -> Sequence[Any]:
        """Return the feedback messages since the last call, in order."""
        ...

    def result(self) -> tuple[str, Any]:
        """Return (terminal, result message) of the ended goal."""
        ...

    def halt(self) -> None:
        """Leave the device safe after the guard aborted the goal (stop what the goal set moving)."""
        ...


class RunningGoal:
    """One executing goal: its adapter, its handle, and the wake-up its coroutine awaits."""

    def __init__(self, device: ManagedDevice, name: str, goal: DeviceGoal, handle: ServerGoalHandle) -> None:
        self.device = device
        self.name = name
        self.goal = goal
        self.handle = handle
        self.error = ""
        self.wake: Future | None = None

    def advance_guarded(self, now_ns: int) -> None:
        """Advance the goal at a tick; a bug in it ends the goal (ABORTED), never the device's tick."""
        if self.error or self.goal.done:
            return
        try:
            self.goal.advance(now_ns)
        except Exception as error:  # noqa: BLE001 - the guard: any bug inside a goal aborts that goal
            self.fail(error)

    def fail(self, error: BaseException) -> None:
        """Record a goal's internal error (logged with its traceback) and wake its coroutine to end it."""
        self.error = f"internal error in {self.name}: {type(error).__name__}: {error}"
        trace = "".join(traceback.format_exception(error)).rstrip()
        self.device.get_logger().error(
            f"{self.error} (the goal is aborted; the device keeps serving)\n{trace}"
        )
        try:
            self.goal.halt()
        finally:
            self.poke()

    def poke(self) -> None:
        """Wake the coroutine now (a cancel under a held clock, an error)."""
        if self.wake is not None and not self.wake.done():
            self.wake.set_result(True)

    def wait(self) -> Future:
        """Return a future done after the device's next tick, on deactivation, or on a poke."""
        wake = Future()
        self.device.next_tick().add_done_callback(lambda _: wake.done() or wake.set_result(True))
        self.wake = wake
        return wake


Validate = Callable[[object], None]  # takes the action's goal request (the runner assumes nothing of it)
Start = Callable[[ServerGoalHandle], DeviceGoal]


def serve_goal(
    device: ManagedDevice, action_type: Any, name: str, validate: Validate, start: Start
) -> ActionServer:
    """Create the device's action server ``name`` (a private name such as ``~/feed_part``).

    ``validate(goal)`` raises a ``FeederError`` naming the bad field; ``start(handle)`` returns the
    ``DeviceGoal`` of an accepted goal (its request is ``handle.request``), its machine started at the
    node clock's now. The action's result
    must have the fields ``outcome``, ``outcome_name``, ``message`` and a ``FAULT`` outcome (the guard's).
    """
    callbacks = _GoalCallbacks(device, action_type, name, validate, start)
    # Goal, cancel and result requests queue as deep as the device's services (node_kit.services).
    queue = request_qos(request_queue_depth(device))
    server = ActionServer(
        device,
        action_type,
        name,
        execute_callback=callbacks.on_execute,
        goal_callback=callbacks.on_goal,
        cancel_callback=callbacks.on_cancel,
        goal_service_qos_profile=queue,
        result_service_qos_profile=queue,
        cancel_service_qos_profile=queue,
    )
    device.action_servers.append(
        server
    )  # rclpy's destroy_node leaves action servers alive: the kit ends them
    return server


class _GoalCallbacks:
    """The goal, execute and cancel callbacks of one device action, with the goal count they share."""

    def __init__(
        self, device: ManagedDevice, action_type: Any, name: str, validate: Validate, start: Start
    ) -> None:
        self.device = device
        self.action_type = action_type
        self.name = name
        self.validate = validate
        self.start = start
        # Counted from acceptance, not from execution: two goals sent together must not both be accepted.
        self.goals = 0
        # The device's tick count when the executing goal was accepted (one goal at a time).
        self.accepted_at_tick = 0

    def on_goal(self, goal: Any) -> GoalResponse:
        """Accept a goal when the device is ready, no goal executes and the goal validates; else reject it.

        A refusal is recorded on the device (WARN log, ``last_goal_rejection``): ROS 2 has no field for it.
        """
        try:
            self.device.require_ready(f"{self.name} goal")
            if self.goals:
                raise FeederError(f"{self.name} goal refused: a goal is executing; cancel it first")
            self.validate(goal)
        except FeederError as error:
            self.device.record_goal_rejection(self.name, str(error))
            return GoalResponse.REJECT
        self.goals += 1
        self.accepted_at_tick = self.device.ticks_done
        return GoalResponse.ACCEPT

    async def on_execute(self, handle: ServerGoalHandle) -> object:
        """Start the accepted goal, drive it to its end under the guard, and end its handle with its result.

        Whatever happens, the goal leaves the device's goals and the status is published before the
        handle ends (the guard's FAULT result replaces the goal's own after an internal error).
        """
        running: RunningGoal | None = None
        poll: Timer | None = None
        try:
            await self._wait_for_lockstep_start()
            running = RunningGoal(self.device, self.name, self.start(handle), handle)
            self.device.goals.append(running)
            self.device.publish_status()
            poll = self._cancel_poll(handle, running)
            terminal, result = await self._run(running)
        except Exception as error:  # noqa: BLE001 - the guard: a bug in the goal aborts only the goal
            if running is None:
                running = RunningGoal(self.device, self.name, _Failed(), handle)
            running.fail(error)
            terminal, result = "abort", None
        finally:
            self._release(running, poll)
        if running.error:
            terminal, result = "abort", _error_result(self.action_type, running.error)
        getattr(handle, terminal)()
        return result

    def on_cancel(self, goal_handle: ServerGoalHandle) -> CancelResponse:
        """Accept every cancel: the runner tells the goal at its next wake (the one cancel rule)."""
        return CancelResponse.ACCEPT

    async def _wait_for_lockstep_start(self) -> None:
        """In lockstep, wait for the device's first tick after the goal's acceptance (none elsewhere)."""
        if self.device.in_lockstep and self.device.ticks_done == self.accepted_at_tick:
            # In lockstep a goal starts after the device's first tick after its acceptance: what its
            # start publishes then belongs to a defined quantum (a recorder would otherwise take it
            # in this quantum or the next, by chance). rclpy creates this task after it has sent the
            # accept answer, so on a loaded host the next quantum's tick can come before the task
            # first runs (seen once in CI: the fixture's RUNNING status a quantum late); the tick
            # count taken at acceptance places the start the same way in both orders.
            await self.device.next_tick()

    def _cancel_poll(self, handle: ServerGoalHandle, running: RunningGoal) -> Timer | None:
        """Return the steady-clock timer that wakes a canceled goal, or None in lockstep.

        A cancel under a held clock: no tick would wake the goal. In lockstep the ticks come, and a
        cancel is taken at the next one, at a defined cell time.
        """
        if self.device.in_lockstep:
            return None
        return self.device.create_timer(
            CANCEL_POLL,
            lambda: _poke_if_canceled(handle, running),
            clock=Clock(clock_type=ClockType.STEADY_TIME),
        )

    async def _run(self, running: RunningGoal) -> tuple[str, Any]:
        """Drive the goal to its end, send its last feedback, and return (terminal, result message)."""
        await _drive(self.device, running)
        for message in running.goal.feedback():
            running.handle.publish_feedback(message)
        return ("abort", None) if running.error else running.goal.result()

    def _release(self, running: RunningGoal | None, poll: Timer | None) -> None:
        """Free the action for the next goal: count down, stop the poll, drop the goal, publish the status."""
        self.goals -= 1
        if poll is not None:
            self.device.destroy_timer(poll)
        if running is not None and running in self.device.goals:
            self.device.goals.remove(running)
        self.device.publish_status()


async def _drive(device: ManagedDevice, running: RunningGoal) -> None:
    """Wake after every tick until the goal ends: feedback out, cancel and deactivation in."""
    goal, handle = running.goal, running.handle
    canceled = False
    while not running.error:
        for message in goal.feedback():
            handle.publish_feedback(message)
        if goal.done:
            return
        if not device.active:
            goal.interrupt(
                f"device {device.state().name} (deactivated) during the goal: the physics is frozen "
                "where it was; activate it and send a new goal"
            )
            continue
        if handle.is_cancel_requested and not canceled:
            canceled = True
            try:
                goal.cancel("canceled by its client")
            except Exception as error:  # noqa: BLE001 - the guard
                running.fail(error)
            continue
        await running.wait()


def _poke_if_canceled(handle: ServerGoalHandle, running: RunningGoal | None) -> None:
    """Wake a goal whose client asked to cancel: under a held clock no tick would."""
    if handle.is_cancel_requested and running is not None:
        running.poke()


class _Failed:
    """Stand-in for a goal whose start raised: it is done, and the guard's result replaces its own."""

    done = True

    def advance(self, now_ns: int) -> None:
        """Nothing to advance."""

    def cancel(self, reason: str) -> None:
        """Nothing to cancel."""

    def interrupt(self, reason: str) -> None:
        """Nothing to interrupt."""

    def feedback(self) -> Sequence[Any]:
        """No feedback."""
        return ()

    def result(self) -> tuple[str, Any]:
        """Return nothing: the guard's result stands."""
        return "abort", None

    def halt(self) -> None:
        """Nothing moves."""


def _error_result(action_type: Any, message: str) -> Any:
    """Return the action's result for a goal the guard aborted: outcome FAULT, the reason in ``message``."""
    result = action_type.Result()
    result.outcome = action_type.Result.FAULT
    result.outcome_name = "FAULT"
    result.message = message
    return result
