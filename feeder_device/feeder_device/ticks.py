"""The tick and who drives it: the device's timer when it runs free, the cell clock's lockstep otherwise.

As in ros2_control, the kit owns the loop and the device implements one step of it (``tick(now_ns)``:
advance the model, publish). One tick (``_tick_at``) is the device's ``tick``, then the running goals
advanced at the same instant, then the tick counted for the rate monitor and the goals' coroutines woken.
What calls it depends on the mode:

- **free-running**: a timer on the node clock at the device's rate (``expect_rate``), made at activate and
  destroyed at deactivate;
- **lockstep** (parameter ``lockstep``): no timer. Whoever announces cell time T calls
  ``advance_lockstep(T)``, which ticks every instant of the rate's grid up to T, in order, each stamped with
  its own ``now_ns``, then publishes the status. That is the device's ``Participant`` (made by
  ``make_lockstep_participant``; over DDS, or through the cell host's hub) or a host that calls it
  directly (``feeder_device.drive``).

So ``tick`` must stamp with ``now_ns``, never with the clock. ``elapsed_ns(now_ns)`` is the one definition
of the node-clock time since the model last advanced.
"""

from __future__ import annotations

import time

from rclpy.clock import JumpThreshold
from rclpy.duration import Duration
from rclpy.task import Future

from feeder_device.core import P
from feeder_device.drive import LockstepDriver
from feeder_device.status import StatusReporting
from feeder_planner.node_kit.lockstep import Participant

__all__ = ["TickLoop"]


