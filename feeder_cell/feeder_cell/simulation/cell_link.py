"""The simulation node's link to the cell: what it observes of each device and the calls it makes.

rclpy-facing (clients and subscriptions of the node it is given), and nothing else: the rules are in
``control``, ``entities`` and ``spawning``. Every change goes through the device's and the clock's own
services (``~/place_parts``, ``~/place_part``, ``~/spawn_part``, ``~/remove_part``, ``~/load_part``,
lifecycle ``change_state``, the clock's ``~/pause``, ``~/resume``, ``~/step``), so driving the cell through
the standard and through those services cannot disagree. A call that gets no answer within the timeout
fails with a message naming the service; the node keeps serving.
"""

from __future__ import annotations

import time
from typing import Any

from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState, GetState
from rcl_interfaces.msg import ParameterType
from rcl_interfaces.srv import GetParameters
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node
from rclpy.parameter import parameter_value_to_python

from feeder_cell.simulation.clock_link import ClockLink
from feeder_cell.simulation.entities import EntityState
from feeder_cell.simulation.observations import KINDS, STREAM_QOS, Device, Observations, namespace_of
from feeder_cell.simulation.results import OPERATION_FAILED, SimulationError
from feeder_cell.simulation.service_calls import READ_RESEND_S, ServiceCalls
from feeder_msgs.srv import (
    ArmLoadPart,
    ArmPlacePart,
    MemsPlaceParts,
    MemsRemovePart,
    MemsSpawnPart,
)
from feeder_planner.node_kit.tf import check_cell_pose, quaternion_from_rpy

__all__ = ["Device", "CellLink", "KINDS", "READ_RESEND_S", "STREAM_QOS"]


def device_services(kind: str) -> dict[str, Any]:
    """Return the services the link calls on a device of ``kind``, by name (clients made in this order)."""
    services: dict[str, Any] = {"change_state": ChangeState, "get_state": GetState}
    if kind == "mems_field_array":
        # get_parameters: what the array was configured with, its parts' initial state after a reset.
        services |= {
            "get_parameters": GetParameters,
            "place_parts": MemsPlaceParts,
            "spawn_part": MemsSpawnPart,
            "remove_part": MemsRemovePart,
        }
    elif kind == "throwing_arm":
        # get_parameters: the arm's offset h, which a rest pose's height depends on.
        services |= {
            "place_part": ArmPlacePart,
            "load_part": ArmLoadPart,
            "get_parameters": GetParameters,
        }
    else:  # the fixture: its bodies are those of the assembly its assembly_file parameter names
        services |= {"get_parameters": GetParameters}
    return services


