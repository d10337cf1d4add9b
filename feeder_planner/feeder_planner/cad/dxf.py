"""Planar parts from DXF drawings, read with ezdxf.

Outline entities: LWPOLYLINE and 2-D POLYLINE (bulges are arcs), LINE, ARC, CIRCLE, ELLIPSE and SPLINE,
in the model space or in one block definition (``block``), on every layer or on one (``layer``); INSERTs
in the chosen space are expanded with their placement. Curves are flattened by ezdxf's Path, with chords
within ``chord_tolerance`` times the drawing's bounding-box diagonal (ezdxf converts a SPLINE to cubic
Bezier segments first: exact for cubic B-splines, the usual export). Coordinates are the WCS x and y: a
part is drawn in the XY plane. Other entities (TEXT, DIMENSION, HATCH, POINT...) are listed as ignored.

The unit is the header's ``$INSUNITS``; 0 (unitless) or a code without a length for parts is refused
unless ``unit`` overrides it. A file is read through the project's reading layer (size limit, regular
file) and parsed by ezdxf's recover mode, which tolerates the small structural faults of real exports.
"""

from __future__ import annotations

import io
from collections import Counter
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from feeder_planner.cad.options import CAD_UNITS, CadOptions, unit_scale
from feeder_planner.cad.outline import Outline, Piece, assemble_outline
from feeder_planner.errors import InputError
from feeder_planner.limits import quote
from feeder_planner.reading import read_bytes

__all__ = ["INSUNITS", "read_dxf"]

# $INSUNITS codes (AutoCAD's DXF reference) of the length units a part can have: metres per unit.
INSUNITS: dict[int, tuple[str, float]] = {
    1: ("in", 0.0254),
    2: ("ft", 0.3048),
    4: ("mm", 1e-3),
    5: ("cm", 1e-2),
    6: ("m", 1.0),
    8: ("microinch", 2.54e-8),
    9: ("mil", 2.54e-5),
    13: ("um", 1e-6),
    14: ("dm", 0.1),
}
_OUTLINE_TYPES = ("LWPOLYLINE", "POLYLINE", "LINE", "ARC", "CIRCLE", "ELLIPSE", "SPLINE")
# INSERTs inside blocks inside blocks...: deeper than this is refused (a block that inserts itself loops).
_MAX_INSERT_DEPTH = 8


def read_dxf(path: str | Path, options: CadOptions) -> Outline:
    """Read the outline and holes of the part a DXF file draws; InputError naming the entity otherwise."""
    doc = _document(path)
    scale, unit_name = _unit(doc, options)
    entities, ignored = _entities(doc, options)
    where = (f" on layer {options.layer!r}" if options.layer else "") + (
        f" in block {options.block!r}" if options.block else ""
    )
    if not entities:
        kinds = ", ".join(_OUTLINE_TYPES)
        raise InputError(
            "<file>",
            f"no outline entity{where} ({kinds}); it is empty or holds only {_listed(ignored) or 'nothing'}: "
            "draw the part's boundary, or choose its layer or block",
        )
    pieces = _pieces(entities, options.chord_tolerance)
    choose = _choice_hint(doc, options)
    outer, holes = assemble_outline(pieces, choose)
    notes = (f"ignored: {_listed(ignored)}",) if ignored else ()
    return Outline(outer, holes, scale, unit_name, tuple(pieces), notes)


def _document(path: str | Path) -> Any:
    """Parse the file with ezdxf's recover mode; any parse failure is one InputError line."""
    import ezdxf.recover  # imported here: ezdxf takes about 0.2 s to import and most parts are YAML

    data = read_bytes(path)
    if not data.strip():
        raise InputError("<file>", "is empty; export the drawing again")
    try:
        doc, _auditor = ezdxf.recover.read(io.BytesIO(data))
    except Exception as exc:  # ezdxf raises DXFStructureError, ValueError, UnicodeError... on broken files
        raise InputError(
            "<file>", f"is not a readable DXF file ({type(exc).__name__}: {quote(str(exc))}); export it again"
        ) from None
    return doc


