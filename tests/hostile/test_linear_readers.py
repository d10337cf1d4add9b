"""Linear memory in the readers (issue 16 item 8): the sweep and the box union give today's results.

The all-pairs simplicity check and the dense (2N)^3 box grid they replace are kept here as references
(brute force, small inputs only); memory is measured with tracemalloc (numpy reports its buffers to it).
"""

from __future__ import annotations

import itertools
import math
import time
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from feeder_planner import polygon
from feeder_planner.assembly import load_assembly
from feeder_planner.assembly.geometry import box_piece
from feeder_planner.assembly.model import _box_union, assembly_from_document
from feeder_planner.errors import InputError
from feeder_planner.parts import load_part, make_part

ROOT = Path(__file__).resolve().parents[2]
MEMORY_BOUND = 200 * 1024 * 1024


def all_pairs_check(vertices: np.ndarray) -> str:
    """The quadratic check the sweep replaced (its message for a self-intersection), or "ok"."""
    n = len(vertices)
    try:
        polygon.check_simple(vertices, "v")  # the parts of the check that are not pairwise
    except InputError as error:
        if "self-intersecting polygon: edge" not in error.problem:
            return str(error)
    scale = float(np.ptp(vertices, axis=0).max())
    start, end = vertices, np.roll(vertices, -1, axis=0)
    for i, j in itertools.combinations(range(n), 2):
        if j == i + 1 or (i == 0 and j == n - 1):
            continue
        if polygon._segments_cross(start[i], end[i], start[j], end[j], scale):
            return f"v: self-intersecting polygon: edge {i} meets edge {j}"
    try:
        polygon.check_simple(vertices, "v")
    except InputError as error:
        return str(error)
    return "ok"


def sweep_check(vertices: np.ndarray) -> str:
    try:
        polygon.check_simple(vertices, "v")
    except InputError as error:
        return str(error)
    return "ok"


def test_the_sweep_finds_the_same_first_crossing_as_all_pairs() -> None:
    rng = np.random.default_rng(16)
    kinds = {"ok": 0, "bad": 0}
    for trial in range(150):
        n = int(rng.integers(3, 24))
        if trial % 3 == 0:
            v = rng.normal(size=(n, 2))
        elif trial % 3 == 1:
            angles = np.sort(rng.uniform(0, 2 * np.pi, n))
            v = np.stack([np.cos(angles), np.sin(angles)], axis=1) * rng.uniform(0.5, 1, (n, 1))
        else:
            v = rng.integers(0, 4, size=(n, 2)).astype(float)  # collinear and touching cases
        expected = all_pairs_check(v)
        assert sweep_check(v) == expected, v.tolist()
        kinds["ok" if expected == "ok" else "bad"] += 1
    assert min(kinds.values()) > 20  # both outcomes exercised


def test_hole_checks_keep_their_messages() -> None:
    outer = [[0, 0], [10, 0], [10, 10], [0, 10]]
    square = lambda x, y, s: [[x, y], [x + s, y], [x + s, y + s], [x, y + s]]  # noqa: E731
    with pytest.raises(InputError, match=r"holes\[0\]: hole is not strictly inside"):
        make_part(outer, [square(8, 8, 4)])
    with pytest.raises(InputError, match=r"holes\[0\]: hole is not strictly inside"):
        make_part(outer, [square(20, 20, 1)])
    with pytest.raises(InputError, match=r"holes\[1\]: hole overlaps holes\[0\]"):
        make_part(outer, [square(1, 1, 4), square(2, 2, 1)])  # nested
    with pytest.raises(InputError, match=r"holes\[2\]: hole overlaps holes\[0\]"):
        make_part(outer, [square(1, 1, 2), square(5, 5, 2), square(2, 2, 2)])  # crossing
    part = make_part(outer, [square(1, 1, 2), square(5, 5, 2)])
    assert part.area == pytest.approx(100 - 8)


def circle_part(n: int) -> dict:
    angles = 2 * math.pi * np.arange(n) / n
    return {"vertices": np.stack([np.cos(angles), np.sin(angles)], axis=1).tolist()}


