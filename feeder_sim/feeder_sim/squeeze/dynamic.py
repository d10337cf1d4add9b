"""The dynamic fidelity: a squeeze simulated with pymunk, with Coulomb friction at the jaws and jaw speed.

Goldberg's model assumes frictionless jaws and a quasi-static squeeze. Here the part is a rigid convex
polygon (its hull) lying on a table that resists its motion (linear and angular damping, the table's
support friction, which keeps the motion slow as the quasi-static model assumes), and each jaw is a heavy
pad driven towards the part by a bounded force at up to half the closing speed, sliding along the
gripper's x axis only. Friction between pads and part is ``friction`` (pymunk multiplies the two shapes'
coefficients; the part's is 1). The squeeze ends when the jaws and the part have been still for
``settle_time``, or at ``max_time``; the outcome is the part's orientation relative to the gripper and
the gap between the pads, the width the jaw sensor reads.

Lengths are simulated in millimetres (pymunk's tolerances are absolute: a part a few centimetres across
is then tens of units). What it does not model: pad compliance, the part's out-of-plane motion.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pymunk

from feeder_planner.errors import SolverError
from feeder_planner.squeeze import check_friction, convex_hull

__all__ = ["DynamicOutcome", "DynamicSettings", "dynamic_squeeze"]

MM = 1000.0  # simulation units per metre


@dataclass(frozen=True)
class DynamicSettings:
    """The model's constants: step (s), table damping (fraction of velocity kept per s), pad force, stops."""

    step: float = 5e-4
    linear_damping: float = 0.02  # velocity kept after 1 s of sliding on the table
    pad_force_per_mass: float = 4.0e4  # mm/s^2 of the pad drive on a part of unit mass
    pad_mass_ratio: float = 50.0
    settle_time: float = 0.05
    still_speed: float = 0.5  # mm/s (pads) and the part's speed at its hull radius
    max_time: float = 20.0


@dataclass(frozen=True)
class DynamicOutcome:
    """A dynamic squeeze's end: orientation relative to the gripper (rad), width (m), time (s), steps."""

    orientation: float
    width: float
    time: float
    steps: int


def _pad(space: pymunk.Space, side: int, x: float, half: float, mass: float, friction: float) -> pymunk.Body:
    """Add a jaw pad at x (its face towards the part), sliding along x only."""
    body = pymunk.Body(mass, math.inf)
    body.position = (x + side * half * 0.5, 0.0)
    shape = pymunk.Poly.create_box(body, (half, 4.0 * half))
    shape.friction = friction
    space.add(body, shape)
    groove = pymunk.GrooveJoint(space.static_body, body, (-1e6, 0.0), (1e6, 0.0), (0.0, 0.0))
    space.add(groove)
    return body


def dynamic_squeeze(
    vertices: object,
    theta: float,
    friction: float,
    jaw_speed: float,
    settings: DynamicSettings = DynamicSettings(),
) -> DynamicOutcome:
    """Squeeze the part (outline in metres) from orientation ``theta`` relative to the gripper.

    ``jaw_speed`` (m/s) is the closing speed (each pad moves at half of it); ``friction`` the Coulomb
    coefficient between pads and part, in [0, MAX_FRICTION]. Raises SolverError if the simulation leaves
    the squeeze's geometry (a pad passing through the part).
    """
    friction = check_friction(friction)
    if not (math.isfinite(jaw_speed) and jaw_speed > 0.0):
        raise SolverError(f"jaw_speed must be > 0 m/s, got {jaw_speed!r}")
    hull = convex_hull(vertices) * MM
    # The part's body frame at its area centroid: pymunk's moment and rotation are about it.
    area, cx, cy = 0.0, 0.0, 0.0
    for i in range(len(hull)):
        x0, y0 = hull[i]
        x1, y1 = hull[(i + 1) % len(hull)]
        cross = x0 * y1 - x1 * y0
        area += cross / 2.0
        cx += (x0 + x1) * cross / 6.0
        cy += (y0 + y1) * cross / 6.0
    centred = hull - np.array([cx / area, cy / area])
    radius = float(np.hypot(centred[:, 0], centred[:, 1]).max())
    space = pymunk.Space()
    space.iterations = 30
    mass = 1.0
    part = pymunk.Body(mass, pymunk.moment_for_poly(mass, centred.tolist()))
    part.angle = theta
    shape = pymunk.Poly(part, centred.tolist())
    shape.friction = 1.0
    space.add(part, shape)
    keep = settings.linear_damping

    def table(body: pymunk.Body, gravity: tuple[float, float], damping: float, dt: float) -> None:
        # The table's support friction as damping, on the part only (the pads' drive is their own).
        pymunk.Body.update_velocity(body, gravity, keep**dt, dt)

    part.velocity_func = table
    speed = 0.5 * jaw_speed * MM
    pad_mass = settings.pad_mass_ratio * mass
    force = settings.pad_force_per_mass * mass
    start = 1.2 * radius
    pads = [_pad(space, side, side * start, radius, pad_mass, friction) for side in (-1, 1)]

    def drive(side: int) -> object:
        def update(body: pymunk.Body, gravity: tuple[float, float], damping: float, dt: float) -> None:
            vx = body.velocity.x - side * force / pad_mass * dt
            vx = max(-speed, min(speed, vx))
            body.velocity = (vx, 0.0)

        return update

    for side, pad in zip((-1, 1), pads, strict=True):
        pad.velocity_func = drive(side)
    step, still_for, t, steps = settings.step, 0.0, 0.0, 0
    while t < settings.max_time:
        space.step(step)
        t += step
        steps += 1
        moving = max(abs(p.velocity.x) for p in pads)
        part_speed = float(abs(part.angular_velocity) * radius + abs(part.velocity))
        gap = (pads[1].position.x - 0.5 * radius) - (pads[0].position.x + 0.5 * radius)
        if gap < 0.0:
            raise SolverError("the jaws passed through the part (pymunk step too long for the jaw speed)")
        touching = gap < 2.0 * radius
        if touching and moving < settings.still_speed and part_speed < settings.still_speed:
            still_for += step
            if still_for >= settings.settle_time:
                break
        else:
            still_for = 0.0
    return DynamicOutcome(float(part.angle), gap / MM, t, steps)