def _unit(doc: Any, options: CadOptions) -> tuple[float, str]:
    """Metres per drawing unit: the ``unit`` option, else ``$INSUNITS``."""
    if options.unit is not None:
        return unit_scale(options.unit, "cad.unit"), f"{options.unit} (given by unit)"
    code = doc.header.get("$INSUNITS", 0)
    override = f"or give unit: ({', '.join(CAD_UNITS)}) in the part YAML's cad: mapping"
    if code in (0, None):
        raise InputError(
            "$INSUNITS",
            f"units missing: the drawing is unitless; set its insertion units in the CAD tool {override}",
        )
    if code not in INSUNITS:
        raise InputError(
            "$INSUNITS", f"unknown or unsupported unit code {quote(code)}; set mm, cm, m or in {override}"
        )
    name, scale = INSUNITS[code]
    return scale, f"{name} ($INSUNITS {code})"


def _entities(doc: Any, options: CadOptions) -> tuple[list[tuple[Any, str]], Counter[str]]:
    """Return the outline entities of the chosen space and layer, with their labels, and the ignored kinds."""
    if options.block is not None:
        space = doc.blocks.get(options.block)
        if space is None or options.block.startswith("*"):
            names = [b.name for b in doc.blocks if not b.name.startswith("*")]
            raise InputError(
                "cad.block",
                f"no block {options.block!r} in the drawing; its blocks: {', '.join(names) or 'none'}",
            )
    else:
        space = doc.modelspace()
    chosen: list[tuple[Any, str]] = []
    ignored: Counter[str] = Counter()
    layers: set[str] = set()
    for entity, label in _flattened_inserts(space, "", 0):
        kind = entity.dxftype()
        layer = _layer(entity)
        layers.add(layer)
        if options.layer is not None and layer != options.layer:
            continue
        if kind == "POLYLINE" and not entity.is_2d_polyline:
            ignored["3-D POLYLINE or mesh"] += 1
        elif kind in _OUTLINE_TYPES:
            chosen.append((entity, f"{label}{kind} #{_handle(entity)} on layer {layer}"))
        else:
            ignored[kind] += 1
    if options.layer is not None and options.layer not in layers:
        raise InputError(
            "cad.layer", f"no entity on layer {options.layer!r}; the layers used: {', '.join(sorted(layers))}"
        )
    return chosen, ignored


def _flattened_inserts(space: Iterable[Any], prefix: str, depth: int) -> Iterator[tuple[Any, str]]:
    """Every entity of ``space``, INSERTs replaced by their block's entities in place (label prefix)."""
    for entity in space:
        if entity.dxftype() != "INSERT":
            yield entity, prefix
            continue
        name = entity.dxf.get("name", "?")
        handle = _handle(entity)
        if depth >= _MAX_INSERT_DEPTH:
            raise InputError(
                f"INSERT #{handle}",
                f"block {name!r} nests inserts deeper than {_MAX_INSERT_DEPTH} (or inserts itself); "
                "explode it",
            )
        try:
            children = list(entity.virtual_entities())
        except Exception as exc:  # a broken reference or a non-uniform scale ezdxf cannot apply
            raise InputError(
                f"INSERT #{handle} of block {name!r}",
                f"cannot be placed ({type(exc).__name__}); explode it in the CAD tool",
            ) from None
        layer = _layer(entity)
        for child in children:
            if _layer(child) == "0":  # CAD's rule: a block's layer-0 entities take the INSERT's layer
                child.dxf.layer = layer
        yield from _flattened_inserts(children, f"{prefix}INSERT #{handle} of {name!r}: ", depth + 1)


