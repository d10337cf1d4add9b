"""From the curves of a CAD file to one planar outline with holes, every problem named by its source entity.

A reader (DXF, SVG, a solid's section) hands over ``Piece`` objects: polylines already flattened, in the
file's length unit, each labelled by the entity it came from (``LWPOLYLINE #2F on layer PART``). This
module chains open pieces into closed loops (``JOIN_TOLERANCE``), refuses what is not one part, and sorts
the loops into the outer boundary and its holes by nesting:

- a piece whose end meets no other piece: an open contour;
- three or more pieces meeting at one point: a branch, not a boundary;
- a loop that crosses itself or another loop; a loop of zero area;
- more than one outermost loop: several parts, and no choice made (the reader's ``choose`` hint says how);
- a loop inside a hole: an island, which is another part.

Every refusal is an InputError whose field is the entity's label and whose problem ends with what to do.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from feeder_planner import polygon
from feeder_planner.errors import InputError
from feeder_planner.limits import MAX_PART_VERTICES

__all__ = ["JOIN_TOLERANCE", "Piece", "Loop", "Outline", "assemble_outline"]

# Two piece ends closer than this, relative to the drawing's bounding-box diagonal, are one joint: a DXF
# written in single precision or rounded to 6 decimals still chains, two ends a visible gap apart do not.
JOIN_TOLERANCE = 1e-6


@dataclass(frozen=True)
class Piece:
    """One flattened curve of the file: points (n, 2) in the file's unit, closed or open, and its label."""

    points: np.ndarray
    closed: bool
    label: str


@dataclass(frozen=True)
class Loop:
    """A closed loop (no repeated last point) and the labels of the pieces it is made of."""

    points: np.ndarray
    labels: tuple[str, ...]

    @property
    def label(self) -> str:
        """The loop's name in messages: its one piece, or its first pieces when chained."""
        if len(self.labels) == 1:
            return self.labels[0]
        more = f" and {len(self.labels) - 2} more" if len(self.labels) > 2 else ""
        return f"the chain of {self.labels[0]}, {self.labels[1]}{more}"


@dataclass(frozen=True)
class Outline:
    """What a CAD file gave: the outer loop and holes (file unit), the unit and every source entity."""

    outer: Loop
    holes: tuple[Loop, ...]
    unit_scale: float  # metres per file unit
    unit_name: str  # where the unit came from, for part-info ("$INSUNITS 4 (mm)")
    pieces: tuple[Piece, ...]  # every piece read, for part-info and its drawing
    notes: tuple[str, ...] = field(default=())  # what was skipped and why (ignored entity kinds)


def assemble_outline(pieces: Sequence[Piece], choose: str) -> tuple[Loop, tuple[Loop, ...]]:
    """Chain ``pieces`` into loops and return the outer loop and its holes.

    ``choose`` finishes the message for several disjoint outlines: how this format selects one part.
    """
    if not pieces:
        raise InputError("<file>", "holds no outline")
    everything = np.concatenate([p.points for p in pieces])
    with np.errstate(over="ignore", invalid="ignore"):  # a huge coordinate: refused just below
        diagonal = float(np.hypot(*np.ptp(everything, axis=0)))
    if not np.isfinite(diagonal):
        raise InputError(pieces[0].label, "a coordinate is not finite; fix or delete the entity")
    loops = [_closed(p) for p in pieces if p.closed] + _chain([p for p in pieces if not p.closed], diagonal)
    total = sum(len(loop.points) for loop in loops)
    if total > MAX_PART_VERTICES:
        raise InputError(
            "<file>",
            f"{total} outline vertices after flattening exceed the limit of {MAX_PART_VERTICES}; "
            "raise chord_tolerance or simplify the splines",
        )
    for loop in loops:
        _check_loop(loop)
    _check_apart(loops)
    return _nest(loops, choose)


def _closed(piece: Piece) -> Loop:
    """Return a closed piece as a loop, without the repeated first point."""
    points = piece.points
    span = float(np.ptp(points, axis=0).max()) if len(points) else 0.0
    while len(points) > 1 and np.abs(points[0] - points[-1]).max() <= JOIN_TOLERANCE * span:
        points = points[:-1]  # the closing point, repeated (to rounding) by the curve's last step
    return Loop(points, (piece.label,))


