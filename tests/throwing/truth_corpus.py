"""An independent truth for the limit-set planner (issue 25): a seeded corpus of designs, each run long.

The truth of a start is what the throw map does when it is simply iterated: the start is thrown
``throws`` times, one throw after the other, with no recurrence test, no window and no early stop. Its
attractor is what the last half of the run shows: the edges visited there, and the exact cycle of its
visit sequence there (a visit begins at each flip) when one repeats at least three times, or none (a
quasi-periodic attractor). Nothing here uses ``feeder_planner.throwing.attractors``.

Unambiguous (``StartTruth.reason`` empty). A finite run can only show what it shows, so a start's truth
counts only when its last half looks settled:

- the third and the last quarter of the run each hold at least three flips (a part still jogging out
  along one edge is in transit, Prop. IV.1, not in an attractor);
- both quarters visit the same edges;
- the last quarter has the same exact cycle as the last half, or both have none;
- each edge's radius range over the last quarter reaches its range over the last half to a quarter of
  that range or 1 % of the part radius (the run is not still drifting);

and a design's truth counts when every start's does and no start's edges are a proper subset of
another start's, or its cycle a stretch of another's cycle-free run on the same edges, within that
start's radii: a longer run could still show the rarer edge or break. These tests are deliberately
looser than the planner's own (a quarter of the range, not a tenth; no look at what came before the
last half), so a design can be unambiguous here and still not confirm in ``limit_set``.

The runs: the starts of every design of one part (the corpus draws several designs per part, all with
the part's gravity) are thrown together by ``throw_rows``, each row with its own h, W and mu. The map is
elementwise, so each row's throw is bit for bit that of the scalar ``throw`` of its state alone
(``test_limit_truth`` checks that on a sample), but one call serves every row.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from feeder_planner.errors import FeederError
from feeder_planner.parts import make_part
from feeder_planner.throwing.geometry import ArmPart, arm_part
from feeder_planner.throwing.limit_set import edge_bounds, single_design_rows
from feeder_planner.throwing.throw_map import ThrowParams, lowest_radius, radius_in_domain, throw_rows

SEED = 25
DESIGNS_PER_PART = 8
# Parts of the bench's corpus (8 designs each; about half of them have a limit set) and of its --quick run.
CORPUS_PARTS = 80
QUICK_PARTS = 4
# Gravities of the corpus (m/s^2): the bracket's inclined plane of the paper, the paper's, standard.
GRAVITIES = (-2.20, -9.66, -9.81)
REPEATS = 3  # an exact cycle counts when the last half shows it this many times
FLIPS = 3  # flips each of the last two quarters must hold
RANGE_SHARE = 0.25  # how far a quarter's radius range may fall short of the half's, as a share of it
RADIUS_SHARE = 0.01  # ... or as a share of the part radius
# How far an attractor's radius range end (and so a trigger range end) may lie from the long runs' (issue
# 35), in mean gaps (span / states on that edge) of the sample the planner certifies its ranges against:
# the union of its members' recent quarters (attractors._trim_to_group). The planner admits an older state
# up to TAIL_GAPS = 3 such gaps beyond that sample (attractors.tail_start), and a sample that fills its
# interval has its extreme within about one gap of the interval's end: 3 + 1 gaps. The tolerance thus
# shrinks as the tails fill their intervals (more starts, a longer window); the long runs' own gaps are
# smaller (their last halves hold more states).
RANGE_GAPS = 4.0
# ... and at least this share of the radius: rounding, and a periodic orbit whose radii converge to
# points, which the long run shows converged and the planner's tail a few ulps to micrometres away.
RANGE_FLOOR = 1e-6
# Marks of a disagreement on the unsafe side: a range end inside the long runs' (a visited radius left
# out), and a trigger range reaching beyond the long runs' (a sensor there could read true off the goal
# edge, against contract 3's promise); the other side only costs the designer some of the range.
SHORT = "short of the long runs"
UNSAFE = "reaches beyond the long runs"


@dataclass(frozen=True)
class CorpusDesign:
    """One design of the corpus: part ``part_index``'s design ``design_index``."""

    part_index: int
    design_index: int
    part: ArmPart
    params: ThrowParams
    convex: bool

    @property
    def name(self) -> str:
        """Return the design's name in reports: part.design."""
        return f"{self.part_index}.{self.design_index}"


