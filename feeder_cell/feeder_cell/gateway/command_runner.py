"""The PackML commands run on a device: the plan for its state, its service calls, the transient state shown.

What each command does in each state is data (``commands.COMMANDS``, ``commands.plan``); this module runs
a plan: it waits for the calls' services to be discovered, shows the transient state (Clearing), makes
the calls in the executor's thread (``in_ros``) and cancels the gateway's goal when the command halts the
device. It reads the ``DeviceLink`` under the link's lock only.
"""

from __future__ import annotations

import asyncio

from lifecycle_msgs.srv import ChangeState
from rclpy.action.client import ClientGoalHandle
from std_srvs.srv import Trigger

from feeder_cell.gateway.commands import LIFECYCLE, Command, cancels_goal, plan
from feeder_cell.gateway.config import PACKML_STATES, packml_state
from feeder_cell.gateway.device_link import DeviceLink
from feeder_cell.gateway.in_ros import InRos
from feeder_cell.gateway.server import GatewayServer
from feeder_cell.gateway.spec import Values

__all__ = ["CommandRunner"]


class CommandRunner:
    """Runs PackML commands (Stop, Reset, Clear, Abort, ...) as the device's service calls."""

    def __init__(self, server: GatewayServer, in_ros: InRos) -> None:
        self.server, self.in_ros = server, in_ros

    def _post_all(self, link: DeviceLink, values: Values, stamp_ns: int = 0) -> None:
        self.server.post_all(link.entry.key, values, stamp_ns)

    async def run(self, link: DeviceLink, command: Command) -> tuple[str, str]:
        """Run a PackML command: its plan for the device's state, the transient state shown meanwhile."""
        name = command.method.name
        with link.lock:
            state, online = link.state, link.online
        if state is None or not online:
            return "BadInvalidState", f"{name} refused: {link.entry.node} reports no status (is it running?)"
        row = plan(command, state)
        if isinstance(row, str):
            return "BadInvalidState", row
        await self._discovered(link, row.calls)
        if row.transient:
            self._post_all(link, _packml_values(row.transient))
            await self.server.flush_now()
        status, message = await self.in_ros.answer(self._calls(link, name, row.calls))
        if cancels_goal(command):
            with link.lock:
                goal = link.goal
            if goal is not None:  # the device halted; do not leave the goal running behind it
                await self.in_ros.answer(self._cancel(goal))
        if status != "Good" and row.transient:
            with link.lock:
                shown = link.state
            self._post_all(link, _packml_values(packml_state(shown)[0]))  # nothing changed: say so
        return status, message

    async def _discovered(self, link: DeviceLink, calls: tuple[str, ...]) -> None:
        """Wait, at most call_timeout, until the services of a command's calls are discovered.

        A device that has just come up (or back) reports its status before every one of its services is
        discovered; the command then waits for them rather than failing at once. Whatever is still missing
        after the wait is answered by ``_calls`` (BadCommunicationError, naming the service).
        """
        clients = [link.change_state if c in LIFECYCLE else link.triggers[c] for c in calls]
        loop = asyncio.get_running_loop()
        deadline = loop.time() + self.in_ros.call_timeout
        while loop.time() < deadline:
            if await self.in_ros.value(lambda: all(c.service_is_ready() for c in clients)):
                return
            await asyncio.sleep(0.05)

    async def _calls(self, link: DeviceLink, method: str, calls: tuple[str, ...]) -> tuple[str, str]:
        """Make a command's device calls in order; the first refusal ends it (executor thread)."""
        said: list[str] = []
        for call in calls:
            if call in LIFECYCLE:
                client = link.change_state
                request = ChangeState.Request()
                request.transition.id = LIFECYCLE[call]
            else:
                client, request = link.triggers[call], Trigger.Request()
            if not client.service_is_ready():
                return (
                    "BadCommunicationError",
                    f"{method}: {client.srv_name} is not available (is the device running?)",
                )
            response = await client.call_async(request)
            text = getattr(response, "message", "") or ("done" if response.success else "refused")
            said.append(f"{call}: {text}")
            if not response.success:  # a PackML command has no arguments: only the state refuses it
                return "BadInvalidState", f"{method}: {'; '.join(said)}"
        return "Good", f"{method}: {'; '.join(said)}"

    async def _cancel(self, goal: ClientGoalHandle) -> tuple[str, str]:
        goal.cancel_goal_async()
        return "Good", ""


def _packml_values(name: str) -> Values:
    """Return the two PackML variables of a state, by name."""
    number = next(n for n, state, _ in PACKML_STATES if state == name)
    return {"Status.PackMLState": name, "Status.PackMLStateCode": number}
