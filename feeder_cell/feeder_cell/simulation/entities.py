"""What is in the cell, as the standard's entities: stable names, categories and the query filters.

Entity names are the device's fully qualified node name without its leading slash, and a part's or a
body's name under it: ``cell/mems_field_array`` (the device itself, CATEGORY_ROBOT),
``cell/mems_field_array/plus`` (a part on the array), ``cell/throwing_arm/triangle`` (the part the arm
holds), ``cell/assembly_fixture/block`` (a body of the assembly the fixture holds); parts and free bodies
are CATEGORY_OBJECT, grounded bodies (the bracket) CATEGORY_STATIC_OBJECT.
A name stays the same for as long as the thing exists, so a harness can keep it between calls.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from feeder_cell.simulation.posix import PosixError, compile_ere
from feeder_cell.simulation.results import FEATURE_UNSUPPORTED, OPERATION_FAILED, SimulationError

__all__ = [
    "CATEGORY_OBJECT",
    "CATEGORY_ROBOT",
    "CATEGORY_STATIC_OBJECT",
    "MAX_FILTER_CHARS",
    "Entity",
    "EntityState",
    "device_entity",
    "select",
    "Sphere",
]

# simulation_interfaces/msg/EntityCategory
CATEGORY_OBJECT, CATEGORY_ROBOT, CATEGORY_STATIC_OBJECT = 0, 1, 5
# A name filter longer than any entity name list could need is refused, not compiled.
MAX_FILTER_CHARS = 1000


@dataclass(frozen=True)
class Entity:
    """One entity: its name, category and description, and the device that owns it."""

    name: str
    category: int
    description: str
    device: str  # the device's fully qualified node name
    kind: str  # "device", "array_part", "arm_part" or "fixture_body"
    local: str = ""  # the part's or body's name on its device ("" for the device itself)
    spawned: bool = False


@dataclass
class EntityState:
    """A pose and twist in a named frame at a cell time (what GetEntityState answers)."""

    frame_id: str
    stamp_ns: int
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    orientation: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)  # x, y, z, w
    linear: tuple[float, float, float] = (0.0, 0.0, 0.0)
    angular: tuple[float, float, float] = (0.0, 0.0, 0.0)
    extra: dict[str, float] = field(default_factory=dict)


def device_entity(fqn: str, kind: str, description: str) -> Entity:
    """Return the entity of a device node (its base frame in the cell)."""
    return Entity(fqn.lstrip("/"), CATEGORY_ROBOT, description, fqn, kind)


def select(entities: list[Entity], pattern: str, categories: list[int], tags: list[str]) -> list[Entity]:
    """Return the entities matching the standard's name, category and tag filters, in name order.

    ``pattern`` is a POSIX Extended regular expression searched in the name (regexec: a match anywhere),
    translated by ``posix``; ``categories`` any of; tag filters are not supported (no entity has tags).
    Bounds are the caller's (they need states): ``Sphere``.
    """
    if tags:
        raise SimulationError(FEATURE_UNSUPPORTED, "filters.tags: entity tags are not supported")
    if len(pattern) > MAX_FILTER_CHARS:
        raise SimulationError(
            OPERATION_FAILED, f"filters.filter: at most {MAX_FILTER_CHARS} characters, got {len(pattern)}"
        )
    try:
        compiled = compile_ere(pattern)
    except PosixError as error:
        raise SimulationError(
            OPERATION_FAILED, f"filters.filter: not a POSIX Extended regular expression: {error}"
        ) from None
    wanted = set(categories)
    return sorted(
        (e for e in entities if compiled.search(e.name) and (not wanted or e.category in wanted)),
        key=lambda e: e.name,
    )


# simulation_interfaces/msg/Bounds
BOUNDS_EMPTY, BOUNDS_BOX, BOUNDS_CONVEX_HULL, BOUNDS_SPHERE = 0, 1, 2, 3


@dataclass(frozen=True)
class Sphere:
    """A sphere bounds filter (Bounds TYPE_SPHERE): centre and radius in the world frame, m."""

    center: tuple[float, float, float]
    radius: float

    @staticmethod
    def of(kind: int, points: list[tuple[float, float, float]]) -> Sphere | None:
        """Return the sphere of a Bounds (None: TYPE_EMPTY, no bounds), or raise naming the field.

        TYPE_BOX and TYPE_CONVEX_HULL are FEATURE_UNSUPPORTED (the standard's rule for a type not
        supported); the sphere needs two points, a finite centre and a finite radius >= 0 (points[1].x).
        """
        if kind == BOUNDS_EMPTY and not points:
            return None
        if kind in (BOUNDS_BOX, BOUNDS_CONVEX_HULL):
            name = "TYPE_BOX" if kind == BOUNDS_BOX else "TYPE_CONVEX_HULL"
            raise SimulationError(
                FEATURE_UNSUPPORTED, f"filters.bounds.type: {name} is not supported (TYPE_SPHERE is)"
            )
        if kind != BOUNDS_SPHERE:
            raise SimulationError(OPERATION_FAILED, f"filters.bounds.type: unknown bounds type {kind}")
        if len(points) != 2:
            raise SimulationError(
                OPERATION_FAILED, f"filters.bounds.points: a sphere has 2 points, got {len(points)}"
            )
        center, radius = points[0], points[1][0]
        if not all(math.isfinite(v) for v in center) or not math.isfinite(radius) or radius < 0:
            raise SimulationError(
                OPERATION_FAILED,
                f"filters.bounds.points: a finite centre and a finite radius >= 0, got {center} and {radius}",
            )
        return Sphere((float(center[0]), float(center[1]), float(center[2])), float(radius))

    def holds(self, position: tuple[float, float, float]) -> bool:
        """Whether a point lies in the sphere (its surface included)."""
        return math.dist(position, self.center) <= self.radius
