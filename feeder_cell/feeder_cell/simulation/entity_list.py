"""Which entities the cell holds now, and which of them the standard's filters select.

The devices, the parts each holds (as its latched part list last said, and what was spawned since) and
the bodies of each fixture's assembly (read once from its read-only ``assembly_file`` parameter).
Separate from the states (``entity_states``) and from the requests that change the cell (``world``):
GetEntities, GetEntityState and every request naming an entity look an entity up here first.
"""

from __future__ import annotations

from dataclasses import dataclass

from feeder_cell.simulation.cell_link import CellLink, Device
from feeder_cell.simulation.entities import (
    CATEGORY_OBJECT,
    CATEGORY_STATIC_OBJECT,
    Entity,
    Sphere,
    device_entity,
    select,
)
from feeder_cell.simulation.entity_states import EntityStates
from feeder_cell.simulation.frames import WORLD
from feeder_cell.simulation.results import NOT_FOUND, SimulationError
from feeder_cell.simulation.spawning import Spawnable
from feeder_planner.assembly.model import Body
from feeder_planner.assembly.parameters import load_assembly_parameter
from feeder_planner.errors import InputError

__all__ = ["EntityList", "SpawnRecord"]


@dataclass(frozen=True)
class SpawnRecord:
    """A spawned part: enough to spawn it again after a STATE reset."""

    device: str
    name: str
    spawnable: Spawnable
    pose: tuple[float, float, float]  # x, y, theta on the array
    namespace: str = ""  # the request's entity_namespace (a part has no interfaces under it)


class EntityList:
    """The entities of the cell now: devices, their parts, the fixtures' bodies; looked up and filtered.

    ``spawned`` and ``bodies`` are the world's dicts (the same objects): the world records spawns, this
    list reads them, and fills ``bodies`` as fixtures come up.
    """

    def __init__(
        self,
        link: CellLink,
        spawned: dict[str, SpawnRecord],
        bodies: dict[str, list[Body]],
        states: EntityStates,
    ) -> None:
        self.link = link
        self.spawned = spawned
        self.bodies = bodies
        self.states = states

    async def observe_fixtures(self) -> None:
        """Read the assembly of every fixture not read yet (its assembly_file parameter, read-only).

        And place every device's frame in the cell not placed yet (``CellLink.observe_device_frames``).
        """
        await self.link.observe_device_frames()
        for device in self.link.devices.values():
            if device.kind != "assembly_fixture" or device.fqn in self.bodies:
                continue
            try:
                path = await self.link.parameter(device.fqn, "assembly_file")
                self.bodies[device.fqn] = list(load_assembly_parameter(str(path)).bodies)
            except (SimulationError, InputError):
                continue  # not up yet, or no assembly it could load: no bodies listed until it is

    def entities(self) -> list[Entity]:
        """Return every entity of the cell now: the devices and the parts they hold."""
        found: list[Entity] = []
        for device in self.link.devices.values():
            found.append(device_entity(device.fqn, "device", f"{device.kind} device {device.fqn}"))
            kind = "array_part" if device.kind == "mems_field_array" else "arm_part"
            for part in self.parts_of(device):
                name = f"{device.fqn.lstrip('/')}/{part}"
                record = self.spawned.get(name)
                origin = f"spawned from {record.spawnable.source}" if record else "configured"
                if record and record.namespace:
                    origin += f" in namespace {record.namespace}"
                description = f"part {part} on {device.fqn} ({origin})"
                found.append(Entity(name, CATEGORY_OBJECT, description, device.fqn, kind, part, bool(record)))
            for body in self.bodies.get(device.fqn, []):
                category = CATEGORY_STATIC_OBJECT if body.grounded else CATEGORY_OBJECT
                held = "grounded" if body.grounded else "free"
                description = f"body {body.name} ({held}) of the assembly {device.fqn} holds"
                found.append(
                    Entity(
                        f"{device.fqn.lstrip('/')}/{body.name}",
                        category,
                        description,
                        device.fqn,
                        "fixture_body",
                        body.name,
                    )
                )
        return found

    def parts_of(self, device: Device) -> list[str]:
        """Return the device's parts: as its latched topic last said, and what was spawned since."""
        spawned = [r.name for r in self.spawned.values() if r.device == device.fqn]
        return [*device.parts, *(name for name in spawned if name not in device.parts)]

    def entity(self, name: str) -> Entity:
        """Return the entity named ``name``, or raise NOT_FOUND."""
        for entity in self.entities():
            if entity.name == name:
                return entity
        raise SimulationError(NOT_FOUND, f"entity: no entity named {name!r} (GetEntities lists them)")

    def selected(
        self, pattern: str, categories: list[int], tags: list[str], sphere: Sphere | None
    ) -> list[Entity]:
        """Return the entities the standard's filters select.

        A sphere selects an entity whose state's position (world frame) lies in it: entities are taken
        as points. An entity with no state yet is in no sphere.
        """
        found = select(self.entities(), pattern, categories, tags)
        if sphere is None:
            return found
        inside = []
        for entity in found:
            try:
                state = self.states.state_of(entity)
                if state.frame_id != WORLD:
                    state = self.states.placement.frames.state_in_world(state)
            except SimulationError:
                continue
            if sphere.holds(state.position):
                inside.append(entity)
        return inside
