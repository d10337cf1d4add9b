"""ROS 2 node: the cell as a simulator of the ROS 2 simulation standard (``simulation_interfaces``).

`feeder launch SCENE --real-time-factor F|max` starts it as ``/cell_simulation`` beside the cell clock,
with the scene's devices as parameters; its services and action are under its own name
(``/cell_simulation/step_simulation``, ...). What each does, the entity names, frames and units:
docs/cell.md, "Driving the cell with simulation_interfaces". The rules live in ``feeder_cell.simulation``
(states, steps and resets; entities and filters; what a spawn or a set accepts); the calls to the clock
and the devices in ``simulation.cell_link``. One request that changes the cell runs at a time; a second
is answered INCORRECT_STATE while it runs, except a SetSimulationState during a step, which ends the step
at its next chunk of quanta and is then carried out. Reads answer from what the node has observed. What
is supported, row by row as the standard's features: ``simulation.support`` (docs/cell.md repeats it).
"""

from __future__ import annotations

from typing import Any, Awaitable, Callable

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.node import Node
from simulation_interfaces.action import SimulateSteps
from simulation_interfaces.msg import EntityInfo, SimulationState, SimulatorFeatures, Spawnable
from simulation_interfaces.srv import (
    DeleteEntity,
    GetEntities,
    GetEntitiesStates,
    GetEntityInfo,
    GetEntityState,
    GetSimulationState,
    GetSimulatorFeatures,
    GetSpawnables,
    ResetSimulation,
    SetEntityState,
    SetSimulationState,
    SpawnEntity,
    StepSimulation,
)
from std_msgs.msg import Header

from feeder_cell.simulation import control
from feeder_cell.simulation.cell_link import KINDS, CellLink
from feeder_cell.simulation.entities import Entity, Sphere
from feeder_cell.simulation.msgs import accel_tuple, pose_tuple, result_msg, state_msg, twist_tuples
from feeder_cell.simulation.parameters import CLOCK_HARDWARE_ID, PARAMETERS, STEPPING, SimulationParameters
from feeder_cell.simulation.results import (
    INCORRECT_STATE,
    OK,
    OPERATION_FAILED,
    SET_INVALID_POSE,
    SPAWN_INVALID_POSE,
    SimulationError,
)
from feeder_cell.simulation.spawning import (
    SPAWN_FORMAT,
    check_at_rest,
    read_spawnable,
)
from feeder_cell.simulation.support import FEATURES, custom_info
from feeder_cell.simulation.unsupported import UNSUPPORTED, unsupported
from feeder_cell.simulation.world import CellWorld
from feeder_planner.node_kit import declare_parameters, run_node
from feeder_planner.node_kit.lockstep import ANNOUNCE_TOPIC, LOCKSTEP_QOS
from feeder_planner.parameter_specs import from_values

__all__ = ["SimulationParameters", "PARAMETERS", "CellSimulation", "FEATURES", "main"]


