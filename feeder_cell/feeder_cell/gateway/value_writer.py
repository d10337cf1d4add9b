"""The values posted from any thread, written to the address space on the loop, and the alarms they change.

Its own module because it is the one thread hand-off of the values: ``post_all`` may be called from any
thread (the rclpy executor's); it keeps the newest value per variable under ``_lock`` and schedules one
flush on the loop (``call_soon_threadsafe``). ``_lock`` guards ``_pending``, ``_written`` and
``_scheduled`` and nothing else; ``_flush_lock`` (an asyncio lock, on the loop) lets one flush run at a
time, and ``_alarm_lock`` keeps the alarm updates in flush order outside it.
"""

from __future__ import annotations

import asyncio
import logging
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from datetime import datetime, timezone
from typing import cast

from asyncua import Server, ua

from feeder_cell.gateway import layout
from feeder_cell.gateway.alarms import Alarms
from feeder_cell.gateway.config import DeviceEntry
from feeder_cell.gateway.spec import Value
from feeder_cell.gateway.ua_casts import status_code

__all__ = ["ValueWriter"]

_UNSET = object()


@dataclass
class _Pending:
    value: Value
    stamp_ns: int


def _stamp(ns: int) -> ua.DateTime:
    stamp = datetime.fromtimestamp(ns / 1e9, tz=timezone.utc) if ns > 0 else datetime.now(timezone.utc)
    return cast(ua.DateTime, stamp)


class ValueWriter:
    """The devices' variables: pending values, their writes with source timestamps, the alarms they raise."""

    def __init__(
        self,
        devices: tuple[DeviceEntry, ...],
        types: Mapping[str, ua.VariantType],
        node_id: Callable[[str], ua.NodeId],
        log: logging.Logger,
    ) -> None:
        self.devices, self.types, self.node_id, self.log = devices, types, node_id, log
        self.server: Server | None = None  # set once it listens (GatewayServer.start), None once stopped
        self.loop: asyncio.AbstractEventLoop | None = None  # the server's loop, from its start
        self.alarms: Alarms | None = None  # made with the address space
        self._lock = threading.Lock()
        self._pending: dict[str, _Pending] = {}
        self._written: dict[str, Value] = {}
        self._scheduled = False
        self._flushing: asyncio.Task[None] | None = None
        self._flush_lock = asyncio.Lock()
        self._alarm_lock = asyncio.Lock()

    def post_all(self, key: str, values: Mapping[str, Value], stamp_ns: int = 0) -> None:
        """Set several variables of a device together (any thread): one flush writes them all.

        They are pending together under one lock, so no flush writes some of them without the others,
        and the flush writes them without yielding to the loop between them: a subscription's next
        publish carries all of their changes (Command.Busy with the state that shows the goal, say).
        """
        with self._lock:
            for path, value in values.items():
                vid = layout.variable_id(key, path)
                if self._written.get(vid, _UNSET) == value and vid not in self._pending:
                    continue
                self._pending[vid] = _Pending(value, stamp_ns)
            if self._scheduled or self.loop is None or not self._pending:
                return
            self._scheduled = True
        self.loop.call_soon_threadsafe(self._start_flush)

    async def flush_now(self) -> None:
        """Write what is pending before the caller goes on (on the loop).

        A PackML command's transient state (Clearing) must be written before the device calls that end
        it: posted only, the device's answer (Stopped) could be pending with it and replace it unseen.
        """
        await self._flush()

    def schedule(self) -> None:
        """Flush what was posted before the server listened (on the loop)."""
        with self._lock:
            if self._scheduled or not self._pending:
                return
            self._scheduled = True
        self._start_flush()

    def _start_flush(self) -> None:
        self._flushing = asyncio.ensure_future(self._flush())

    async def _flush(self) -> None:
        # One flush at a time: a second one started while the first awaits its writes would otherwise
        # write a newer value before the first writes an older one of the same variable.
        async with self._flush_lock:
            with self._lock:
                self._scheduled = False
                if self.server is None:
                    return  # not listening yet: start() flushes what is pending
                pending, self._pending = self._pending, {}
                for vid, item in pending.items():
                    self._written[vid] = item.value
                changes = self._alarm_changes(pending)
            now = cast(ua.DateTime, datetime.now(timezone.utc))
            for vid, item in pending.items():
                dv = ua.DataValue(
                    ua.Variant(item.value, self.types[vid]),
                    StatusCode=status_code(ua.StatusCodes.Good),
                    SourceTimestamp=_stamp(item.stamp_ns),
                    ServerTimestamp=now,
                )
                await self.server.write_attribute_value(self.node_id(vid), dv)
            # The alarms follow the values, in flush order, but outside the flush lock: the next values
            # are not held up by the events.
            await self._alarm_lock.acquire()
        try:
            await self._update_alarms(changes)
        finally:
            self._alarm_lock.release()

    def _alarm_changes(self, pending: Mapping[str, _Pending]) -> list[tuple[str, str, int, str]]:
        """Return (key, condition, code, text) of each device whose fault or warning changed."""
        changes = []
        for device in self.devices:
            for name in ("Fault", "Warning"):
                code_vid = layout.variable_id(device.key, f"Status.{name}Code")
                text_vid = layout.variable_id(device.key, f"Status.{name}Text")
                if code_vid not in pending and text_vid not in pending:
                    continue
                code = cast(int, self._written.get(code_vid, 0))
                text = str(self._written.get(text_vid, ""))
                changes.append((device.key, name, int(code), text))
        return changes

    async def _update_alarms(self, changes: list[tuple[str, str, int, str]]) -> None:
        """Raise or clear the devices' Fault and Warning conditions (alarms.py)."""
        if self.alarms is None:
            return
        for key, name, code, text in changes:
            try:
                await self.alarms.update(key, name, code, text)
            except Exception:  # noqa: BLE001 - an alarm's failure must not stop the values
                self.log.exception("%s: the %s alarm failed", key, name)

    def read(self, key: str, path: str) -> Value | None:
        """Return the last value set of a variable (for the handler's own bookkeeping)."""
        vid = layout.variable_id(key, path)
        with self._lock:
            if vid in self._pending:
                return self._pending[vid].value
            return self._written.get(vid)
