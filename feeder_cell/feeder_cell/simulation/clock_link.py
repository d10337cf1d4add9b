"""The simulation node's calls to the cell clock: hold and run it, step it, set it back, its lockstep.

Only the clock's own services (``~/pause``, ``~/resume``, ``~/step``, ``~/rewind``, ``~/is_paused``) and
its ``lockstep`` parameter, so that driving the cell through the standard and through those services
cannot disagree. Separate from the devices' calls (``cell_link``): one clock, its own answers.
"""

from __future__ import annotations

from builtin_interfaces.msg import Duration
from rcl_interfaces.srv import GetParameters
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node
from std_srvs.srv import Trigger

from feeder_cell.lockstep_barrier import REWIND_REFUSED, REWOUND_TO
from feeder_cell.simulation.msgs import nanoseconds
from feeder_cell.simulation.results import OPERATION_FAILED, SimulationError
from feeder_cell.simulation.service_calls import ServiceCalls
from feeder_msgs.srv import IsPaused, StepClock

__all__ = ["ClockLink"]


class ClockLink:
    """Clients of the cell clock's services, and the calls through them.

    The clients are made in this order: pause, resume, step, rewind, is_paused, get_parameters.
    """

    def __init__(
        self, node: Node, clock_node: str, group: ReentrantCallbackGroup, calls: ServiceCalls
    ) -> None:
        self.calls = calls
        self.clock_node = clock_node
        self.pause_client = node.create_client(Trigger, f"{self.clock_node}/pause", callback_group=group)
        self.resume_client = node.create_client(Trigger, f"{self.clock_node}/resume", callback_group=group)
        self.step_client = node.create_client(StepClock, f"{self.clock_node}/step", callback_group=group)
        self.rewind_client = node.create_client(Trigger, f"{self.clock_node}/rewind", callback_group=group)
        self.paused_client = node.create_client(
            IsPaused, f"{self.clock_node}/is_paused", callback_group=group
        )
        self.clock_parameters = node.create_client(
            GetParameters, f"{self.clock_node}/get_parameters", callback_group=group
        )
        self.lockstep: bool | None = None  # the clock's lockstep parameter, once read

    async def clock_in_lockstep(self) -> bool:
        """Whether the cell clock runs in lockstep (read once; unknown while it does not answer: True)."""
        if self.lockstep is None:
            if not self.clock_parameters.service_is_ready():
                return True
            request = GetParameters.Request(names=["lockstep"])
            response = await self.calls.call(
                self.clock_parameters, request, "cell clock parameter lockstep", read=True
            )
            self.lockstep = bool(response.values[0].bool_value) if response.values else True
        return self.lockstep

    async def paused(self) -> bool:
        """Whether the cell clock is held."""
        return bool(
            (await self.calls.call(self.paused_client, IsPaused.Request(), "is_paused", read=True)).paused
        )

    async def pause(self, pause: bool) -> None:
        """Hold or run the cell clock."""
        client = self.pause_client if pause else self.resume_client
        response = await self.calls.call(client, Trigger.Request(), "pause" if pause else "resume")
        if not response.success:
            raise SimulationError(OPERATION_FAILED, f"{client.srv_name}: {response.message}")

    async def rewind(self) -> tuple[int, str]:
        """Set the held clock back to its start; return (the start in ns, '') or (-1, why it was refused).

        Refused, nothing changed, when a lockstep participant that is no device (a controller, a
        recorder) would not follow (``lockstep_barrier.REWIND_REFUSED``); any other failure raises.
        """
        client = self.rewind_client
        response = await self.calls.call(client, Trigger.Request(), "rewind", patient=True)
        if not response.success and REWIND_REFUSED in response.message:
            return -1, response.message.removeprefix("bad request: ")
        if not response.success or not response.message.startswith(REWOUND_TO):
            raise SimulationError(OPERATION_FAILED, f"{client.srv_name}: {response.message}")
        return int(response.message.removeprefix(REWOUND_TO).split()[0]), ""

    async def step(self, quanta: int, quantum_ns: int) -> int:
        """Advance the held clock by ``quanta`` quanta; return the cell time reached (ns)."""
        total = quanta * quantum_ns
        request = StepClock.Request(
            duration=Duration(sec=total // 1_000_000_000, nanosec=total % 1_000_000_000)
        )
        # A step takes as long as the cell needs: waited for while the clock is there.
        response = await self.calls.call(self.step_client, request, "step", patient=True)
        if not response.ok:
            raise SimulationError(OPERATION_FAILED, f"{self.clock_node}/step: {response.error}")
        return nanoseconds(response.now)