def test_a_5000_vertex_part_reads_in_linear_memory(tmp_path: Path) -> None:
    import json

    path = tmp_path / "circle.yaml"
    path.write_text(json.dumps(circle_part(5000)))
    tracemalloc.start()
    started = time.perf_counter()
    part = load_part(path)
    seconds = time.perf_counter() - started
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert part.area == pytest.approx(math.pi, rel=1e-6)
    assert peak < MEMORY_BOUND, f"peak {peak / 2**20:.0f} MB"
    print(f"5000-vertex part: {seconds:.2f} s, peak {peak / 2**20:.1f} MB (traced)")
    assert seconds < 10.0  # a hang guard only; the figure is in the report


def dense_grid_union(boxes: list) -> tuple[float, np.ndarray]:
    """The (2N)^3 grid the sweep replaced: exact, for small N."""
    grids = [np.unique(np.concatenate([[b.lower[a], b.upper[a]] for b in boxes])) for a in range(3)]
    cells = np.zeros(tuple(len(g) - 1 for g in grids), dtype=bool)
    for b in boxes:
        cells[
            tuple(
                slice(np.searchsorted(grids[a], b.lower[a]), np.searchsorted(grids[a], b.upper[a]))
                for a in range(3)
            )
        ] = True
    widths = [np.diff(g) for g in grids]
    mids = [(g[1:] + g[:-1]) / 2 for g in grids]
    filled = np.where(
        cells, widths[0][:, None, None] * widths[1][None, :, None] * widths[2][None, None, :], 0.0
    )
    volume = float(filled.sum())
    center = np.array(
        [
            (filled.sum(axis=(1, 2)) * mids[0]).sum(),
            (filled.sum(axis=(0, 2)) * mids[1]).sum(),
            (filled.sum(axis=(0, 1)) * mids[2]).sum(),
        ]
    )
    return volume, center / volume


def test_the_box_sweep_matches_the_dense_grid_on_the_examples_and_random_unions() -> None:
    for name in ("cube_in_corner", "block_in_l_bracket", "block_between_parallel_faces"):
        assembly = load_assembly(ROOT / "examples" / "assembly" / f"{name}.yaml")
        for body in assembly.bodies:
            boxes = [p for p in body.pieces if p.is_box]
            if boxes:
                volume, center = _box_union(boxes)
                ref_volume, ref_center = dense_grid_union(boxes)
                assert volume == pytest.approx(ref_volume, rel=1e-14)
                assert center == pytest.approx(ref_center, rel=1e-14, abs=1e-15)
    rng = np.random.default_rng(8)
    for _ in range(100):
        n = int(rng.integers(1, 10))
        lower = rng.integers(0, 6, size=(n, 3)) * rng.choice([1.0, 0.37])
        upper = lower + rng.integers(1, 4, size=(n, 3))
        boxes = [box_piece(lo, hi, "box") for lo, hi in zip(lower, upper, strict=True)]
        volume, center = _box_union(boxes)
        ref_volume, ref_center = dense_grid_union(boxes)
        assert volume == pytest.approx(ref_volume, rel=1e-13)
        assert center == pytest.approx(ref_center, rel=1e-13, abs=1e-14)


def test_a_300_box_body_reads_in_linear_memory() -> None:
    rng = np.random.default_rng(300)
    lower = rng.uniform(0, 1, size=(300, 3))
    upper = lower + rng.uniform(0.05, 0.5, size=(300, 3))
    free = [{"min": lo.tolist(), "max": hi.tolist()} for lo, hi in zip(lower, upper, strict=True)]
    document = {
        "bodies": [
            {"name": "ground", "grounded": True, "boxes": [{"min": [-1, -1, -2], "max": [3, 3, -1]}]},
            {"name": "heap", "boxes": free},
        ]
    }
    started = time.perf_counter()
    assembly = assembly_from_document(document)
    seconds = time.perf_counter() - started
    assert 0 < assembly.bodies[1].mass < float(np.prod(upper.max(axis=0) - lower.min(axis=0)))
    # The union is what grew as (2N)^3; its memory is traced alone (tracing slows the rest fivefold).
    boxes = list(assembly.bodies[1].pieces)
    tracemalloc.start()
    volume, _ = _box_union(boxes)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert volume == pytest.approx(assembly.bodies[1].mass)  # density 1
    assert peak < MEMORY_BOUND, f"peak {peak / 2**20:.0f} MB"
    print(f"300-box body: read in {seconds:.2f} s; union peak {peak / 2**20:.1f} MB (traced)")
    assert seconds < 10.0  # a hang guard only; the figure is in the report
