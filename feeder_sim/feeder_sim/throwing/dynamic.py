"""The `dynamic` fidelity: pymunk rigid bodies, finite restitution, Coulomb friction, a kinematic arm."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pymunk

from feeder_planner.errors import SolverError
from feeder_planner.throwing.flight import rest_pose
from feeder_planner.throwing.geometry import ArmPart
from feeder_planner.throwing.grasp import carry_in_grasp
from feeder_planner.throwing.throw_map import ThrowParams, throw_kind, whole_turns
from feeder_sim.throwing.outcome import PathPoint, ThrowOutcome
from feeder_sim.throwing.tolerances import (
    ARM_ELASTICITY,
    ARM_FRICTION,
    ARM_LEVEL,
    ARM_THICKNESS,
    CARRY_ANGLE,
    CARRY_CHECKS,
    COLLISION_SLOP,
    DEFAULT_STEP,
    DROP_GAP,
    EXTRA_TIME,
    FALL_ALLOWANCE,
    FALL_HEIGHT,
    FLIGHT_ALLOWANCE,
    FREE_ARM_MARGIN,
    JUDGE_AFTER,
    LOST_DEPTH,
    MAX_TILT,
    PART_MASS,
    RECORD_EVERY,
    RESTITUTION,
    SETTLE_BEFORE,
    SOLVER_ITERATIONS,
    STILL_SPEED,
    STILL_TIME,
)

__all__ = ["carry_fault", "arm_rate", "time_limit", "resting_edge", "rest_outcome", "dynamic_throw"]


def carry_fault(
    part: ArmPart, params: ThrowParams, edge: int, radius: float, carry_angle: float
) -> str | None:
    """Return why the carry leaves the dynamic grasp, or None if it does not.

    The arm accelerates uniformly through ``carry_angle`` to W; the wrench-cone test of section III-A.1
    is applied at CARRY_CHECKS arm states (theta, theta_dot, theta_ddot) along it.
    """
    alpha = params.speed**2 / (2 * carry_angle)  # uniform angular acceleration over the carry
    for theta in np.linspace(0.0, carry_angle, CARRY_CHECKS):
        rate = math.sqrt(2 * alpha * theta)
        if not carry_in_grasp(
            part, edge, radius, params.offset, params.gravity, params.mu, float(theta), rate, alpha
        ):
            return f"the carry leaves the dynamic grasp at arm angle {theta:.3g} rad"
    return None


def arm_rate(t: float, angle: float, carry_time: float, alpha: float, speed: float, step: float) -> float:
    """Return the arm's angular velocity over the step starting at ``t``.

    Uniform acceleration ``alpha`` during the carry (midpoint of the step), then straight back down to
    horizontal at up to ``speed`` (faster than the part falls near the pivot), then at rest.
    """
    if t < carry_time:
        return alpha * (t + 0.5 * step)
    if angle > 0:
        return -min(speed, angle / step)
    return 0.0


def time_limit(carry_time: float, speed: float, radius: float, gravity: float) -> float:
    """Return when a throw that has not settled is given up (s); ``radius`` and ``gravity`` in part radii."""
    flight_bound = 2 * speed * max(radius, 1.0) / -gravity + FALL_ALLOWANCE * math.sqrt(
        2 * FALL_HEIGHT / -gravity
    )
    return carry_time + FLIGHT_ALLOWANCE * flight_bound + EXTRA_TIME


def resting_edge(part: ArmPart, theta: float) -> tuple[int, float]:
    """Return the hull edge facing down at absolute angle ``theta`` and the part's tilt from it (rad)."""
    flat = np.mod(theta + part.edge_angle + math.pi, 2 * math.pi) - math.pi  # 0 when edge i faces down
    edge = int(np.argmin(np.abs(flat)))
    return edge, float(flat[edge])


def rest_outcome(
    part: ArmPart,
    edge: int,
    radius: float,
    theta: float,
    x: float,
    path: tuple[PathPoint, ...] = (),
) -> ThrowOutcome:
    """Return the outcome of a throw from (edge, radius) whose part came to rest at ``theta``, x = ``x``.

    Jog or flip and the whole turns are those of the analytic throw map (section III-C), so the two
    fidelities count alike; a part tilted more than MAX_TILT from every edge is a fault.
    """
    landed, tilt = resting_edge(part, theta)
    if abs(tilt) > MAX_TILT:
        return ThrowOutcome.failure(
            edge, radius, f"part came to rest tilted by {tilt:.3g} rad from every hull edge", path
        )
    rotation = theta - float(rest_pose(part, edge, radius, 0.0)[2])  # from the start's resting angle
    kind = throw_kind(edge, landed, rotation)
    return ThrowOutcome(edge, radius, landed, x, kind, int(whole_turns(rotation)), rotation, "", path)


@dataclass(frozen=True)
class _Scene:
    """The pymunk world of one throw, scaled so the part radius is 1."""

    space: pymunk.Space
    arm: pymunk.Body
    body: pymunk.Body
    scale: float  # pymunk lengths per metre
    surface: float  # arm surface height h, scaled
    length: float  # arm length each side of the pivot, scaled


