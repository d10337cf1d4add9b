"""The 'dynamic' fidelity: rigid bodies with inertia, surface friction and collisions (pymunk)."""

from __future__ import annotations

# One part alone has no contacts, so it is integrated directly (semi-implicit Euler, the same
# scheme pymunk uses) and pymunk is not even imported; several parts share a pymunk space whose
# shapes are ear-clipped triangles of each outer boundary (holes do not take part in collisions).
import math
from typing import TYPE_CHECKING

import numpy as np

from feeder_planner.mems.fields import Field

if TYPE_CHECKING:
    from feeder_sim.mems.scene import Body, Scene


def ear_clip(loop: np.ndarray) -> list[np.ndarray]:
    """Triangles of a simple counter-clockwise polygon."""
    idx = list(range(len(loop)))
    triangles = []

    def cross(o: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
        return float((a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]))

    guard = 0
    while len(idx) > 3 and guard < 10 * len(loop) ** 2:
        guard += 1
        for k in range(len(idx)):
            i, j, m = idx[k - 1], idx[k], idx[(k + 1) % len(idx)]
            a, b, c = loop[i], loop[j], loop[m]
            if cross(a, b, c) <= 0:
                continue
            inside = False
            for other in idx:
                if other in (i, j, m):
                    continue
                p = loop[other]
                if cross(a, b, p) >= 0 and cross(b, c, p) >= 0 and cross(c, a, p) >= 0:
                    inside = True
                    break
            if not inside:
                triangles.append(np.array([a, b, c]))
                idx.pop(k)
                break
    triangles.append(loop[idx])
    return triangles


class DynamicWorld:
    """Newtonian motion: m dv/dt = F_field - damping A v - Coulomb, with collisions when several parts."""

    def __init__(self, scene: Scene, friction: float, gravity: float) -> None:
        self.scene = scene
        self.friction = float(friction)
        self.gravity = float(gravity)
        self.space = None
        if len(scene.bodies) > 1:
            import pymunk

            self.space = pymunk.Space()
            self.handles = []
            for body in scene.bodies:
                part = body.part
                handle = pymunk.Body(part.mass, part.density * part.polar_moment)
                handle.position = (float(body.pose[0]), float(body.pose[1]))
                handle.angle = float(body.pose[2])
                shapes = [
                    pymunk.Poly(handle, [tuple(map(float, p)) for p in tri]) for tri in ear_clip(part.outer)
                ]
                for shape in shapes:
                    shape.friction = 0.5
                self.space.add(handle, *shapes)
                self.handles.append(handle)

    def _external(self, body: Body, field: Field) -> np.ndarray:
        part = body.part
        w = self.scene.wrench(body, body.pose, field)
        body.wrench = w
        drag = -self.scene.damping * np.array([part.area, part.area, part.polar_moment]) * body.velocity
        total = w + drag
        # Coulomb friction with the surface: opposes sliding, never reverses it within a step.
        speed = math.hypot(body.velocity[0], body.velocity[1])
        if self.friction > 0 and speed > 0:
            total[:2] -= self.friction * part.mass * self.gravity * body.velocity[:2] / speed
        return total

    def step(self, dt: float, field: Field) -> None:
        bodies = self.scene.bodies
        if self.space is None:
            for body in bodies:
                part = body.part
                total = self._external(body, field)
                inertia = np.array([part.mass, part.mass, part.density * part.polar_moment])
                body.velocity = body.velocity + dt * total / inertia
                body.pose = body.pose + dt * body.velocity
                body.pose[2] %= 2 * math.pi
            return
        for body, handle in zip(bodies, self.handles):
            total = self._external(body, field)
            handle.force = (float(total[0]), float(total[1]))
            handle.torque = float(total[2])
        self.space.step(dt)
        for body, handle in zip(bodies, self.handles):
            body.pose = np.array([handle.position.x, handle.position.y, handle.angle % (2 * math.pi)])
            body.velocity = np.array([handle.velocity.x, handle.velocity.y, handle.angular_velocity])
