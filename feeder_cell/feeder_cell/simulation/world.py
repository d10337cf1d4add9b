"""The cell as the standard's world: its entities, and stopping, resetting, setting, spawning, deleting.

Rules from ``entities`` and ``spawning``, calls through ``cell_link`` (the devices' own services), so this
module holds only what connects them: which entities exist now, what a request does to which device,
and the spawned parts a STATE reset spawns again. Poses arrive as plain tuples (``msgs`` converts them).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from feeder_cell.simulation.cell_link import CellLink, Device
from feeder_cell.simulation.control import Reset
from feeder_cell.simulation.entities import (
    CATEGORY_OBJECT,
    CATEGORY_STATIC_OBJECT,
    Entity,
    EntityState,
    Sphere,
    device_entity,
    select,
)
from feeder_cell.simulation.frames import WORLD, Frames
from feeder_cell.simulation.results import (
    NAME_INVALID,
    NAME_NOT_UNIQUE,
    NOT_FOUND,
    OPERATION_FAILED,
    SimulationError,
)
from feeder_cell.simulation.spawning import (
    PART_SUFFIXES,
    Spawnable,
    arm_rest,
    check_name,
    check_namespace,
    planar_pose,
    read_spawnable,
)
from feeder_msgs.srv import ArmPlacePart, MemsPlaceParts, MemsRemovePart, MemsSpawnPart
from feeder_planner.assembly.model import Body
from feeder_planner.assembly.parameters import load_assembly_parameter
from feeder_planner.errors import InputError
from feeder_planner.node_kit.msg_parts import part_from_msg
from feeder_planner.parameter_specs import from_values, specs_of
from feeder_planner.parts import Part
from feeder_planner.throwing.geometry import arm_part
from feeder_sim.mems.configure import configure_scene
from feeder_sim.mems.parameters import MemsParameters
from feeder_sim.node_kit.msg_mems import part_state_msgs
from feeder_sim.throwing.parameters import ArmParameters, configure_arm

__all__ = ["CellWorld", "SpawnRecord", "Pose", "MAX_SPAWNABLES", "MAX_FILES_PER_SOURCE"]

Pose = tuple[tuple[float, float, float], tuple[float, float, float, float]]  # position, quaternion x y z w
MAX_SPAWNABLES = 1000
# Files looked at per directory GetSpawnables is given: a huge directory is cut, not read whole.
MAX_FILES_PER_SOURCE = 5000


@dataclass(frozen=True)
class SpawnRecord:
    """A spawned part: enough to spawn it again after a STATE reset."""

    device: str
    name: str
    spawnable: Spawnable
    pose: tuple[float, float, float]  # x, y, theta on the array
    namespace: str = ""  # the request's entity_namespace (a part has no interfaces under it)


class CellWorld:
    """The entities of the cell now, and the requests that change them."""

    def __init__(self, link: CellLink, now_ns: Callable[[], int]) -> None:
        self.link = link
        self.now_ns = now_ns
        self.spawned: dict[str, SpawnRecord] = {}
        self.stopped = False
        self.stopped_active: list[str] = []
        self.bodies: dict[str, list[Body]] = {}  # a fixture's assembly bodies, read once (read-only)

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
                await self._initial_states(self.link.devices[fqn])
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
                    await self._initial_states(self.link.devices[fqn])
            for record in kept:
                await self._spawn_record(record)
                x, y, theta = record.pose
                half = 0.5 * theta
                pose = ((x, y, 0.0), (0.0, 0.0, math.sin(half), math.cos(half)))
                self._placed(self.link.devices[record.device], record.name, pose)
        elif reset.spawned:
            for name, record in list(self.spawned.items()):
                remove = MemsRemovePart.Request(name=record.name)
                await self.link.device_call(record.device, "remove_part", remove, "reset")
                del self.spawned[name]
                self.link.devices[record.device].parts = [
                    p for p in self.link.devices[record.device].parts if p != record.name
                ]
        return why

    async def _initial_states(self, device: Device) -> None:
        """Take the configured initial state of the device's parts as their state until its next sample.

        The device's own ROS-free model is built from the parameters it was configured with (the same
        code its configure runs: ``configure_scene``, ``configure_arm``), so the state is exact, seeds
        included. A device whose parameters cannot be read or built leaves its parts without a state
        (GetEntityState says: step once).
        """
        frame, now = self._frame_of(device), self.now_ns()
        try:
            if device.kind == "mems_field_array":
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
            elif device.kind == "throwing_arm":
                names = [spec.name for spec in specs_of(ArmParameters)]
                values = await self.link.parameters(device.fqn, names)
                x, y, theta = configure_arm(from_values(ArmParameters, values)).rest_pose()
                half = 0.5 * theta
                for part in device.parts:
                    device.placed[part] = EntityState(
                        frame, now, (x, y, 0.0), (0.0, 0.0, math.sin(half), math.cos(half))
                    )
        except (InputError, SimulationError, TypeError, ValueError):
            return

    # --- entities ------------------------------------------------------------------------------------
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
            for part in self._parts_of(device):
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

    def _parts_of(self, device: Device) -> list[str]:
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
                state = self.state_of(entity)
                if state.frame_id != WORLD:
                    state = self.frames.state_in_world(state)
            except SimulationError:
                continue
            if sphere.holds(state.position):
                inside.append(entity)
        return inside

    def state_of(self, entity: Entity) -> EntityState:
        """Return the latest observed state (a device: its base frame's pose in the cell, /tf_static)."""
        device = self.link.devices[entity.device]
        if entity.kind == "device":
            if device.base_frame not in self.link.cell_frames:
                raise SimulationError(
                    OPERATION_FAILED,
                    f"entity: no /tf_static transform of {device.base_frame} seen yet (configure the device)",
                )
            position, orientation = self.frames.in_world(device.base_frame)
            return EntityState(WORLD, self.now_ns(), position, orientation)
        if entity.kind == "fixture_body":
            # Held in the assembly frame, which tilts with the table on /tf: the centre of mass, static.
            body = next(b for b in self.bodies[device.fqn] if b.name == entity.local)
            stamp = self.now_ns()
            return EntityState(
                device.frame_id, stamp, (float(body.center[0]), float(body.center[1]), float(body.center[2]))
            )
        state = self.link.state_of(device, entity.local)
        if state is None:
            raise SimulationError(
                OPERATION_FAILED,
                f"entity: {entity.name}: no state since the device was (re)configured; step once",
            )
        return self.frames.state_in_world(state)

    # --- setting, spawning, deleting ------------------------------------------------------------------
    async def set_state(self, name: str, frame_id: str, pose: Pose, code: int) -> None:
        """Place a part at rest at ``pose`` (twist and acceleration checked by the caller)."""
        await self.link.observe_device_frames()
        entity = self.entity(name)
        if entity.kind == "device":
            raise SimulationError(
                OPERATION_FAILED, f"entity: {entity.name} is fixed in the cell (its cell_pose parameter)"
            )
        if entity.kind == "fixture_body":
            raise SimulationError(
                OPERATION_FAILED, f"entity: {entity.name} is held by the fixture: tilt the fixture"
            )
        device = self.link.devices[entity.device]
        pose = self._in_device_frame(device, frame_id, pose, "state.header.frame_id", code)
        if entity.kind == "array_part":
            x, y, theta = planar_pose(*pose, "state.pose", code)
            place = MemsPlaceParts.Request(names=[entity.local], x=[x], y=[y], theta=[theta])
            await self.link.device_call(device.fqn, "place_parts", place, "set_entity_state")
        else:
            part = part_from_msg(device.part_documents[entity.local])
            edge, radius = await self._arm_rest(device, part, pose, "state.pose", code)
            place_arm = ArmPlacePart.Request(edge=edge, radius=radius)
            await self.link.device_call(device.fqn, "place_part", place_arm, "set_entity_state")
        self._placed(device, entity.local, pose)

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
        device, local = self._device_for_spawn(frame_id, pose, code)
        if device.kind == "throwing_arm":
            held = ", ".join(f"{device.fqn.lstrip('/')}/{p}" for p in self._parts_of(device)) or "its part"
            raise SimulationError(
                OPERATION_FAILED,
                f"initial_pose: {device.fqn} holds one part ({held}) and a spawn never removes another "
                "entity; SetEntityState moves that part, the arm's own ~/load_part replaces it",
            )
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
        taken = set(self._parts_of(device))
        if name in taken:
            if not allow_renaming:
                raise SimulationError(
                    NAME_NOT_UNIQUE, f"name: {device.fqn} already holds a part named {name!r}"
                )
            name = next(f"{name}_{k}" for k in range(2, 10_000) if f"{name}_{k}" not in taken)
        at = planar_pose(*local, "initial_pose.pose", code)
        await self._spawn_record(SpawnRecord(device.fqn, name, spawnable, at, namespace))
        self._placed(device, name, local)
        return f"{device.fqn.lstrip('/')}/{name}"

    async def delete(self, name: str) -> None:
        """Remove a part from the array (the arm's one part and the devices are not deleted)."""
        entity = self.entity(name)
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
        """Return (uri, description) of every part file in ``sources``, and the sources found empty.

        A source is a directory (its part files, at most MAX_FILES_PER_SOURCE looked at) or a file.
        """
        found: list[tuple[str, str]] = []
        unrecognized: list[str] = []
        for source in filter(None, sources):
            path = Path(source.removeprefix("file://"))
            files = (
                sorted(path.iterdir())[:MAX_FILES_PER_SOURCE]
                if path.is_dir()
                else [path]
                if path.is_file()
                else []
            )
            if not files:
                unrecognized.append(source)
            for file in files:
                if len(found) >= MAX_SPAWNABLES or file.suffix.lower() not in PART_SUFFIXES:
                    continue
                try:
                    part = read_spawnable(str(file), "").part
                except SimulationError:
                    continue  # a YAML file that is no part file (a program, a scene) is not spawnable
                found.append((f"file://{file.resolve()}", f"part {part.name} ({file.name})"))
        return found, unrecognized

    # --- helpers -------------------------------------------------------------------------------------
    @property
    def frames(self) -> Frames:
        """The static frame tree as last seen (``world`` its root)."""
        return Frames(self.link.cell_frames)

    def _frame_of(self, device: Device) -> str:
        self.link.refresh(device)
        return device.frame_id or device.base_frame

    def _in_device_frame(self, device: Device, frame_id: str, pose: Pose, field: str, code: int) -> Pose:
        """Return ``pose`` in the device's frame: given in the world ('', world) or in that frame."""
        frame = self._frame_of(device)
        if frame_id == frame:
            return pose
        if not self.frames.is_world(frame_id):
            raise SimulationError(
                code,
                f"{field}: {frame_id!r} is neither the world ('', {WORLD!r}, {self.frames.root()!r}) nor "
                f"{device.fqn}'s frame {frame!r}",
            )
        try:
            return self.frames.from_world(frame, pose)
        except SimulationError as error:
            raise SimulationError(code, f"{field}: {error.message}") from None

    def _device_for_spawn(self, frame_id: str, pose: Pose, code: int) -> tuple[Device, Pose]:
        """Return the device a spawn goes to and the pose in its frame (SpawnEntity: the pose's frame)."""
        field = "initial_pose.header.frame_id"
        holders = [d for d in self.link.devices.values() if d.kind != "assembly_fixture"]
        frames = {d.fqn: self._frame_of(d) for d in holders}
        listed = ", ".join(sorted(frames.values()))
        if not self.frames.is_world(frame_id):
            for device in holders:
                if frames[device.fqn] == frame_id:
                    return device, pose
            raise SimulationError(
                code,
                f"{field}: unknown frame {frame_id!r}: the world ('', {WORLD!r}) or a device frame "
                f"({listed})",
            )
        fits: list[tuple[Device, Pose]] = []
        for device in holders:
            try:
                local = self.frames.from_world(frames[device.fqn], pose)
                planar_pose(*local, "initial_pose.pose", code)
            except SimulationError:
                continue
            fits.append((device, local))
        if len(fits) == 1:
            return fits[0]
        which = "no device's plane" if not fits else "the planes of " + ", ".join(d.fqn for d, _ in fits)
        raise SimulationError(
            code,
            f"initial_pose: in the world frame the pose lies in {which}; give it in a device frame "
            f"({listed})",
        )

    async def _arm_rest(
        self, device: Device, part: Part, pose: Pose, field: str, code: int
    ) -> tuple[int, float]:
        x, y, yaw = planar_pose(*pose, field, code)
        offset = float(await self.link.parameter(device.fqn, "offset"))
        geometry = arm_part(part)
        return arm_rest(x, y, yaw, geometry.edge_angle, geometry.d, offset, field, code)

    def _placed(self, device: Device, name: str, pose: Pose) -> None:
        """Remember a pose set or spawned (device frame): its state until the device's next sample."""
        device.placed[name] = EntityState(self._frame_of(device), self.now_ns(), *pose)

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