class TickLoop(StatusReporting[P]):
    """The tick, its drivers (a timer, or the lockstep's announcements), and the goals' wake-ups."""

    # --- the drivers -----------------------------------------------------------------------------
    def _join_clock(self) -> None:
        """Follow the node clock's first reading, and join the lockstep when the parameter says so."""
        threshold = JumpThreshold(
            min_forward=Duration(nanoseconds=1), min_backward=None, on_clock_change=True
        )
        self._clock_jump = self.get_clock().create_jump_callback(threshold, post_callback=self._on_clock_jump)
        if self.p.lockstep:
            self.lockstep_driver = LockstepDriver()
            self.lockstep_driver.on_first = lambda: self.publish_status(force=True)
            self.lockstep = self.make_lockstep_participant()
        self.clock_origin_ns()  # the wall clock (or a /clock already heard) starts the model now

    def make_lockstep_participant(self) -> Participant | None:
        """Return the DDS participant that announces cell time to this device, or None for a cell host.

        By default the device answers the cell clock itself: its ``Participant`` calls
        ``advance_lockstep`` on every ``/lockstep/tick``, and ``run_node`` spins through it. A device that
        a cell host drives by direct calls returns None here (``feeder_device.device.hosted``).
        """
        return Participant(self, "tick", self.advance_lockstep)

    def advance_lockstep(self, now_ns: int) -> None:
        """Take in cell time ``now_ns``: tick every instant of the rate's grid up to it, then publish status.

        The lockstep's tick phase, called by whoever announces cell time (the device's participant, or a
        cell host), the node clock already at ``now_ns``. The time last announced again ticks nothing; an
        earlier one is a rewind (``_rewind_ticks``). Before activation, or inactive, the announcement is
        taken in and nothing is ticked.
        """
        if self.lockstep_driver is None:
            raise RuntimeError(f"{self.get_name()}: advance_lockstep on a device not in lockstep")
        rewinds = self.lockstep_driver.rewinds
        if not self.lockstep_driver.announce(now_ns):
            return
        if self.lockstep_driver.rewinds != rewinds:
            self._rewind_ticks(now_ns)
        if not self.active or self._grid_origin_ns <= 0:
            return
        while self.active and (instant := self._grid_instant(self._grid_index + 1)) <= now_ns:
            self._grid_index += 1
            self._tick_at(instant)
        self.publish_status()  # what the ticks changed (counters), stamped with the quantum's time

    def _rewind_ticks(self, now_ns: int) -> None:
        """Follow the cell clock back to ``now_ns``: forget the tick marks after it, go on along the grid.

        A ResetSimulation of time reconfigures the device after the rewind (its grid then starts at
        configure, as at launch); a device left configured keeps its grid's origin unless that lies after
        the new time.
        """
        self.last_tick_due_ns = 0
        if self._grid_origin_ns > now_ns:
            self._grid_origin_ns = now_ns
        if self._grid_origin_ns > 0:
            self._grid_index = int((now_ns - self._grid_origin_ns) * self.tick_rate // 1e9)
        self.last_advance_ns = min(self.last_advance_ns, now_ns)
        self.monitor.reset()

    def _start_ticks(self) -> None:
        self._stop_ticks()
        if self.in_lockstep:
            # The grid goes on from the present time: instants while inactive are not simulated.
            now = self.get_clock().now().nanoseconds
            if self._grid_origin_ns <= 0:
                self._grid_origin_ns = now
            self._grid_index = int((now - self._grid_origin_ns) * self.tick_rate // 1e9)
            return
        self._tick_timer = self.create_timer(1.0 / self.tick_rate, self._on_tick_timer)

    def _stop_ticks(self) -> None:
        if self._tick_timer is not None:
            self.destroy_timer(self._tick_timer)
            self._tick_timer = None

    def _on_tick_timer(self) -> None:
        """One tick at the clock's present time (the free-running timer)."""
        if self.active:
            self._tick_at(self.get_clock().now().nanoseconds)

    def _grid_instant(self, index: int) -> int:
        # Rounded from the index, not accumulated: a rate whose period is no whole number of
        # nanoseconds does not drift, and every host computes the same instants.
        return self._grid_origin_ns + round(index * 1e9 / self.tick_rate)

    # --- one tick --------------------------------------------------------------------------------
    def _tick_at(self, now: int) -> None:
        """One tick: the device's model and streams, then its goals, then the tick is counted."""
        if not self.tick_due(now):
            return
        self.tick_instant_ns = now  # what a status published inside the tick is stamped with
        try:
            try:
                simulated = self.tick(now)
            except Exception as error:  # noqa: BLE001 - the guard: a bug in the model faults this device only
                self.fail_tick(error)
                return
            for goal in list(self.goals):
                goal.advance_guarded(now)
            self.record_tick(simulated)
        finally:
            self.tick_instant_ns = 0
            self.ticks_done += 1

    def fail_tick(self, error: Exception) -> None:
        """Take the error path of a tick that raised (the lifecycle's layer does: ``lifecycle.py``)."""
        raise NotImplementedError

    def tick_due(self, now_ns: int) -> bool:
        """Return whether a tick of the main stream at ``now_ns`` (node clock) should simulate and publish.

        Not while the clock has not started (0), and not at an instant already ticked or at the clock
        origin itself: rclpy fires a sim-time timer when the first /clock jumps the clock forward, and
        whether that happens depends on whether the device activated before or after the first /clock.
        A held clock must show no tick either way, or lockstep runs would differ. A clock set back
        ticks (it simulates nothing: the caller's elapsed time is clipped at zero).
        """
        reference = self.last_tick_due_ns or self.clock_origin_ns()
        if now_ns <= 0 or now_ns == reference:
            return False
        self.last_tick_due_ns = now_ns
        return True

    def record_tick(self, simulated: float | None = None) -> None:
        """Count one tick of the device's main stream for the rate and real-time-factor figures.

        The tick is over when this is called: the goals waiting in ``next_tick`` resume and read it.
        """
        clock = self.sim_seconds()
        self.monitor.tick(time.monotonic(), clock, clock if simulated is None else simulated)
        self._wake_tick_waiters()

    def expect_rate(self, rate: float) -> None:
        """Set the main stream's rate (Hz of the node clock) that status and diagnostics measure against.

        The device keeps up when it ticks at ``rate`` per second of its node clock and its simulated time
        keeps pace with that clock; under a cell clock at factor F that is F * rate ticks per wall second.
        """
        self.tick_rate = rate
        self.monitor.configure(rate, float(self.p.real_time_factor))
        self._grid_origin_ns = self.get_clock().now().nanoseconds  # the grid starts at configure
        self._grid_index = 0

    # --- the node clock --------------------------------------------------------------------------
    def _on_clock_jump(self, jump: object) -> None:
        self.clock_origin_ns()

    def clock_origin_ns(self) -> int:
        """Return the node clock's first non-zero reading (ns), or 0 while the clock has not started.

        A device whose model has no start time yet (activated before the first /clock) starts it here,
        not at its first tick: the clock may have moved on by then, and that time is the model's too.
        """
        if self.clock_start_ns == 0:
            now = self.get_clock().now().nanoseconds
            if now > 0:
                self.clock_start_ns = now
        return self.clock_start_ns

    def elapsed_ns(self, now_ns: int) -> int:
        """Return the node-clock time (ns) since the model last advanced, and advance the mark to ``now_ns``.

        Activated before the node clock started, the model starts at the clock's first reading; a clock
        set back simulates nothing (never a negative step).
        """
        if self.last_advance_ns <= 0:
            self.last_advance_ns = self.clock_origin_ns() or now_ns
        elapsed = max(0, now_ns - self.last_advance_ns)
        self.last_advance_ns = now_ns
        return elapsed

    # --- the goals' wake-ups ---------------------------------------------------------------------
    def next_tick(self) -> Future:
        """Return a future done after the device's next tick, or when it stops being active.

        The goal runner (``feeder_device.goals``) awaits it: the goal advances with the node
        clock and never blocks the executor. After waking, the goal must check ``self.active``.
        """
        waiter = Future()
        if not self.active:
            waiter.set_result(False)
        else:
            self.tick_waiters.append(waiter)
        return waiter

    def wake_goals(self) -> None:
        """Wake every executing goal's coroutine now (a goal that ended outside a tick sends its result)."""
        for goal in self.goals:
            goal.poke()

    def _wake_tick_waiters(self) -> None:
        waiters, self.tick_waiters = self.tick_waiters, []
        for waiter in waiters:
            if not waiter.done():
                waiter.set_result(self.active)
