"""Who drives a device's tick in lockstep: the device's side of the announcements, free of ROS.

A device ticks on a timer of its own when it runs free. Under the cell clock's lockstep the tick belongs to
whoever announces cell time: ``advance_lockstep(T)`` (``ticks.TickLoop``) runs every instant of the device's
rate grid up to T and publishes its status. It is called by

- the DDS ``Participant`` (``feeder_planner.node_kit.lockstep``) the device makes for itself
  (``make_lockstep_participant``), on every ``/lockstep/tick`` announcement, its node clock already at T;
  the same participant built in the cell host (``feeder_cell.host``) is announced by the host's hub
  instead, by a direct call;
- or a host that runs devices in one process and calls ``advance_lockstep`` itself (the device then makes
  no participant: ``feeder_device.device.hosted``), after setting each device's clock to T.

Either way the device keeps what it must know of the announcements here, in its ``LockstepDriver``: the last
time announced (before the first, the device has no cell time to stamp a status with, so it says nothing)
and what runs once at the first.
"""

from __future__ import annotations

from typing import Callable

__all__ = ["LockstepDriver"]


class LockstepDriver:
    """The announcements a lockstep device has heard: the last cell time, and what the first one starts.

    ``announce(T)`` is called by the device's ``advance_lockstep`` before it ticks: the time last announced
    again is no news (a repeated announcement ticks nothing twice), an earlier one a rewind.
    """

    def __init__(self) -> None:
        self.announced_ns = -1  # the last cell time announced (-1: none yet)
        self.rewinds = 0  # announcements earlier than the one before them
        # Called once, at the first announcement, before its ticks: what a device publishes at start-up
        # waits for it, or its stamp would depend on when the clock came.
        self.on_first: Callable[[], None] | None = None

    @property
    def started(self) -> bool:
        """Whether a cell time has been announced."""
        return self.announced_ns >= 0

    def announce(self, now_ns: int) -> bool:
        """Take in the announcement of ``now_ns``; return whether it is new (the device then ticks to it).

        A time earlier than the last is a rewind (the cell clock set back to its start): new, counted in
        ``rewinds``, so that the device moves its tick marks back before it ticks.
        """
        if now_ns == self.announced_ns:
            return False
        if now_ns < self.announced_ns:
            self.rewinds += 1
        first = not self.started
        self.announced_ns = now_ns
        if first and self.on_first is not None:
            self.on_first()
        return True
