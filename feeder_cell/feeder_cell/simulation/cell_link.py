"""The simulation node's link to the cell: what it observes of each device and the calls it makes.

rclpy-facing (clients and subscriptions of the node it is given), and nothing else: the rules are in
``control``, ``entities`` and ``spawning``. Every change goes through the device's and the clock's own
services (``~/place_parts``, ``~/place_part``, ``~/spawn_part``, ``~/remove_part``, ``~/load_part``,
lifecycle ``change_state``, the clock's ``~/pause``, ``~/resume``, ``~/step``), so driving the cell through
the standard and through those services cannot disagree. A call that gets no answer within the timeout
fails with a message naming the service; the node keeps serving.
"""

from __future__ import annotations

import functools
import time
from dataclasses import dataclass, field
from typing import Any

from builtin_interfaces.msg import Duration
from geometry_msgs.msg import PoseStamped
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState, GetState
from rcl_interfaces.msg import ParameterType
from rcl_interfaces.srv import GetParameters
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.parameter import parameter_value_to_python
from rclpy.task import Future
from std_srvs.srv import Trigger
from tf2_msgs.msg import TFMessage

from feeder_cell.lockstep_barrier import REWIND_REFUSED, REWOUND_TO
from feeder_cell.simulation.entities import EntityState
from feeder_cell.simulation.msgs import nanoseconds
from feeder_cell.simulation.results import OPERATION_FAILED, SimulationError
from feeder_msgs.msg import MemsParts, MemsPartStates, Part
from feeder_msgs.srv import (
    ArmLoadPart,
    ArmPlacePart,
    IsPaused,
    MemsPlaceParts,
    MemsRemovePart,
    MemsSpawnPart,
    StepClock,
)
from feeder_planner.node_kit import LATCHED
from feeder_planner.node_kit.polled import PolledSubscription
from feeder_planner.node_kit.tf import TF_STATIC_QOS, check_cell_pose, quaternion_from_rpy

__all__ = ["Device", "CellLink", "KINDS"]

# The device kinds the cell simulates: launch parameter name -> (kind, base frame under the namespace).
KINDS = {
    "mems_field_arrays": ("mems_field_array", "mems_array"),
    "throwing_arms": ("throwing_arm", "arm_pivot"),
    "assembly_fixtures": ("assembly_fixture", "fixture_base"),
}
STREAM_QOS = 10
# Wall seconds a request without effect waits before it is sent again (docs/cell.md, "A fresh client's
# first request is never answered": 0.5-2 s).
READ_RESEND_S = 1.0


@dataclass
class Device:
    """One device as observed: its part names, the latest state of each, what was set since."""

    fqn: str
    kind: str
    base_frame: str
    parts: list[str] = field(default_factory=list)  # in the device's order
    part_documents: dict[str, Part] = field(default_factory=dict)
    parts_heard: int = 0  # latched part lists heard: a reconfiguration waits for the next one
    states: dict[str, EntityState] = field(default_factory=dict)
    placed: dict[str, EntityState] = field(default_factory=dict)  # set or spawned, not yet ticked
    frame_id: str = ""  # the frame the device's part states are in (from its streams)
    placed_in_cell: bool = False  # its cell_pose read (its base frame known without /tf_static)


