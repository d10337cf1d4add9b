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

__all__ = [
    "PLACE_REACH_FACTOR",
    "MAX_PLACE_ANGLE",
    "placement_reach",
    "check_coordinate",
    "place_parts",
    "reset_parts",
]

PLACE_REACH_FACTOR = 10.0
MAX_PLACE_ANGLE = 1e6  # rad: far beyond any turn count, short of where float angles lose their meaning


def placement_reach(array_size: Sequence[int], pitch: float) -> float:
    """Return the largest |x| or |y| (m) a part may be placed at: the array's extent, with a margin."""
    return PLACE_REACH_FACTOR * max(array_size) * pitch


def reset_parts(scene: Scene, initial: np.ndarray) -> None:
    """Put every part back at its initial pose, at rest."""
    if len(initial) != len(scene.bodies):
        raise ValueError(f"{len(initial)} initial poses for {len(scene.bodies)} parts")
    for index, pose in enumerate(initial):
        scene.place_body(index, pose.copy())


def check_coordinate(key: str, value: float, reach: float, field: str | None = None) -> float:
    """Return a pose coordinate (``key`` x, y or theta) if finite and within reach, else InputError.

    The error names ``field`` (default ``key``); positions stay within ``reach`` (m), angles within
    +-MAX_PLACE_ANGLE.
    """
    field = field or key
    if not math.isfinite(value):
        raise InputError(field, f"must be finite, got {value!r}")
    limit = reach if key != "theta" else MAX_PLACE_ANGLE
    if abs(value) > limit:
        unit = "rad" if key == "theta" else "m (the array's extent)"
        raise InputError(field, f"must be within +-{limit:.6g} {unit}, got {value:.6g}")
    return float(value)


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
        for i, value in enumerate(values):
            check_coordinate(key, value, reach, f"{key}[{i}]")
    targets = []
    for i, name in enumerate(wanted):
        if name not in names:
            raise InputError(f"names[{i}]", f"no part named {name!r} (parts: {', '.join(names)})")
        targets.append((list(names).index(name), np.array([c[i] for c in coordinates], float)))
    for index, pose in targets:
        scene.place_body(index, pose)
