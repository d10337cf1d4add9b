"""Where a request's pose lands: the cell's static frames, each device's frame, the device a spawn goes to.

A pose comes in the world or in a device's frame; a device takes it in its own frame, and the throwing
arm as the rest (edge, radius) it stands for. Separate from the entities and their states because it
answers a different question: not what is in the cell, but which device and which frame a pose given to
SetEntityState or SpawnEntity means (``frames`` composes, ``spawning`` checks what a device can hold).
"""

from __future__ import annotations

from feeder_cell.simulation.cell_link import CellLink, Device
from feeder_cell.simulation.frames import WORLD, Frames, Pose
from feeder_cell.simulation.results import SimulationError
from feeder_cell.simulation.spawning import arm_rest, planar_pose
from feeder_planner.parts import Part
from feeder_planner.throwing.geometry import arm_part

__all__ = ["Placement"]


class Placement:
    """The frames poses are given in, and the device (and the pose in its frame) a request's pose means."""

    def __init__(self, link: CellLink) -> None:
        self.link = link

    @property
    def frames(self) -> Frames:
        """The static frame tree as last seen (``world`` its root)."""
        return Frames(self.link.cell_frames)

    def frame_of(self, device: Device) -> str:
        """Return the frame the device's parts are in (its streams' frame, else its base frame)."""
        self.link.refresh(device)
        return device.frame_id or device.base_frame

    def in_device_frame(self, device: Device, frame_id: str, pose: Pose, field: str, code: int) -> Pose:
        """Return ``pose`` in the device's frame: given in the world ('', world) or in that frame."""
        frame = self.frame_of(device)
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

    def device_for_spawn(self, frame_id: str, pose: Pose, code: int) -> tuple[Device, Pose]:
        """Return the device a spawn goes to and the pose in its frame (SpawnEntity: the pose's frame)."""
        field = "initial_pose.header.frame_id"
        holders = [d for d in self.link.devices.values() if d.kind != "assembly_fixture"]
        frames = {d.fqn: self.frame_of(d) for d in holders}
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

    async def arm_rest(
        self, device: Device, part: Part, pose: Pose, field: str, code: int
    ) -> tuple[int, float]:
        """Return the arm's rest (edge, radius) a pose in its frame stands for (the arm's offset read)."""
        x, y, yaw = planar_pose(*pose, field, code)
        offset = float(await self.link.parameter(device.fqn, "offset"))
        geometry = arm_part(part)
        return arm_rest(x, y, yaw, geometry.edge_angle, geometry.d, offset, field, code)
