"""Attractors of the throw map: periodic cycles and quasi-periodic sets, found from a grid of starts.

Theorem IV.3 of the paper: on a compact invariant Z (Theorem IV.5) every start reaches any neighbourhood
of its forward limit set and stays there; Theorem IV.6 speaks of a unique cycle, but for parts whose visit
sequence never repeats exactly (a 12-vertex convex part, issue 14) the forward limit set is still one
attractor, only not a periodic one. What a finite run can see of it is a tail that no longer changes.

The convergence rule (issue 25). A start is thrown, and at every check (a quarter of a window) after
the first two windows its last n/2 states are compared with their own second half, the last n/4
(``confirms``): both must hold flips (Prop. IV.1: jogs alone are a slow transit, never an attractor),
show the same edges and radius ranges to the resolution (``resolution``; a few older states beyond are
the sampling of a chaotic attractor's extremes, a stretch of them is a transient; a stretch of recent
states beyond the older ones is a range still growing, ``widening``), and the whole n/2
must repeat one exact cycle thrice, with radii that do not drift period after period, or, with enough
visits, none. Then the run must have kept to that tail, on its edges within its ranges and in phase
with its cycle, twice as long as it ever kept to it before leaving it (``settled``): the earlier stays
are how long a stretch of a richer attractor without its rarest edge or break can last. A transient
that the tail still holds shows in its older half only, so the start waits; as n grows the tail moves
past it. The start's tail is then its whole stay since it last left, the approach to the attractor cut
off, beyond its ranges and in the holes between its intervals (``tail_start``, ``hole_start``,
``_trim_to_group``; the transient ends there), and the attractor's edges, ranges, cycle, pattern, throws
per round and basin come from such tails only; the trigger range is read on them and on the older states
of their stays that may be visits (``Search.sensed``). A start that never confirms within the cap is
unconverged, never folded into an attractor (``Search.growing`` names those whose tails a growing range
alone kept from confirming). A start whose tail a richer attractor of its design holds (more edges, or
no exact cycle; ``_nested``) is thrown on and judged again. Starts whose tails have the same edges and
cycle and meeting radius ranges form one attractor (``_clusters``).

The rule replaces the former one (a start converged once the start grid's cells of one window were all
cells it had visited before, and its last two windows were its tail): a slow transient passes through
cells the attractor visits long before it reaches the attractor, so its visits were taken into the
attractor (issue 25's three designs).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from feeder_planner.throwing.throw_map import ASSUMPTIONS, ThrowBatch, radius_in_domain
from feeder_planner.throwing.tolerances import (
    ATTRACTOR_WINDOW,
    CHECKS_PER_WINDOW,
    CONFIRM_FLIPS,
    CYCLE_REPEATS,
    DRIFT_SHARE,
    HOLE_GAPS,
    MAX_MOTIF,
    MIN_WINDOW,
    OUTSIDE_SHARE,
    QUASI_VISITS,
    QUASI_WINDOWS,
    RESOLUTION_SPAN_SHARE,
    ROUNDING,
    SOJOURN_FACTOR,
    TAIL_GAPS,
    TRIGGER_GAPS,
)

__all__ = [
    "Rows",
    "Search",
    "default_window",
    "resolution",
    "Stretch",
    "stretch",
    "confirms",
    "settled",
    "tail_start",
    "closure_gap",
    "hole_start",
    "arrival",
    "widening",
    "iterate_to_attractor",
    "Attractor",
    "group_attractors",
    "visit_runs",
    "cycle_key",
    "find_period",
    "blocks",
    "round_pattern",
]

# The violations an attractor reports (toe_stub is refused outright: such a start leaves the domain).
REPORTED = ("lift_off", "slip", "off_arm")


@dataclass(frozen=True)
class Rows:
    """Per row of a batch (one start of one design): start, domain bound per edge, resolution per edge.

    ``low[b, e]``: lowest throwable R of edge e for row b's design (inf: unstable edge); ``width[b, e]``
    is the unit of the resolution at which radius ranges are compared (``resolution``): the design's
    widest edge span over RESOLUTION_CELLS.
    """

    edge: np.ndarray
    radius: np.ndarray
    low: np.ndarray
    width: np.ndarray


@dataclass
class Search:
    """Trajectories of every row until its tail confirmed or the cap.

    ``edge``, ``radius``, ``jog``, ``flags`` (bit k: ASSUMPTIONS[k]) have one column per throw;
    ``end[b]`` is the last state of row b; ``tail[b]`` and ``tail_end[b]`` the first and last states of
    its confirmed tail (-1: the row did not converge); ``escaped[b]``: a throw left the domain;
    ``width``: the rows' resolution unit; ``stretches[b]``: what row b's confirmed tail shows.
    ``stay[b]``: where row b's run began keeping to its confirmed tail (``settled``), before the approach
    is cut off (``tail_start``); ``sensed[b]``: the first of row b's states the trigger range is read on
    (``_trim_to_group``: the tail and the older states of the stay that may be visits), at most ``tail[b]``.
    ``growing[b]``: the edges whose radius range row b's last window was still widening when the throws
    ran out, its tail confirming but for that (``widening``); such a row is in no attractor.
    """

    edge: np.ndarray
    radius: np.ndarray
    jog: np.ndarray
    flags: np.ndarray
    end: np.ndarray
    tail: np.ndarray
    escaped: np.ndarray
    width: np.ndarray
    window: int
    tail_end: np.ndarray
    stay: np.ndarray
    sensed: np.ndarray
    stretches: dict[int, Stretch] = field(default_factory=dict)
    growing: dict[int, list[int]] = field(default_factory=dict)

    @property
    def converged(self) -> np.ndarray:
        """Rows whose tail confirmed (the same attractor in its last half as in the whole tail)."""
        return self.tail >= 0

    def tail_slice(self, b: int) -> slice:
        """Return the columns of row b's confirmed tail."""
        return slice(int(self.tail[b]), int(self.tail_end[b]) + 1)


