"""Attractors of the throw map: periodic cycles and quasi-periodic sets, found from a grid of starts.

Theorem IV.6 of the paper speaks of a unique cycle; for parts whose visit sequence never repeats
exactly (a 12-vertex convex part, issue 14) the forward limit set is still one attractor, only not a
periodic one. Each start is iterated until its state, at the resolution of the start grid, stays in a
set it has visited before (an adaptive burn-in, capped by the caller's throws); starts whose recurrent
sets share a grid cell belong to one attractor.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from feeder_planner.throwing.throw_map import ASSUMPTIONS, ThrowBatch, radius_in_domain
from feeder_planner.throwing.tolerances import ATTRACTOR_WINDOW, MAX_MOTIF, MIN_WINDOW

__all__ = [
    "Rows",
    "Search",
    "iterate_to_recurrence",
    "Attractor",
    "group_attractors",
    "visit_runs",
    "find_period",
    "blocks",
    "round_pattern",
]

# The violations an attractor reports (toe_stub is refused outright: such a start leaves the domain).
REPORTED = ("lift_off", "slip", "off_arm")


@dataclass(frozen=True)
class Rows:
    """Per row of a batch (one start of one design): start, domain bound per edge, grid cells per edge.

    ``low[b, e]``: lowest throwable R of edge e for row b's design (inf: unstable edge); a cell of edge e
    is ``width[b, e]`` wide from ``low[b, e]`` (the start grid's resolution).
    """

    edge: np.ndarray
    radius: np.ndarray
    low: np.ndarray
    width: np.ndarray


@dataclass
class Search:
    """Trajectories of every row until recurrence or the cap.

    ``edge``, ``radius``, ``jog``, ``flags`` (bit k: ASSUMPTIONS[k]) have one column per throw;
    ``end[b]`` is the last state of row b; ``tail[b]`` the first state of its recurrent tail (-1: the row
    did not converge); ``escaped[b]``: a throw left the domain.
    """

    edge: np.ndarray
    radius: np.ndarray
    jog: np.ndarray
    flags: np.ndarray
    end: np.ndarray
    tail: np.ndarray
    escaped: np.ndarray
    cells: np.ndarray
    window: int

    @property
    def converged(self) -> np.ndarray:
        """Rows whose tail is recurrent (entered a set of cells they had visited before)."""
        return self.tail >= 0

    def tail_slice(self, b: int) -> slice:
        """Return the columns of row b's recurrent tail."""
        return slice(int(self.tail[b]), int(self.end[b]) + 1)


def _cell_codes(rows: Rows, idx: np.ndarray, edge: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """Return one integer per state: its edge and its cell of the start grid (edge-major)."""
    low = rows.low[idx, edge]
    width = rows.width[idx, edge]
    cell = np.floor((radius - low) / width)
    cell = np.clip(np.nan_to_num(cell, nan=-1.0), -1, 10**6).astype(np.int64)
    return edge.astype(np.int64) * (10**7) + cell


def default_window(throws: int) -> int:
    """Return the recurrence window: ATTRACTOR_WINDOW throws, at most a sixth of the cap.

    A sixth leaves a start five chances (windows 2..6) to show recurrence before a short cap; never
    below MIN_WINDOW, so a cap under two such windows cannot converge at all.
    """
    return max(MIN_WINDOW, min(ATTRACTOR_WINDOW, throws // 6))


def iterate_to_recurrence(
    rows: Rows,
    throw: Callable[[np.ndarray, np.ndarray, np.ndarray], ThrowBatch],
    throws: int,
    window: int | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> Search:
    """Iterate every row, in windows of throws, until it recurs at the grid's resolution, or the cap.

    A row has converged after window k (k >= 2) when the grid cells its states visit in window k all
    lie in those it visited before (from its start to the end of window k - 1) and window k holds a
    flip (Prop. IV.1: jogs alone have no
    stable fixed point, so a window of jogs only is a slow transit, not an attractor). Its tail is
    then windows k - 1 and k. The burn-in thus adapts to each start, up to ``throws`` per start.
    ``throw(idx, edge, radius)`` applies the map to rows ``idx``; ``progress(done, total)`` is told
    after each window.
    """
    w = default_window(throws) if window is None else window
    starts = len(rows.edge)
    edge = np.zeros((starts, throws + 1), dtype=np.int64)
    radius = np.full((starts, throws + 1), np.nan)
    jog = np.zeros((starts, throws + 1), dtype=bool)
    flags = np.zeros((starts, throws + 1), dtype=np.uint8)
    cells = np.zeros((starts, throws + 1), dtype=np.int64)
    edge[:, 0], radius[:, 0] = rows.edge, rows.radius
    cells[:, 0] = _cell_codes(rows, np.arange(starts), rows.edge, rows.radius)
    end = np.zeros(starts, dtype=np.int64)
    tail = np.full(starts, -1, dtype=np.int64)
    escaped = np.zeros(starts, dtype=bool)
    alive = np.arange(starts)
    seen: dict[int, set[int]] = {}
    for n in range(1, throws + 1):
        if alive.size == 0:
            break
        out = throw(alive, edge[alive, n - 1], radius[alive, n - 1])
        edge[alive, n], radius[alive, n] = out.edge, out.radius
        jog[alive, n] = out.is_jog(edge[alive, n - 1])
        bits = np.zeros(alive.size, dtype=np.uint8)
        for k, name in enumerate(ASSUMPTIONS):
            bits |= out.flag(name).astype(np.uint8) << k
        flags[alive, n] = bits
        landed = np.maximum(out.edge, 0)
        ok = (out.edge >= 0) & radius_in_domain(out.radius, rows.low[alive, landed])
        cells[alive, n] = _cell_codes(rows, alive, landed, out.radius)
        end[alive] = n
        escaped[alive[~ok]] = True
        alive = alive[ok]
        if n % w == 0:
            keep = []
            for b in alive:
                last = set(cells[b, n - w + 1 : n + 1].tolist())
                before = seen.setdefault(int(b), set(cells[b, : n - w + 1].tolist()))
                if n >= 2 * w and last <= before and not jog[b, n - w + 1 : n + 1].all():
                    tail[b] = n - 2 * w + 1
                else:
                    before |= last
                    keep.append(b)
            alive = np.array(keep, dtype=np.int64)
        if progress is not None and n % w == 0:
            progress(starts - alive.size, starts)
    return Search(edge, radius, jog, flags, end, tail, escaped, cells, w)


@dataclass(frozen=True)
class Attractor:
    """One attractor: its edges and radius ranges, periodic cycle or quasi-periodic pattern, its basin.

    ``pattern`` lists, for one round, each block of the visit sequence (a stretch repeating a motif of
    at most MAX_MOTIF edges) as [edge, min, max]: how many visits that edge gets in the block, over
    the rounds seen. ``throws_per_round`` is (min, mean, max); ``basin`` the fraction of all starts that
    reach it and ``longest_transient`` the most throws any of them took to enter its cells.
    ``violations``: the fraction of its throws that break each assumption (REPORTED).
    """

    edges: list[int]
    edge_radius_ranges: dict[int, tuple[float, float]]
    periodic: bool
    cycle: list[int] | None
    pattern: list[tuple[int, int, int]] | None
    throws_per_round: tuple[int, float, int] | None
    basin: float
    longest_transient: int
    median_transient: float
    violations: dict[str, float]
    members: list[int] = field(default_factory=list)

    def to_json(self) -> dict[str, Any]:
        """Return one entry of `limit-set --json` `attractors` (contract 3, SI)."""
        return {
            "edges": self.edges,
            "edge_radius_ranges": {str(e): list(r) for e, r in self.edge_radius_ranges.items()},
            "periodic": self.periodic,
            "cycle": self.cycle,
            "pattern": None if self.pattern is None else [list(p) for p in self.pattern],
            "throws_per_round": None if self.throws_per_round is None else list(self.throws_per_round),
            "basin": self.basin,
            "longest_transient": self.longest_transient,
            "median_transient": self.median_transient,
            "assumption_violations": self.violations,
        }


def visit_runs(edge_row: np.ndarray, jog_row: np.ndarray) -> tuple[list[int], list[int]]:
    """Return the visited edges (a visit starts at each flip) and the throws of each visit."""
    visits: list[int] = []
    lengths: list[int] = []
    for n in range(len(edge_row)):
        if n == 0 or not jog_row[n]:
            visits.append(int(edge_row[n]))
            lengths.append(1)
        else:
            lengths[-1] += 1
    return visits, lengths


def blocks(visits: list[int]) -> list[tuple[int, int]]:
    """Cut a visit sequence into blocks: maximal stretches with a period of at most MAX_MOTIF visits.

    Returns (start, end) index pairs. At each position the period reaching farthest wins (ties: the
    shorter), so (3, 2, 3, 2, ..., 0, 6, 0, 6) gives one block of 3/2 and one of 0/6.
    """
    out: list[tuple[int, int]] = []
    i, total = 0, len(visits)
    while i < total:
        best_end, best_len = i + 1, 1
        for length in range(1, MAX_MOTIF + 1):
            j = i + length
            if j > total:
                break
            while j < total and visits[j] == visits[j - length]:
                j += 1
            if j - i >= 2 * length and j > best_end:
                best_end, best_len = j, length
        if best_len == 1 and best_end == i + 1:
            # No repetition here: this visit joins the previous block (or opens one).
            if out and out[-1][1] == i:
                out[-1] = (out[-1][0], i + 1)
            else:
                out.append((i, i + 1))
        else:
            out.append((i, best_end))
        i = best_end
    return out


def round_pattern(
    visits: list[int], lengths: list[int]
) -> tuple[list[tuple[int, ...]], list[list[Counter[int]]], list[int], list[list[int]]] | None:
    """Return one row's rounds: block keys of a round, per round per block the visit counts, throws.

    A round is the shortest period of the sequence of block keys (the set of edges in a block), with
    the first and last blocks dropped (the window cuts them); the round starts at the block position
    with the most visits (ties: the smallest key). Also the order of first appearance of the edges
    in each block of the first round. None when the keys have no period within the tail.
    """
    cut = blocks(visits)[1:-1]
    keys = [tuple(sorted(set(visits[a:b]))) for a, b in cut]
    total = len(keys)
    period = None
    for p in range(1, total // 2 + 1):
        if all(keys[i] == keys[i + p] for i in range(total - p)):
            period = p
            break
    if period is None:
        return None
    size = [sum(b - a for a, b in cut[j::period]) / len(cut[j::period]) for j in range(period)]
    first = max(range(period), key=lambda j: (size[j], [-e for e in keys[j]]))
    rounds: list[list[Counter[int]]] = []
    throws: list[int] = []
    orders: list[list[int]] = []
    for start in range(first, total - period + 1, period):
        counts, spent = [], 0
        for a, b in cut[start : start + period]:
            counts.append(Counter(visits[a:b]))
            spent += sum(lengths[a:b])
            if not rounds:
                orders.append(list(dict.fromkeys(visits[a:b])))
        rounds.append(counts)
        throws.append(spent)
    if not rounds:
        return None
    round_keys = [keys[(first + j) % period] for j in range(period)]
    return round_keys, rounds, throws, orders


def find_period(visits: list[int], lengths: list[int]) -> tuple[list[int], list[int]] | None:
    """Return (one period of the visits, canonically rotated; throws of each whole period), or None."""
    visits, lengths = visits[1:-1], lengths[1:-1]
    total = len(visits)
    for p in range(1, total // 2 + 1):
        if all(visits[i] == visits[i + p] for i in range(total - p)):
            break
    else:
        return None
    if total < 2 * p:
        return None
    period = visits[:p]
    # Start the cycle at the visit with the longest stay (ties: smallest edge), as the paper tells its cycles.
    start = max(
        range(p), key=lambda j: (sum(n for _, n in zip(visits[j::p], lengths[j::p], strict=True)), -period[j])
    )
    canonical = period[start:] + period[:start]
    per_cycle = [sum(lengths[c : c + p]) for c in range(start, total - p + 1, p)]
    return canonical, per_cycle


def group_attractors(search: Search, rows: np.ndarray | None = None) -> list[Attractor]:
    """Group the converged rows (all, or those in ``rows``) into attractors and describe each.

    Rows whose tails share a grid cell belong to one attractor (union-find). The basin is over the
    rows considered, converged or not.
    """
    considered = np.arange(len(search.tail)) if rows is None else np.asarray(rows)
    members = [int(b) for b in considered if search.tail[b] >= 0]
    parent = {b: b for b in members}

    def root(b: int) -> int:
        while parent[b] != b:
            parent[b] = parent[parent[b]]
            b = parent[b]
        return b

    owner: dict[int, int] = {}
    tails = {b: set(search.cells[b, search.tail_slice(b)].tolist()) for b in members}
    for b in members:
        for c in tails[b]:
            if c in owner:
                ra, rb = root(owner[c]), root(b)
                if ra != rb:
                    parent[rb] = ra
            else:
                owner[c] = b
    groups: dict[int, list[int]] = {}
    for b in members:
        groups.setdefault(root(b), []).append(b)
    found = [_describe(search, g, len(considered)) for g in groups.values()]
    return sorted(found, key=lambda a: (-a.basin, a.edges))


def _describe(search: Search, group: list[int], total: int) -> Attractor:
    """Return the Attractor of one group of rows."""
    cellset: set[int] = set()
    for b in group:
        cellset |= set(search.cells[b, search.tail_slice(b)].tolist())
    transients = []
    ranges: dict[int, tuple[float, float]] = {}
    counts = np.zeros(len(ASSUMPTIONS))
    n_throws = 0
    seqs = []
    for b in group:
        sl = search.tail_slice(b)
        outside = np.flatnonzero(~np.isin(search.cells[b, : search.end[b] + 1], list(cellset)))
        transients.append(int(outside[-1]) + 1 if outside.size else 0)
        e, r = search.edge[b, sl], search.radius[b, sl]
        for edge in np.unique(e):
            values = r[e == edge]
            lo, hi = float(values.min()), float(values.max())
            old = ranges.get(int(edge))
            ranges[int(edge)] = (lo, hi) if old is None else (min(old[0], lo), max(old[1], hi))
        fl = search.flags[b, sl][1:]
        for k in range(len(ASSUMPTIONS)):
            counts[k] += int(((fl >> k) & 1).sum())
        n_throws += fl.size
        seqs.append(visit_runs(e, search.jog[b, sl]))
    violations = {name: float(counts[ASSUMPTIONS.index(name)] / max(n_throws, 1)) for name in REPORTED}
    cycles = [find_period(v, n) for v, n in seqs]
    names = [c[0] if c else None for c in cycles]
    periodic = names[0] is not None and all(n == names[0] for n in names)
    cycle = None
    pattern: list[tuple[int, int, int]] | None = None
    per_round: tuple[int, float, int] | None = None
    if periodic:
        cycle = names[0]
        spans = [t for c in cycles if c for t in c[1]]
        counter = Counter(cycle)
        pattern = [(e, counter[e], counter[e]) for e in dict.fromkeys(cycle)] if cycle else None
        if spans:
            per_round = (min(spans), float(np.mean(spans)), max(spans))
    else:
        pattern, per_round = _quasi_pattern(seqs)
    return Attractor(
        edges=sorted(ranges),
        edge_radius_ranges=dict(sorted(ranges.items())),
        periodic=periodic,
        cycle=cycle,
        pattern=pattern,
        throws_per_round=per_round,
        basin=len(group) / total,
        longest_transient=max(transients),
        median_transient=float(np.median(transients)),
        violations=violations,
        members=sorted(group),
    )


def _quasi_pattern(
    seqs: list[tuple[list[int], list[int]]],
) -> tuple[list[tuple[int, int, int]] | None, tuple[int, float, int] | None]:
    """Return the pattern and throws per round of a quasi-periodic attractor, from its rows' tails.

    Rows whose round has other block keys than the first row's are left out of the counts.
    """
    found = [f for f in (round_pattern(v, n) for v, n in seqs) if f is not None]
    if not found:
        return None, None
    keys, _, _, orders = found[0]
    lo: dict[tuple[int, int], int] = {}
    hi: dict[tuple[int, int], int] = {}
    spans: list[int] = []
    for f in found:
        if f[0] != keys:
            continue
        for counts in f[1]:
            for j, counter in enumerate(counts):
                for e in orders[j]:
                    c = counter.get(e, 0)
                    lo[(j, e)] = min(lo.get((j, e), c), c)
                    hi[(j, e)] = max(hi.get((j, e), c), c)
        spans += f[2]
    pattern = [(e, lo[(j, e)], hi[(j, e)]) for j in range(len(keys)) for e in orders[j] if (j, e) in lo]
    return pattern, (min(spans), float(np.mean(spans)), max(spans)) if spans else None