class CellSimulation(Node):
    """Serves the standard's simulation services and the SimulateSteps action for the whole cell."""

    def __init__(self) -> None:
        super().__init__("cell_simulation")
        self.p = from_values(SimulationParameters, declare_parameters(self, PARAMETERS))
        devices = {name: list(getattr(self.p, name)) for name in KINDS}
        self.link = CellLink(self, self.p.clock_node, devices, float(self.p.call_timeout))
        self.quantum_ns = int(round(self.p.quantum * 1e9))
        self.busy = ""  # the request changing the cell now
        self.interrupt = ""  # a state change asked for while a step runs: the step ends between chunks
        # LOADING_WORLD until the clock's lockstep has left its join phase (its /diagnostics say so).
        # The first react announcement says the same at once (the clock announces react phases only once
        # every expected participant has joined); the diagnostics, once a second, cover a clock whose
        # first announcement came before this node listened.
        self.joined = False
        self.diagnostics_sub: Any = self.create_subscription(
            DiagnosticArray, "/diagnostics", self._on_clock_diagnostics, 10, callback_group=self.link.group
        )
        self.settled_sub: Any = self.create_subscription(
            Header, ANNOUNCE_TOPIC["react"], lambda _: self._on_joined(), LOCKSTEP_QOS,
            callback_group=self.link.group,
        )  # fmt: skip
        self.world = CellWorld(self.link, lambda: self.get_clock().now().nanoseconds)
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
            serve(srv, name, unsupported(what), changes=False)
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
            if name == "set_simulation_state" and self.busy in STEPPING:
                self.interrupt = f"SetSimulationState to {int(request.state.state)}"
                while self.busy:  # the step ends at its next chunk boundary
                    await self.link.sleep(0.01)
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

    # --- features and simulation state -------------------------------------------------------------
    async def _features(self, request: Any, response: GetSimulatorFeatures.Response) -> None:
        response.features = SimulatorFeatures(
            features=list(FEATURES),
            spawn_formats=[SPAWN_FORMAT],
            custom_info=custom_info(self.p.quantum),
        )

    async def _current(self) -> int:
        if not await self._joined():
            return control.LOADING_WORLD
        if self.world.stopped:
            return control.STOPPED
        return control.PAUSED if await self.link.paused() else control.PLAYING

    async def _joined(self) -> bool:
        """Whether every expected lockstep participant has joined (a free-running clock: at once)."""
        if not self.joined and not await self.link.clock_in_lockstep():
            self._on_joined()
        return self.joined

    def _on_clock_diagnostics(self, msg: DiagnosticArray) -> None:
        for status in msg.status:
            if status.hardware_id != CLOCK_HARDWARE_ID:
                continue
            phase = next((v.value for v in status.values if v.key == "phase"), "join")
            if phase != "join":
                self._on_joined()

    def _on_joined(self) -> None:
        self.joined = True
        for name in ("diagnostics_sub", "settled_sub"):  # never again: the join happens once
            subscription = getattr(self, name)
            if subscription is not None:
                self.destroy_subscription(subscription)
                setattr(self, name, None)

    async def _get_state(self, request: Any, response: GetSimulationState.Response) -> None:
        response.state = SimulationState(state=await self._current())

    async def _set_state(self, request: SetSimulationState.Request, response: Any) -> None:
        for action in control.transition(await self._current(), int(request.state.state)):
            if action in ("pause", "resume"):
                await self.link.pause(action == "pause")
            elif action == "stop":
                why = await self.world.stop()
                if why:
                    response.result = result_msg(OK, f"stopped; {control.TIME_NOT_RESET} ({why})")
            else:
                await self.world.start()

    # --- steps ---------------------------------------------------------------------------------------
    async def _step(self, request: StepSimulation.Request, response: Any) -> None:
        steps = control.check_steps(int(request.steps), await self._current())
        self.interrupt = ""
        done = 0
        while done < steps:
            if self.interrupt:
                raise SimulationError(
                    OPERATION_FAILED, f"steps: interrupted after {done} of {steps} steps by {self.interrupt}"
                )
            chunk = min(control.STEP_CHUNK, steps - done)
            await self.link.step(chunk, self.quantum_ns)
            done += chunk

    def _accept_steps(self, goal: SimulateSteps.Goal) -> GoalResponse:
        # Every goal is accepted: one that cannot run is aborted with a Result that says why.
        return GoalResponse.ACCEPT

    async def _simulate_steps(self, handle: ServerGoalHandle) -> SimulateSteps.Result:
        result = SimulateSteps.Result()
        steps = int(handle.request.steps)
        if self.busy:
            result.result = result_msg(INCORRECT_STATE, f"busy: {self.busy} is being carried out")
            handle.abort()
            return result
        self.busy = "simulate_steps"
        self.interrupt = ""
        done = 0
        try:
            control.check_steps(steps, await self._current())
            while done < steps:
                if self.interrupt:
                    raise SimulationError(OPERATION_FAILED, f"interrupted by {self.interrupt}")
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
        why = await self.world.reset(reset)
        if why:
            response.result = result_msg(
                OK, f"state and spawned entities reset; {control.TIME_NOT_RESET} ({why})"
            )

    # --- entities ------------------------------------------------------------------------------------
    async def _selected(self, filters: Any) -> list[Entity]:
        await self.world.observe_fixtures()
        points = [(float(p.x), float(p.y), float(p.z)) for p in filters.bounds.points]
        sphere = Sphere.of(int(filters.bounds.type), points)
        categories = [int(c.category) for c in filters.categories]
        return self.world.selected(filters.filter, categories, list(filters.tags.tags), sphere)

    async def _get_entities(self, request: GetEntities.Request, response: Any) -> None:
        response.entities = [e.name for e in await self._selected(request.filters)]

    async def _get_entities_states(self, request: GetEntitiesStates.Request, response: Any) -> None:
        selected = await self._selected(request.filters)
        response.entities = [e.name for e in selected]
        response.states = [state_msg(self.world.state_of(e)) for e in selected]

    async def _get_entity_state(self, request: GetEntityState.Request, response: Any) -> None:
        await self.world.observe_fixtures()
        response.state = state_msg(self.world.state_of(self.world.entity(request.entity)))

    async def _get_entity_info(self, request: GetEntityInfo.Request, response: Any) -> None:
        await self.world.observe_fixtures()
        entity = self.world.entity(request.entity)
        response.info = EntityInfo(description=entity.description)
        response.info.category.category = entity.category

    # --- setting, spawning, deleting ------------------------------------------------------------------
    async def _set_entity_state(self, request: SetEntityState.Request, response: Any) -> None:
        state = request.state
        linear, angular = twist_tuples(state.twist)
        entity = self.world.entity(request.entity)
        check_at_rest(entity.kind, linear, angular, accel_tuple(state.acceleration))
        frame_id = state.header.frame_id
        await self.world.set_state(request.entity, frame_id, pose_tuple(state.pose), SET_INVALID_POSE)

    async def _spawn(self, request: SpawnEntity.Request, response: Any) -> None:
        spawnable = read_spawnable(request.uri, request.resource_string)
        pose = request.initial_pose
        response.entity_name = await self.world.spawn(
            spawnable,
            request.name,
            request.allow_renaming,
            request.entity_namespace,
            pose.header.frame_id,
            pose_tuple(pose.pose),
            SPAWN_INVALID_POSE,
        )

    async def _delete(self, request: DeleteEntity.Request, response: Any) -> None:
        await self.world.delete(request.entity)

    async def _spawnables(self, request: GetSpawnables.Request, response: Any) -> None:
        found, unrecognized = self.world.spawnables([*self.p.part_directories, *request.sources])
        response.spawnables = [Spawnable(uri=uri, description=text) for uri, text in found]
        if unrecognized:
            response.result = result_msg(
                OK, f"sources not found (no directory or file): {', '.join(unrecognized)}"
            )


NODE = CellSimulation  # what the cell host builds (feeder_cell.host)


def main(args: list[str] | None = None) -> None:
    """Run the simulation node."""
    run_node(CellSimulation, "cell_simulation", args)


if __name__ == "__main__":
    main()
