"""The ``dynamic`` drop distribution: the share of random pymunk drops that end on each hull edge.

A part is released at rest with a uniformly random orientation, its lowest vertex ``drop_height`` above a
flat floor, and falls under gravity with restitution e = 0 and Coulomb friction ``friction``; where it comes
to rest (the hull edge facing down) is counted. With N drops the share of edge i estimates P(i) with the
binomial standard error sqrt(p (1 - p) / N). The quasi-static distribution
(``feeder_planner.throwing.drop``, eq. D3) is the limit where the part rolls down its radius function
without momentum; a falling part pivots over a vertex with momentum, so the two differ where a basin is
shallow (docs/experiments.md).

The table is computed once per part and settings and cached on disk (``drop_cache_dir``), keyed by the
hull, the radius of gyration, the settings, the seed and MODEL_VERSION: a second call reads the file.
Lengths in pymunk are scaled so the part radius is 1 and times so gravity is 1 (pymunk's contact
tolerances are absolute); the result depends on the shape and drop_height / radius only.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final

import numpy as np
import pymunk

from feeder_planner.errors import InputError, SolverError
from feeder_planner.throwing.drop import DropDistribution, quasi_static_drop
from feeder_planner.throwing.geometry import ArmPart
from feeder_sim.throwing.dynamic import resting_edge
from feeder_sim.throwing.tolerances import COLLISION_SLOP, MAX_TILT, SOLVER_ITERATIONS

__all__ = [
    "DropSettings",
    "DEFAULT_DROP_HEIGHT",
    "DEFAULT_DROP_FRICTION",
    "DEFAULT_DROPS",
    "MODEL_VERSION",
    "drop_cache_dir",
    "dynamic_drop",
    "drop_distribution",
    "simulate_drops",
]

# --- Settings' defaults (docs/experiments.md) --------------------------------------------------------
# The measurement: 4,000 drops, mu = 0.5, from 0.1 mm (the part barely falls: the nearest to the
# quasi-static release a drop can be while still a drop).
DEFAULT_DROP_HEIGHT: Final = 1e-4  # m, lowest vertex above the floor at release
DEFAULT_DROP_FRICTION: Final = 0.5
DEFAULT_DROPS: Final = 4000
DEFAULT_DROP_SEED: Final = 0
# Limits of the settings: 100,000 drops take about 10 CPU minutes (a table is made once, but a typo must
# not hold a controller for hours); a part falls from at most 1 m (for a 1 mm part 1,000 radii, a fall
# of about 45 time units, well inside TIME_LIMIT).
MAX_DROPS: Final = 100_000
MAX_DROP_HEIGHT: Final = 1.0
# --- Model constants (part radii r, time unit sqrt(r / g)) -------------------------------------------
# Step in units of sqrt(r / g): a 1 cm part under 9.81 m/s^2 steps 32 us. A fall from 0.1 mm is
# about 0.14 time units (70 steps); halving the step moved no share of the bracket by more than its
# standard error (docs/experiments.md).
STEP: Final = 2e-3
# Bodies per pymunk space: the parts do not collide with one another (one shape filter group), so a
# batch is that many independent drops stepped by one call.
BATCH: Final = 250
# A part is still when |v| + |omega| (radii per time unit) stays below STILL_SPEED for STILL_TIME.
STILL_SPEED: Final = 1e-3
STILL_TIME: Final = 0.5
# Stillness is looked at every CHECK_EVERY steps (the Python loop over a batch costs as much as a step).
CHECK_EVERY: Final = 25
# A drop that has not settled in TIME_LIMIT time units is a SolverError (settling takes a few tens).
TIME_LIMIT: Final = 400.0
# Floor half-width and thickness (radii): wider than any slide of a dropped part.
FLOOR_HALF_WIDTH: Final = 1000.0
FLOOR_THICKNESS: Final = 1.0
# Part released this far (radii) above the floor even at drop_height 0, so the shapes never overlap.
RELEASE_GAP: Final = 1e-6
# Part of the cache key: raised whenever a change here changes results.
MODEL_VERSION: Final = 1


@dataclass(frozen=True)
class DropSettings:
    """How the dynamic drops are made: height (m), friction, count, seed of the orientations."""

    drop_height: float = DEFAULT_DROP_HEIGHT
    friction: float = DEFAULT_DROP_FRICTION
    drops: int = DEFAULT_DROPS
    seed: int = DEFAULT_DROP_SEED

    def __post_init__(self) -> None:
        if not (math.isfinite(self.drop_height) and 0.0 <= self.drop_height <= MAX_DROP_HEIGHT):
            raise InputError(
                "drop_height", f"must be a length in [0, {MAX_DROP_HEIGHT:g}] m, got {self.drop_height!r}"
            )
        if not (math.isfinite(self.friction) and self.friction >= 0.0):
            raise InputError("friction", f"must be a finite coefficient >= 0, got {self.friction!r}")
        if (
            isinstance(self.drops, bool)
            or not isinstance(self.drops, int)
            or not 1 <= self.drops <= MAX_DROPS
        ):
            raise InputError("drops", f"must be an integer in [1, {MAX_DROPS}], got {self.drops!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise InputError("seed", f"must be an integer >= 0, got {self.seed!r}")

    def to_json(self) -> dict[str, Any]:
        """Return the settings as a JSON object (restitution is always 0)."""
        return {
            "drop_height": self.drop_height,
            "friction": self.friction,
            "restitution": 0.0,
            "drops": self.drops,
            "seed": self.seed,
        }


def drop_cache_dir() -> Path:
    """Where tables are cached: $FEEDER_CACHE_DIR/drops, else $XDG_CACHE_HOME (or ~/.cache)/feeder/drops."""
    root = os.environ.get("FEEDER_CACHE_DIR")
    if root:
        return Path(root) / "drops"
    xdg = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(xdg) / "feeder" / "drops"


def _cache_key(part: ArmPart, settings: DropSettings) -> str:
    """Return a digest of what a table depends on: hull (m), radius of gyration, settings, model."""
    content = {
        "hull": [[float(x).hex(), float(y).hex()] for x, y in part.hull],
        "rho": float(part.rho).hex(),
        "settings": settings.to_json(),
        "model": MODEL_VERSION,
        "step": STEP,
    }
    return hashlib.sha256(json.dumps(content, sort_keys=True).encode()).hexdigest()[:32]


def _batch_space(
    part: ArmPart, angles: np.ndarray, settings: DropSettings
) -> tuple[pymunk.Space, list[pymunk.Body]]:
    """Return a space with a floor at y = 0 and one part per angle, released at rest above it."""
    scale = 1.0 / part.radius
    space = pymunk.Space()
    space.gravity = (0.0, -1.0)
    space.collision_slop = COLLISION_SLOP
    space.iterations = SOLVER_ITERATIONS
    floor = pymunk.Poly(
        space.static_body,
        [
            (-FLOOR_HALF_WIDTH, -FLOOR_THICKNESS),
            (FLOOR_HALF_WIDTH, -FLOOR_THICKNESS),
            (FLOOR_HALF_WIDTH, 0.0),
            (-FLOOR_HALF_WIDTH, 0.0),
        ],
    )
    # pymunk multiplies the two shapes' coefficients: the floor carries 1, the part the contact's own.
    floor.friction, floor.elasticity = 1.0, 1.0
    space.add(floor)
    hull = part.hull * scale
    rho = part.rho * scale
    height = settings.drop_height * scale + RELEASE_GAP
    parts_only = pymunk.ShapeFilter(group=1)  # the parts pass through one another, never the floor
    bodies = []
    for angle in angles:
        body = pymunk.Body(1.0, rho * rho)
        shape = pymunk.Poly(body, [(float(x), float(y)) for x, y in hull], radius=0.0)
        shape.friction, shape.elasticity = settings.friction, 0.0
        shape.filter = parts_only
        c, s = math.cos(angle), math.sin(angle)
        lowest = float(np.min(hull[:, 0] * s + hull[:, 1] * c))
        body.angle = float(angle)
        body.position = (0.0, height - lowest)
        space.add(body, shape)
        bodies.append(body)
    return space, bodies


def simulate_drops(part: ArmPart, angles: np.ndarray, settings: DropSettings) -> np.ndarray:
    """Return the resting hull edge of a drop from each orientation in ``angles`` (rad).

    A drop is at rest once |v| + |omega| stays below STILL_SPEED for STILL_TIME lying on an edge (within
    MAX_TILT); one slow but tilted is balanced near a vertex and goes on. Raises SolverError if a drop
    does not come to rest within TIME_LIMIT.
    """
    result = np.empty(len(angles), dtype=np.int64)
    for first in range(0, len(angles), BATCH):
        chunk = angles[first : first + BATCH]
        space, bodies = _batch_space(part, chunk, settings)
        moving = dict(enumerate(bodies))
        still = dict.fromkeys(moving, 0.0)
        steps = 0
        while moving:
            space.step(STEP)
            steps += 1
            if steps % CHECK_EVERY:
                continue
            for k, body in list(moving.items()):
                speed = body.velocity.length + abs(body.angular_velocity)
                still[k] = still[k] + CHECK_EVERY * STEP if speed < STILL_SPEED else 0.0
                if still[k] <= STILL_TIME:
                    continue
                edge, tilt = resting_edge(part, body.angle)
                # Slow but tilted: balanced near a vertex (an unstable equilibrium); it falls on.
                if abs(tilt) <= MAX_TILT:
                    # At rest: counted and taken out, so the batch's cost follows the drops still moving.
                    result[first + k] = edge
                    space.remove(body, *body.shapes)
                    del moving[k]
            if steps * STEP > TIME_LIMIT:
                raise SolverError(f"{len(moving)} drops did not settle in {TIME_LIMIT:g} time units")
    return result


def dynamic_drop(
    part: ArmPart, settings: DropSettings = DropSettings(), cache: Path | None = None
) -> DropDistribution:
    """Return the dynamic drop distribution of ``part``: from the cache, or tabulated and cached.

    ``cache`` is the folder (default ``drop_cache_dir()``); the orientations are ``settings.drops``
    uniform draws of numpy's default generator seeded with ``settings.seed``.
    """
    folder = drop_cache_dir() if cache is None else cache
    path = folder / f"{_cache_key(part, settings)}.json"
    if path.is_file():
        try:
            stored = json.loads(path.read_text())
            counts = np.array(stored["counts"], dtype=np.int64)
            if counts.shape == (part.n,) and int(counts.sum()) == settings.drops:
                return _distribution(counts, settings)
        except (OSError, ValueError, KeyError, TypeError):
            pass  # an unreadable table is tabulated again and overwritten
    angles = np.random.default_rng(settings.seed).uniform(0.0, 2.0 * math.pi, settings.drops)
    edges = simulate_drops(part, angles, settings)
    counts = np.bincount(edges, minlength=part.n)
    distribution = _distribution(counts, settings)
    folder.mkdir(parents=True, exist_ok=True)
    # Written aside and renamed: a reader never sees half a table, two writers leave one whole.
    with tempfile.NamedTemporaryFile("w", dir=folder, suffix=".tmp", delete=False) as handle:
        json.dump({**distribution.to_json(), "part": part.part.name}, handle)
    os.replace(handle.name, path)
    return distribution


def _distribution(counts: np.ndarray, settings: DropSettings) -> DropDistribution:
    total = int(counts.sum())
    return DropDistribution(
        "dynamic", counts / total, samples=total, counts=counts, settings=settings.to_json()
    )


def drop_distribution(
    part: ArmPart,
    fidelity: str = "quasi_static",
    settings: DropSettings = DropSettings(),
    cache: Path | None = None,
) -> DropDistribution:
    """Return the drop distribution of ``part`` at ``fidelity`` (``quasi_static`` or ``dynamic``)."""
    if fidelity == "quasi_static":
        return quasi_static_drop(part)
    if fidelity == "dynamic":
        return dynamic_drop(part, settings, cache)
    raise InputError("drop", f"must be quasi_static or dynamic, got {fidelity!r}")
