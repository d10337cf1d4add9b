"""Placing parts on the MEMS field array, ROS-free: the checks of a ``~/place_parts`` request and the move.

A part is placed at rest. Positions stay within ``PLACE_REACH_FACTOR`` array extents of the origin: a part
far off the array only drifts in no field, and one at 1e308 m would make the model's arithmetic overflow
into NaN poses for every subscriber. Angles stay within +-``MAX_PLACE_ANGLE``. Every refusal names the
request's field (``x[2]``, ``names[0]``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from feeder_planner.errors import InputError
from feeder_sim.mems.scene import Scene

__all__ = ["PLACE_REACH_FACTOR", "MAX_PLACE_ANGLE", "placement_reach", "place_parts", "reset_parts"]

PLACE_REACH_FACTOR = 10.0
MAX_PLACE_ANGLE = 1e6  # rad: far beyond any turn count, short of where float angles lose their meaning


def placement_reach(array_size: Sequence[int], pitch: float) -> float:
    """Return the largest |x| or |y| (m) a part may be placed at: the array's extent, with a margin."""
    return PLACE_REACH_FACTOR * max(array_size) * pitch


def reset_parts(scene: Scene, initial: np.ndarray) -> None:
    """Put every part back at its initial pose, at rest."""
    for body, pose in zip(scene.bodies, initial, strict=True):
        body.pose, body.velocity = pose.copy(), np.zeros(3)


def place_parts(
    scene: Scene,
    names: Sequence[str],
    request: tuple[Sequence[str], Sequence[float], Sequence[float], Sequence[float]],
    reach: float,
) -> None:
    """Place the named parts at (x, y, theta), at rest; check everything before moving anything.

    The request's size is the node's to check first (its per-request limits).
    """
    wanted, *coordinates = request
    n = len(wanted)
    for key, values in zip(("x", "y", "theta"), coordinates, strict=True):
        if len(values) != n:
            raise InputError(key, f"needs one value per name ({n}), got {len(values)}")
        bad = [i for i, v in enumerate(values) if not math.isfinite(v)]
        if bad:
            raise InputError(f"{key}[{bad[0]}]", "must be finite")
        limit = reach if key != "theta" else MAX_PLACE_ANGLE
        far = [i for i, v in enumerate(values) if abs(v) > limit]
        if far:
            unit = "rad" if key == "theta" else "m (the array's extent)"
            raise InputError(
                f"{key}[{far[0]}]", f"must be within +-{limit:.6g} {unit}, got {values[far[0]]:.6g}"
            )
    targets = []
    for i, name in enumerate(wanted):
        if name not in names:
            raise InputError(f"names[{i}]", f"no part named {name!r} (parts: {', '.join(names)})")
        targets.append((list(names).index(name), np.array([c[i] for c in coordinates], float)))
    for index, pose in targets:
        body = scene.bodies[index]
        body.pose, body.velocity = pose, np.zeros(3)