def _chain(pieces: list[Piece], diagonal: float) -> list[Loop]:
    """Join open pieces end to end into closed loops; refuse a dangling end or a branch point."""
    if not pieces:
        return []
    ends = np.array([[p.points[0], p.points[-1]] for p in pieces]).reshape(-1, 2)  # 2k: start, 2k+1: end
    tolerance = JOIN_TOLERANCE * max(diagonal, np.finfo(float).tiny)
    from scipy.spatial import cKDTree  # here, not at the top: parts and every node import this module

    tree = cKDTree(ends)
    neighbours: list[list[int]] = [[] for _ in ends]
    for a, b in tree.query_pairs(tolerance):
        if a // 2 != b // 2 or len(pieces[a // 2].points) > 2:  # a piece's own two ends meet: it closes
            neighbours[a].append(b)
            neighbours[b].append(a)
    for end, joined in enumerate(neighbours):
        piece = pieces[end // 2]
        x, y = ends[end]
        if not joined:
            raise InputError(
                piece.label,
                f"open contour: its {'start' if end % 2 == 0 else 'end'} ({x:.6g}, {y:.6g}) meets no other "
                "entity; close the gap in the drawing (or give the polyline the closed flag)",
            )
        if len(joined) > 1:
            others = ", ".join(pieces[j // 2].label for j in joined)
            raise InputError(
                piece.label,
                f"branch: {len(joined) + 1} entities meet at ({x:.6g}, {y:.6g}) (also {others}); "
                "a boundary has two per joint, delete the extra entity or move it to another layer",
            )
    used = [False] * len(pieces)
    loops = []
    for first in range(len(pieces)):
        if used[first]:
            continue
        parts, labels, end = [], [], 2 * first + 1  # walk from the first piece's end
        index, forward = first, True
        while True:
            used[index] = True
            points = pieces[index].points if forward else pieces[index].points[::-1]
            parts.append(points[:-1])
            labels.append(pieces[index].label)
            nxt = neighbours[end][0]
            index, forward = nxt // 2, nxt % 2 == 0
            end = nxt + 1 if forward else nxt - 1
            if index == first:
                break
        loops.append(Loop(np.concatenate(parts), tuple(labels)))
    return loops


def _check_loop(loop: Loop) -> None:
    """Refuse a loop that crosses itself or has zero area, naming its entity."""
    try:
        polygon.check_simple(loop.points, loop.label)
    except InputError as error:
        hint = (
            "the entity encloses no area, delete it or draw the part's boundary"
            if "zero area" in error.problem or "coincide" in error.problem or "at least 3" in error.problem
            else "redraw the boundary so that it does not cross itself"
        )
        raise InputError(loop.label, f"{error.problem}; {hint}") from None


def _check_apart(loops: list[Loop]) -> None:
    """Refuse two loops whose boundaries touch or cross (an outline and a hole must be apart)."""
    if len(loops) < 2:
        return
    contacts = polygon.loop_contacts([loop.points for loop in loops])
    if len(contacts):
        a, b = (int(k) for k in contacts[0])
        raise InputError(
            loops[a].label,
            f"crosses or touches {loops[b].label}; a hole must lie strictly inside the outline, "
            "and two parts apart",
        )


def _nest(loops: list[Loop], choose: str) -> tuple[Loop, tuple[Loop, ...]]:
    """Sort apart loops by how many others enclose them: 0 the outline, 1 its holes; refuse the rest."""
    firsts = np.array([loop.points[0] for loop in loops])
    inside = np.stack([polygon.points_in_polygon(firsts, loop.points) for loop in loops], axis=1)
    np.fill_diagonal(inside, False)
    depth = inside.sum(axis=1)  # inside[i, j]: loop i lies inside loop j
    outers = [loops[i] for i in np.flatnonzero(depth == 0)]
    if len(outers) > 1:
        names = "; ".join(loop.label for loop in outers[:3])
        more = f" and {len(outers) - 3} more" if len(outers) > 3 else ""
        raise InputError(
            "<file>", f"{len(outers)} disjoint outlines ({names}{more}) and no choice made; {choose}"
        )
    islands = np.flatnonzero(depth >= 2)
    if islands.size:
        raise InputError(
            loops[int(islands[0])].label,
            f"lies inside a hole: it is another part; {choose}",
        )
    return outers[0], tuple(loops[i] for i in np.flatnonzero(depth == 1))
