"""Planar parts from SVG drawings, read with svgelements (paths, basic shapes, groups and transforms).

Every shape (path, rect, circle, ellipse, polygon, polyline, line) becomes one piece per subpath, with
its transforms applied; text and images are ignored. ``element`` keeps only the element with that id and
its children. Curves are flattened here with chords within ``chord_tolerance`` times the drawing's
bounding-box diagonal: a cubic or quadratic Bezier into n equal parameter steps, n from the bound on the
distance between a curve and its chords (|B''| h^2 / 8), an elliptical arc into equal angle steps.

The file frame is the SVG's user space with y pointing up (SVG's y is negated), so the part looks as in
a viewer. The unit rule: ``unit`` says what one user unit is (the viewBox's unit, or a CSS pixel without
a viewBox); else the root's width has an absolute unit (mm, cm, in, pt, pc, Q) and with the viewBox gives
the scale; else the units are missing and the file is refused (a px or unitless width says nothing about
the part's size).
"""

from __future__ import annotations

import io
import math
import re
from pathlib import Path
from typing import Any

import numpy as np

from feeder_planner.cad.options import CadOptions, unit_scale
from feeder_planner.cad.outline import Outline, Piece, assemble_outline
from feeder_planner.errors import InputError
from feeder_planner.limits import quote
from feeder_planner.reading import decode_utf8, read_bytes

__all__ = ["read_svg"]

# A CSS pixel: the user unit of an SVG whose width has an absolute unit but which has no viewBox.
_METRES_PER_PX = 0.0254 / 96.0
_ABSOLUTE_UNITS = {"mm": 1e-3, "cm": 1e-2, "in": 0.0254, "pt": 0.0254 / 72, "pc": 0.0254 / 6, "q": 2.5e-4}
_LENGTH = re.compile(r"^\s*([0-9.eE+-]+)\s*([a-zA-Z%]*)\s*$")
# The most chords one curve becomes: with the vertex limit of a part, more could never be used.
_MAX_CHORDS = 10_000


def read_svg(path: str | Path, options: CadOptions) -> Outline:
    """Read the outline and holes of the part an SVG file draws; InputError naming the element otherwise."""
    svg = _document(path)
    scale, unit_name = _unit(svg, options)
    shapes, ignored = _shapes(svg, options)
    if not shapes:
        where = f" in element {options.element!r}" if options.element else ""
        raise InputError(
            "<file>",
            f"no shape{where} (path, rect, circle, ellipse, polygon, polyline, line); it is empty"
            f"{' or holds only ' + ', '.join(ignored) if ignored else ''}: draw the part's boundary",
        )
    pieces = _pieces(shapes, options.chord_tolerance, svg.viewbox_transform)
    choose = "give each part an id and choose it with element: in the part YAML's cad: mapping"
    outer, holes = assemble_outline(pieces, choose)
    notes = (f"ignored: {', '.join(ignored)}",) if ignored else ()
    return Outline(outer, holes, scale, unit_name, tuple(pieces), notes)


def _document(path: str | Path) -> Any:
    """Parse the file (bounded reading layer, UTF-8) with svgelements; a failure is one InputError."""
    import svgelements  # type: ignore[import-untyped]  # untyped; imported here, most parts are YAML

    text = decode_utf8(read_bytes(path), str(path))
    if not text.strip():
        raise InputError("<file>", "is empty; export the drawing again")
    try:
        svg = svgelements.SVG.parse(io.StringIO(text), reify=True, ppi=96.0)
    except Exception as exc:  # ParseError, ValueError, RecursionError... on broken XML or attributes
        raise InputError(
            "<file>", f"is not a readable SVG file ({type(exc).__name__}: {quote(str(exc))}); export it again"
        ) from None
    if not isinstance(svg, svgelements.SVG):
        raise InputError("<file>", "has no <svg> root element; export it again")
    return svg


def _unit(svg: Any, options: CadOptions) -> tuple[float, str]:
    """Return metres per user unit, by the unit rule of the module's docstring."""
    if options.unit is not None:
        return unit_scale(options.unit, "cad.unit"), f"{options.unit} per user unit (given by unit)"
    width_text = str(svg.values.get("width", "") or "")
    match = _LENGTH.match(width_text)
    suffix = match.group(2).lower() if match else ""
    if match and suffix in _ABSOLUTE_UNITS:
        try:
            width = float(match.group(1))
        except ValueError:
            width = math.nan
        box = svg.viewbox
        # The unit times the ratio: exact when the width and the viewBox's width are the same number.
        unit = _ABSOLUTE_UNITS[suffix]
        scale = unit * (width / box.width) if box is not None and box.width else _METRES_PER_PX
        if math.isfinite(scale) and scale > 0:
            return scale, f"{width_text} over the viewBox's width"
    raise InputError(
        "<svg width>",
        f"units missing: the root's width is {quote(width_text or 'absent')}, not in mm, cm, in, pt or pc; "
        "set the document's size in mm (with a viewBox), or give unit: (the length of one user unit) "
        "in the part YAML's cad: mapping",
    )


