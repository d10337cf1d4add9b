"""The latest state of each entity: observed, placed since the last sample, or configured.

A device's state is its base frame's pose in the cell (``/tf_static``); a fixture's body is its centre of
mass in the assembly frame; a part's is what its device last sampled, or what a request placed it at
since, or, right after a reconfiguration, the configured initial state (built from the device's own
parameters by the device's own ROS-free model). Separate from the entity list because it answers where
an entity is, not which entities exist; GetEntityState and a sphere filter both ask it.
"""

from __future__ import annotations

import math
from typing import Callable

from feeder_cell.simulation.cell_link import CellLink, Device
from feeder_cell.simulation.entities import Entity, EntityState
from feeder_cell.simulation.frames import WORLD, Pose
from feeder_cell.simulation.placement import Placement
from feeder_cell.simulation.results import OPERATION_FAILED, SimulationError
from feeder_planner.assembly.model import Body
from feeder_planner.errors import InputError
from feeder_planner.parameter_specs import from_values, specs_of
from feeder_sim.mems.configure import configure_scene
from feeder_sim.mems.parameters import MemsParameters
from feeder_sim.node_kit.msg_mems import part_state_msgs
from feeder_sim.throwing.parameters import ArmParameters, configure_arm

__all__ = ["EntityStates"]


class EntityStates:
    """Each entity's latest state, and the states a placement or a reconfiguration sets until the next sample.

    ``bodies`` is the world's dict of the fixtures' assembly bodies (read here, filled by the entity list).
    """

    def __init__(
        self,
        link: CellLink,
        now_ns: Callable[[], int],
        placement: Placement,
        bodies: dict[str, list[Body]],
    ) -> None:
        self.link = link
        self.now_ns = now_ns
        self.placement = placement
        self.bodies = bodies

    def state_of(self, entity: Entity) -> EntityState:
        """Return the latest observed state (a device: its base frame's pose in the cell, /tf_static)."""
        device = self.link.devices[entity.device]
        if entity.kind == "device":
            return self._device_state(device)
        if entity.kind == "fixture_body":
            return self._body_state(device, entity)
        return self._part_state(device, entity)

    def _device_state(self, device: Device) -> EntityState:
        if device.base_frame not in self.link.cell_frames:
            raise SimulationError(
                OPERATION_FAILED,
                f"entity: no /tf_static transform of {device.base_frame} seen yet (configure the device)",
            )
        position, orientation = self.placement.frames.in_world(device.base_frame)
        return EntityState(WORLD, self.now_ns(), position, orientation)

    def _body_state(self, device: Device, entity: Entity) -> EntityState:
        # Held in the assembly frame, which tilts with the table on /tf: the centre of mass, static.
        body = next(b for b in self.bodies[device.fqn] if b.name == entity.local)
        stamp = self.now_ns()
        return EntityState(
            device.frame_id, stamp, (float(body.center[0]), float(body.center[1]), float(body.center[2]))
        )

    def _part_state(self, device: Device, entity: Entity) -> EntityState:
        state = self.link.state_of(device, entity.local)
        if state is None:
            raise SimulationError(
                OPERATION_FAILED,
                f"entity: {entity.name}: no state since the device was (re)configured; step once",
            )
        return self.placement.frames.state_in_world(state)

    def placed(self, device: Device, name: str, pose: Pose) -> None:
        """Remember a pose set or spawned (device frame): its state until the device's next sample."""
        device.placed[name] = EntityState(self.placement.frame_of(device), self.now_ns(), *pose)

    async def initial_states(self, device: Device) -> None:
        """Take the configured initial state of the device's parts as their state until its next sample.

        The device's own ROS-free model is built from the parameters it was configured with (the same
        code its configure runs: ``configure_scene``, ``configure_arm``), so the state is exact, seeds
        included. A device whose parameters cannot be read or built leaves its parts without a state
        (GetEntityState says: step once).
        """
        frame, now = self.placement.frame_of(device), self.now_ns()
        try:
            if device.kind == "mems_field_array":
                await self._mems_initial_states(device, frame, now)
            elif device.kind == "throwing_arm":
                await self._arm_initial_states(device, frame, now)
        except (InputError, SimulationError, TypeError, ValueError):
            return

    async def _mems_initial_states(self, device: Device, frame: str, now: int) -> None:
        names = [spec.name for spec in specs_of(MemsParameters)]
        values = await self.link.parameters(device.fqn, names)
        configured = configure_scene(from_values(MemsParameters, values))
        for state in part_state_msgs(configured.names, configured.scene.bodies):
            p, q, v, w = (
                state.pose.position,
                state.pose.orientation,
                state.twist.linear,
                state.twist.angular,
            )
            device.placed[state.name] = EntityState(
                frame, now, (p.x, p.y, p.z), (q.x, q.y, q.z, q.w), (v.x, v.y, v.z), (w.x, w.y, w.z)
            )

    async def _arm_initial_states(self, device: Device, frame: str, now: int) -> None:
        names = [spec.name for spec in specs_of(ArmParameters)]
        values = await self.link.parameters(device.fqn, names)
        x, y, theta = configure_arm(from_values(ArmParameters, values)).rest_pose()
        half = 0.5 * theta
        for part in device.parts:
            device.placed[part] = EntityState(
                frame, now, (x, y, 0.0), (0.0, 0.0, math.sin(half), math.cos(half))
            )