class CellLink:
    """Clients of the clock and the devices, and subscriptions to what they publish."""

    def __init__(self, node: Node, clock_node: str, devices: dict[str, list[str]], timeout_s: float) -> None:
        self.node = node
        # Reentrant: a request's coroutine waits for a device's answer, which the client's callback
        # delivers while the request is suspended (in the default, exclusive group it never would).
        self.group = ReentrantCallbackGroup()
        self.timeout_s = timeout_s
        self.clock_node = clock_node.rstrip("/")
        self.pause_client = node.create_client(Trigger, f"{self.clock_node}/pause", callback_group=self.group)
        self.resume_client = node.create_client(
            Trigger, f"{self.clock_node}/resume", callback_group=self.group
        )
        self.step_client = node.create_client(StepClock, f"{self.clock_node}/step", callback_group=self.group)
        self.rewind_client = node.create_client(
            Trigger, f"{self.clock_node}/rewind", callback_group=self.group
        )
        self.paused_client = node.create_client(
            IsPaused, f"{self.clock_node}/is_paused", callback_group=self.group
        )
        self.clock_parameters = node.create_client(
            GetParameters, f"{self.clock_node}/get_parameters", callback_group=self.group
        )
        self.lockstep: bool | None = None  # the clock's lockstep parameter, once read
        self.devices: dict[str, Device] = {}
        # A device's state stream, taken when a request needs it (never a wake-up per sample).
        self._streams: dict[str, PolledSubscription] = {}
        self.clients: dict[tuple[str, str], Any] = {}
        self.cell_frames: dict[str, EntityState] = {}  # child frame -> its pose in its parent
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        for parameter, fqns in devices.items():
            kind, base = KINDS[parameter]
            for fqn in fqns:
                if fqn:
                    self._add(fqn, kind, base)
        node.create_subscription(TFMessage, "/tf_static", self._on_tf_static, TF_STATIC_QOS)

    def _add(self, fqn: str, kind: str, base: str) -> None:
        namespace = fqn.rpartition("/")[0].strip("/")
        device = Device(fqn, kind, f"{namespace}/{base}" if namespace else base)
        self.devices[fqn] = device
        services: dict[str, Any] = {"change_state": ChangeState, "get_state": GetState}
        if kind == "mems_field_array":
            # get_parameters: what the array was configured with, its parts' initial state after a reset.
            services |= {
                "get_parameters": GetParameters,
                "place_parts": MemsPlaceParts,
                "spawn_part": MemsSpawnPart,
                "remove_part": MemsRemovePart,
            }
            self.node.create_subscription(
                MemsParts, f"{fqn}/parts", lambda m, d=device: self._on_mems_parts(d, m), LATCHED
            )
            self._streams[fqn] = PolledSubscription(
                self.node,
                MemsPartStates,
                f"{fqn}/part_states",
                functools.partial(self._on_part_states, device),
                STREAM_QOS,
            )
        elif kind == "throwing_arm":
            # get_parameters: the arm's offset h, which a rest pose's height depends on.
            services |= {
                "place_part": ArmPlacePart,
                "load_part": ArmLoadPart,
                "get_parameters": GetParameters,
            }
            self.node.create_subscription(
                Part, f"{fqn}/part", lambda m, d=device: self._on_arm_part(d, m), LATCHED
            )
            self._streams[fqn] = PolledSubscription(
                self.node,
                PoseStamped,
                f"{fqn}/part_pose",
                functools.partial(self._on_part_pose, device),
                STREAM_QOS,
            )
        else:  # the fixture: its bodies are those of the assembly its assembly_file parameter names
            services |= {"get_parameters": GetParameters}
            device.frame_id = f"{namespace}/assembly" if namespace else "assembly"
        for name, srv in services.items():
            self.clients[(fqn, name)] = self.node.create_client(
                srv, f"{fqn}/{name}", callback_group=self.group
            )

    # --- observations -------------------------------------------------------------------------------
    def _on_tf_static(self, msg: TFMessage) -> None:
        for transform in msg.transforms:
            t, r = transform.transform.translation, transform.transform.rotation
            self.cell_frames[transform.child_frame_id] = EntityState(
                transform.header.frame_id,
                nanoseconds(transform.header.stamp),
                (t.x, t.y, t.z),
                (r.x, r.y, r.z, r.w),
            )

    def _on_mems_parts(self, device: Device, msg: MemsParts) -> None:
        device.parts = [part.name for part in msg.parts]
        device.part_documents = {part.name: part for part in msg.parts}
        device.parts_heard += 1

    def _on_part_states(self, device: Device, msg: MemsPartStates) -> None:
        stamp = nanoseconds(msg.header.stamp)
        device.frame_id = msg.header.frame_id
        for part in msg.parts:
            p, q = part.pose.position, part.pose.orientation
            v, w = part.twist.linear, part.twist.angular
            device.states[part.name] = EntityState(
                msg.header.frame_id,
                stamp,
                (p.x, p.y, p.z),
                (q.x, q.y, q.z, q.w),
                (v.x, v.y, v.z),
                (w.x, w.y, w.z),
            )
            self._forget_placed(device, part.name, stamp)

    def _on_arm_part(self, device: Device, msg: Part) -> None:
        device.parts = [msg.name]
        device.part_documents = {msg.name: msg}

    def _on_part_pose(self, device: Device, msg: PoseStamped) -> None:
        stamp = nanoseconds(msg.header.stamp)
        device.frame_id = msg.header.frame_id
        p, q = msg.pose.position, msg.pose.orientation
        for name in device.parts:
            device.states[name] = EntityState(
                msg.header.frame_id, stamp, (p.x, p.y, p.z), (q.x, q.y, q.z, q.w)
            )
            self._forget_placed(device, name, stamp)

    @staticmethod
    def _forget_placed(device: Device, name: str, stamp: int) -> None:
        placed = device.placed.get(name)
        if placed is not None and stamp > placed.stamp_ns:
            del device.placed[name]

    def refresh(self, device: Device) -> None:
        """Take the device's state samples queued since the last look (its states and frame follow them)."""
        stream = self._streams.get(device.fqn)
        if stream is not None:
            stream.take()

    def state_of(self, device: Device, name: str) -> EntityState | None:
        """Return a part's latest state: what was placed since the last sample, else the last sample."""
        self.refresh(device)
        return device.placed.get(name) or device.states.get(name)

    # --- calls --------------------------------------------------------------------------------------
    async def call(
        self, client: Any, request: Any, what: str, patient: bool = False, read: bool = False
    ) -> Any:
        """Call a service; raise OPERATION_FAILED naming it when it is not there or does not answer.

        ``patient``: wait as long as the server is still there (checked every ``timeout_s``), for a call
        that takes as long as the cell needs (a step of many quanta; the clock's own lockstep timeout drops
        a participant that stops answering, so the step ends).
        ``read``: the request has no effect, so it is sent again every READ_RESEND_S while unanswered, up to
        ``timeout_s``: a fresh client's first request can be answered into the void (docs/cell.md,
        Troubleshooting; measured: GetSimulationState said LOADING_WORLD 30 s after the join in 2 of 20
        launches with one process per node, a first is_paused or get_parameters to the clock unanswered).
        """
        if not client.service_is_ready():
            raise SimulationError(OPERATION_FAILED, f"{what}: the service {client.srv_name} is not available")
        if read:
            deadline = time.monotonic() + self.timeout_s
            while time.monotonic() < deadline:
                future = client.call_async(request)
                if await self._within(future, READ_RESEND_S):
                    return future.result()
                client.remove_pending_request(future)
            raise SimulationError(
                OPERATION_FAILED, f"{what}: {client.srv_name} did not answer within {self.timeout_s:g} s"
            )
        future = client.call_async(request)
        while not future.done():
            if not await self._within(future, self.timeout_s) and not (patient and client.service_is_ready()):
                client.remove_pending_request(future)
                gone = " (its server went away)" if patient else ""
                raise SimulationError(
                    OPERATION_FAILED,
                    f"{what}: {client.srv_name} did not answer within {self.timeout_s:g} s{gone}",
                )
        return future.result()

    async def sleep(self, seconds: float) -> None:
        """Wait ``seconds`` wall seconds without holding the executor."""
        await self._within(Future(), seconds)

    async def clock_in_lockstep(self) -> bool:
        """Whether the cell clock runs in lockstep (read once; unknown while it does not answer: True)."""
        if self.lockstep is None:
            if not self.clock_parameters.service_is_ready():
                return True
            request = GetParameters.Request(names=["lockstep"])
            response = await self.call(
                self.clock_parameters, request, "cell clock parameter lockstep", read=True
            )
            self.lockstep = bool(response.values[0].bool_value) if response.values else True
        return self.lockstep

    async def _within(self, future: Future, timeout_s: float) -> bool:
        """Wait until ``future`` is done or ``timeout_s`` wall seconds have passed; return whether done."""
        wake = Future()
        future.add_done_callback(lambda _: wake.done() or wake.set_result(True))
        timer = self.node.create_timer(
            timeout_s,
            lambda: wake.done() or wake.set_result(False),
            clock=self._steady,
            callback_group=self.group,
        )
        try:
            return bool(await wake)
        finally:
            self.node.destroy_timer(timer)

    async def device_call(self, fqn: str, service: str, request: Any, what: str) -> Any:
        """Call a device service whose response is (ok, error); raise OPERATION_FAILED with its error."""
        response = await self.call(self.clients[(fqn, service)], request, what)
        if not response.ok:
            raise SimulationError(OPERATION_FAILED, f"{what}: {fqn}: {response.error}")
        return response

    async def paused(self) -> bool:
        """Whether the cell clock is held."""
        return bool((await self.call(self.paused_client, IsPaused.Request(), "is_paused", read=True)).paused)

    async def pause(self, pause: bool) -> None:
        """Hold or run the cell clock."""
        client = self.pause_client if pause else self.resume_client
        response = await self.call(client, Trigger.Request(), "pause" if pause else "resume")
        if not response.success:
            raise SimulationError(OPERATION_FAILED, f"{client.srv_name}: {response.message}")

    async def rewind(self) -> tuple[int, str]:
        """Set the held clock back to its start; return (the start in ns, '') or (-1, why it was refused).

        Refused, nothing changed, when a lockstep participant that is no device (a controller, a
        recorder) would not follow (``lockstep_barrier.REWIND_REFUSED``); any other failure raises.
        """
        client = self.rewind_client
        response = await self.call(client, Trigger.Request(), "rewind", patient=True)
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
        response = await self.call(self.step_client, request, "step", patient=True)
        if not response.ok:
            raise SimulationError(OPERATION_FAILED, f"{self.clock_node}/step: {response.error}")
        return nanoseconds(response.now)

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
