"""The cell as the standard's world: its entities, and stopping, resetting, setting, spawning, deleting.

Rules from ``entities`` and ``spawning``, calls through ``cell_link`` (the devices' own services). Which
entities exist now is ``entity_list``'s, their states ``entity_states``'s, where a request's pose lands
``placement``'s; this module holds what a request does to which device, and the spawned parts a STATE
reset spawns again. Poses arrive as plain tuples (``msgs`` converts them).
"""

from __future__ import annotations

import math
import time
from typing import Callable

from feeder_cell.simulation.cell_link import CellLink, Device
from feeder_cell.simulation.control import Reset
from feeder_cell.simulation.entities import Entity, EntityState, Sphere
from feeder_cell.simulation.entity_list import EntityList, SpawnRecord
from feeder_cell.simulation.entity_states import EntityStates
from feeder_cell.simulation.placement import Placement
from feeder_cell.simulation.results import (
    NAME_INVALID,
    NAME_NOT_UNIQUE,
    OPERATION_FAILED,
    SimulationError,
)
from feeder_cell.simulation.spawnables import MAX_FILES_PER_SOURCE, MAX_SPAWNABLES
from feeder_cell.simulation.spawnables import spawnables as list_spawnables
from feeder_cell.simulation.spawning import Spawnable, check_name, check_namespace, planar_pose
from feeder_msgs.srv import ArmPlacePart, MemsPlaceParts, MemsRemovePart, MemsSpawnPart
from feeder_planner.assembly.model import Body
from feeder_planner.node_kit.msg_parts import part_from_msg

__all__ = ["CellWorld", "SpawnRecord", "Pose", "MAX_SPAWNABLES", "MAX_FILES_PER_SOURCE"]

Pose = tuple[tuple[float, float, float], tuple[float, float, float, float]]  # position, quaternion x y z w