def _shapes(svg: Any, options: CadOptions) -> tuple[list[tuple[Any, str]], list[str]]:
    """Return the shapes to read (with labels) and the kinds of elements ignored."""
    import svgelements

    root = svg
    if options.element is not None:
        root = svg.get_element_by_id(options.element)
        if root is None:
            ids = [e.id for e in svg.elements() if getattr(e, "id", None)][:8]
            raise InputError(
                "cad.element", f"no element with id {options.element!r}; ids here: {', '.join(ids) or 'none'}"
            )
    elements = list(root.select()) if isinstance(root, svgelements.Group) else [root]
    shapes, ignored = [], []
    for index, element in enumerate(elements):
        if isinstance(element, svgelements.Shape):
            name = type(element).__name__.lower()
            ident = f" id={element.id!r}" if getattr(element, "id", None) else f" number {index}"
            shapes.append((element, f"<{name}>{ident}"))
        elif isinstance(element, (svgelements.Text, svgelements.Image)):
            ignored.append(type(element).__name__.lower())
    return shapes, ignored


def _pieces(
    shapes: list[tuple[Any, str]], chord_tolerance: float, viewbox_transform: str | None
) -> list[Piece]:
    """Flatten every subpath of every shape into a Piece (y up)."""
    import svgelements

    # Back from the viewport (where svgelements puts the shapes, through the root's viewBox and size, in
    # pixels rounded to 7 digits) to user space, the file frame, which _unit scales exactly.
    try:
        viewport = ~svgelements.Matrix(viewbox_transform or "")
    except (ZeroDivisionError, ValueError, OverflowError):
        raise InputError(
            "<svg viewBox>", "maps the drawing to nothing (a zero or huge size); fix the viewBox"
        ) from None
    paths = []
    for shape, label in shapes:
        try:
            path = svgelements.Path(shape) * viewport
            path.reify()
            paths.append((list(path), label))
        except Exception as exc:  # a shape with bad geometry (negative radius...)
            raise InputError(label, f"cannot be read ({type(exc).__name__}); redraw or delete it") from None
    ends = [(s.end.x, s.end.y) for segments, _ in paths for s in segments if s.end is not None]
    if not ends or not np.isfinite(ends).all():
        raise InputError(shapes[0][1], "has no extent or a coordinate that is not finite; redraw it")
    with np.errstate(over="ignore", invalid="ignore"):  # a huge coordinate is refused by the outline
        diagonal = float(np.hypot(*np.ptp(np.array(ends), axis=0)))
    tolerance = chord_tolerance * diagonal if diagonal > 0 else 1e-12
    pieces = []
    for segments, label in paths:
        pieces.extend(_subpaths(segments, label, tolerance))
    if not pieces:
        raise InputError(shapes[0][1], "draws no line or curve; redraw it")
    return pieces


def _subpaths(segments: list[Any], label: str, tolerance: float) -> list[Piece]:
    """Split a path's segments at each move into pieces, flattening curves (y negated)."""
    import svgelements

    pieces: list[Piece] = []
    points: list[tuple[float, float]] = []
    closed = False
    count = 0

    def finish() -> None:
        if len(points) > 1:
            name = label if count == 1 else f"{label} subpath {count}"
            pieces.append(Piece(np.array(points) * [1.0, -1.0], closed, name))

    for segment in segments:
        if isinstance(segment, svgelements.Move):
            finish()
            points, closed, count = [(segment.end.x, segment.end.y)], False, count + 1
            continue
        if not points:
            continue
        if isinstance(segment, svgelements.Close):
            closed = True
            if (segment.end.x, segment.end.y) != points[-1]:
                points.append((segment.end.x, segment.end.y))
            continue
        points.extend(_flatten(segment, tolerance, label))
    finish()
    return pieces


def _flatten(segment: Any, tolerance: float, label: str) -> list[tuple[float, float]]:
    """Return the points after a segment's start, chords within ``tolerance`` of the curve."""
    import svgelements

    if isinstance(segment, svgelements.Line):
        return [(segment.end.x, segment.end.y)]
    if isinstance(segment, svgelements.Arc):
        radius = max(abs(segment.rx), abs(segment.ry))
        step = 2.0 * math.acos(max(-1.0, 1.0 - tolerance / radius)) if radius > tolerance else math.pi
        n = math.ceil(abs(segment.sweep) / step) if step > 0 else 1
    elif isinstance(segment, (svgelements.CubicBezier, svgelements.QuadraticBezier)):
        control = np.array([(p.x, p.y) for p in (segment.start, *_controls(segment), segment.end)])
        second = np.diff(control, n=2, axis=0)
        bend = float(np.linalg.norm(second, axis=1).max())
        factor = 0.75 if len(control) == 4 else 0.25  # max|B''| / 8: 6 M / 8 for a cubic, 2 M / 8 quadratic
        n = math.ceil(math.sqrt(factor * bend / tolerance)) if bend > 0 else 1
    else:
        raise InputError(label, f"has a segment SVG does not define ({type(segment).__name__}); redraw it")
    if not 1 <= n <= _MAX_CHORDS:
        raise InputError(
            label, f"a curve needs {n} chords at this tolerance; raise chord_tolerance or redraw it"
        )
    return [(p.x, p.y) for p in (segment.point(k / n) for k in range(1, n + 1))]


def _controls(segment: Any) -> tuple[Any, ...]:
    """Return the inner control points of a Bezier segment."""
    if hasattr(segment, "control1"):
        return (segment.control1, segment.control2)
    return (segment.control,)
