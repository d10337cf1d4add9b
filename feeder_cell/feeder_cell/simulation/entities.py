"""What is in the cell, as the standard's entities: stable names, categories and the query filters.

Entity names are the device's fully qualified node name without its leading slash, and a part's or a
body's name under it: ``cell/mems_field_array`` (the device itself, CATEGORY_ROBOT),
``cell/mems_field_array/plus`` (a part on the array), ``cell/throwing_arm/triangle`` (the part the arm
holds), ``cell/assembly_fixture/block`` (a body of the assembly the fixture holds); parts and free bodies
are CATEGORY_OBJECT, grounded bodies (the bracket) CATEGORY_STATIC_OBJECT.
A name stays the same for as long as the thing exists, so a harness can keep it between calls.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

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


def select(
    entities: list[Entity], pattern: str, categories: list[int], tags: list[str], bounded: bool
) -> list[Entity]:
    """Return the entities matching the standard's filters, in name order.

    ``pattern`` is a regular expression searched in the name (POSIX regexec semantics: a match anywhere;
    Python's syntax, which accepts the POSIX Extended expressions a harness writes); ``categories`` any of;
    tag and bounds filters are not supported (the cell's entities carry no tags and no bounds).
    """
    if tags:
        raise SimulationError(FEATURE_UNSUPPORTED, "filters.tags: entity tags are not supported")
    if bounded:
        raise SimulationError(FEATURE_UNSUPPORTED, "filters.bounds: bounds filters are not supported")
    if len(pattern) > MAX_FILTER_CHARS:
        raise SimulationError(
            OPERATION_FAILED, f"filters.filter: at most {MAX_FILTER_CHARS} characters, got {len(pattern)}"
        )
    try:
        compiled = re.compile(pattern)
    except re.error as error:
        raise SimulationError(OPERATION_FAILED, f"filters.filter: bad regular expression: {error}") from None
    wanted = set(categories)
    return sorted(
        (e for e in entities if compiled.search(e.name) and (not wanted or e.category in wanted)),
        key=lambda e: e.name,
    )
