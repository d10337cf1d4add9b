"""The part the throwing arm holds, ROS-free: the configured one, and one loaded at runtime (``~/load_part``).

The arm holds one part. ``HeldPart`` says which: its name, its part document (what the latched ``~/part``
describes, so that another node can rebuild the hull the arm numbers its edges by) and where it came from.
The configured part is the ``part_file`` parameter's: its name is the document's ``name`` (``part`` without
one). ``load_arm_part`` replaces it by a part document given as YAML text (contract section 2), read
through the project's part-reading layer (``fields_io``, ``parts``: every problem names
``part_yaml.<field>``), at rest on hull edge ``edge`` at throw radius ``radius``: -1 is the part's first
stable edge and 0 is ``DEFAULT_RADIUS_FACTOR`` times the edge's lowest throwable radius, as the parameters
``initial_edge`` and ``initial_radius`` mean them; otherwise the start is checked as ``~/place_part``
checks one, against the new part. Its name is the one asked for, else the document's, else ``part``.
Nothing changes before every check has passed.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

from feeder_planner.errors import InputError
from feeder_planner.fields_io import short_string, yaml_mapping_from_text
from feeder_planner.limits import quote
from feeder_planner.parts import part_document, part_from_mapping
from feeder_planner.throwing import ArmPart, arm_part, lowest_radius
from feeder_sim.throwing.cycle import ThrowCycle
from feeder_sim.throwing.parameters import DEFAULT_RADIUS_FACTOR, ArmParameters

__all__ = ["MAX_SOURCE_CHARS", "HeldPart", "configured_part", "arm_part_from_yaml", "load_arm_part"]

# The longest source (a path or URI, quoted in messages).
MAX_SOURCE_CHARS = 4096


@dataclass(frozen=True)
class HeldPart:
    """The part the arm holds: its name, its part document and where it came from."""

    name: str
    document: dict[str, Any]
    source: str

    def description(self) -> dict[str, Any]:
        """Return the part document with the part's name (what ``~/part`` publishes)."""
        return {**self.document, "name": self.name}


def configured_part(p: ArmParameters, part: ArmPart) -> HeldPart:
    """Return the configured part (``part`` as ``configure_arm`` read it from ``p.part_file``)."""
    try:
        document = part_document(p.part_file)  # a CAD part file as the outline it was read as
    except InputError as error:
        raise InputError("parameter part_file", str(error)) from None
    return HeldPart(part.part.name, document, p.part_file)


def _check_text_fields(name: str, source: str) -> None:
    """Refuse a name that cannot name a part and a source that is not one printable line."""
    if name:
        short_string(name, "name", "a part name")
        if name != name.strip() or not name.isprintable():
            raise InputError(
                "name",
                f"expected a part name: printable characters without blanks at either end, got {quote(name)}",
            )
    if len(source) > MAX_SOURCE_CHARS or not source.isprintable():
        raise InputError(
            "source",
            f"expected one printable line of at most {MAX_SOURCE_CHARS} characters, got {quote(source)}",
        )


def arm_part_from_yaml(
    text: str, name: str = "", source: str = "", field: str = "part_yaml"
) -> tuple[ArmPart, HeldPart]:
    """Read a part document given as YAML text: the arm's view of the part, and the part as held.

    Every problem names ``field`` or ``field.<the document's field>`` (``part_yaml.vertices``), attributed
    to ``source``; ``name`` (default: the document's, else ``part``) must be a part name.
    """
    _check_text_fields(name, source)
    where = source or None
    try:
        document = yaml_mapping_from_text(text, field, field)
    except InputError as error:
        raise InputError(field, error.problem, where) from None
    try:
        part = part_from_mapping(document)
    except InputError as error:
        raise InputError(f"{field}.{error.field}", error.problem, where) from None
    if name:
        part = replace(part, name=name)
    return arm_part(part), HeldPart(part.name, document, source)


def start_on(part: ArmPart, edge: int, radius: float, cycle: ThrowCycle) -> tuple[int, float]:
    """Return the start (edge, R) asked for: -1 and 0 as ``initial_edge`` and ``initial_radius`` read them."""
    if edge == -1:
        edge = part.stable_edges[0]
    elif not (0 <= edge < part.n) or not part.stable[edge]:
        raise InputError(
            "edge",
            f"must be a stable hull edge of the part {part.stable_edges} (or -1: the first), got {edge}",
        )
    if radius == 0.0:
        radius = DEFAULT_RADIUS_FACTOR * lowest_radius(part, edge, cycle.arm.params)
    return edge, radius


def load_arm_part(
    cycle: ThrowCycle, text: str, name: str, source: str, start: tuple[int, float], arm_length: float
) -> HeldPart:
    """Replace the part the arm of ``cycle`` holds by the document ``text``, at rest at ``start`` (edge, R).

    Raises InputError naming the field (``part_yaml.vertices``, ``name``, ``edge``, ``radius``) before
    anything changes; ends any throw being shown and a part lost, as placing does.
    """
    part, held = arm_part_from_yaml(text, name, source)
    edge, radius = start_on(part, *start, cycle)
    cycle.load(part, edge, radius, arm_length)
    return held