def _pieces(entities: list[tuple[Any, str]], chord_tolerance: float) -> list[Piece]:
    """Flatten every entity into a Piece, chords within ``chord_tolerance`` x the drawing's diagonal."""
    from ezdxf import bbox

    try:
        box = bbox.extents([entity for entity, _ in entities], fast=True)
        diagonal = float(np.linalg.norm(np.array(box.size)[:2])) if box.has_data else 0.0
    except Exception:  # a malformed entity: the flattening below names it
        diagonal = 0.0
    distance = chord_tolerance * diagonal if np.isfinite(diagonal) and diagonal > 0.0 else 1e-9
    pieces = []
    for entity, label in entities:
        try:
            points, closed = _flattened(entity, distance)
        except InputError:
            raise
        except Exception as exc:  # a curve with bad parameters (zero radius, too few control points...)
            raise InputError(
                label, f"cannot be flattened ({type(exc).__name__}); redraw or delete it"
            ) from None
        if len(points) < 2 or not np.isfinite(points).all():
            raise InputError(label, "has no extent or a coordinate that is not finite; redraw or delete it")
        pieces.append(Piece(points, closed, label))
    return pieces


def _flattened(entity: Any, distance: float) -> tuple[np.ndarray, bool]:
    """Return an entity's points, chords within ``distance`` of the exact curve, and whether it closes.

    Arcs, circles, ellipses and splines are flattened on their exact geometry (ezdxf's construction
    tools), not through ezdxf's Path, whose cubic Bezier arcs are off the circle by up to 2.7e-4 of the
    radius whatever the tolerance. A polyline's bulges are exploded into its ARCs first.
    """
    kind = entity.dxftype()
    if kind == "LINE":
        return np.array([entity.dxf.start, entity.dxf.end], dtype=float)[:, :2], False
    if kind in ("ARC", "CIRCLE"):
        points = _xy(entity.flattening(sagitta=distance))
        return points, kind == "CIRCLE"
    if kind in ("ELLIPSE", "SPLINE"):
        points = _xy(entity.flattening(distance))
        span = float(np.ptp(points, axis=0).max()) if len(points) else 0.0
        return points, len(points) > 2 and float(np.abs(points[0] - points[-1]).max()) <= 1e-9 * span
    closed = bool(entity.is_closed)
    if not getattr(entity, "has_arc", True):
        vertices = (
            entity.get_points("xy") if kind == "LWPOLYLINE" else [v.dxf.location for v in entity.vertices]
        )
        return np.array([(p[0], p[1]) for p in vertices], dtype=float), closed
    points = np.zeros((0, 2))
    for part in entity.virtual_entities():  # LINEs and ARCs in the polyline's order
        segment, _ = _flattened(part, distance)
        if len(points) and np.abs(segment[-1] - points[-1]).max() < np.abs(segment[0] - points[-1]).max():
            segment = segment[::-1]  # an exploded ARC runs counter-clockwise, its bulge may not
        points = np.concatenate([points, segment[1:] if len(points) else segment])
    return points, closed


def _xy(vertices: Iterable[Any]) -> np.ndarray:
    """Return the x and y of ezdxf vectors as an (n, 2) array."""
    return np.array([(v.x, v.y) for v in vertices], dtype=float).reshape(-1, 2)


def _choice_hint(doc: Any, options: CadOptions) -> str:
    """How to choose one part in this drawing, naming its layers and blocks."""
    layers = sorted({_layer(e) for e in doc.modelspace()})
    blocks = [b.name for b in doc.blocks if not b.name.startswith("*")]
    listed = f"layers: {', '.join(layers[:8]) or 'none'}; blocks: {', '.join(blocks[:8]) or 'none'}"
    return (
        "put one part per layer or block and choose it with layer: or block: in the part YAML's cad: "
        f"mapping ({listed})"
    )


def _layer(entity: Any) -> str:
    """Return an entity's layer name ("0" when a damaged entity has none)."""
    try:
        return str(entity.dxf.get("layer", "0"))
    except Exception:  # ezdxf's DXFAttributeError: the entity's kind has no layer attribute
        return "0"


def _handle(entity: Any) -> str:
    """Return an entity's handle ("?" when a damaged entity has none)."""
    try:
        return str(entity.dxf.get("handle", "?"))
    except Exception:  # as _layer
        return "?"


def _listed(kinds: Counter[str]) -> str:
    """``3 TEXT, 1 DIMENSION``."""
    return ", ".join(f"{n} {kind}" for kind, n in kinds.most_common())
