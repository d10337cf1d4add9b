"""The 'dynamic' fidelity: rigid bodies with inertia, surface friction and collisions (pymunk).

One part alone has no contacts, so it is integrated directly (semi-implicit Euler, the same scheme
pymunk uses) and pymunk is not even imported; several parts share a pymunk space whose shapes are
ear-clipped triangles of each outer boundary (holes do not take part in collisions). The world sees
the bodies and a force model only, never the scene that owns it.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from feeder_planner.mems.fields import Field
from feeder_sim.mems.bodies import Body, ForceModel, drag_coefficients, inertia, wrench_on
from feeder_sim.mems.tolerances import COLLISION_FRICTION, EAR_CLIP_PASSES

if TYPE_CHECKING:
    import pymunk

__all__ = ["ear_clip", "DynamicWorld"]


def _cross(o: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """Return (a - o) x (b - o): > 0 when o, a, b turn counter-clockwise."""
    return float((a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]))


def _is_ear(loop: np.ndarray, idx: list[int], k: int) -> bool:
    """Return whether vertex idx[k] is an ear: convex, and no other remaining vertex in its triangle."""
    i, j, m = idx[k - 1], idx[k], idx[(k + 1) % len(idx)]
    a, b, c = loop[i], loop[j], loop[m]
    if _cross(a, b, c) <= 0:
        return False
    for other in idx:
        if other in (i, j, m):
            continue
        p = loop[other]
        if _cross(a, b, p) >= 0 and _cross(b, c, p) >= 0 and _cross(c, a, p) >= 0:
            return False
    return True


def ear_clip(loop: np.ndarray) -> list[np.ndarray]:
    """Return triangles covering a simple counter-clockwise polygon (the last one what remains)."""
    idx = list(range(len(loop)))
    triangles = []
    passes = 0
    while len(idx) > 3 and passes < EAR_CLIP_PASSES * len(loop) ** 2:
        passes += 1
        for k in range(len(idx)):
            if _is_ear(loop, idx, k):
                triangles.append(loop[[idx[k - 1], idx[k], idx[(k + 1) % len(idx)]]])
                idx.pop(k)
                break
    triangles.append(loop[idx])
    return triangles


class DynamicWorld:
    """Newtonian motion: m dv/dt = F_field - damping A v - Coulomb, with collisions when several parts."""

    def __init__(
        self, bodies: list[Body], forces: ForceModel, damping: float, friction: float, gravity: float
    ) -> None:
        self.bodies = bodies
        self.forces = forces
        self.damping = float(damping)
        self.friction = float(friction)
        self.gravity = float(gravity)
        self.space: pymunk.Space | None = None  # with several parts (pymunk ships no types: Any to mypy)
        self.handles: list[pymunk.Body] = []
        if len(bodies) > 1:
            self._build_space()

    def _build_space(self) -> None:
        """Put every body into a pymunk space (imported only here: several parts can collide)."""
        import pymunk

        self.space = pymunk.Space()
        self.handles = []
        for body in self.bodies:
            self.handles.append(self._add_handle(body))

    def _add_handle(self, body: Body) -> pymunk.Body:
        """Put ``body`` into the space at its pose and velocity, its outer boundary as triangles."""
        import pymunk

        assert self.space is not None
        part = body.part
        mass = inertia(part)
        handle = pymunk.Body(mass[0], mass[2])
        self._sync(body, handle)
        shapes = [pymunk.Poly(handle, [tuple(map(float, p)) for p in tri]) for tri in ear_clip(part.outer)]
        for shape in shapes:
            shape.friction = COLLISION_FRICTION
        self.space.add(handle, *shapes)
        return handle

    @staticmethod
    def _sync(body: Body, handle: pymunk.Body) -> None:
        """Put the body's pose and velocity into its pymunk handle."""
        handle.position = (float(body.pose[0]), float(body.pose[1]))
        handle.angle = float(body.pose[2])
        handle.velocity = (float(body.velocity[0]), float(body.velocity[1]))
        handle.angular_velocity = float(body.velocity[2])

    def added(self) -> None:
        """Take in the body just appended to the shared list of bodies (a space once there are several)."""
        if self.space is not None:
            self.handles.append(self._add_handle(self.bodies[-1]))
        elif len(self.bodies) > 1:
            self._build_space()

    def removed(self, index: int) -> None:
        """Let go of the body that was at ``index`` of the shared list (one part left: no space)."""
        if self.space is None:
            return
        handle = self.handles.pop(index)
        self.space.remove(handle, *handle.shapes)
        if len(self.bodies) <= 1:  # a part alone has no contacts: integrated directly again
            self.space, self.handles = None, []

    def placed(self, index: int) -> None:
        """Move body ``index``'s handle to the pose and velocity the body was given (a placement)."""
        if self.space is not None:
            self._sync(self.bodies[index], self.handles[index])

    def _external(self, body: Body, field: Field) -> np.ndarray:
        """Return the field's wrench plus viscous drag and Coulomb surface friction on the body."""
        part = body.part
        w = wrench_on(body, self.forces, field)
        body.wrench = w
        drag = -drag_coefficients(part, self.damping) * body.velocity
        total = w + drag
        # Coulomb friction with the surface: opposes sliding, never reverses it within a step.
        speed = math.hypot(body.velocity[0], body.velocity[1])
        if self.friction > 0 and speed > 0:
            total[:2] -= self.friction * part.mass * self.gravity * body.velocity[:2] / speed
        return total

    def step(self, dt: float, field: Field) -> None:
        """Advance every body by dt seconds in ``field``."""
        if self.space is None:
            for body in self.bodies:
                total = self._external(body, field)
                body.velocity = body.velocity + dt * total / inertia(body.part)
                body.pose = body.pose + dt * body.velocity
                body.pose[2] %= 2 * math.pi
            return
        for body, handle in zip(self.bodies, self.handles, strict=True):
            total = self._external(body, field)
            handle.force = (float(total[0]), float(total[1]))
            handle.torque = float(total[2])
        self.space.step(dt)
        for body, handle in zip(self.bodies, self.handles, strict=True):
            body.pose = np.array([handle.position.x, handle.position.y, handle.angle % (2 * math.pi)])
            body.velocity = np.array([handle.velocity.x, handle.velocity.y, handle.angular_velocity])
