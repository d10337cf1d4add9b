"""The parts on the MEMS field array, ROS-free: the configured ones, and those spawned and removed at runtime.

``ArrayParts`` keeps, in the order of the scene's bodies (the order of ``~/part_states`` and ``~/parts``),
each part's name on the array, its part document, where it came from, its body in the scene and, for a
configured part, its initial pose. What ``~/spawn_part``, ``~/remove_part`` and ``~/place_parts`` with
reset do to them is decided here (docs/mems.md, "Parts at runtime"):

- **spawn** adds a part, read from a part document given as YAML text through the project's part-reading
  layer (``fields_io``, ``parts``: every problem names ``part_yaml.<field>``), at rest at a pose checked
  as ``~/place_parts`` checks one (finite, within the array's reach), under a name: the one asked for,
  else the document's ``name``, else ``part<i>`` (``i`` the number of parts on the array, or the next
  integer free). A name is one line of 1 to ``MAX_NAME_CHARS`` printable characters without blanks at
  either end, and no two parts share one. The array holds at most ``MAX_PARTS`` parts.
- **remove** takes a part (configured or spawned) off the array by name.
- **reset** gives the array as configured: the configured parts (removed ones too) at their initial poses,
  at rest, in their configured order; spawned parts are gone.

Every refusal names the request's field, and nothing changes before every check has passed.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from feeder_device.declarations import DeviceError
from feeder_planner.errors import InputError
from feeder_planner.fields_io import short_string, yaml_mapping_from_text
from feeder_planner.limits import quote
from feeder_planner.parts import Part, part_from_mapping
from feeder_sim.mems.bodies import Body
from feeder_sim.mems.placing import check_coordinate
from feeder_sim.mems.scene import Scene

__all__ = [
    "MAX_PARTS",
    "MAX_SOURCE_CHARS",
    "ArrayPart",
    "ArrayParts",
    "check_part_name",
    "part_from_yaml",
]

# The most parts the array holds (configured and spawned): far above any cell's dozen, and a bound on
# what one tick costs (the ideal model takes about 0.2 ms per part and step on this machine).
MAX_PARTS = 100
# The longest source (a path or URI, quoted in messages).
MAX_SOURCE_CHARS = 4096


def check_part_name(name: str, field: str = "name") -> str:
    """Return ``name`` if it can name a part on the array, else raise InputError naming ``field``."""
    short_string(name, field, "a part name")
    if name != name.strip() or not name.isprintable():
        raise InputError(
            field,
            f"expected a part name: printable characters without blanks at either end, got {quote(name)}",
        )
    return name


def check_source(source: str, field: str = "source") -> str:
    """Return ``source`` (may be empty) if it is one printable line of at most MAX_SOURCE_CHARS."""
    if len(source) > MAX_SOURCE_CHARS or not source.isprintable():
        raise InputError(
            field,
            f"expected one printable line of at most {MAX_SOURCE_CHARS} characters, got {quote(source)}",
        )
    return source


def part_from_yaml(text: str, field: str = "part_yaml", source: str = "") -> tuple[Part, dict[str, Any]]:
    """Read a part document given as YAML text (contract section 2): the Part and the document.

    Through the project's reading layer (bounded YAML, the part file's checks); every problem names
    ``field`` or ``field.<the document's field>`` (``part_yaml.vertices``), attributed to ``source``.
    """
    where = source or None
    try:
        document = yaml_mapping_from_text(text, field, field)
    except InputError as error:
        raise InputError(field, error.problem, where) from None
    try:
        return part_from_mapping(document), document
    except InputError as error:
        raise InputError(f"{field}.{error.field}", error.problem, where) from None


@dataclass(frozen=True)
class ArrayPart:
    """A part on the array: its name, part document, source, body, and initial pose (configured only)."""

    name: str
    document: dict[str, Any]
    source: str
    body: Body
    initial: np.ndarray | None = None  # None: spawned at runtime

    @property
    def spawned(self) -> bool:
        """Whether the part was spawned at runtime (not configured)."""
        return self.initial is None


class ArrayParts:
    """The parts on one scene's array, in the order of its bodies; configured at first."""

    def __init__(
        self,
        scene: Scene,
        names: Sequence[str],
        documents: Sequence[dict[str, Any]],
        initial: np.ndarray,
        sources: Sequence[str] = (),
    ) -> None:
        count = len(scene.bodies)
        if not (len(names) == len(documents) == len(initial) == count):
            raise ValueError(f"{count} bodies need as many names, documents and initial poses")
        sources = list(sources) or [""] * count
        self.scene = scene
        self.configured = tuple(
            ArrayPart(name, document, source, body, np.array(pose, float))
            for name, document, source, body, pose in zip(
                names, documents, sources, scene.bodies, initial, strict=True
            )
        )
        self.entries: list[ArrayPart] = list(self.configured)

    @property
    def names(self) -> list[str]:
        """The names of the parts on the array, in the order of the scene's bodies."""
        return [entry.name for entry in self.entries]

    def documents(self) -> list[dict[str, Any]]:
        """Return the parts' documents, each with its name on the array (what ``~/parts`` describes)."""
        return [{**entry.document, "name": entry.name} for entry in self.entries]

    def spawn(
        self,
        name: str,
        text: str,
        source: str,
        pose: tuple[float, float, float],
        reach: float,
    ) -> ArrayPart:
        """Add the part of document ``text`` at rest at ``pose`` (x, y, theta) under a name; return it.

        Raises InputError naming the field (``name``, ``part_yaml.vertices``, ``x``, ``source``), or
        DeviceError when the array holds MAX_PARTS parts already.
        """
        if len(self.entries) >= MAX_PARTS:
            raise DeviceError(
                f"spawn_part refused: the array holds {len(self.entries)} parts, the most it takes "
                f"(MAX_PARTS); ~/remove_part one first"
            )
        check_source(source)
        if name:
            check_part_name(name)
        coordinates = [
            check_coordinate(key, v, reach) for key, v in zip(("x", "y", "theta"), pose, strict=True)
        ]
        part, document = part_from_yaml(text, "part_yaml", source)
        derived = not name
        if derived:
            name = self._derived_name(document)
        taken = self.names
        if name in taken:
            how = " (the document's name; give the part another in name)" if derived else ""
            raise InputError(
                "name", f"a part named {quote(name)} is on the array already{how} (parts: {_listed(taken)})"
            )
        entry = ArrayPart(name, document, source, Body(part, np.array(coordinates, float)))
        self.scene.add_body(entry.body)
        self.entries.append(entry)
        return entry

    def _derived_name(self, document: dict[str, Any]) -> str:
        """Return the name of a part spawned without one: the document's, else the first free part<i>."""
        if isinstance(document.get("name"), str):
            return str(document["name"])  # part_from_mapping has checked it as a name
        taken, index = set(self.names), len(self.entries)
        while f"part{index}" in taken:
            index += 1
        return f"part{index}"

    def index(self, name: str, field: str = "name") -> int:
        """Return the index of the part named ``name``, or raise InputError listing the known names."""
        for index, entry in enumerate(self.entries):
            if entry.name == name:
                return index
        raise InputError(field, f"no part named {quote(name)} on the array (parts: {_listed(self.names)})")

    def remove(self, name: str) -> ArrayPart:
        """Take the part named ``name`` (configured or spawned) off the array and return it."""
        index = self.index(name)
        self.scene.remove_body(index)
        return self.entries.pop(index)

    def as_configured(self) -> bool:
        """Whether the array holds its configured parts in their order (nothing spawned or removed)."""
        return len(self.entries) == len(self.configured) and all(
            a is b for a, b in zip(self.entries, self.configured, strict=True)
        )

    def reset(self) -> bool:
        """Give the array as configured: configured parts at their initial poses at rest, spawned ones gone.

        Returns whether the set of parts changed (a spawned part removed, a removed configured part back).
        """
        if self.as_configured():
            for index, entry in enumerate(self.entries):
                assert entry.initial is not None
                self.scene.place_body(index, entry.initial.copy())
            return False
        for index in reversed(range(len(self.entries))):
            self.scene.remove_body(index)
        for entry in self.configured:
            assert entry.initial is not None
            entry.body.pose, entry.body.velocity = entry.initial.copy(), np.zeros(3)
            entry.body.wrench = np.zeros(3)
            self.scene.add_body(entry.body)
        self.entries = list(self.configured)
        return True


def _listed(names: Sequence[str]) -> str:
    """Return the names for a message: quoted, comma-separated, at most 20 and a count of the rest."""
    shown = ", ".join(quote(n, 40) for n in names[:20])
    more = f" and {len(names) - 20} more" if len(names) > 20 else ""
    return (shown + more) if names else "none"