def _scene(
    part: ArmPart,
    params: ThrowParams,
    edge: int,
    radius: float,
    elasticity: float,
    friction: float,
    arm_length: float,
) -> _Scene:
    """Return the world: a kinematic arm slab below y = h and the part resting on ``edge`` at ``radius``."""
    scale = 1.0 / part.radius
    h = params.offset * scale
    space = pymunk.Space()
    space.gravity = (0.0, params.gravity * scale)
    space.collision_slop = COLLISION_SLOP
    space.iterations = SOLVER_ITERATIONS
    if math.isfinite(arm_length):
        length = arm_length * scale
    else:
        length = FREE_ARM_MARGIN * (radius * scale + FREE_ARM_MARGIN)
    arm = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
    arm.position = (0.0, 0.0)
    low = h - ARM_THICKNESS
    slab = pymunk.Poly(arm, [(-length, low), (length, low), (length, h), (-length, h)])
    slab.friction, slab.elasticity = ARM_FRICTION, ARM_ELASTICITY
    body = pymunk.Body(PART_MASS, PART_MASS * (part.rho * scale) ** 2)
    shape = pymunk.Poly(body, [(float(x) * scale, float(y) * scale) for x, y in part.hull], radius=0.0)
    shape.friction, shape.elasticity = friction, elasticity
    # At rest on the edge, eq. (5) at t = 0: centre of mass d^i above the surface, angle -alpha_i.
    body.angle = float(rest_pose(part, edge, radius, params.offset)[2])
    body.position = (radius * scale, h + float(part.d[edge]) * scale + DROP_GAP)
    space.add(arm, slab, body, shape)
    return _Scene(space, arm, body, scale, h, length)


@dataclass(frozen=True)
class _Run:
    """How a simulated throw ended: the recorded path, and whether the part was lost off the arm."""

    path: tuple[PathPoint, ...]
    lost: bool


def _run(
    scene: _Scene, params: ThrowParams, edge: int, radius: float, step: float, carry_angle: float
) -> _Run:
    """Carry, release, swing the arm back and step until the part is still or has left the arm.

    Raises SolverError if the part does not settle within ``time_limit``.
    """
    space, arm, body, scale = scene.space, scene.arm, scene.body, scene.scale
    for _ in range(int(SETTLE_BEFORE / step)):  # into contact before the throw
        space.step(step)
    w = params.speed
    alpha = w**2 / (2 * carry_angle)
    carry_time = w / alpha
    t_end = time_limit(carry_time, w, radius * scale, params.gravity * scale)
    still_speed = STILL_SPEED * w * max(radius * scale, 1.0)
    record_every = max(1, int(RECORD_EVERY / step))
    t, angle, still, n = 0.0, 0.0, 0.0, 0
    path: list[PathPoint] = []
    while t < t_end:
        arm.angular_velocity = arm_rate(t, angle, carry_time, alpha, w, step)
        space.step(step)
        angle = arm.angle
        t += step
        n += 1
        if n % record_every == 0:
            path.append((t, body.position.x / scale, body.position.y / scale, body.angle))
        if body.position.y < scene.surface - LOST_DEPTH or abs(body.position.x) > scene.length:
            return _Run(tuple(path), lost=True)
        if t > carry_time + JUDGE_AFTER and angle <= ARM_LEVEL:
            speed = body.velocity.length + abs(body.angular_velocity)
            still = still + step if speed < still_speed else 0.0
            if still > STILL_TIME:
                return _Run(tuple(path), lost=False)
    raise SolverError(f"dynamic throw from edge {edge} at R = {radius:.4g} m did not settle in {t_end:.3g} s")


def dynamic_throw(
    part: ArmPart,
    params: ThrowParams,
    edge: int,
    radius: float,
    step: float = DEFAULT_STEP,
    elasticity: float = RESTITUTION,
    friction: float | None = None,
    carry_angle: float = CARRY_ANGLE,
    arm_length: float = math.inf,
) -> ThrowOutcome:
    """Return one throw in pymunk: the arm accelerates uniformly through ``carry_angle`` to W, stops dead.

    The part flies off; the arm swings back to horizontal, and the part bounces, slides and settles under
    gravity. Lengths are scaled so the part radius is 1 (pymunk's contact tolerances are absolute). The
    result is the resting edge (hull edge facing down), R = centre-of-mass x, and the net rotation; a
    carry outside the dynamic grasp, a part that leaves the arm or comes to rest tilted is a fault.
    """
    reason = carry_fault(part, params, edge, radius, carry_angle)
    if reason is not None:
        return ThrowOutcome.failure(edge, radius, reason)
    mu = params.mu if friction is None else friction
    scene = _scene(part, params, edge, radius, elasticity, mu, arm_length)
    run = _run(scene, params, edge, radius, step, carry_angle)
    if run.lost:
        return ThrowOutcome.failure(edge, radius, "part left the arm", run.path, lost=True)
    body = scene.body
    return rest_outcome(part, edge, radius, body.angle, body.position.x / scene.scale, run.path)
