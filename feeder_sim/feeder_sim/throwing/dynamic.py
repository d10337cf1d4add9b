"""The `dynamic` fidelity: pymunk rigid bodies, finite restitution and Coulomb friction, a kinematic arm that carries."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import pymunk

from feeder_planner.errors import SolverError
from feeder_planner.throwing.geometry import ArmPart
from feeder_planner.throwing.grasp import carry_in_grasp
from feeder_planner.throwing.throw_map import ThrowParams

if TYPE_CHECKING:  # arm.py imports this module, so only the type checker may import arm.py here
    from feeder_sim.throwing.arm import ThrowOutcome

CARRY_ANGLE = 0.02  # rad: the arm turns this far while accelerating to W (a short but real carry)


def dynamic_throw(
    part: ArmPart,
    params: ThrowParams,
    edge: int,
    radius: float,
    step: float = 1e-4,
    elasticity: float = 0.05,
    friction: float | None = None,
    carry_angle: float = CARRY_ANGLE,
    arm_length: float = math.inf,
) -> ThrowOutcome:
    """One throw in pymunk: the arm (kinematic) accelerates uniformly through ``carry_angle`` to W, stops dead
    (the part flies off), swings back to horizontal, and the part bounces, slides and settles under gravity.

    Lengths are scaled so the part radius is 1 (pymunk's contact tolerances are absolute). The result is the
    resting edge (hull edge facing down), R = centre-of-mass x, and the net rotation; a part that leaves the arm
    or does not settle is a fault.
    """
    from feeder_sim.throwing.arm import ThrowOutcome

    alpha = params.speed**2 / (2 * carry_angle)  # uniform angular acceleration over the carry
    for theta in np.linspace(0.0, carry_angle, 9):
        # Wrench-cone test of section III-A.1 along the real carry (theta, theta_dot, theta_ddot).
        if not carry_in_grasp(
            part,
            edge,
            radius,
            params.offset,
            params.gravity,
            params.mu,
            float(theta),
            math.sqrt(2 * alpha * theta),
            alpha,
        ):
            return ThrowOutcome(
                edge,
                radius,
                -1,
                math.nan,
                "fault",
                0,
                0.0,
                f"the carry leaves the dynamic grasp at arm angle {theta:.3g} rad",
            )
    scale = 1.0 / part.radius
    w, g, h = params.speed, params.gravity * scale, params.offset * scale
    mu = params.mu if friction is None else friction
    space = pymunk.Space()
    space.gravity = (0.0, g)
    space.collision_slop = 1e-4
    space.iterations = 30
    length = (arm_length * scale) if math.isfinite(arm_length) else 10 * (radius * scale + 10)
    arm = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
    arm.position = (0.0, 0.0)
    thick = 0.5
    slab = pymunk.Poly(arm, [(-length, h - thick), (length, h - thick), (length, h), (-length, h)])
    slab.friction, slab.elasticity = 1.0, 1.0
    mass = 1.0
    body = pymunk.Body(mass, mass * (part.rho * scale) ** 2)
    hull = [(float(x) * scale, float(y) * scale) for x, y in part.hull]
    shape = pymunk.Poly(body, hull, radius=0.0)
    shape.friction, shape.elasticity = mu, elasticity
    theta0 = -float(part.edge_angle[edge])
    body.angle = theta0
    body.position = (radius * scale, h + float(part.d[edge]) * scale + 1e-6)
    space.add(arm, slab, body, shape)
    # Let the part settle into contact before the throw.
    for _ in range(int(0.02 / step)):
        space.step(step)
    carry_time = w / alpha
    t, angle = 0.0, 0.0
    path: list[tuple[float, float, float, float]] = []
    flight_bound = 2 * w * max(radius * scale, 1.0) / -g + 4 * math.sqrt(2 * 4 / -g)
    t_end = carry_time + 4 * flight_bound + 2.0
    still = 0.0
    v_tol = 1e-3 * w * max(radius * scale, 1.0)
    record_every = max(1, int(0.005 / step))
    n = 0
    while t < t_end:
        if t < carry_time:
            arm.angular_velocity = alpha * (t + 0.5 * step)
        elif angle > 0:
            arm.angular_velocity = -min(
                w, angle / step
            )  # back down, faster than the part falls near the pivot
        else:
            arm.angular_velocity = 0.0
        space.step(step)
        angle = arm.angle
        t += step
        n += 1
        if n % record_every == 0:
            path.append((t, body.position.x / scale, body.position.y / scale, body.angle))
        if body.position.y < h - 5.0 or abs(body.position.x) > length:
            return ThrowOutcome(edge, radius, -1, math.nan, "fault", 0, 0.0, "part left the arm", path)
        if t > carry_time + 0.05 and angle <= 1e-12:
            speed = body.velocity.length + abs(body.angular_velocity)
            still = still + step if speed < v_tol else 0.0
            if still > 0.05:
                break
    else:
        raise SolverError(
            f"dynamic throw from edge {edge} at R = {radius:.4g} m did not settle in {t_end:.3g} s"
        )
    theta = body.angle
    flat = np.mod(theta + part.edge_angle + math.pi, 2 * math.pi) - math.pi  # 0 when edge i faces down
    e1 = int(np.argmin(np.abs(flat)))
    if abs(flat[e1]) > 0.05:
        return ThrowOutcome(
            edge,
            radius,
            -1,
            math.nan,
            "fault",
            0,
            0.0,
            f"part came to rest tilted by {flat[e1]:.3g} rad from every hull edge",
            path,
        )
    rotation = theta - theta0
    kind = "jog" if e1 == edge and abs(rotation) < math.pi else "flip"
    turns = int(math.trunc(rotation / (2 * math.pi)))
    return ThrowOutcome(edge, radius, e1, body.position.x / scale, kind, turns, rotation, "", path)
