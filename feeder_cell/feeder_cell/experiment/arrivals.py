"""How parts arrive: a scene's ``arrivals:`` section, validated, and the seeded draws of each cycle.

    seed: 7                        # the scene's seed (top level; default 0)
    arrivals:
      mems:                        # each part on the MEMS array, each cycle (~/place_parts)
        orientation: uniform       # theta uniform in [-pi, pi); or {range: [lo, hi]} (rad, uniform);
                                   # or {angles: [a, b, ...], weights: [wa, wb, ...]} (rad, discrete)
        feed_area: {x: [-2.0e-3, 2.0e-3], y: [-2.0e-3, 2.0e-3]}   # m, position uniform in the box
      arm:                         # the part at the arm's infeed, each cycle (~/place_part)
        drop: quasi_static         # the resting edge's distribution: quasi_static or dynamic
        radius: [0.115, 0.125]     # m, R uniform in [lo, hi]; or one number (fixed)
        # dynamic only: drop_height (m, 1e-4), friction (0.5), drops (4000): feeder_sim.throwing.drop

Either device may be left out (it keeps the controller's fixed placement). Replication i's cycle k draws
from its own stream (``streams``: purpose ``mems_arrival`` or ``arm_arrival``, key k), so cycle k's part
is the same in every scenario of that replication, however many draws an earlier cycle made.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Final

import numpy as np

from feeder_cell.experiment.streams import check_seed, stream
from feeder_planner.errors import InputError
from feeder_planner.fields_io import finite_number, optional
from feeder_planner.limits import describe
from feeder_planner.throwing.drop import DROP_FIDELITIES, DropDistribution
from feeder_planner.throwing.geometry import ArmPart
from feeder_sim.throwing.drop import DropSettings, drop_distribution

__all__ = [
    "Orientation",
    "MemsArrivals",
    "ArmArrivals",
    "Arrivals",
    "ArmArrival",
    "ArrivalStream",
    "arrivals_from_mapping",
    "scene_arrivals",
    "scene_seed",
    "MAX_ANGLES",
]

MAX_ANGLES: Final = 1000  # entries of a discrete orientation distribution


@dataclass(frozen=True)
class Orientation:
    """theta of a part placed on the array: uniform in [low, high), or one of ``angles`` by ``weights``."""

    low: float = -math.pi
    high: float = math.pi
    angles: tuple[float, ...] = ()
    weights: tuple[float, ...] = ()

    def draw(self, rng: np.random.Generator) -> float:
        """Draw theta (rad) with one uniform number of ``rng``."""
        u = float(rng.random())
        if not self.angles:
            return self.low + (self.high - self.low) * u
        cumulative = np.cumsum(self.weights)
        index = int(np.searchsorted(cumulative, u * float(cumulative[-1]), side="right"))
        return self.angles[min(index, len(self.angles) - 1)]


@dataclass(frozen=True)
class MemsArrivals:
    """Each part placed on the MEMS array: its orientation and its position uniform in the feed area."""

    orientation: Orientation
    x: tuple[float, float]
    y: tuple[float, float]

    def draw(self, rng: np.random.Generator, count: int) -> tuple[tuple[float, float, float], ...]:
        """Draw ``count`` poses (x, y, theta) (three uniform numbers per part: theta, x, y)."""
        poses = []
        for _ in range(count):
            theta = self.orientation.draw(rng)
            x = self.x[0] + (self.x[1] - self.x[0]) * float(rng.random())
            y = self.y[0] + (self.y[1] - self.y[0]) * float(rng.random())
            poses.append((x, y, theta))
        return tuple(poses)


@dataclass(frozen=True)
class ArmArrivals:
    """The part at the arm's infeed: its resting edge from the drop distribution, R uniform in a range."""

    drop: str = "quasi_static"
    settings: DropSettings = field(default_factory=DropSettings)
    radius: tuple[float, float] = (0.12, 0.12)


@dataclass(frozen=True)
class Arrivals:
    """A scene's arrivals; a device left out (None) keeps the controller's fixed placement."""

    mems: MemsArrivals | None = None
    arm: ArmArrivals | None = None


