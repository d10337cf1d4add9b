"""The choices a CAD part file may need: which entities, which unit, how fine, which face or section.

They come from a part YAML's ``cad:`` mapping (``cad: {file: bracket.dxf, layer: BRACKET}``) or from
``feeder part-info``'s flags. Every one is optional: a file with one outline and its units needs none.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any

from feeder_planner.errors import InputError
from feeder_planner.fields_io import finite_number, positive_number, short_string
from feeder_planner.limits import quote

__all__ = ["CHORD_TOLERANCE", "CAD_UNITS", "CadOptions", "options_from_mapping", "unit_scale"]

# Arcs, circles, ellipses and splines become polylines whose chords stay within this distance of the
# curve, relative to the drawing's bounding-box diagonal. Measured on examples/mems/bracket_filleted.dxf
# (5.3 mm across) against 1e-6: the equilibria's angles move by at most 1.3e-3 rad and their positions by
# 1.9e-7 m (delta 0.1 and 0.5), the grasp radii by 2.5e-7 m (docs/cli.md, "Importing parts"); 1e-5 moves
# the angles by 1.2e-4 rad with three times the vertices. A full circle as large as the drawing gets
# about 160 chords.
CHORD_TOLERANCE = 1e-4

# Length units a CAD file may be given in by ``unit:`` (metres each).
CAD_UNITS: dict[str, float] = {
    "m": 1.0,
    "dm": 0.1,
    "cm": 1e-2,
    "mm": 1e-3,
    "um": 1e-6,
    "in": 0.0254,
    "ft": 0.3048,
    "mil": 2.54e-5,
}


@dataclass(frozen=True)
class CadOptions:
    """How to read a CAD part; None leaves the choice to the file (or to the default)."""

    layer: str | None = None  # DXF: only entities on this layer
    block: str | None = None  # DXF: the entities of this block definition instead of the model space
    element: str | None = None  # SVG: only the element with this id (and its children)
    unit: str | None = None  # overrides the file's unit (a name of CAD_UNITS)
    chord_tolerance: float = CHORD_TOLERANCE  # relative to the drawing's bounding-box diagonal
    face: str | None = None  # STEP/STL: the face the solid rests on ('-z' default, '+x', ...)
    section: float | None = None  # STEP/STL: instead of resting, the section at this height along face
    body: int | None = None  # STEP: the solid to read (1, 2, ... in the file's order)


_FACES = ("-z", "+z", "-x", "+x", "-y", "+y")


def unit_scale(name: str, field: str) -> float:
    """Metres per unit ``name`` (CAD_UNITS); InputError naming ``field`` otherwise."""
    if name not in CAD_UNITS:
        raise InputError(field, f"unknown unit {name!r}; use one of {', '.join(CAD_UNITS)}")
    return CAD_UNITS[name]


def options_from_mapping(raw: dict[str, Any], prefix: str) -> CadOptions:
    """Read the options of a ``cad:`` mapping (its ``file`` is the caller's); errors name ``prefix.key``."""
    known = {f.name for f in fields(CadOptions)} | {"file"}
    unknown = sorted(set(raw) - known)
    if unknown:
        raise InputError(f"{prefix}.{unknown[0]}", f"unknown key (known: {', '.join(sorted(known))})")
    values: dict[str, Any] = {}
    for key in ("layer", "block", "element", "unit", "face"):
        if key in raw:
            values[key] = short_string(raw[key], f"{prefix}.{key}")
    if "unit" in values:
        unit_scale(values["unit"], f"{prefix}.unit")
    if "face" in values and values["face"] not in _FACES:
        raise InputError(f"{prefix}.face", f"expected one of {', '.join(_FACES)}, got {values['face']!r}")
    if "chord_tolerance" in raw:
        tolerance = positive_number(raw["chord_tolerance"], f"{prefix}.chord_tolerance")
        if tolerance > 0.1 or tolerance < 1e-9:
            raise InputError(
                f"{prefix}.chord_tolerance", f"expected 1e-9 to 0.1 (relative), got {tolerance:g}"
            )
        values["chord_tolerance"] = tolerance
    if "body" in raw:
        body = raw["body"]
        if isinstance(body, bool) or not isinstance(body, int) or body < 1:
            raise InputError(f"{prefix}.body", f"expected a solid's number 1, 2, ..., got {quote(body)}")
        values["body"] = body
    if "section" in raw:
        values["section"] = finite_number(raw["section"], f"{prefix}.section")
    return CadOptions(**values)
