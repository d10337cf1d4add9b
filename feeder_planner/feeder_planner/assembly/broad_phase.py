"""Broad phase of contact finding: the pairs of axis-aligned bounding boxes that touch or overlap.

A sweep over sorted bounds on the axis along which the boxes spread most: boxes are sorted by their lower
bound there, each box meets only the boxes that start before it ends (one ``searchsorted``), and those
candidates are filtered on the other two axes, all in numpy. For n bodies of bounded size and
neighbourhood this is O(n log n + pairs); 1,000 bodies take milliseconds (tests/assembly/test_meshes.py).
"""

from __future__ import annotations

import numpy as np

__all__ = ["touching_pairs"]


def touching_pairs(lower: np.ndarray, upper: np.ndarray, tolerance: float) -> np.ndarray:
    """Return the index pairs (i < j, sorted) whose boxes overlap or are within ``tolerance`` on every axis.

    ``lower`` and ``upper`` are (n, 3) box corners. The result is an (m, 2) integer array in lexicographic
    order, so callers visit pairs in the same order as a double loop over i < j would.
    """
    lower = np.asarray(lower, float).reshape(-1, 3)
    upper = np.asarray(upper, float).reshape(-1, 3)
    count = len(lower)
    if count < 2:
        return np.zeros((0, 2), dtype=np.int64)
    spread = np.ptp((lower + upper) / 2.0, axis=0) / np.maximum(np.mean(upper - lower, axis=0), 1e-300)
    axis = int(np.argmax(spread))
    order = np.argsort(lower[:, axis], kind="stable")
    starts = lower[order, axis]
    # Box order[k] meets the boxes order[k+1 .. stop[k]-1]: those that start before it ends (plus tolerance).
    stop = np.searchsorted(starts, upper[order, axis] + tolerance, side="right")
    lengths = np.maximum(stop - np.arange(count) - 1, 0)
    total = int(lengths.sum())
    if total == 0:
        return np.zeros((0, 2), dtype=np.int64)
    first = np.repeat(np.arange(count), lengths)
    # Positions k+1, k+2, ... for each k: a running index minus each run's start.
    run_start = np.repeat(np.cumsum(lengths) - lengths, lengths)
    second = first + 1 + (np.arange(total) - run_start)
    i, j = order[first], order[second]
    gap = np.minimum(upper[i], upper[j]) - np.maximum(lower[i], lower[j])
    keep = np.all(gap >= -tolerance, axis=1)
    pairs = np.column_stack([np.minimum(i, j), np.maximum(i, j)])[keep]
    if len(pairs) == 0:
        return pairs.astype(np.int64)
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))].astype(np.int64)
