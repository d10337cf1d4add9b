"""One connected client of the WebSocket server: what it subscribed and advertised, and its outgoing queues.

Every client has two outgoing queues: control messages (advertisements, answers, statuses), which are
never dropped, and data (message data, time), of which at most ``DATA_BACKLOG`` frames wait; when a
client reads slower than the cell publishes, its oldest data frame is dropped and it is told how many
were (a status at most every ``DROP_REPORT_PERIOD``), as the ROS foxglove_bridge does with its
message backlog. A client whose control queue passes ``CONTROL_BACKLOG`` is disconnected.

A session lives on the server's event loop only (``bridge.ws``), so nothing here is locked. Its own
module because backpressure and a client's bookkeeping are one concern, apart from serving and routing.
"""

from __future__ import annotations

import asyncio
import time
from collections import deque
from typing import Mapping

from websockets.asyncio.server import ServerConnection
from websockets.exceptions import ConnectionClosed

from feeder_cell.bridge import protocol
from feeder_cell.bridge.adverts import GraphSnapshot
from feeder_cell.bridge.protocol import LEVEL_ERROR, LEVEL_WARNING, ClientChannel

__all__ = ["Session", "DATA_BACKLOG", "CONTROL_BACKLOG", "DROP_REPORT_PERIOD"]

DATA_BACKLOG = 1024  # data frames waiting per client (foxglove_bridge's message_backlog_size default)
CONTROL_BACKLOG = 10000  # control messages waiting per client before it is cut off
DROP_REPORT_PERIOD = 5.0  # s between two "dropped" statuses to one client


class Session:
    """One connected client: what it subscribed and advertised, and its outgoing queues."""

    def __init__(self, client_id: int, ws: ServerConnection, follows_clock: bool) -> None:
        self.id = client_id
        self.ws = ws
        self.follows_clock = follows_clock
        self.subscriptions: dict[int, int] = {}  # subscription id -> channel id
        self.by_channel: dict[int, int] = {}  # channel id -> subscription id
        self.client_channels: dict[int, ClientChannel] = {}
        self.unknown_reported: set[int] = set()  # client channel ids an error was sent for (once each)
        self.parameters: set[str] = set()
        self.all_parameters = False
        self.graph: GraphSnapshot | None = None  # last snapshot sent, when subscribed to the graph
        self.control: deque[str | bytes] = deque()
        self.data: deque[bytes] = deque()
        self.wake = asyncio.Event()
        self.dropped = 0
        self.reported_drop = 0.0

    def send(self, message: Mapping[str, object] | bytes) -> None:
        """Queue a control message (never dropped; a client that lets too many wait is cut off)."""
        self.control.append(message if isinstance(message, bytes) else protocol.to_json(message))
        if len(self.control) > CONTROL_BACKLOG:
            self.control.clear()
            asyncio.get_running_loop().create_task(
                self.ws.close(1008, "client too slow: control backlog full")
            )
        self.wake.set()

    def send_data(self, frame: bytes) -> None:
        """Queue a data frame (the oldest is dropped when ``DATA_BACKLOG`` wait)."""
        if len(self.data) >= DATA_BACKLOG:
            self.data.popleft()  # the oldest: a viewer wants the newest samples
            self.dropped += 1
        self.data.append(frame)
        self.wake.set()

    def status(self, level: int, message: str) -> None:
        """Queue a status line."""
        self.send({"op": "status", "level": level, "message": message})

    def error(self, message: str) -> None:
        """Queue an error status line."""
        self.status(LEVEL_ERROR, message)

    def failure(self, service_id: int, call_id: int, message: str) -> None:
        """Queue the answer to a service call that has no response: why."""
        self.send(
            {"op": "serviceCallFailure", "serviceId": service_id, "callId": call_id, "message": message}
        )

    async def write(self) -> None:
        """Send what is queued, control first, until the connection closes."""
        try:
            while True:
                await self.wake.wait()
                self.wake.clear()
                while self.control or self.data:
                    frame = self.control.popleft() if self.control else self.data.popleft()
                    await self.ws.send(frame)
                    self._report_drops()
        except ConnectionClosed:
            pass

    def _report_drops(self) -> None:
        now = time.monotonic()
        if self.dropped and now - self.reported_drop >= DROP_REPORT_PERIOD:
            self.status(
                LEVEL_WARNING,
                f"{self.dropped} message(s) dropped: this client reads slower than the cell publishes "
                f"(at most {DATA_BACKLOG} wait)",
            )
            self.dropped, self.reported_drop = 0, now

    def wants_parameter(self, name: str) -> bool:
        """Whether the client subscribed to updates of the parameter."""
        return self.all_parameters or name in self.parameters
