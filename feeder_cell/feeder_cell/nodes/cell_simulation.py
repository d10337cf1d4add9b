"""ROS 2 node: the cell as a simulator of the ROS 2 simulation standard (``simulation_interfaces``).

`feeder launch SCENE --real-time-factor F|max` starts it as ``/cell_simulation`` beside the cell clock,
with the scene's devices as parameters; its services and action are under its own name
(``/cell_simulation/step_simulation``, ...). What each does, the entity names, frames and units:
docs/cell.md, "Driving the cell with simulation_interfaces". The rules live in ``feeder_cell.simulation``
(states, steps and resets; entities and filters; what a spawn or a set accepts); the calls to the clock
and the devices in ``simulation.cell_link``. One request that changes the cell runs at a time; a second
is answered INCORRECT_STATE while it runs. Reads answer from what the node has observed.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Awaitable, Callable

from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.node import Node
from simulation_interfaces.action import SimulateSteps
from simulation_interfaces.msg import EntityInfo, SimulationState, SimulatorFeatures, Spawnable
from simulation_interfaces.srv import (
    DeleteEntity,
    GetAvailableWorlds,
    GetCurrentWorld,
    GetEntities,
    GetEntitiesStates,
    GetEntityBounds,
    GetEntityInfo,
    GetEntityState,
    GetNamedPoseBounds,
    GetNamedPoses,
    GetSimulationState,
    GetSimulatorFeatures,
    GetSpawnables,
    LoadWorld,
    ResetSimulation,
    SetEntityInfo,
    SetEntityState,
    SetSimulationState,
    SpawnEntities,
    SpawnEntity,
    StepSimulation,
    UnloadWorld,
)

from feeder_cell.simulation import control
from feeder_cell.simulation.cell_link import KINDS, CellLink, Device
from feeder_cell.simulation.entities import CATEGORY_OBJECT, Entity, EntityState, device_entity, select
from feeder_cell.simulation.msgs import accel_tuple, pose_tuple, result_msg, state_msg, twist_tuples
from feeder_cell.simulation.results import (
    FEATURE_UNSUPPORTED,
    INCORRECT_STATE,
    NAME_NOT_UNIQUE,
    NAMESPACE_INVALID,
    NOT_FOUND,
    OK,
    OPERATION_FAILED,
    SET_INVALID_POSE,
    SPAWN_INVALID_POSE,
    SimulationError,
)
from feeder_cell.simulation.spawning import (
    PART_SUFFIXES,
    SPAWN_FORMAT,
    arm_rest,
    check_at_rest,
    check_name,
    planar_pose,
    read_spawnable,
)
from feeder_cell.simulation.spawning import (
    Spawnable as PartSpawnable,
)
from feeder_msgs.srv import ArmLoadPart, ArmPlacePart, MemsPlaceParts, MemsRemovePart, MemsSpawnPart
from feeder_planner.node_kit import declare_parameters, run_node
from feeder_planner.node_kit.msg_parts import part_from_msg
from feeder_planner.parameter_specs import from_values, param, positive, specs_of
from feeder_planner.throwing.geometry import arm_part

__all__ = ["SimulationParameters", "PARAMETERS", "CellSimulation", "FEATURES", "main"]

F = SimulatorFeatures
# Exactly what works (each is exercised by tests/cell/test_simulation_interfaces_ros.py).
FEATURES = (
    F.SPAWNING,
    F.DELETING,
    F.ENTITY_CATEGORIES,
    F.SPAWNING_RESOURCE_STRING,
    F.ENTITY_STATE_GETTING,
    F.ENTITY_STATE_SETTING,
    F.ENTITY_INFO_GETTING,
    F.SPAWNABLES,
    F.SIMULATION_RESET,
    F.SIMULATION_RESET_STATE,
    F.SIMULATION_RESET_SPAWNED,
    F.SIMULATION_STATE_GETTING,
    F.SIMULATION_STATE_SETTING,
    F.SIMULATION_STATE_PAUSE,
    F.STEP_SIMULATION_SINGLE,
    F.STEP_SIMULATION_MULTIPLE,
    F.STEP_SIMULATION_ACTION,
)
# Standard services the cell has no use for: served, so that a harness gets FEATURE_UNSUPPORTED, not silence.
UNSUPPORTED = {
    "get_entity_bounds": (GetEntityBounds, "entity bounds"),
    "set_entity_info": (SetEntityInfo, "setting entity info"),
    "get_named_poses": (GetNamedPoses, "named poses"),
    "get_named_pose_bounds": (GetNamedPoseBounds, "named pose bounds"),
    "spawn_entities": (SpawnEntities, "spawning several entities in one call (use spawn_entity)"),
    "load_world": (LoadWorld, "worlds (the cell's one world is its scene)"),
    "unload_world": (UnloadWorld, "worlds (the cell's one world is its scene)"),
    "get_current_world": (GetCurrentWorld, "worlds (the cell's one world is its scene)"),
    "get_available_worlds": (GetAvailableWorlds, "worlds (the cell's one world is its scene)"),
}
MAX_SPAWNABLES = 1000


@dataclass(frozen=True)
class SimulationParameters:
    """The simulation node's parameters (docs/cell.md); `feeder launch` sets the scene's devices."""

    clock_node: str = param("/cell_clock", "the cell clock node it pauses, resumes and steps", read_only=True)
    quantum: float = param(
        0.1, "cell seconds per step: the cell clock's lockstep quantum", positive, read_only=True
    )
    mems_field_arrays: list[str] = param(
        [""], "fully qualified names of the scene's MEMS arrays", read_only=True
    )
    throwing_arms: list[str] = param(
        [""], "fully qualified names of the scene's throwing arms", read_only=True
    )
    assembly_fixtures: list[str] = param(
        [""], "fully qualified names of the scene's fixtures", read_only=True
    )
    part_directories: list[str] = param(
        [""],
        "directories whose part files GetSpawnables lists (feeder launch: those the scene names)",
        read_only=True,
    )
    call_timeout: float = param(
        30.0, "wall seconds a device or the clock may take to answer a call", positive, read_only=True
    )


PARAMETERS = specs_of(SimulationParameters)


@dataclass(frozen=True)
class SpawnRecord:
    """A spawned part: enough to spawn it again after a STATE reset."""

    device: str
    name: str
    spawnable: PartSpawnable
    pose: tuple[float, float, float]  # array: x, y, theta; arm: edge, R, 0


class CellSimulation(Node):
    """Serves the standard's simulation services and the SimulateSteps action for the whole cell."""

    def __init__(self) -> None:
        super().__init__("cell_simulation")
        self.p = from_values(SimulationParameters, declare_parameters(self, PARAMETERS))
        devices = {name: list(getattr(self.p, name)) for name in KINDS}
        self.link = CellLink(self, self.p.clock_node, devices, float(self.p.call_timeout))
        self.quantum_ns = int(round(self.p.quantum * 1e9))
        self.busy = ""  # the request changing the cell now
        self.stopped = False
        self.stopped_active: list[str] = []
        self.spawned: dict[str, SpawnRecord] = {}
        serve = self._serve
        serve(GetSimulatorFeatures, "get_simulator_features", self._features, changes=False)
        serve(GetSimulationState, "get_simulation_state", self._get_state, changes=False)
        serve(SetSimulationState, "set_simulation_state", self._set_state)
        serve(StepSimulation, "step_simulation", self._step)
        serve(ResetSimulation, "reset_simulation", self._reset)
        serve(GetEntities, "get_entities", self._get_entities, changes=False)
        serve(GetEntitiesStates, "get_entities_states", self._get_entities_states, changes=False)
        serve(GetEntityState, "get_entity_state", self._get_entity_state, changes=False)
        serve(GetEntityInfo, "get_entity_info", self._get_entity_info, changes=False)
        serve(SetEntityState, "set_entity_state", self._set_entity_state)
        serve(SpawnEntity, "spawn_entity", self._spawn)
        serve(DeleteEntity, "delete_entity", self._delete)
        serve(GetSpawnables, "get_spawnables", self._spawnables, changes=False)
        for name, (srv, what) in UNSUPPORTED.items():
            serve(srv, name, self._unsupported(what), changes=False)
        ActionServer(
            self,
            SimulateSteps,
            "~/simulate_steps",
            execute_callback=self._simulate_steps,
            goal_callback=self._accept_steps,
            cancel_callback=lambda _: CancelResponse.ACCEPT,
            callback_group=self.link.group,
        )
        self.get_logger().info(
            f"simulation_interfaces for {len(self.link.devices)} devices, a step being {self.p.quantum:g} s"
        )

    # --- the one service wrapper: results, one change at a time, never a traceback ------------------
    def _serve(
        self, srv: Any, name: str, handler: Callable[..., Awaitable[None]], changes: bool = True
    ) -> None:
        async def callback(request: Any, response: Any) -> Any:
            if changes and self.busy:
                response.result = result_msg(INCORRECT_STATE, f"busy: {self.busy} is being carried out")
                return response
            if changes:
                self.busy = name
            try:
                await handler(request, response)
                if hasattr(response, "result") and not response.result.result:
                    response.result = result_msg(OK)
            except SimulationError as error:
                response.result = result_msg(error.code, error.message)
            except Exception as error:  # noqa: BLE001 - a bug answers the request and is logged; the node serves on
                self.get_logger().error(f"{name}: internal error: {type(error).__name__}: {error}")
                response.result = result_msg(
                    OPERATION_FAILED, f"internal error: {type(error).__name__}: {error}"
                )
            finally:
                if changes:
                    self.busy = ""
            return response

        self.create_service(srv, f"~/{name}", callback, callback_group=self.link.group)

    @staticmethod
    def _unsupported(what: str) -> Callable[[Any, Any], Awaitable[None]]:
        async def handler(request: Any, response: Any) -> None:
            raise SimulationError(FEATURE_UNSUPPORTED, f"{what} is not supported by this cell")

        return handler

    # --- features and simulation state -------------------------------------------------------------
    async def _features(self, request: Any, response: GetSimulatorFeatures.Response) -> None:
        response.features = SimulatorFeatures(
            features=list(FEATURES),
            spawn_formats=[SPAWN_FORMAT],
            custom_info=(
                "feeder cell: a step is one lockstep quantum of cell time "
                f"({self.p.quantum:g} s); spawn_format {SPAWN_FORMAT} is a part file (contract section 2); "
                "entities, frames and units: docs/cell.md"
            ),
        )

    async def _current(self) -> int:
        if self.stopped:
            return control.STOPPED
        return control.PAUSED if await self.link.paused() else control.PLAYING

    async def _get_state(self, request: Any, response: GetSimulationState.Response) -> None:
        response.state = SimulationState(state=await self._current())

    async def _set_state(self, request: SetSimulationState.Request, response: Any) -> None:
        for action in control.transition(await self._current(), int(request.state.state)):
            if action in ("pause", "resume"):
                await self.link.pause(action == "pause")
            elif action == "stop":
                self.stopped_active = [
                    fqn for fqn in self.link.devices if await self.link.lifecycle(fqn) == "active"
                ]
                for fqn in self.link.devices:
                    await self.link.reconfigure(fqn, activate=False)
                self.spawned.clear()
                self.stopped = True
            else:  # start
                for fqn in self.stopped_active:
                    await self.link.transition(fqn, "activate")
                self.stopped_active, self.stopped = [], False

    # --- steps ---------------------------------------------------------------------------------------
    async def _step(self, request: StepSimulation.Request, response: Any) -> None:
        steps = control.check_steps(int(request.steps), await self._current())
        await self.link.step(steps, self.quantum_ns)

    def _accept_steps(self, goal: SimulateSteps.Goal) -> GoalResponse:
        # Checked again when it runs: the state may change between acceptance and execution.
        if self.busy or not (1 <= goal.steps <= control.MAX_STEPS):
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    async def _simulate_steps(self, handle: ServerGoalHandle) -> SimulateSteps.Result:
        result = SimulateSteps.Result()
        steps = int(handle.request.steps)
        if self.busy:
            result.result = result_msg(INCORRECT_STATE, f"busy: {self.busy} is being carried out")
            handle.abort()
            return result
        self.busy = "simulate_steps"
        done = 0
        try:
            control.check_steps(steps, await self._current())
            while done < steps:
                if handle.is_cancel_requested:
                    handle.canceled()
                    result.result = result_msg(OK, f"canceled after {done} of {steps} steps")
                    return result
                await self.link.step(1, self.quantum_ns)
                done += 1
                handle.publish_feedback(
                    SimulateSteps.Feedback(completed_steps=done, remaining_steps=steps - done)
                )
            handle.succeed()
            result.result = result_msg(OK)
        except SimulationError as error:
            handle.abort()
            result.result = result_msg(error.code, f"after {done} of {steps} steps: {error.message}")
        finally:
            self.busy = ""
        return result

    # --- reset ---------------------------------------------------------------------------------------
    async def _reset(self, request: ResetSimulation.Request, response: Any) -> None:
        reset = control.reset_of_scope(int(request.scope))
        if reset.state:
            for fqn in self.link.devices:
                await self.link.reconfigure(fqn, activate=None)
            kept = [] if reset.spawned else list(self.spawned.values())
            self.spawned.clear()
            for record in kept:
                await self._spawn_record(record)
        elif reset.spawned:
            for name, record in list(self.spawned.items()):
                if self.link.devices[record.device].kind == "throwing_arm":
                    await self.link.reconfigure(record.device, activate=None)  # back to its configured part
                else:
                    await self.link.device_call(
                        record.device, "remove_part", MemsRemovePart.Request(name=record.name), "reset"
                    )
                del self.spawned[name]

    # --- entities ------------------------------------------------------------------------------------
    def entities(self) -> list[Entity]:
        """Every entity of the cell now: the devices and the parts they hold."""
        found: list[Entity] = []
        for device in self.link.devices.values():
            found.append(device_entity(device.fqn, "device", f"{device.kind} device {device.fqn}"))
            kind = "array_part" if device.kind == "mems_field_array" else "arm_part"
            for part in device.parts:
                name = f"{device.fqn.lstrip('/')}/{part}"
                spawned = name in self.spawned
                origin = f"spawned from {self.spawned[name].spawnable.source}" if spawned else "configured"
                found.append(
                    Entity(
                        name,
                        CATEGORY_OBJECT,
                        f"part {part} on {device.fqn} ({origin})",
                        device.fqn,
                        kind,
                        part,
                        spawned,
                    )
                )
        return found

    def entity(self, name: str) -> Entity:
        """Return the entity named ``name``, or raise NOT_FOUND."""
        for entity in self.entities():
            if entity.name == name:
                return entity
        raise SimulationError(NOT_FOUND, f"entity: no entity named {name!r} (GetEntities lists them)")

    def _selected(self, filters: Any) -> list[Entity]:
        bounded = int(filters.bounds.type) != 0 or len(filters.bounds.points) > 0
        categories = [int(c.category) for c in filters.categories]
        return select(self.entities(), filters.filter, categories, list(filters.tags.tags), bounded)

    async def _get_entities(self, request: GetEntities.Request, response: Any) -> None:
        response.entities = [e.name for e in self._selected(request.filters)]

    async def _get_entities_states(self, request: GetEntitiesStates.Request, response: Any) -> None:
        selected = self._selected(request.filters)
        response.entities = [e.name for e in selected]
        response.states = [state_msg(self.state_of(e)) for e in selected]

    async def _get_entity_state(self, request: GetEntityState.Request, response: Any) -> None:
        response.state = state_msg(self.state_of(self.entity(request.entity)))

    async def _get_entity_info(self, request: GetEntityInfo.Request, response: Any) -> None:
        entity = self.entity(request.entity)
        response.info = EntityInfo(description=entity.description)
        response.info.category.category = entity.category

    def state_of(self, entity: Entity) -> EntityState:
        """Return the latest observed state (a device: its base frame's pose in the cell, /tf_static)."""
        device = self.link.devices[entity.device]
        if entity.kind == "device":
            frame = self.link.cell_frames.get(device.base_frame)
            if frame is None:
                raise SimulationError(
                    OPERATION_FAILED,
                    f"entity: no /tf_static transform of {device.base_frame} seen yet (configure the device)",
                )
            return frame
        state = self.link.state_of(device, entity.local)
        if state is None:
            raise SimulationError(
                OPERATION_FAILED,
                f"entity: {entity.name}: no state since the device was (re)configured; step once",
            )
        return state

    # --- setting, spawning, deleting ------------------------------------------------------------------
    def _frame_checked(self, device: Device, frame_id: str, field: str, code: int) -> None:
        frame = device.frame_id or device.base_frame
        if frame_id not in ("", frame):
            raise SimulationError(
                code, f"{field}: poses on {device.fqn} are in its frame {frame!r}, got {frame_id!r}"
            )

    async def _arm_rest(
        self, device: Device, part: Any, pose: Any, field: str, code: int
    ) -> tuple[int, float]:
        position, orientation = pose_tuple(pose)
        x, y, yaw = planar_pose(position, orientation, field, code)
        offset = await self.link.parameter(device.fqn, "offset")
        geometry = arm_part(part)
        return arm_rest(x, y, yaw, geometry.edge_angle, geometry.d, float(offset), field, code)

    async def _set_entity_state(self, request: SetEntityState.Request, response: Any) -> None:
        entity = self.entity(request.entity)
        if entity.kind == "device":
            raise SimulationError(
                OPERATION_FAILED, f"entity: {entity.name} is fixed in the cell (its cell_pose parameter)"
            )
        state = request.state
        linear, angular = twist_tuples(state.twist)
        check_at_rest(linear, angular, accel_tuple(state.acceleration))
        device = self.link.devices[entity.device]
        self._frame_checked(device, state.header.frame_id, "state.header.frame_id", SET_INVALID_POSE)
        if entity.kind == "array_part":
            x, y, theta = planar_pose(*pose_tuple(state.pose), "state.pose", SET_INVALID_POSE)
            place = MemsPlaceParts.Request(names=[entity.local], x=[x], y=[y], theta=[theta])
            await self.link.device_call(device.fqn, "place_parts", place, "set_entity_state")
        else:
            part = part_from_msg(device.part_documents[entity.local])
            edge, radius = await self._arm_rest(device, part, state.pose, "state.pose", SET_INVALID_POSE)
            place_arm = ArmPlacePart.Request(edge=edge, radius=radius)
            await self.link.device_call(device.fqn, "place_part", place_arm, "set_entity_state")
        self._placed(device, entity.local, state.pose, frame_id=device.frame_id or device.base_frame)

    def _placed(self, device: Device, name: str, pose: Any, frame_id: str) -> None:
        position, orientation = pose_tuple(pose)
        now = self.get_clock().now().nanoseconds
        device.placed[name] = EntityState(frame_id, now, position, orientation)

    def _device_for_spawn(self, namespace: str) -> Device:
        if not namespace:
            arrays = [d for d in self.link.devices.values() if d.kind == "mems_field_array"]
            if len(arrays) == 1:
                return arrays[0]
            raise SimulationError(NAMESPACE_INVALID, "entity_namespace: name the device to spawn onto")
        wanted = "/" + namespace.strip("/")
        device = self.link.devices.get(wanted)
        if device is None or device.kind == "assembly_fixture":
            holders = [d.fqn for d in self.link.devices.values() if d.kind != "assembly_fixture"]
            raise SimulationError(
                NAMESPACE_INVALID,
                f"entity_namespace: {namespace!r} is no device parts spawn onto ({', '.join(holders)})",
            )
        return device

    async def _spawn(self, request: SpawnEntity.Request, response: Any) -> None:
        spawnable = read_spawnable(request.uri, request.resource_string)
        device = self._device_for_spawn(request.entity_namespace)
        name = check_name(request.name or spawnable.part.name)
        if name in device.parts or f"{device.fqn.lstrip('/')}/{name}" in self.spawned:
            if not request.allow_renaming:
                raise SimulationError(
                    NAME_NOT_UNIQUE, f"name: {device.fqn} already holds a part named {name!r}"
                )
            name = next(f"{name}_{k}" for k in range(2, 10_000) if f"{name}_{k}" not in device.parts)
        pose = request.initial_pose
        self._frame_checked(device, pose.header.frame_id, "initial_pose.header.frame_id", SPAWN_INVALID_POSE)
        if device.kind == "mems_field_array":
            at = planar_pose(*pose_tuple(pose.pose), "initial_pose.pose", SPAWN_INVALID_POSE)
        else:
            edge, radius = await self._arm_rest(
                device, spawnable.part, pose.pose, "initial_pose.pose", SPAWN_INVALID_POSE
            )
            at = (float(edge), radius, 0.0)
        record = SpawnRecord(device.fqn, name, spawnable, at)
        await self._spawn_record(record)
        self._placed(device, name, pose.pose, frame_id=device.frame_id or device.base_frame)
        response.entity_name = f"{device.fqn.lstrip('/')}/{name}"

    async def _spawn_record(self, record: SpawnRecord) -> None:
        device = self.link.devices[record.device]
        text, source = record.spawnable.text, record.spawnable.source
        if device.kind == "mems_field_array":
            x, y, theta = record.pose
            request: Any = MemsSpawnPart.Request(
                name=record.name, part_yaml=text, source=source, x=x, y=y, theta=theta
            )
            await self.link.device_call(device.fqn, "spawn_part", request, "spawn_entity")
        else:
            # The arm holds one part: the one it held before is replaced (and no longer a spawned entity).
            for key in [k for k, r in self.spawned.items() if r.device == device.fqn]:
                del self.spawned[key]
            request = ArmLoadPart.Request(
                name=record.name,
                part_yaml=text,
                source=source,
                edge=int(record.pose[0]),
                radius=record.pose[1],
            )
            await self.link.device_call(device.fqn, "load_part", request, "spawn_entity")
        self.spawned[f"{device.fqn.lstrip('/')}/{record.name}"] = record

    async def _delete(self, request: DeleteEntity.Request, response: Any) -> None:
        entity = self.entity(request.entity)
        if entity.kind == "device":
            raise SimulationError(
                OPERATION_FAILED, f"entity: {entity.name} is a device of the scene; it is not deleted"
            )
        if entity.kind == "arm_part":
            raise SimulationError(
                OPERATION_FAILED,
                f"entity: the throwing arm always holds one part: spawn a part onto it to replace "
                f"{entity.name}",
            )
        remove = MemsRemovePart.Request(name=entity.local)
        await self.link.device_call(entity.device, "remove_part", remove, "delete_entity")
        self.spawned.pop(entity.name, None)
        device = self.link.devices[entity.device]
        if entity.local in device.parts:
            device.parts.remove(entity.local)

    async def _spawnables(self, request: GetSpawnables.Request, response: Any) -> None:
        found: list[Spawnable] = []
        unrecognized: list[str] = []
        for source in [*self.p.part_directories, *request.sources]:
            if not source:
                continue
            path = Path(source.removeprefix("file://"))
            files = sorted(path.iterdir()) if path.is_dir() else [path] if path.is_file() else []
            if not files:
                unrecognized.append(source)
            for file in files:
                if len(found) >= MAX_SPAWNABLES or file.suffix.lower() not in PART_SUFFIXES:
                    continue
                try:
                    part = read_spawnable(str(file), "").part
                except SimulationError:
                    continue  # a YAML file that is no part file (a program, a scene) is not spawnable
                found.append(
                    Spawnable(uri=f"file://{file.resolve()}", description=f"part {part.name} ({file.name})")
                )
        response.spawnables = found
        if unrecognized:
            response.result = result_msg(
                OK, f"sources not found (no directory or file): {', '.join(unrecognized)}"
            )


def main(args: list[str] | None = None) -> None:
    """Run the simulation node."""
    run_node(CellSimulation, "cell_simulation", args)


if __name__ == "__main__":
    main()