class CellLink:
    """Clients of the clock and the devices, and subscriptions to what they publish.

    What it hears is ``observations``'s (``devices``' parts and states, ``cell_frames``), the clock's calls
    ``clock``'s, how a call waits ``calls``'s; the devices' calls (parameters, lifecycle) are here.
    """

    def __init__(self, node: Node, clock_node: str, devices: dict[str, list[str]], timeout_s: float) -> None:
        self.node = node
        # Reentrant: a request's coroutine waits for a device's answer, which the client's callback
        # delivers while the request is suspended (in the default, exclusive group it never would).
        self.group = ReentrantCallbackGroup()
        self.timeout_s = timeout_s
        self.clock_node = clock_node.rstrip("/")
        self.calls = ServiceCalls(node, self.group, timeout_s)
        self.clock = ClockLink(node, self.clock_node, self.group, self.calls)
        self.devices: dict[str, Device] = {}
        self.observations = Observations(node)
        self.clients: dict[tuple[str, str], Any] = {}
        self.cell_frames: dict[str, EntityState] = self.observations.cell_frames  # the same dict
        for parameter, fqns in devices.items():
            kind, base = KINDS[parameter]
            for fqn in fqns:
                if fqn:
                    self._add(fqn, kind, base)
        self.observations.observe_tf_static()

    def _add(self, fqn: str, kind: str, base: str) -> None:
        namespace = namespace_of(fqn)
        device = Device(fqn, kind, f"{namespace}/{base}" if namespace else base)
        self.devices[fqn] = device
        self.observations.observe(device)
        for name, srv in device_services(kind).items():
            self.clients[(fqn, name)] = self.node.create_client(
                srv, f"{fqn}/{name}", callback_group=self.group
            )

    # --- observations (``observations``) ------------------------------------------------------------
    def refresh(self, device: Device) -> None:
        """Take the device's state samples queued since the last look (its states and frame follow them)."""
        self.observations.refresh(device)

    def state_of(self, device: Device, name: str) -> EntityState | None:
        """Return a part's latest state: what was placed since the last sample, else the last sample."""
        return self.observations.state_of(device, name)

    # --- waiting (``service_calls``) and the clock (``clock_link``) -----------------------------------
    async def call(
        self, client: Any, request: Any, what: str, patient: bool = False, read: bool = False
    ) -> Any:
        """Call a service; raise OPERATION_FAILED naming it when it is not there or does not answer."""
        return await self.calls.call(client, request, what, patient, read)

    async def sleep(self, seconds: float) -> None:
        """Wait ``seconds`` wall seconds without holding the executor."""
        await self.calls.sleep(seconds)

    async def clock_in_lockstep(self) -> bool:
        """Whether the cell clock runs in lockstep (read once; unknown while it does not answer: True)."""
        return await self.clock.clock_in_lockstep()

    async def paused(self) -> bool:
        """Whether the cell clock is held."""
        return await self.clock.paused()

    async def pause(self, pause: bool) -> None:
        """Hold or run the cell clock."""
        await self.clock.pause(pause)

    async def rewind(self) -> tuple[int, str]:
        """Set the held clock back to its start; return (the start in ns, '') or (-1, why it was refused)."""
        return await self.clock.rewind()

    async def step(self, quanta: int, quantum_ns: int) -> int:
        """Advance the held clock by ``quanta`` quanta; return the cell time reached (ns)."""
        return await self.clock.step(quanta, quantum_ns)

    # --- the devices' calls ---------------------------------------------------------------------------
    async def device_call(self, fqn: str, service: str, request: Any, what: str) -> Any:
        """Call a device service whose response is (ok, error); raise OPERATION_FAILED with its error."""
        response = await self.call(self.clients[(fqn, service)], request, what)
        if not response.ok:
            raise SimulationError(OPERATION_FAILED, f"{what}: {fqn}: {response.error}")
        return response

    async def parameter(self, fqn: str, name: str) -> float | str:
        """Return a device's number or string parameter (the client is made at start: see call)."""
        request = GetParameters.Request(names=[name])
        response = await self.call(
            self.clients[(fqn, "get_parameters")], request, f"{fqn} parameter {name}", read=True
        )
        value = response.values[0]
        if value.type == ParameterType.PARAMETER_DOUBLE:
            return float(value.double_value)
        if value.type == ParameterType.PARAMETER_INTEGER:
            return float(value.integer_value)
        if value.type == ParameterType.PARAMETER_STRING:
            return str(value.string_value)
        raise SimulationError(OPERATION_FAILED, f"{fqn}: parameter {name} is neither a number nor a string")

    async def parameters(self, fqn: str, names: list[str]) -> dict[str, object]:
        """Return a device's parameters by name (those it does not declare are left out)."""
        request = GetParameters.Request(names=names)
        response = await self.call(
            self.clients[(fqn, "get_parameters")], request, f"{fqn} parameters", read=True
        )
        return {
            name: parameter_value_to_python(value)
            for name, value in zip(names, response.values, strict=False)
            if value.type != ParameterType.PARAMETER_NOT_SET
        }

    async def observe_device_frames(self) -> None:
        """Place every device's base frame in the cell from its own read-only cell_pose and cell_frame.

        The same numbers its /tf_static carries, which a device sends only from its drawing timer (once a
        second while nobody draws): read here, a device's frame is known as soon as the device answers.
        A device not up yet is asked again on the next request.
        """
        for device in self.devices.values():
            if device.placed_in_cell:
                continue
            try:
                values = await self.parameters(device.fqn, ["cell_pose", "cell_frame", "frame_id"])
            except SimulationError:
                continue
            pose, cell = values.get("cell_pose"), values.get("cell_frame")
            if check_cell_pose(pose) is not None or not isinstance(pose, list):
                continue
            if not isinstance(cell, str) or not cell:
                continue
            numbers = [float(v) for v in pose]
            child = device.base_frame
            if device.kind != "assembly_fixture" and values.get("frame_id"):
                child = str(values["frame_id"])  # the array's and the arm's drawings place their own frame
            if child not in self.cell_frames:
                self.cell_frames[child] = EntityState(
                    cell, 0, (numbers[0], numbers[1], numbers[2]), quaternion_from_rpy(*numbers[3:6])
                )
            device.placed_in_cell = True

    async def lifecycle(self, fqn: str) -> str:
        """Return the device's primary lifecycle state (unconfigured, inactive, active, ...)."""
        response = await self.call(
            self.clients[(fqn, "get_state")], GetState.Request(), f"{fqn} get_state", read=True
        )
        return str(response.current_state.label)

    async def transition(self, fqn: str, name: str) -> None:
        """Run one lifecycle transition; a refusal names the device and the transition."""
        ids = {
            "configure": Transition.TRANSITION_CONFIGURE,
            "activate": Transition.TRANSITION_ACTIVATE,
            "deactivate": Transition.TRANSITION_DEACTIVATE,
            "cleanup": Transition.TRANSITION_CLEANUP,
        }
        request = ChangeState.Request()
        request.transition.id = ids[name]
        response = await self.call(self.clients[(fqn, "change_state")], request, f"{fqn} {name}")
        if not response.success:
            raise SimulationError(OPERATION_FAILED, f"{fqn}: lifecycle transition {name} refused")

    async def reconfigure(self, fqn: str, activate: bool | None) -> bool:
        """Bring a device back to its configured initial state (cleanup, configure); active again if asked.

        ``activate`` None keeps it as it was; an unconfigured device is left unconfigured (it has no
        configured state to go back to): False.
        """
        state = await self.lifecycle(fqn)
        if state == "unconfigured":
            return False
        was_active = state == "active"
        if was_active:
            await self.transition(fqn, "deactivate")
        device = self.devices[fqn]
        heard = device.parts_heard
        await self.transition(fqn, "cleanup")
        await self.transition(fqn, "configure")
        self.refresh(device)  # the samples of the former configuration are taken, not left to come back
        device.states.clear()
        device.placed.clear()
        if device.kind == "mems_field_array":
            # The configured parts come on the latched ~/parts the configuration publishes: until that
            # list is here, the former one (spawned parts included) must not be listed.
            deadline = time.monotonic() + self.timeout_s
            while device.parts_heard == heard and time.monotonic() < deadline:
                await self.sleep(0.01)
            if device.parts_heard == heard:
                raise SimulationError(
                    OPERATION_FAILED, f"{fqn}: no ~/parts list within {self.timeout_s:g} s of configure"
                )
        if activate or (activate is None and was_active):
            await self.transition(fqn, "activate")
        return True