class CellWorld:
    """The entities of the cell now, and the requests that change them."""

    def __init__(self, link: CellLink, now_ns: Callable[[], int]) -> None:
        self.link = link
        self.now_ns = now_ns
        self.spawned: dict[str, SpawnRecord] = {}
        self.stopped = False
        self.stopped_active: list[str] = []
        self.bodies: dict[str, list[Body]] = {}  # a fixture's assembly bodies, read once (read-only)
        # The concerns this world's requests use; ``spawned`` and ``bodies`` are shared with them (the
        # same dicts, never rebound).
        self.placement = Placement(link)
        self.states = EntityStates(link, now_ns, self.placement, self.bodies)
        self.listing = EntityList(link, self.spawned, self.bodies, self.states)

    # --- lifecycle: STOPPED and back, resets ---------------------------------------------------------
    async def stop(self) -> str:
        """Set the clock back to its start, reset every device there and hold it inactive (STOPPED).

        Returns '' or why time was not reset (``rewind``).
        """
        self.stopped_active = [fqn for fqn in self.link.devices if await self.link.lifecycle(fqn) == "active"]
        why = await self.rewind()
        self.spawned.clear()
        for fqn in self.link.devices:
            if await self.link.reconfigure(fqn, activate=False):
                await self.states.initial_states(self.link.devices[fqn])
        self.stopped = True
        return why

    async def start(self) -> None:
        """Activate the devices ``stop`` held (leaving STOPPED)."""
        for fqn in self.stopped_active:
            await self.link.transition(fqn, "activate")
        self.stopped_active, self.stopped = [], False

    async def rewind(self) -> str:
        """Set the held cell clock back to its start; return '' or why it was not (nothing changed then).

        First, with every device as it is: paused, no device ticks at the start, so the reconfiguration
        that follows puts each at its configured initial state there, its tick grid starting there, as at
        launch. This node's own clock follows (its /clock) before the states are stamped.
        """
        start_ns, why = await self.link.rewind()
        if why:
            return why
        deadline = time.monotonic() + self.link.timeout_s
        while self.now_ns() != start_ns:
            if time.monotonic() > deadline:
                raise SimulationError(
                    OPERATION_FAILED, f"rewind: /clock did not read the start time {start_ns} ns here"
                )
            await self.link.sleep(0.01)
        return ""

    async def reset(self, reset: Reset) -> str:
        """Reset time (``rewind``), device state (reconfigure, spawn the spawned parts again), spawned parts.

        Returns '' or why time was not reset.
        """
        running = reset.time and not await self.link.paused()
        if running:
            await self.link.pause(True)  # the clock goes back only while held: after the present quantum
        try:
            return await self._reset(reset)
        finally:
            if running:
                await self.link.pause(False)

    async def _reset(self, reset: Reset) -> str:
        why = await self.rewind() if reset.time else ""
        if reset.state:
            kept = [] if reset.spawned else list(self.spawned.values())
            self.spawned.clear()
            for fqn in self.link.devices:
                if await self.link.reconfigure(fqn, activate=None):
                    await self.states.initial_states(self.link.devices[fqn])
            for record in kept:
                await self._spawn_record(record)
                x, y, theta = record.pose
                half = 0.5 * theta
                pose = ((x, y, 0.0), (0.0, 0.0, math.sin(half), math.cos(half)))
                self.states.placed(self.link.devices[record.device], record.name, pose)
        elif reset.spawned:
            for name, record in list(self.spawned.items()):
                remove = MemsRemovePart.Request(name=record.name)
                await self.link.device_call(record.device, "remove_part", remove, "reset")
                del self.spawned[name]
                self.link.devices[record.device].parts = [
                    p for p in self.link.devices[record.device].parts if p != record.name
                ]
        return why

    # --- entities (``entity_list``) and their states (``entity_states``) ------------------------------
    async def observe_fixtures(self) -> None:
        """Read the assembly of every fixture not read yet, and place every device's frame in the cell."""
        await self.listing.observe_fixtures()

    def entities(self) -> list[Entity]:
        """Return every entity of the cell now: the devices and the parts they hold."""
        return self.listing.entities()

    def entity(self, name: str) -> Entity:
        """Return the entity named ``name``, or raise NOT_FOUND."""
        return self.listing.entity(name)

    def selected(
        self, pattern: str, categories: list[int], tags: list[str], sphere: Sphere | None
    ) -> list[Entity]:
        """Return the entities the standard's filters select (a sphere: by their states' positions)."""
        return self.listing.selected(pattern, categories, tags, sphere)

    def state_of(self, entity: Entity) -> EntityState:
        """Return the latest observed state (a device: its base frame's pose in the cell, /tf_static)."""
        return self.states.state_of(entity)

    # --- setting, spawning, deleting ------------------------------------------------------------------
    async def set_state(self, name: str, frame_id: str, pose: Pose, code: int) -> None:
        """Place a part at rest at ``pose`` (twist and acceleration checked by the caller)."""
        await self.link.observe_device_frames()
        entity = self.listing.entity(name)
        if entity.kind == "device":
            raise SimulationError(
                OPERATION_FAILED, f"entity: {entity.name} is fixed in the cell (its cell_pose parameter)"
            )
        if entity.kind == "fixture_body":
            raise SimulationError(
                OPERATION_FAILED, f"entity: {entity.name} is held by the fixture: tilt the fixture"
            )
        device = self.link.devices[entity.device]
        pose = self.placement.in_device_frame(device, frame_id, pose, "state.header.frame_id", code)
        if entity.kind == "array_part":
            x, y, theta = planar_pose(*pose, "state.pose", code)
            place = MemsPlaceParts.Request(names=[entity.local], x=[x], y=[y], theta=[theta])
            await self.link.device_call(device.fqn, "place_parts", place, "set_entity_state")
        else:
            part = part_from_msg(device.part_documents[entity.local])
            edge, radius = await self.placement.arm_rest(device, part, pose, "state.pose", code)
            place_arm = ArmPlacePart.Request(edge=edge, radius=radius)
            await self.link.device_call(device.fqn, "place_part", place_arm, "set_entity_state")
        self.states.placed(device, entity.local, pose)

    async def spawn(
        self,
        spawnable: Spawnable,
        name: str,
        allow_renaming: bool,
        namespace: str,
        frame_id: str,
        pose: Pose,
        code: int,
    ) -> str:
        """Spawn a part onto the device the pose's frame names (or whose plane a world pose lies in).

        Returns its entity name. A spawn never removes another entity: the arm, which holds one part,
        refuses a second. ``namespace`` is the standard's: a ROS namespace for the entity's interfaces
        (a part has none), checked and recorded, never a device choice.
        """
        check_namespace(namespace)
        await self.link.observe_device_frames()
        device, local = self.placement.device_for_spawn(frame_id, pose, code)
        if device.kind == "throwing_arm":
            held = (
                ", ".join(f"{device.fqn.lstrip('/')}/{p}" for p in self.listing.parts_of(device))
                or "its part"
            )
            raise SimulationError(
                OPERATION_FAILED,
                f"initial_pose: {device.fqn} holds one part ({held}) and a spawn never removes another "
                "entity; SetEntityState moves that part, the arm's own ~/load_part replaces it",
            )
        name = self._spawn_name(device, spawnable, name, allow_renaming)
        at = planar_pose(*local, "initial_pose.pose", code)
        await self._spawn_record(SpawnRecord(device.fqn, name, spawnable, at, namespace))
        self.states.placed(device, name, local)
        return f"{device.fqn.lstrip('/')}/{name}"

    def _spawn_name(self, device: Device, spawnable: Spawnable, name: str, allow_renaming: bool) -> str:
        """Return the name a spawned part takes on ``device``: asked, the document's, or renamed."""
        if not name:
            if spawnable.named:
                name = spawnable.part.name
            elif allow_renaming:
                name = "part"
            else:
                raise SimulationError(
                    NAME_INVALID,
                    "name: empty, the part document names none and allow_renaming is false",
                )
        name = check_name(name)
        taken = set(self.listing.parts_of(device))
        if name in taken:
            if not allow_renaming:
                raise SimulationError(
                    NAME_NOT_UNIQUE, f"name: {device.fqn} already holds a part named {name!r}"
                )
            name = next(f"{name}_{k}" for k in range(2, 10_000) if f"{name}_{k}" not in taken)
        return name

    async def delete(self, name: str) -> None:
        """Remove a part from the array (the arm's one part and the devices are not deleted)."""
        entity = self.listing.entity(name)
        if entity.kind == "device":
            raise SimulationError(
                OPERATION_FAILED, f"entity: {entity.name} is a device of the scene; it is not deleted"
            )
        if entity.kind == "fixture_body":
            raise SimulationError(
                OPERATION_FAILED, f"entity: {entity.name} is a body of the fixture's assembly"
            )
        if entity.kind == "arm_part":
            raise SimulationError(
                OPERATION_FAILED,
                f"entity: the throwing arm always holds one part ({entity.name}): SetEntityState moves "
                "it, the arm's own ~/load_part replaces it",
            )
        remove = MemsRemovePart.Request(name=entity.local)
        await self.link.device_call(entity.device, "remove_part", remove, "delete_entity")
        self.spawned.pop(entity.name, None)
        device = self.link.devices[entity.device]
        if entity.local in device.parts:
            device.parts.remove(entity.local)

    @staticmethod
    def spawnables(sources: list[str]) -> tuple[list[tuple[str, str]], list[str]]:
        """Return (uri, description) of every part file in ``sources``, and the sources found empty."""
        return list_spawnables(sources)

    async def _spawn_record(self, record: SpawnRecord) -> None:
        device = self.link.devices[record.device]
        x, y, theta = record.pose
        request = MemsSpawnPart.Request(
            name=record.name,
            part_yaml=record.spawnable.text,
            source=record.spawnable.source,
            x=x,
            y=y,
            theta=theta,
        )
        await self.link.device_call(device.fqn, "spawn_part", request, "spawn_entity")
        self.spawned[f"{device.fqn.lstrip('/')}/{record.name}"] = record