def default_window(throws: int) -> int:
    """Return the window: ATTRACTOR_WINDOW throws, at most a sixth of the cap, never below MIN_WINDOW.

    A start is first judged after two windows and then every quarter window, so a sixth leaves a short
    cap some checks; a cap under two windows of MIN_WINDOW cannot converge at all.
    """
    return max(MIN_WINDOW, min(ATTRACTOR_WINDOW, throws // 6))


def resolution(width: float, low: float, high: float) -> float:
    """Return how far two radius-range ends may differ and still count equal, for a range [low, high].

    The resolution unit ``width`` (1 % of the widest edge span: a converging periodic orbit's range
    shrinks to points) or RESOLUTION_SPAN_SHARE of the range's own span (a quasi-periodic or chaotic
    attractor, whose extremes a finite stretch only approaches), whichever is larger.
    """
    return max(width, RESOLUTION_SPAN_SHARE * (high - low))


@dataclass(frozen=True)
class Stretch:
    """What a stretch of one row's states shows: its edges, each edge's radius range, its exact cycle."""

    edges: tuple[int, ...]
    low: tuple[float, ...]
    high: tuple[float, ...]
    cycle: tuple[int, ...] | None

    def ranges(self) -> dict[int, tuple[float, float]]:
        """Return the radius range of each edge."""
        return {e: (lo, hi) for e, lo, hi in zip(self.edges, self.low, self.high, strict=True)}


def _ranges(edge: np.ndarray, radius: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return the visited edges (sorted) and the lowest and highest radius on each."""
    order = np.argsort(edge, kind="stable")
    e, r = edge[order], radius[order]
    cuts = np.flatnonzero(np.diff(e)) + 1
    starts = np.concatenate([[0], cuts])
    return e[starts], np.minimum.reduceat(r, starts), np.maximum.reduceat(r, starts)


def _visits(edge: np.ndarray, jog: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return the edge of every visit (one starts at the first state and at each flip) and its throws."""
    starts = np.concatenate([[0], np.flatnonzero(~jog[1:]) + 1])
    return edge[starts], np.diff(np.concatenate([starts, [len(edge)]]))


def _period(visits: np.ndarray) -> int | None:
    """Return the shortest exact period of ``visits`` seen CYCLE_REPEATS times at least, or None."""
    # A period p has visits[p] == visits[0]: only those p are compared whole (a quasi-periodic tail of
    # hundreds of visits would otherwise cost hundreds of comparisons).
    for p in np.flatnonzero(visits[1 : len(visits) // CYCLE_REPEATS + 1] == visits[:1]) + 1:
        if np.array_equal(visits[p:], visits[:-p]):
            return int(p)
    return None


def cycle_key(visits: np.ndarray) -> tuple[int, ...] | None:
    """Return the exact cycle of a stretch's visits, as its least rotation; None when it has none.

    The first and last visits are dropped (the stretch's ends cut them). The least rotation names a
    cycle independently of where a stretch starts, so two stretches of one orbit compare equal.
    """
    inner = visits[1:-1]
    p = _period(inner)
    if p is None:
        return None
    one = [int(v) for v in inner[:p]]
    return min(tuple(one[k:] + one[:k]) for k in range(p))


def stretch(edge: np.ndarray, radius: np.ndarray, jog: np.ndarray) -> Stretch:
    """Return the Stretch of consecutive states (``jog[k]``: state k was reached from k - 1 by a jog)."""
    edges, low, high = _ranges(edge, radius)
    return Stretch(
        tuple(int(e) for e in edges),
        tuple(float(v) for v in low),
        tuple(float(v) for v in high),
        cycle_key(_visits(edge, jog)[0]),
    )


# A tail's edges, each edge's lowest and highest radius, and its exact cycle (None: quasi-periodic).
_Tail = tuple[np.ndarray, np.ndarray, np.ndarray, "tuple[int, ...] | None"]


def confirms(edge: np.ndarray, radius: np.ndarray, jog: np.ndarray, width: np.ndarray) -> bool:
    """Return whether a tail (a row's last 2N states) shows the same attractor as its last N states.

    See ``_confirm``.
    """
    return _confirm(edge, radius, jog, width) is not None


def _confirm(
    edge: np.ndarray,
    radius: np.ndarray,
    jog: np.ndarray,
    width: np.ndarray,
    quasi_min: int = 0,
    growth: bool = True,
) -> _Tail | None:
    """Return the tail's edges, ranges and cycle when it shows the same attractor as its last N states.

    Both halves hold CONFIRM_FLIPS flips (Prop. IV.1); the whole tail and its recent half visit the same
    edges; each edge's radius range over the recent half reaches the whole tail's to the resolution
    (``resolution``, ``width[e]`` the unit of edge e), or at most OUTSIDE_SHARE of the older half's
    states lie beyond it; no range is still growing (``widening``; ``growth`` False skips this test);
    and the whole tail repeats one exact cycle CYCLE_REPEATS times without drifting (``_drifting``), or,
    holding QUASI_VISITS visits and ``quasi_min`` states, has no cycle and neither has its recent half.
    Cheap tests first: most rejections are an edge the older half still visits.
    """
    recent = len(edge) - len(edge) // 2
    if int((~jog[1:recent]).sum()) < CONFIRM_FLIPS or int((~jog[recent:]).sum()) < CONFIRM_FLIPS:
        return None
    edges, low, high = _ranges(edge, radius)
    edges_new, low_new, high_new = _ranges(edge[recent:], radius[recent:])
    if not np.array_equal(edges, edges_new):
        return None
    older_e, older_r = edge[:recent], radius[:recent]
    for k, e in enumerate(edges):
        tol = resolution(float(width[e]), float(low[k]), float(high[k]))
        if low_new[k] - low[k] <= tol and high[k] - high_new[k] <= tol:
            continue
        # A chaotic attractor's extremes show up now and then: a few older states beyond the recent
        # range are sampling, a stretch of them (a transit, a slow approach) is a transient.
        mine = older_r[older_e == e]
        beyond = (mine < low_new[k] - tol) | (mine > high_new[k] + tol)
        if beyond.sum() > max(1, OUTSIDE_SHARE * mine.size):
            return None
    if growth and widening(edge, radius, width):
        return None
    visits, lengths = _visits(edge, jog)
    key = cycle_key(visits)
    if key is not None:
        # The whole tail repeats the cycle, so its recent half does too.
        return None if _drifting(radius, visits, lengths, len(key)) else (edges, low, high, key)
    if len(edge) < quasi_min or len(visits) < QUASI_VISITS:
        return None
    if cycle_key(_visits(edge[recent:], jog[recent:])[0]) is None:
        return edges, low, high, None
    return None


def widening(edge: np.ndarray, radius: np.ndarray, width: np.ndarray) -> list[int]:
    """Return the edges whose radius range a tail's recent half (its last N of 2N states) still widens.

    The mirror of ``_confirm``'s test of a transient in the older half: a range the recent half reaches
    beyond the older half's by more than the resolution, with more than OUTSIDE_SHARE of its states on
    that edge (at least two) out there, is still growing: the part has not yet reached the extremes of
    its attractor, and a range read now would be too narrow (issue 35; quad35 thrown 60-100 times from
    2 starts per edge shows it). A few such states are the sampling of a chaotic attractor's rare
    extremes. An edge only the recent half visits has no older range to widen.
    """
    recent = len(edge) - len(edge) // 2
    edges, low, high = _ranges(edge, radius)
    older_e, older_r = edge[:recent], radius[:recent]
    out = []
    for k, e in enumerate(edges):
        mine_old = older_r[older_e == e]
        if mine_old.size == 0:
            continue
        tol = resolution(float(width[e]), float(low[k]), float(high[k]))
        lo, hi = float(mine_old.min()), float(mine_old.max())
        if lo - low[k] <= tol and high[k] - hi <= tol:
            continue
        mine = radius[recent:][edge[recent:] == e]
        beyond = (mine < lo - tol) | (mine > hi + tol)
        if beyond.sum() > max(1, OUTSIDE_SHARE * mine.size):
            out.append(int(e))
    return out


def _grown(
    edge: np.ndarray, radius: np.ndarray, jog: np.ndarray, width: np.ndarray, quasi_min: int
) -> list[int]:
    """Return the edges of a tail's growing ranges when they alone keep it from confirming, else []."""
    if _confirm(edge, radius, jog, width, quasi_min, growth=False) is None:
        return []
    return widening(edge, radius, width)


def _drifting(radius: np.ndarray, visits: np.ndarray, lengths: np.ndarray, p: int) -> bool:
    """Return whether a periodic tail's radii still drift: at some phase of its cycle, steadily one way.

    At each phase of the cycle, the radius at the start of its visit, period after period (the cut
    first and last visits left out): differences all of one sign, and the last at least DRIFT_SHARE of
    the first, is a slow drift through the states (a quasi-periodic orbit whose cycle will break when
    the drift reaches the next flip), not a converging orbit (whose differences shrink) or a settled
    one (whose radii wander both ways).
    """
    starts = np.concatenate([[0], np.cumsum(lengths)[:-1]])[1:-1]
    for phase in range(p):
        r = radius[starts[phase::p]]
        if len(r) < CYCLE_REPEATS:
            continue
        d = np.diff(r)
        if ((d > 0).all() or (d < 0).all()) and abs(d[-1]) >= DRIFT_SHARE * abs(d[0]):
            return True
    return False


def _consistent(
    edge: np.ndarray, radius: np.ndarray, jog: np.ndarray, first: int, width: np.ndarray, tail: _Tail | None
) -> tuple[np.ndarray, np.ndarray]:
    """Return, per state of a row's run (0..n), whether it is consistent with the tail from ``first`` on.

    Consistent: on one of the tail's edges within that edge's radius range (to the resolution) and,
    when the tail has an exact cycle, in a visit the cycle has there. Two answers: in the tail's own
    phase (the cycle continued backwards visit by visit), and in any phase (within p consecutive visits
    that are the cycle in some rotation; a run of one edge is in none).
    """
    ok = np.zeros(len(edge), dtype=bool)
    if tail is None:
        tail = (*_ranges(edge[first:], radius[first:]), cycle_key(_visits(edge[first:], jog[first:])[0]))
    edges, low, high, key = tail
    for k, e in enumerate(edges):
        tol = resolution(float(width[e]), float(low[k]), float(high[k]))
        ok |= (edge == e) & (radius >= low[k] - tol) & (radius <= high[k] + tol)
    if key is None:
        return ok, ok
    p = len(key)
    visits, lengths = _visits(edge, jog)
    starts = np.concatenate([[0], np.cumsum(lengths)[:-1]])
    f = min(int(np.searchsorted(starts, first)), len(visits) - p)
    phased = visits == visits[f : f + p][(np.arange(len(visits)) - f) % p]
    windows = np.lib.stride_tricks.sliding_window_view(visits, p)
    match = np.zeros(len(windows), dtype=bool)
    for k in range(p):
        match |= (windows == np.roll(np.array(key), -k)).all(axis=1)
    anyhow = np.zeros(len(visits), dtype=bool)
    for k in range(p):
        anyhow[k : k + len(match)] |= match
    return ok & np.repeat(phased, lengths), ok & np.repeat(anyhow, lengths)


def settled(
    edge: np.ndarray,
    radius: np.ndarray,
    jog: np.ndarray,
    first: int,
    width: np.ndarray,
    tail: _Tail | None = None,
) -> int:
    """Return where a row's run (states 0..n) began keeping to its tail (from ``first``), or -1: not yet.

    The run has been consistent with the tail, in its phase (``_consistent``), since its last departure;
    that stay must last SOJOURN_FACTOR times the longest earlier stay (consistent in any phase) that the
    run ended by departing. An attractor with rare excursions (convex12's visits to edge 5, a
    quasi-periodic round's rare other block) leaves tails that happen to hold none of them; the earlier
    stays, each ended by an excursion, say how long such a tail can last, and a stay no longer than those
    proves nothing. The stay holds the tail, and its start is where the transient ends. ``tail``: the
    tail's edges, ranges and cycle when the caller has them (``_confirm``).
    """
    ok, anyhow = _consistent(edge, radius, jog, first, width, tail)
    out = np.flatnonzero(~ok)
    if out.size == 0:
        return 0
    last = int(out[-1])
    before = anyhow[:last].astype(np.int8)
    if before.any():
        steps = np.diff(np.concatenate([[0], before, [0]]))
        longest = int((np.flatnonzero(steps == -1) - np.flatnonzero(steps == 1)).max())
        if len(edge) - 1 - last < SOJOURN_FACTOR * longest:
            return -1
    return last + 1


# Per edge of a reference stretch: its radii there, sorted.
_Reference = dict[int, np.ndarray]


def _reference(edge: np.ndarray, radius: np.ndarray) -> _Reference:
    """Return the reference of states for ``tail_start`` and ``hole_start``: per edge, its radii, sorted."""
    return {int(e): np.sort(radius[edge == e]) for e in np.unique(edge)}


def closure_gap(sample: np.ndarray, gaps: float = HOLE_GAPS) -> float:
    """Return the mean gap of a sorted sample of radii over the closure it fills: its span less its holes.

    An attractor's visits to an edge may fill several intervals (design 31.0's flips land in two bands 10 mm
    apart, a periodic orbit's visits converge to points): span / states then counts the holes between them
    as gaps. A hole is a gap between neighbouring states wider than ``gaps`` mean gaps; the mean gap is
    the fixed point of (span - holes) / states, reached from span / states downwards (each step finds
    only more holes, so it ends within as many steps as the sample has gaps). A sample that fills one
    interval has none: the gaps of a rotation take at most three lengths, the largest the sum of the
    other two (the three-gap theorem), so its mean gap is span / states.
    """
    if sample.size < 2:
        return 0.0
    steps = np.diff(sample)
    span = float(sample[-1] - sample[0])
    mean = span / sample.size
    while True:
        filled = (span - float(steps[steps > gaps * mean].sum())) / sample.size
        if filled >= mean:
            return mean
        mean = filled


def hole_start(
    edge: np.ndarray,
    radius: np.ndarray,
    stay: int,
    first: int,
    reference: _Reference,
    gaps: float = HOLE_GAPS,
) -> int:
    """Return where a row's run leaves the holes of the attractor's closure for good, from ``stay`` on.

    The states ``stay``..``first`` - 1 of the run are judged against ``reference`` (the attractor's
    sample, ``_trim_to_group``): a state inside its edge's sampled range, but more than ``gaps`` closure
    mean gaps (``closure_gap``) from every sampled radius, lies in a hole of the closure, so it is no
    visit of the forward limit set (Theorem IV.3) but the approach to it, passing between its intervals.
    ``tail_start`` cannot see such states, which lie inside the ranges (issue 35, design 31.0: four of
    eight starts' flips onto edge 0 land between its two bands, moving 0.2-0.7 mm a round towards one,
    so each visit's ladder of jogs on goal edge 4 is shifted and the goal visits' common cover closes).
    Returns the state after the last one in a hole, or ``stay``. A state beyond the sampled range is
    ``tail_start``'s to judge.
    """
    if stay >= first:
        return stay
    e_old, r_old = edge[stay:first], radius[stay:first]
    holed = np.zeros(len(e_old), dtype=bool)
    for e, sample in reference.items():
        on = e_old == e
        if sample.size < 2 or not on.any():
            continue
        r = r_old[on]
        k = np.clip(np.searchsorted(sample, r), 1, sample.size - 1)
        near = np.minimum(r - sample[k - 1], sample[k] - r)
        far = max(gaps * closure_gap(sample, gaps), ROUNDING * abs(float(sample[-1])))
        holed[on] = (r > sample[0]) & (r < sample[-1]) & (near > far)
    out = np.flatnonzero(holed)
    return stay if out.size == 0 else stay + int(out[-1]) + 1


def arrival(
    edge: np.ndarray,
    radius: np.ndarray,
    stay: int,
    first: int,
    reference: _Reference,
    gaps: float = TRIGGER_GAPS,
) -> int:
    """Return where a row's run first comes within ``gaps`` mean gaps of ``reference`` (else ``first``).

    The states ``stay``..``first`` - 1 are judged as ``tail_start`` judges them (beyond the reference's
    range on their edge by more than ``gaps`` mean gaps of the reference there: outside), but the run is
    taken to have arrived at its first state inside: every state before it is the approach, every one
    after it a visit, however far out (issue 35, the trigger range's states). A rare excursion comes after
    the run has arrived, an approach before: corpus design 44.2 (bench settings) visits edges 1 and 3
    1.5 mm (about 46 mean gaps) below the members' recent quarters in pairs 47 throws apart every 500-700
    throws, and cut after its last state lying so far out, its trigger read 1.44 mm beyond the long
    runs' at its top (a goal visit of such an excursion covers less). An approach that comes inside and
    leaves again is kept, which can only narrow the trigger.
    """
    if stay >= first:
        return stay
    e_old, r_old = edge[stay:first], radius[stay:first]
    inside = np.zeros(len(e_old), dtype=bool)
    for e, sample in reference.items():
        lo, hi = float(sample[0]), float(sample[-1])
        gap = max(gaps * (hi - lo) / sample.size, ROUNDING * abs(hi))
        inside |= (e_old == e) & (r_old >= lo - gap) & (r_old <= hi + gap)
    found = np.flatnonzero(inside)
    return first if found.size == 0 else stay + int(found[0])


def tail_start(
    edge: np.ndarray,
    radius: np.ndarray,
    stay: int,
    first: int,
    reference: _Reference | None = None,
    gaps: float = TAIL_GAPS,
) -> int:
    """Return where a confirmed row's tail begins: its stay (``settled``) without the approach to it.

    ``edge``/``radius``: the row's run, states 0..n; the tail confirmed over the window ``first``..n
    (``_confirm``), and the run kept to it from ``stay`` on, each state on a tail edge within that
    edge's range widened by the resolution (``resolution``: up to a tenth of the range's span). The
    attractor is the forward limit set (Theorem IV.3), the closure of the states the run keeps
    visiting, and ``reference`` samples it (default: the window's own states); a state of the stay
    before ``first`` that lies beyond the reference's range on its edge by more than TAIL_GAPS mean
    gaps between the reference's states there (span / states, at least ROUNDING of the radius) is no
    visit of that closure but the approach to it, which the resolution band let in (issue 35: on
    examples/throwing/quad35.yaml each start's first landing on the attractor made edge 0's range end,
    155.4 mm where long runs never go below 159.25 mm). The tail begins after the last such state, so
    an attractor's ranges, pattern and throws per round come from its visits only. ``gaps``: how many
    mean gaps beyond the reference a state may lie and still count as a visit (TAIL_GAPS; the trigger
    range's states are cut with TRIGGER_GAPS, ``_trim_to_group``).
    """
    if stay >= first:
        return stay
    ref = _reference(edge[first:], radius[first:]) if reference is None else reference
    e_old, r_old = edge[stay:first], radius[stay:first]
    # ``settled`` kept the stay on the tail's edges; an edge the reference lacks is no visit of it.
    outside = ~np.isin(e_old, np.fromiter(ref, dtype=np.int64, count=len(ref)))
    for e, sample in ref.items():
        lo, hi = float(sample[0]), float(sample[-1])
        gap = max(gaps * (hi - lo) / sample.size, ROUNDING * abs(hi))
        outside |= (e_old == e) & ((r_old < lo - gap) | (r_old > hi + gap))
    out = np.flatnonzero(outside)
    return stay if out.size == 0 else stay + int(out[-1]) + 1


def _holds_period(edge: np.ndarray, jog: np.ndarray, key: tuple[int, ...]) -> bool:
    """Return whether a stretch's inner visits (its cut ends dropped) hold one whole period of ``key``."""
    inner = [int(v) for v in _visits(edge, jog)[0][1:-1]]
    p = len(key)
    return any(tuple(inner[k : k + p]) == key for k in range(p))


def _trim_to_group(search: Search, group: list[int], key: tuple[int, ...] | None) -> None:
    """Begin each member's tail after its approach to the group's attractor, judged on all members.

    The members' tails are one attractor (``_clusters``), so their recent quarters (each row's last n/4
    states, which ``_confirm`` compared with its window) together sample its closure far more densely
    than one row's window: their mean gaps are the members' count times smaller. ``tail_start`` against
    that reference drops what one row's window let in: the approach's states within TAIL_GAPS of its
    own sparser window, and a transient still in the older quarter of its window within ``_confirm``'s
    allowances (the resolution, OUTSIDE_SHARE of the states; a periodic orbit's visits still converging
    to its cycle, corpus design 0.3: an edge's first landing of the window 0.11 m below the cycle's).
    A tail keeps at least its recent quarter; a periodic one (``key``, the group's cycle) also one whole
    period, or else it keeps its window, which ``_confirm`` saw repeat the cycle thrice. ``search.tail``
    and ``search.stretches`` of the members are updated in place.

    The trigger range is read on more states (``search.sensed``): the tail and the older states of the
    stay from the run's first arrival within TRIGGER_GAPS mean gaps of the same reference (``arrival``).
    Where an attractor's visits thin out towards an end of an interval, or it makes rare excursions, the
    gap test at TAIL_GAPS cannot tell a rare visit from the approach (issue 35: corpus design 2.1's edge 1
    reads its top 1.5 mm short), and a trigger read without such a visit reaches beyond the truth: a
    blocking edge's visit left out lets a sensor there read true off the goal edge, a goal visit left out
    one that never reads true in it. A trigger read on more states is never wider (the goal visits'
    common cover only shrinks, the other edges' covers only grow), so what the arrival lets in of the
    approach costs width only.

    Neither the tail nor the trigger's states begin before the last state of the stay that lies in a hole
    of the closure the reference fills (``hole_start``): an approach passing between the attractor's
    intervals lies inside its ranges, where no gap test beyond them sees it (design 31.0). The fallback
    that keeps a periodic tail's window keeps it whole, as ``_confirm`` saw it.
    """
    recent = {b: int(search.tail_end[b]) - int(search.tail_end[b]) // 4 for b in group}
    reference = _reference(
        np.concatenate([search.edge[b, recent[b] : search.tail_end[b] + 1] for b in group]),
        np.concatenate([search.radius[b, recent[b] : search.tail_end[b] + 1] for b in group]),
    )
    for b in group:
        n = int(search.tail_end[b])
        edge, radius, jog = search.edge[b, : n + 1], search.radius[b, : n + 1], search.jog[b, : n + 1]
        hole = hole_start(edge, radius, int(search.stay[b]), recent[b], reference)
        start = tail_start(edge, radius, max(int(search.tail[b]), hole), recent[b], reference)
        if key is not None and not _holds_period(edge[start:], jog[start:], key):
            start = tail_start(edge, radius, int(search.tail[b]), n - n // 2 + 1, reference)
        wide = arrival(edge, radius, max(int(search.stay[b]), hole), recent[b], reference)
        search.sensed[b] = min(wide, start)
        if start != search.tail[b]:
            old = search.stretches.get(b)
            search.tail[b] = start
            found = stretch(edge[start:], radius[start:], jog[start:])
            # The cluster's cycle stands: a recent quarter may hold too few periods to show it thrice.
            search.stretches[b] = Stretch(
                found.edges, found.low, found.high, key if old is None else old.cycle
            )


def _clusters(
    tails: list[Stretch], width: np.ndarray
) -> list[tuple[list[int], dict[int, tuple[float, float]]]]:
    """Return tails grouped as ``group_attractors`` groups rows: same edges and cycle, meeting ranges.

    Each group as (indices into ``tails``, the ranges covering them all).
    """
    buckets: dict[
        tuple[tuple[int, ...], tuple[int, ...] | None], list[tuple[list[int], dict[int, tuple[float, float]]]]
    ] = {}
    for k, t in enumerate(tails):
        groups = buckets.setdefault((t.edges, t.cycle), [])
        ranges, joined, rest = t.ranges(), [k], []
        for g_members, g_ranges in groups:
            if _overlaps(ranges, g_ranges, width):
                ranges = {
                    e: (min(lo, g_ranges[e][0]), max(hi, g_ranges[e][1])) for e, (lo, hi) in ranges.items()
                }
                joined += g_members
            else:
                rest.append((g_members, g_ranges))
        buckets[(t.edges, t.cycle)] = [*rest, (joined, ranges)]
    return [g for groups in buckets.values() for g in groups]


def _nested(tails: list[Stretch], width: np.ndarray) -> np.ndarray:
    """Return, per tail, whether a richer attractor of the design holds it: more edges, or no exact cycle.

    A tail is held by another group of tails (``_clusters``) whose edges include its own, all of them or
    more, whose ranges include its ranges, and which shows more: another edge, or no exact cycle where
    it has one. Such a tail may be a stretch of the richer attractor that happens to miss its rarest
    edge or its rare break of the cycle.
    """
    groups = _clusters(tails, width)
    held = np.zeros(len(tails), dtype=bool)
    for members, ranges in groups:
        t = tails[members[0]]
        for others, outer in groups:
            o = tails[others[0]]
            richer = set(t.edges) < set(o.edges) or (
                t.edges == o.edges and t.cycle is not None and o.cycle is None
            )
            if richer and _overlaps(ranges, outer, width, within=True):
                held[members] = True
                break
    return held


def iterate_to_attractor(
    rows: Rows,
    throw: Callable[[np.ndarray, np.ndarray, np.ndarray], ThrowBatch],
    throws: int,
    window: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    design: np.ndarray | None = None,
) -> Search:
    """Throw every row until its tail confirms, or the cap; rows whose tails nest in others' go on.

    From two windows on, at every quarter window and at the cap, a row's last n/2 states are its tail:
    it confirms when ``confirms`` holds for them (the same edges, ranges and cycle over the last n/4 as
    over the last n/2) and ``settled`` holds for its run (it kept to that tail twice as long as ever
    before), and then stops. The tail thus grows with n, and a transient of up to about n/2 throws has
    left it. A confirmed row whose tail a richer group of confirmed tails of its design holds
    (``_nested``; ``design[b]``, one design when None) is thrown on from where it stopped and judged
    again (its latest confirmed tail counts) until it no longer nests or reaches the cap. A row that
    never confirms within ``throws`` stays unconverged; when a growing range alone kept its last tail from
    confirming (``widening``), ``growing`` names the row and those edges.
    Each row advances from its own state, one throw per call of ``throw(idx, edge, radius)`` (which
    applies the map to rows ``idx``); ``progress(done, total)`` is told after each check.
    """
    w = default_window(throws) if window is None else window
    step = max(1, w // CHECKS_PER_WINDOW)
    starts = len(rows.edge)
    owner = np.zeros(starts, dtype=np.int64) if design is None else np.asarray(design, dtype=np.int64)
    search = _empty_search(rows, throws, w)
    running = np.full(starts, throws > 0)
    while running.any():
        alive = np.flatnonzero(running)
        ok = _throw_rows(search, rows, throw, alive)
        search.escaped[alive[~ok]] = True
        running[alive[~ok]] = False
        at = search.end[alive]
        running[alive[at == throws]] = False
        due = alive[ok & ((at == throws) | ((at >= 2 * w) & (at % step == 0)))]
        if due.size == 0:
            continue
        for b in due:
            _judge_row(search, rows, b, throws)
        _resume_nested(search, rows, owner, due, running, throws)
        if progress is not None:
            progress(starts - int(running.sum()), starts)
    search.sensed = search.tail.copy()  # the trigger's states, widened per attractor by _trim_to_group
    return search


def _empty_search(rows: Rows, throws: int, window: int) -> Search:
    """Return the Search the rows' runs are written into: each row at its start, no tail, nothing escaped.

    One column per throw and the start; ``tail``, ``tail_end`` and ``stay`` are -1 until a row confirms,
    ``sensed`` is filled once the search ends (a copy of ``tail``).
    """
    starts = len(rows.edge)
    edge = np.zeros((starts, throws + 1), dtype=np.int64)
    radius = np.full((starts, throws + 1), np.nan)
    edge[:, 0], radius[:, 0] = rows.edge, rows.radius
    return Search(
        edge,
        radius,
        np.zeros((starts, throws + 1), dtype=bool),
        np.zeros((starts, throws + 1), dtype=np.uint8),
        np.zeros(starts, dtype=np.int64),
        np.full(starts, -1, dtype=np.int64),
        np.zeros(starts, dtype=bool),
        rows.width,
        window,
        np.full(starts, -1, dtype=np.int64),
        stay=np.full(starts, -1, dtype=np.int64),
        sensed=np.full(starts, -1, dtype=np.int64),
    )


def _throw_rows(
    search: Search,
    rows: Rows,
    throw: Callable[[np.ndarray, np.ndarray, np.ndarray], ThrowBatch],
    alive: np.ndarray,
) -> np.ndarray:
    """Throw each row of ``alive`` once from its last state; record the throw; return which stayed in Z.

    The new state, its jog bit and its assumption flags (bit k: ASSUMPTIONS[k]) go in the next column;
    a throw stays in the domain when it lands on an edge at a radius the edge can throw.
    """
    now = search.end[alive]
    out = throw(alive, search.edge[alive, now], search.radius[alive, now])
    search.edge[alive, now + 1], search.radius[alive, now + 1] = out.edge, out.radius
    search.jog[alive, now + 1] = out.is_jog(search.edge[alive, now])
    bits = np.zeros(alive.size, dtype=np.uint8)
    for k, name in enumerate(ASSUMPTIONS):
        bits |= out.flag(name).astype(np.uint8) << k
    search.flags[alive, now + 1] = bits
    landed = np.maximum(out.edge, 0)
    ok: np.ndarray = (out.edge >= 0) & radius_in_domain(out.radius, rows.low[alive, landed])
    search.end[alive] = now + 1
    return ok


def _judge_row(search: Search, rows: Rows, b: int, throws: int) -> None:
    """Judge row b at a check: record its tail when its last n/2 states confirm and its run settled.

    ``confirms`` on the last n/2 states, then ``settled`` on the whole run; the tail is cut to its stay
    (``tail_start``). A row that does not confirm when the throws run out may have a growing range
    (``_grown``), noted in ``growing``.
    """
    edge, radius, jog, width = search.edge, search.radius, search.jog, rows.width[b]
    n = int(search.end[b])
    first = n - n // 2 + 1
    sl = slice(first, n + 1)
    found = _confirm(edge[b, sl], radius[b, sl], jog[b, sl], width, QUASI_WINDOWS * search.window)
    if found is None:
        if n == throws and search.tail[b] < 0:
            # The throws ran out: a tail that a growing range alone kept from confirming is said
            # to be so (a range read now would be too narrow), never folded in as it stands.
            grown = _grown(edge[b, sl], radius[b, sl], jog[b, sl], width, QUASI_WINDOWS * search.window)
            if grown:
                search.growing[int(b)] = grown
        return
    stay = settled(edge[b, : n + 1], radius[b, : n + 1], jog[b, : n + 1], first, width, found)
    if stay >= 0:
        search.stay[b] = stay
        stay = tail_start(edge[b, : n + 1], radius[b, : n + 1], stay, first)
        search.tail[b], search.tail_end[b] = stay, n
        search.stretches[int(b)] = stretch(
            edge[b, stay : n + 1], radius[b, stay : n + 1], jog[b, stay : n + 1]
        )


def _resume_nested(
    search: Search, rows: Rows, owner: np.ndarray, due: np.ndarray, running: np.ndarray, throws: int
) -> None:
    """Set which confirmed rows of the checked rows' designs run on: those whose tails nest (``_nested``).

    A confirmed row stops unless a richer group of its design's confirmed tails holds its tail, and it
    has throws left and has not escaped.
    """
    for g in np.unique(owner[due]):
        members = np.flatnonzero(owner == g)
        confirmed = members[search.tail[members] >= 0]
        if confirmed.size:
            small = _nested([search.stretches[int(b)] for b in confirmed], rows.width[members[0]])
            running[confirmed] = small & (search.end[confirmed] < throws) & ~search.escaped[confirmed]


@dataclass(frozen=True)
class Attractor:
    """One attractor: its edges and radius ranges, periodic cycle or quasi-periodic pattern, its basin.

    ``pattern`` lists, for one round, each block of the visit sequence (a stretch repeating a motif of
    at most MAX_MOTIF edges) as [edge, min, max]: how many visits that edge gets in the block, over
    the rounds seen. ``throws_per_round`` is (min, mean, max); ``basin`` the fraction of all starts whose
    confirmed tails are this attractor. ``longest_transient`` (and ``median_transient``): over those
    starts, the throws before the state stays inside the attractor for good, on its edges and within
    each edge's radius range to the resolution; the tails, and so everything above, exclude them.
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
    visits, lengths = _visits(np.asarray(edge_row), np.asarray(jog_row, dtype=bool))
    return [int(v) for v in visits], [int(n) for n in lengths]


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
    """Return (one period of the visits, canonically rotated; throws of each whole period), or None.

    The period is the shortest exact one seen CYCLE_REPEATS times (first and last visits dropped, as
    cut by the stretch's ends), the same test as ``cycle_key``. The cycle starts at the visit with the
    longest stay (ties: smallest edge), as the paper tells its cycles.
    """
    inner_v, inner_n = visits[1:-1], lengths[1:-1]
    p = _period(np.asarray(inner_v, dtype=np.int64))
    if p is None:
        return None
    total = len(inner_v)
    period = inner_v[:p]
    start = max(
        range(p),
        key=lambda j: (sum(n for _, n in zip(inner_v[j::p], inner_n[j::p], strict=True)), -period[j]),
    )
    canonical = period[start:] + period[:start]
    per_cycle = [sum(inner_n[c : c + p]) for c in range(start, total - p + 1, p)]
    return canonical, per_cycle


def _overlaps(
    a: dict[int, tuple[float, float]],
    b: dict[int, tuple[float, float]],
    width: np.ndarray,
    within: bool = False,
) -> bool:
    """Return whether ``a``'s radius ranges meet ``b``'s on every edge of ``a``, to the resolution.

    ``within``: whether they also lie inside ``b``'s.
    """
    for e, (lo, hi) in a.items():
        blo, bhi = b[e]
        tol = resolution(float(width[e]), min(lo, blo), max(hi, bhi))
        if within and (lo < blo - tol or hi > bhi + tol):
            return False
        if lo > bhi + tol or blo > hi + tol:
            return False
    return True


def group_attractors(search: Search, rows: np.ndarray | None = None) -> list[Attractor]:
    """Group the converged rows (all, or those in ``rows``) into attractors and describe each.

    Rows whose tails have the same edges and exact cycle (or none) and whose radius ranges meet on every
    edge belong to one attractor (``_clusters``; the rows are one design's). The basin is over the rows
    considered, converged or not.
    """
    considered = np.arange(len(search.tail)) if rows is None else np.asarray(rows)
    members = [int(b) for b in considered if search.tail[b] >= 0]
    tails = {
        b: search.stretches.get(b)
        or stretch(
            search.edge[b, search.tail_slice(b)],
            search.radius[b, search.tail_slice(b)],
            search.jog[b, search.tail_slice(b)],
        )
        for b in members
    }
    if not members:
        return []
    listed = [tails[b] for b in members]
    found = []
    for group, _ in _clusters(listed, search.width[members[0]]):
        rows_of = sorted(members[k] for k in group)
        key = listed[group[0]].cycle
        _trim_to_group(search, rows_of, key)
        trimmed = {b: search.stretches[b] if b in search.stretches else tails[b] for b in rows_of}
        found.append(_describe(search, rows_of, len(considered), trimmed, key))
    return sorted(found, key=lambda a: (-a.basin, a.edges))


def _transient(search: Search, b: int, ranges: dict[int, tuple[float, float]]) -> int:
    """Return the throws row b took before its states stayed inside ``ranges`` (edges and radii) for good."""
    e = search.edge[b, : search.end[b] + 1]
    r = search.radius[b, : search.end[b] + 1]
    inside = np.zeros(len(e), dtype=bool)
    for edge, (lo, hi) in ranges.items():
        tol = resolution(float(search.width[b, edge]), lo, hi)
        inside |= (e == edge) & (r >= lo - tol) & (r <= hi + tol)
    outside = np.flatnonzero(~inside)
    return int(outside[-1]) + 1 if outside.size else 0


def _describe(
    search: Search, group: list[int], total: int, tails: dict[int, Stretch], key: tuple[int, ...] | None
) -> Attractor:
    """Return the Attractor of one group of rows, from their confirmed tails only."""
    ranges: dict[int, tuple[float, float]] = {}
    for b in group:
        for e, (lo, hi) in tails[b].ranges().items():
            old = ranges.get(e)
            ranges[e] = (lo, hi) if old is None else (min(old[0], lo), max(old[1], hi))
    ranges = dict(sorted(ranges.items()))
    transients = [_transient(search, b, ranges) for b in group]
    counts = np.zeros(len(ASSUMPTIONS))
    n_throws = 0
    seqs = []
    for b in group:
        sl = search.tail_slice(b)
        fl = search.flags[b, sl][1:]
        for k in range(len(ASSUMPTIONS)):
            counts[k] += int(((fl >> k) & 1).sum())
        n_throws += fl.size
        seqs.append(visit_runs(search.edge[b, sl], search.jog[b, sl]))
    violations = {name: float(counts[ASSUMPTIONS.index(name)] / max(n_throws, 1)) for name in REPORTED}
    cycle = None
    pattern: list[tuple[int, int, int]] | None = None
    per_round: tuple[int, float, int] | None = None
    if key is not None:
        cycle, per_round = _cycle_of(list(key), seqs)
        counter = Counter(cycle)
        pattern = [(e, counter[e], counter[e]) for e in dict.fromkeys(cycle)]
    else:
        pattern, per_round = _quasi_pattern(seqs)
    return Attractor(
        edges=sorted(ranges),
        edge_radius_ranges=ranges,
        periodic=key is not None,
        cycle=cycle,
        pattern=pattern,
        throws_per_round=per_round,
        basin=len(group) / total,
        longest_transient=max(transients),
        median_transient=float(np.median(transients)),
        violations=violations,
        members=sorted(group),
    )


def _cycle_of(
    key: list[int], seqs: list[tuple[list[int], list[int]]]
) -> tuple[list[int], tuple[int, float, int] | None]:
    """Return a periodic attractor's cycle, from its longest stay over all members, and throws per cycle.

    ``key`` is the cycle as its least rotation; each member's tail is aligned to it, so the stays add up
    over members whose tails begin at different visits of the cycle.
    """
    p = len(key)
    stay = np.zeros(p)
    spans: list[int] = []
    phases = []
    for visits, lengths in seqs:
        inner_v, inner_n = visits[1:-1], lengths[1:-1]
        phase = next(k for k in range(p) if inner_v[k : k + p] == key)
        phases.append((phase, inner_n))
        for j, n in enumerate(inner_n):
            stay[(j - phase) % p] += n
    start = max(range(p), key=lambda j: (stay[j], -key[j]))
    cycle = key[start:] + key[:start]
    for phase, inner_n in phases:
        first = (phase + start) % p
        spans += [sum(inner_n[c : c + p]) for c in range(first, len(inner_n) - p + 1, p)]
    per_round = (min(spans), float(np.mean(spans)), max(spans)) if spans else None
    return cycle, per_round


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