@dataclass(frozen=True)
class ArmArrival:
    """One part at the infeed: the hull edge it rests on and its radius R (m)."""

    edge: int
    radius: float


class ArrivalStream:
    """The arrivals of one replication, cycle by cycle (cycles count from 1, as the controller's)."""

    def __init__(self, arrivals: Arrivals, seed: int, replication: int = 0) -> None:
        self.arrivals = arrivals
        self.seed = seed
        self.replication = replication
        self.drop: DropDistribution | None = None

    def set_part(self, part: ArmPart, cache: Path | None = None) -> DropDistribution:
        """Compute (or read from the cache) the arm part's drop distribution at the section's fidelity."""
        arm = self.arrivals.arm
        if arm is None:
            raise ValueError("the arrivals have no arm section")
        self.drop = drop_distribution(part, arm.drop, arm.settings, cache)
        return self.drop

    def mems(self, cycle: int, count: int) -> tuple[tuple[float, float, float], ...]:
        """Return the poses (x, y, theta) of ``count`` parts placed on the array in ``cycle``."""
        if self.arrivals.mems is None:
            raise ValueError("the arrivals have no mems section")
        return self.arrivals.mems.draw(stream(self.seed, self.replication, "mems_arrival", cycle), count)

    def arm(self, cycle: int) -> ArmArrival:
        """Return the part placed at the infeed in ``cycle`` (one uniform for the edge, one for R)."""
        arm = self.arrivals.arm
        if arm is None or self.drop is None:
            raise ValueError("the arm's arrivals need its section and its part (set_part)")
        rng = stream(self.seed, self.replication, "arm_arrival", cycle)
        edge = self.drop.draw(rng)
        low, high = arm.radius
        return ArmArrival(edge, low + (high - low) * float(rng.random()))


# --- validation ------------------------------------------------------------------------------------------
def _mapping(value: Any, field: str, keys: tuple[str, ...]) -> dict[str, Any]:
    """Return a mapping whose keys are among ``keys``; else an InputError naming the field (or the key)."""
    if not isinstance(value, dict):
        raise InputError(field, f"expected a mapping with {', '.join(keys)}, got {describe(value)}")
    unknown = sorted(str(k) for k in value if k not in keys)
    if unknown:
        raise InputError(f"{field}.{unknown[0]}", f"is not a field here (fields: {', '.join(keys)})")
    return value