def _hull_area(hull: np.ndarray) -> float:
    x, y = hull[:, 0], hull[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def corpus_part(k: int) -> tuple[ArmPart, bool, float]:
    """Return part k of the corpus, whether it is convex, and its gravity.

    Even k: convex (vertices on a jittered ellipse); odd k: non-convex (a star-shaped polygon with
    radii 0.35-1 of its size, so that several vertices lie inside the hull). The hull has 4 to 14
    edges (cycling through all of them with k), at least two of them stable; the size is 8-50 mm.
    """
    rng = np.random.default_rng([SEED, k])
    convex = k % 2 == 0
    edges = 4 + (5 * k) % 11
    gravity = float(GRAVITIES[k % len(GRAVITIES)])
    while True:
        size = 10 ** rng.uniform(math.log10(0.008), math.log10(0.05))
        aspect = rng.uniform(0.3, 1.0)
        count = edges if convex else edges + int(rng.integers(1, 6))
        angles = np.sort(rng.uniform(0.0, 2 * math.pi, count))
        radii = 1 + rng.uniform(-0.15, 0.15, count) if convex else rng.uniform(0.35, 1.0, count)
        points = np.c_[size * radii * np.cos(angles), size * aspect * radii * np.sin(angles)]
        try:
            part = arm_part(make_part(points.tolist()))
        except FeederError:
            continue
        sides = np.hypot(*(np.roll(part.hull, -1, axis=0) - part.hull).T)
        if part.n != edges or len(part.stable_edges) < 2 or sides.min() < 0.03 * part.radius:
            continue
        if convex != (part.part.area > (1 - 1e-9) * _hull_area(part.hull)):
            continue
        return part, convex, gravity


def corpus_designs(k: int) -> list[CorpusDesign]:
    """Return the DESIGNS_PER_PART designs of part k: offsets and speeds across the regimes.

    h = -f d_min with f log-uniform in [0.01, 0.95] (from barely below the arm to nearly -d_min); W
    from kappa = W^2 r / |g| log-uniform in [0.005, 0.3] (the flight's turn grows with W^2 R / |g|: from
    parts that barely turn to parts that tumble); mu uniform in [0.3, 1].
    """
    part, convex, gravity = corpus_part(k)
    out = []
    for j in range(DESIGNS_PER_PART):
        rng = np.random.default_rng([SEED, k, j])
        h = -(10 ** rng.uniform(-2.0, math.log10(0.95))) * part.d_min
        kappa = 10 ** rng.uniform(math.log10(0.005), math.log10(0.3))
        w = math.sqrt(kappa * abs(gravity) / part.radius)
        mu = float(rng.uniform(0.3, 1.0))
        out.append(CorpusDesign(k, j, part, ThrowParams(float(h), float(w), gravity, mu), convex))
    return out


def grid_starts(design: CorpusDesign, starts_per_edge: int) -> tuple[np.ndarray, np.ndarray] | None:
    """Return the limit set's grid of starts for a design (None: no R_flip, so no limit set)."""
    try:
        bounds = edge_bounds(design.part, design.params)
    except FeederError:
        return None
    rows = single_design_rows(design.part, bounds, starts_per_edge)
    return rows.edge, rows.radius


@dataclass(frozen=True)
class Run:
    """One start's long run: edge, radius and jog per throw (jog[0] meaningless); escaped: left the domain."""

    edge: np.ndarray
    radius: np.ndarray
    jog: np.ndarray
    escaped: bool


def long_runs(
    designs: list[CorpusDesign], starts: list[tuple[np.ndarray, np.ndarray]], throws: int
) -> list[list[Run]]:
    """Throw every start of every design (all of one part) ``throws`` times; return the runs per design.

    One throw after the other for each start, nothing else: a start that leaves the domain stops.
    """
    part = designs[0].part
    owner = np.concatenate([np.full(len(e), d) for d, (e, _) in enumerate(starts)]).astype(int)
    m = len(owner)
    h = np.array([designs[d].params.offset for d in owner])
    w = np.array([designs[d].params.speed for d in owner])
    mu = np.array([designs[d].params.mu for d in owner])
    low = np.full((len(designs), part.n), np.inf)
    for d, design in enumerate(designs):
        for i in part.stable_edges:
            low[d, i] = lowest_radius(part, i, design.params)
    edge = np.zeros((m, throws + 1), dtype=int)
    radius = np.full((m, throws + 1), np.nan)
    jog = np.zeros((m, throws + 1), dtype=bool)
    edge[:, 0] = np.concatenate([e for e, _ in starts])
    radius[:, 0] = np.concatenate([r for _, r in starts])
    escaped = np.zeros(m, dtype=bool)
    alive = np.arange(m)
    for n in range(1, throws + 1):
        if alive.size == 0:
            break
        out = throw_rows(
            part,
            edge[alive, n - 1],
            radius[alive, n - 1],
            h[alive],
            w[alive],
            designs[0].params.gravity,
            mu[alive],
        )
        edge[alive, n], radius[alive, n] = out.edge, out.radius
        jog[alive, n] = out.is_jog(edge[alive, n - 1])
        ok = (out.edge >= 0) & radius_in_domain(out.radius, low[owner[alive], np.maximum(out.edge, 0)])
        escaped[alive[~ok]] = True
        alive = alive[ok]
    runs = [Run(edge[b], radius[b], jog[b], bool(escaped[b])) for b in range(m)]
    return [[runs[b] for b in np.flatnonzero(owner == d)] for d in range(len(designs))]


def visits(edge: np.ndarray, jog: np.ndarray) -> list[int]:
    """Return the edge of each visit of a stretch: one begins at its first state and at each flip."""
    return [int(edge[n]) for n in range(len(edge)) if n == 0 or not jog[n]]


def exact_cycle(seq: list[int]) -> tuple[int, ...] | None:
    """Return the shortest exact cycle of a visit sequence seen REPEATS times, as its least rotation.

    The first and last visits are dropped: the stretch's ends cut them.
    """
    inner = seq[1:-1]
    for p in range(1, len(inner) // REPEATS + 1):
        if all(inner[i] == inner[i + p] for i in range(len(inner) - p)):
            one = inner[:p]
            return min(tuple(one[k:] + one[:k]) for k in range(p))
    return None


@dataclass(frozen=True)
class StartTruth:
    """What one start's long run shows: its edges, its exact cycle, why it is ambiguous ('' if not)."""

    edges: tuple[int, ...]
    cycle: tuple[int, ...] | None
    ranges: dict[int, tuple[float, float]]
    reason: str
    transient: int

    @property
    def periodic(self) -> bool:
        """Whether the last half repeats one exact cycle."""
        return self.cycle is not None


def judge(run: Run, part_radius: float) -> StartTruth:
    """Return a start's truth from its long run (see the module's "Unambiguous")."""
    if run.escaped:
        return StartTruth((), None, {}, "escaped", 0)
    total = len(run.edge) - 1
    half, last = total // 2, total - total // 4
    e, r, j = run.edge, run.radius, run.jog
    edges = tuple(sorted({int(x) for x in e[half:]}))
    cycle = exact_cycle(visits(e[half:], j[half:]))
    ranges = {x: (float(r[half:][e[half:] == x].min()), float(r[half:][e[half:] == x].max())) for x in edges}
    reason = ""
    if min(int((~j[half + 1 : last]).sum()), int((~j[last + 1 :]).sum())) < FLIPS:
        reason = "jogs on one edge (in transit)"
    elif {int(x) for x in e[half:last]} != {int(x) for x in e[last:]}:
        reason = "quarters visit other edges"
    elif exact_cycle(visits(e[last:], j[last:])) != cycle:
        reason = "last quarter has another cycle"
    else:
        for x, (lo, hi) in ranges.items():
            q = r[last:][e[last:] == x]
            slack = max(RANGE_SHARE * (hi - lo), RADIUS_SHARE * part_radius)
            if q.min() - lo > slack or hi - q.max() > slack:
                reason = "radii still drifting"
                break
    return StartTruth(edges, cycle, ranges, reason, _transient(e, j, edges, cycle))


def _transient(
    edge: np.ndarray, jog: np.ndarray, edges: tuple[int, ...], cycle: tuple[int, ...] | None
) -> int:
    """Return the throws before the run keeps to its long-run edges (and, if periodic, its cycle)."""
    off = np.flatnonzero(~np.isin(edge, edges))
    start = int(off[-1]) + 1 if off.size else 0
    if cycle is None:
        return start
    starts = [n for n in range(len(edge)) if n == 0 or not jog[n]]
    seq = [int(edge[n]) for n in starts]
    p = len(cycle)
    k = len(seq) - 1
    while k - p >= 0 and seq[k - p] == seq[k]:
        k -= 1
    return max(start, starts[max(k - p + 1, 0)])


def design_truth(runs: list[Run], part_radius: float) -> tuple[list[StartTruth], str]:
    """Return every start's truth and why the design's truth is ambiguous ('' if it is not)."""
    truths = [judge(run, part_radius) for run in runs]
    for t in truths:
        if t.reason:
            return truths, t.reason
    for t in truths:
        for other in truths:
            richer = set(t.edges) < set(other.edges) or (
                t.edges == other.edges and t.cycle is not None and other.cycle is None
            )
            if richer and all(
                other.ranges[x][0] - 0.01 * part_radius <= lo
                and hi <= other.ranges[x][1] + 0.01 * part_radius
                for x, (lo, hi) in t.ranges.items()
            ):
                return truths, "one start's set lies inside another's richer set"
    return truths, ""


def rotation_free(cycle: list[int] | None) -> tuple[int, ...] | None:
    """Return a cycle as its least rotation (how ``exact_cycle`` names it)."""
    if cycle is None:
        return None
    return min(tuple(cycle[k:] + cycle[:k]) for k in range(len(cycle)))


@dataclass
class CorpusReport:
    """limit_set against the truth over a set of corpus designs."""

    throws: int
    starts_per_edge: int
    designs: int = 0
    excluded: dict[str, int] | None = None
    unambiguous: int = 0
    agree: int = 0
    mismatches: list[str] | None = None
    kinds: dict[str, int] | None = None
    seconds: float = 0.0
    baseline_agree: int = 0
    ranges_agree: int = 0
    triggers_agree: int = 0
    triggers: int = 0
    range_mismatches: list[str] | None = None
    unsafe_triggers: int = 0
    # Per range end and per trigger end (both sides reading one): |planner - long runs| in m and in mean gaps.
    range_ends: list[tuple[float, float]] | None = None
    trigger_ends: list[tuple[float, float]] | None = None

    @classmethod
    def merged(cls, reports: list[CorpusReport]) -> CorpusReport:
        """Return one report of several over disjoint sets of parts (run apart, at the same settings).

        Parts are judged independently, so counts add; ``seconds`` adds too (the time of one process).
        """
        first = reports[0]
        if any((r.throws, r.starts_per_edge) != (first.throws, first.starts_per_edge) for r in reports):
            raise ValueError("reports merged must share throws and starts per edge")
        out = cls(
            first.throws,
            first.starts_per_edge,
            excluded={},
            mismatches=[],
            kinds={},
            range_mismatches=[],
            range_ends=[],
            trigger_ends=[],
        )
        for r in reports:
            for name in (
                "designs",
                "unambiguous",
                "agree",
                "baseline_agree",
                "ranges_agree",
                "triggers_agree",
                "triggers",
                "unsafe_triggers",
                "seconds",
            ):
                setattr(out, name, getattr(out, name) + getattr(r, name))
            for mine, theirs in ((out.excluded, r.excluded), (out.kinds, r.kinds)):
                assert mine is not None
                for key, count in (theirs or {}).items():
                    mine[key] = mine.get(key, 0) + count
            assert out.mismatches is not None and out.range_mismatches is not None
            out.mismatches += r.mismatches or []
            out.range_mismatches += r.range_mismatches or []
            assert out.range_ends is not None and out.trigger_ends is not None
            out.range_ends += [(float(a), float(b)) for a, b in r.range_ends or []]
            out.trigger_ends += [(float(a), float(b)) for a, b in r.trigger_ends or []]
        return out

    def distances(self) -> str:
        """Return the range and trigger ends' distances from the long runs': median, 90 %, largest."""

        def spread(ends: list[tuple[float, float]] | None, k: int, scale: float) -> str:
            values = np.array([e[k] for e in ends or []]) / scale
            if not values.size:
                return "none"
            return ", ".join(f"{v:.2f}" for v in (np.median(values), np.quantile(values, 0.9), values.max()))

        return (
            f"range ends ({len(self.range_ends or [])}): {spread(self.range_ends, 0, 1e-3)} mm, "
            f"{spread(self.range_ends, 1, 1.0)} mean gaps; trigger ends ({len(self.trigger_ends or [])}): "
            f"{spread(self.trigger_ends, 0, 1e-3)} mm, {spread(self.trigger_ends, 1, 1.0)} mean gaps"
        )

    def figure(self) -> str:
        """Return the corpus figure: designs, why some are left out, agreement, what the corpus holds."""
        left = ", ".join(f"{n} {why}" for why, n in sorted((self.excluded or {}).items()))
        kinds = ", ".join(f"{n} {what}" for what, n in (self.kinds or {}).items())
        share = 100.0 * self.agree / self.unambiguous if self.unambiguous else float("nan")
        return (
            f"limit-set vs long runs ({self.throws} throws from {self.starts_per_edge} starts per edge): "
            f"{self.designs} designs, {self.unambiguous} with an unambiguous truth ({kinds}); "
            f"{self.agree} agree on every start's attractor edges and periodicity ({share:.1f} %), "
            f"{self.ranges_agree} on every attractor's radius ranges and {self.triggers_agree} on the "
            f"trigger range of every goal edge ({self.unsafe_triggers} of the others reaching beyond the "
            f"long runs'; {self.triggers} triggers; within {RANGE_GAPS:g} mean gaps "
            f"of the recent quarters); left out: {left or 'none'}; {self.seconds:.0f} s"
        )


def compare(ls_attractors: list, truths: list[StartTruth]) -> list[str]:
    """Return, per start where limit_set and the truth differ, what differs (empty: they agree)."""
    owner = {b: a for a in ls_attractors for b in a.members}
    out = []
    for b, t in enumerate(truths):
        a = owner.get(b)
        if a is None:
            out.append(f"start {b}: unconverged, truth {list(t.edges)} {t.cycle}")
        elif tuple(a.edges) != t.edges or a.periodic != t.periodic:
            kind = "periodic" if a.periodic else "quasi"
            out.append(f"start {b}: {a.edges} {kind} {a.cycle}, truth {list(t.edges)} {t.cycle}")
    return out


def tail_states(traj: Any, b: int) -> list[tuple[int, float]]:
    """Return the resting states (edge, R) of start b's confirmed tail in limit_set's kept trajectories."""
    sl = slice(int(traj.tail[b]), int(traj.tail_end[b]) + 1)
    return list(zip(traj.edge[b, sl].tolist(), traj.radius[b, sl].tolist(), strict=True))


def _last_half(run: Run) -> tuple[np.ndarray, np.ndarray]:
    """Return the edges and radii of a long run's last half (its attractor, as ``judge`` reads it)."""
    half = (len(run.edge) - 1) // 2
    return run.edge[half:], run.radius[half:]


def range_tolerance(ls: Any, a: Any, edge: int) -> float:
    """Return how far attractor ``a``'s range ends on ``edge`` may lie from the long runs' (RANGE_GAPS).

    In mean gaps of the members' recent quarters on that edge (each member's last n/4 states, n the
    end of its confirmed tail), the sample ``attractors._trim_to_group`` judges the tails against.
    """
    t = ls.trajectories
    r = np.concatenate(
        [
            t.radius[b, n - n // 4 : n + 1][t.edge[b, n - n // 4 : n + 1] == edge]
            for b, n in ((b, int(t.tail_end[b])) for b in a.members)
        ]
    )
    return max(RANGE_GAPS * float(r.max() - r.min()) / r.size, RANGE_FLOOR * float(r.max()))


def compare_ranges(
    ls: Any, runs: list[Run], part: ArmPart, ends: tuple[list, list] | None = None
) -> tuple[list[str], list[str], int]:
    """Return what differs in radius ranges, and in trigger ranges, between limit_set and the long runs.

    Per attractor, its range on each edge against the union of its member starts' last halves, each end
    within ``range_tolerance``. Per goal edge every attractor visits, the trigger range limit_set reads
    (on its tails and the older states of their stays that may be visits, ``sensed_states``) against
    the long runs' free range it overlaps most (a sensor radius range that reads true in every goal visit of
    the same starts' last halves, grouped as limit_set groups them, and never elsewhere: where two free
    ranges are about as wide, each side may name another as the widest, and both keep the promise), each
    end within the largest tolerance of the attractors' edges (a trigger end is a range end moved by the
    part's geometry); a planner's trigger overlapping no free range of the long runs reaches beyond them.
    A trigger present on one side only counts when it is longer than that tolerance. Also
    the number of triggers compared. ``ends``: two lists that get each range end's and each trigger end's
    distance from the long runs', in m and in mean gaps (its tolerance over RANGE_GAPS).
    """
    from feeder_planner.throwing.limit_set import sensed_states
    from feeder_planner.throwing.sensor import read_trigger, sensing_height_or_default

    ranges_out: list[str] = []
    tol_all = 0.0
    for k, a in enumerate(ls.attractors):
        for e, (lo, hi) in a.edge_radius_ranges.items():
            truth = np.concatenate([rr[ee == e] for ee, rr in (_last_half(runs[b]) for b in a.members)])
            tol = range_tolerance(ls, a, e)
            tol_all = max(tol_all, tol)
            if ends is not None:
                for x, y in ((lo, truth.min()), (hi, truth.max())):
                    ends[0].append((abs(x - y), abs(x - y) * RANGE_GAPS / tol))
            if abs(lo - truth.min()) > tol or abs(hi - truth.max()) > tol:
                short = lo > truth.min() + tol or hi < truth.max() - tol
                ranges_out.append(
                    f"attractor {k} edge {e}: [{lo:.6g}, {hi:.6g}] m, long runs [{truth.min():.6g}, "
                    f"{truth.max():.6g}] m (tolerance {tol:.2g} m{'; ' + SHORT if short else ''})"
                )
    height = sensing_height_or_default(part, None)
    goals = sorted(set.intersection(*(set(a.edges) for a in ls.attractors))) if ls.attractors else []
    triggers_out: list[str] = []
    for goal in goals:
        # The planner's trigger as limit_set reads it (its tails and the older states of their stays that
        # may be visits), the truth's on the long runs' last halves.
        mine = read_trigger(
            part,
            goal,
            height,
            [[sensed_states(ls.trajectories, b) for b in a.members] for a in ls.attractors],
        ).trigger
        halves = [
            [
                list(zip((int(v) for v in ee), (float(v) for v in rr), strict=True))
                for ee, rr in (_last_half(runs[b]) for b in a.members)
            ]
            for a in ls.attractors
        ]
        free = read_trigger(part, goal, height, halves).free
        truth = max(free, key=lambda iv: iv[1] - iv[0]) if free else None
        if mine is not None and free:
            # The long runs' free range the planner's trigger overlaps most (overlapping none: the nearest,
            # and the trigger reaches beyond it).
            truth = max(free, key=lambda iv: (min(iv[1], mine[1]) - max(iv[0], mine[0]), -iv[0]))
        if mine is None and truth is None:
            continue
        if mine is not None and truth is not None and ends is not None:
            for x, y in zip(mine, truth, strict=True):
                ends[1].append((abs(x - y), abs(x - y) * RANGE_GAPS / tol_all))
        if mine is None or truth is None:
            other = mine or truth
            assert other is not None
            if other[1] - other[0] > tol_all:
                note = f" ({UNSAFE})" if mine is not None else ""
                triggers_out.append(f"goal edge {goal}: trigger {mine}, long runs {truth}{note}")
        elif abs(mine[0] - truth[0]) > tol_all or abs(mine[1] - truth[1]) > tol_all:
            wide = mine[0] < truth[0] - tol_all or mine[1] > truth[1] + tol_all
            triggers_out.append(
                f"goal edge {goal}: trigger [{mine[0]:.6g}, {mine[1]:.6g}] m, long runs "
                f"[{truth[0]:.6g}, {truth[1]:.6g}] m (tolerance {tol_all:.2g} m"
                + (f"; {UNSAFE})" if wide else ")")
            )
    return ranges_out, triggers_out, len(goals)


def evaluate(
    designs: list[CorpusDesign],
    throws: int,
    starts_per_edge: int,
    window: int | None = None,
    progress: bool = False,
    baseline: Callable[..., Any] | None = None,
) -> CorpusReport:
    """Return limit_set (``starts_per_edge``, ``throws``, ``window``) against long runs of ``throws``.

    ``baseline``: another limit_set (the bench passes the previous rule's) judged on the same designs
    and truths; its agreements are counted in ``baseline_agree``.

    A design is left out when it has no limit set (no R_flip, or some start's run leaves the domain:
    no invariant set) or when its truth is ambiguous (``design_truth``); on every other design each
    start's attractor in limit_set must have the truth's edges and periodicity. The long runs start
    from limit_set's own grid of starts (its trajectories' first states, or ``grid_starts`` when it
    found no attractor at all), so that the grid's bounds are scanned once.
    """
    import time

    from feeder_planner.errors import SolverError
    from feeder_planner.throwing.limit_set import LimitSet, limit_set

    started = time.perf_counter()
    excluded: dict[str, int] = {}
    mismatches: list[str] = []
    kinds: dict[str, int] = {}
    range_mismatches: list[str] = []
    report = CorpusReport(
        throws,
        starts_per_edge,
        excluded=excluded,
        mismatches=mismatches,
        kinds=kinds,
        range_mismatches=range_mismatches,
        range_ends=[],
        trigger_ends=[],
    )
    parts: dict[int, list[CorpusDesign]] = {}
    for d in designs:
        parts.setdefault(d.part_index, []).append(d)
    for group in parts.values():
        valid: list[CorpusDesign] = []
        starts: list[tuple[np.ndarray, np.ndarray]] = []
        results: list[LimitSet | str] = []
        for d in group:
            report.designs += 1
            try:
                ls = limit_set(
                    d.part,
                    d.params,
                    starts_per_edge=starts_per_edge,
                    throws=throws,
                    window=window,
                    keep_trajectories=True,
                )
            except SolverError as error:
                text = str(error)
                if "never flips" in text or "leave the throw map's domain" in text:
                    # No limit set: no R_flip, or a start's run leaves the domain (no invariant set).
                    why = (
                        "without R_flip" if "never flips" in text else "leaving the domain (no invariant set)"
                    )
                    excluded[why] = excluded.get(why, 0) + 1
                    continue
                found = grid_starts(d, starts_per_edge)
                if found is None:
                    continue
                valid.append(d)
                starts.append(found)
                results.append(f"limit_set: {text}")
                continue
            assert ls.trajectories is not None
            valid.append(d)
            starts.append((ls.trajectories.edge[:, 0], ls.trajectories.radius[:, 0]))
            results.append(ls)
        if not valid:
            continue
        for d, runs, ls in zip(valid, long_runs(valid, starts, throws), results, strict=True):
            if any(run.escaped for run in runs):
                why = "leaving the domain (no invariant set)"
                excluded[why] = excluded.get(why, 0) + 1
                continue
            truths, why = design_truth(runs, d.part.radius)
            if why:
                excluded[f"ambiguous: {why}"] = excluded.get(f"ambiguous: {why}", 0) + 1
                continue
            report.unambiguous += 1
            keys = {(t.edges, t.cycle) for t in truths}
            for what, yes in (
                ("with one periodic attractor", len(keys) == 1 and truths[0].periodic),
                ("quasi-periodic", any(not t.periodic for t in truths)),
                ("several attractors", len(keys) > 1),
                ("transients over 100 throws", max(t.transient for t in truths) > 100),
                ("non-convex", not d.convex),
            ):
                if yes:
                    kinds[what] = kinds.get(what, 0) + 1
            wrong = [ls] if isinstance(ls, str) else compare(ls.attractors, truths)
            if baseline is not None:
                try:
                    other = baseline(d.part, d.params, starts_per_edge=starts_per_edge, throws=throws)
                    report.baseline_agree += not compare(other.attractors, truths)
                except SolverError:
                    pass
            if wrong:
                mismatches.append(f"design {d.name}: " + "; ".join(wrong[:3]))
            else:
                report.agree += 1
                # Ranges and triggers only where the attractors agree (issue 35): otherwise the
                # edge disagreement is the finding.
                assert not isinstance(ls, str)
                assert report.range_ends is not None and report.trigger_ends is not None
                bad_ranges, bad_triggers, goals = compare_ranges(
                    ls, runs, d.part, (report.range_ends, report.trigger_ends)
                )
                report.triggers += goals
                report.ranges_agree += not bad_ranges
                report.triggers_agree += not bad_triggers
                report.unsafe_triggers += any(UNSAFE in m for m in bad_triggers)
                if bad_ranges or bad_triggers:
                    range_mismatches.append(f"design {d.name}: " + "; ".join((bad_ranges + bad_triggers)[:3]))
            if progress:
                print(f"{d.name}: {'agrees' if not wrong else wrong[0]}", flush=True)
                if range_mismatches and range_mismatches[-1].startswith(f"design {d.name}:"):
                    print(f"  {range_mismatches[-1]}", flush=True)
    report.seconds = time.perf_counter() - started
    return report