def _interval(value: Any, field: str, minimum: float | None = None) -> tuple[float, float]:
    """Return [lo, hi] (lo <= hi, finite; above ``minimum`` if given) or one number as (v, v)."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        low = high = finite_number(value, field)
    elif isinstance(value, (list, tuple)) and len(value) == 2:
        low, high = finite_number(value[0], f"{field}[0]"), finite_number(value[1], f"{field}[1]")
        if low > high:
            raise InputError(field, f"needs lo <= hi, got [{low:g}, {high:g}]")
    else:
        raise InputError(field, f"expected [lo, hi] or one number, got {describe(value)}")
    if minimum is not None and low <= minimum:
        raise InputError(field, f"must be > {minimum:g}, got {low:g}")
    return low, high


def _orientation(value: Any, field: str) -> Orientation:
    if value == "uniform":
        return Orientation()
    if isinstance(value, dict) and "range" in value:
        _mapping(value, field, ("range",))
        low, high = _interval(value["range"], f"{field}.range")
        if high - low > 2 * math.pi:
            raise InputError(f"{field}.range", f"spans more than 2 pi ({high - low:.6g} rad)")
        return Orientation(low, high)
    if isinstance(value, dict) and "angles" in value:
        _mapping(value, field, ("angles", "weights"))
        angles, weights = value["angles"], optional(value, "weights", None)
        if not isinstance(angles, list) or not 1 <= len(angles) <= MAX_ANGLES:
            raise InputError(f"{field}.angles", f"expected a list of 1 to {MAX_ANGLES} angles (rad)")
        thetas = tuple(finite_number(a, f"{field}.angles[{i}]") for i, a in enumerate(angles))
        if weights is None:
            weights = [1.0] * len(thetas)
        if not isinstance(weights, list) or len(weights) != len(thetas):
            raise InputError(f"{field}.weights", f"expected one weight per angle ({len(thetas)})")
        checked = []
        for i, w in enumerate(weights):
            number = finite_number(w, f"{field}.weights[{i}]")
            if number < 0:
                raise InputError(f"{field}.weights[{i}]", f"must be >= 0, got {number:g}")
            checked.append(number)
        if sum(checked) <= 0:
            raise InputError(f"{field}.weights", "needs a weight > 0")
        return Orientation(angles=thetas, weights=tuple(checked))
    raise InputError(
        field,
        f"expected uniform, {{range: [lo, hi]}} or {{angles: [...], weights: [...]}}, got {describe(value)}",
    )


def _mems(value: Any, field: str) -> MemsArrivals:
    section = _mapping(value, field, ("orientation", "feed_area"))
    if "feed_area" not in section:
        raise InputError(f"{field}.feed_area", "is required: {x: [lo, hi], y: [lo, hi]} (m)")
    area = _mapping(section["feed_area"], f"{field}.feed_area", ("x", "y"))
    for key in ("x", "y"):
        if key not in area:
            raise InputError(f"{field}.feed_area.{key}", "is required: [lo, hi] (m)")
    return MemsArrivals(
        _orientation(optional(section, "orientation", "uniform"), f"{field}.orientation"),
        _interval(area["x"], f"{field}.feed_area.x"),
        _interval(area["y"], f"{field}.feed_area.y"),
    )


def _arm(value: Any, field: str) -> ArmArrivals:
    section = _mapping(value, field, ("drop", "radius", "drop_height", "friction", "drops"))
    drop = optional(section, "drop", DROP_FIDELITIES[0])
    if drop not in DROP_FIDELITIES:
        raise InputError(
            f"{field}.drop", f"must be one of {', '.join(DROP_FIDELITIES)}, got {describe(drop)}"
        )
    dynamic_only = sorted(k for k in ("drop_height", "friction", "drops") if k in section)
    if drop != "dynamic" and dynamic_only:
        raise InputError(f"{field}.{dynamic_only[0]}", "applies to drop: dynamic only")
    if "radius" not in section:
        raise InputError(f"{field}.radius", "is required: [lo, hi] or one number (m)")
    radius = _interval(section["radius"], f"{field}.radius", minimum=0.0)
    defaults = DropSettings()
    drops = optional(section, "drops", defaults.drops)
    try:
        settings = DropSettings(
            drop_height=finite_number(
                optional(section, "drop_height", defaults.drop_height), f"{field}.drop_height"
            ),
            friction=finite_number(optional(section, "friction", defaults.friction), f"{field}.friction"),
            drops=drops,
        )
    except InputError as error:
        if error.field.startswith(field):
            raise
        raise InputError(f"{field}.{error.field}", error.problem) from None
    return ArmArrivals(drop, settings, radius)


def arrivals_from_mapping(value: Any, field: str = "arrivals") -> Arrivals:
    """Validate an ``arrivals:`` section; a bad value is an InputError naming its field."""
    section = _mapping(value, field, ("mems", "arm"))
    if not section:
        raise InputError(field, "is empty: give mems, arm or both (or leave the section out)")
    mems = _mems(section["mems"], f"{field}.mems") if "mems" in section else None
    arm = _arm(section["arm"], f"{field}.arm") if "arm" in section else None
    return Arrivals(mems, arm)


def scene_seed(document: dict[str, Any]) -> int:
    """Return a scene's ``seed`` (top level; 0 when absent)."""
    return check_seed(optional(document, "seed", 0), "seed")


def scene_arrivals(document: dict[str, Any]) -> Arrivals | None:
    """Return a scene's validated ``arrivals:`` section, or None when it has none."""
    if "arrivals" not in document:
        return None
    return arrivals_from_mapping(document["arrivals"], "arrivals")
