"""The fast support LPs (primal simplex restarted from known vertices' bases) give the reference region."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import sparse
from scipy.optimize import linprog

from feeder_planner.assembly import region as region_module
from feeder_planner.assembly.exact_cone import hausdorff_to
from feeder_planner.assembly.generate import brick_wall, random_assembly
from feeder_planner.assembly.support import SupportOracle
from feeder_planner.assembly.wrench import split_components


class ColdOracle:
    """Reference support function of P: every LP solved from scratch by scipy's linprog (no shared model)."""

    def __init__(self, system) -> None:
        self.A = sparse.hstack([sparse.csc_matrix(system.B), system.A], format="csc")
        self.bounds = [(-1.0, 1.0)] * 3 + [(0.0, None)] * system.columns
        self.calls = 0

    def __call__(self, direction: np.ndarray) -> tuple[float, np.ndarray]:
        self.calls += 1
        cost = np.zeros(self.A.shape[1])
        cost[:3] = -np.asarray(direction, float)
        result = linprog(
            cost,
            A_eq=self.A,
            b_eq=np.zeros(self.A.shape[0]),
            bounds=self.bounds,
            method="highs",
            options={"primal_feasibility_tolerance": 1e-9, "dual_feasibility_tolerance": 1e-9},
        )
        assert result.status == 0, result.message
        g = np.clip(result.x[:3], -1.0, 1.0)
        return float(np.asarray(direction, float) @ g), g


def _same_region(fast, reference) -> None:
    """Same set to the LP tolerance. Facet lists are not compared one to one: the normal of a sliver edge (two
    nearly parallel facets) is ill-conditioned, so two LP paths may describe the same set differently."""
    assert fast.kind == reference.kind
    assert fast.area_sr == pytest.approx(reference.area_sr, rel=1e-6, abs=1e-9)
    if fast.kind == "region":
        distance = max(hausdorff_to(fast, reference, 128), hausdorff_to(reference, fast, 128))
        assert distance < 1e-6
    else:
        assert len(fast.normals) == len(reference.normals)
        assert np.all(np.max(fast.normals @ reference.normals.T, axis=1) > 1 - 1e-7)


@pytest.mark.parametrize(
    "document",
    [
        brick_wall(3, 3, mu=0.5),
        brick_wall(5, 4, mu=0.6),
        random_assembly(11, 6, mu=0.7, walls=True),
        random_assembly(12, 7, mu=0.4, walls=False),
    ],
    ids=["wall3x3", "wall5x4", "tower11", "tower12"],
)
def test_warm_restarted_region_equals_cold_reference(from_doc, document, monkeypatch) -> None:
    prepared = from_doc(document)
    assert len(split_components(prepared.system)) == 1  # one connected sub-assembly: no splitting helps
    restarts = []
    original = SupportOracle.__call__

    def counting(self, direction):
        restarts.append(bool(self._points))
        return original(self, direction)

    monkeypatch.setattr(SupportOracle, "__call__", counting)
    fast = region_module.stable_region(prepared.system)
    assert sum(restarts) >= 3  # the warm restart path was exercised
    reference = region_module.cone_region(ColdOracle(prepared.system), prepared.facets)
    _same_region(fast, reference)


def test_far_support_lps_go_through_interior_point_and_match_cold_reference(from_doc) -> None:
    """On a statically indeterminate wall some restarts exceed FAR_PIVOTS; their interior-point + crossover
    answers must leave the region exactly as the cold reference computes it."""
    prepared = from_doc(brick_wall(8, 6, mu=0.6))
    oracle = SupportOracle(prepared.system)
    assert oracle.lp.interior_point_available()  # clarabel is a pinned requirement, not optional here
    fast = region_module.cone_region(oracle, prepared.facets)
    assert oracle.far_solves >= 1
    reference = region_module.cone_region(ColdOracle(prepared.system), prepared.facets)
    _same_region(fast, reference)


def test_profile_tool_accounts_for_every_lp_and_phase() -> None:
    """tools/profile_region.py (the issue-15 profile) prints one line per LP and the phase totals."""
    import re
    import subprocess
    import sys
    from pathlib import Path

    tool = Path(__file__).resolve().parents[2] / "tools" / "profile_region.py"
    out = subprocess.run(
        [sys.executable, str(tool), "8", "6"], capture_output=True, text=True, timeout=120, check=True
    ).stdout
    lps = int(re.search(r"region: region, \d+ facets, (\d+) LPs", out).group(1))
    lines = [line for line in out.splitlines() if line.lstrip().startswith("LP ")]
    assert len(lines) == lps
    assert any(line.endswith("interior point") for line in lines)  # the wall is large enough for that route
    phases = dict(re.findall(r"^\s+(interior_point|crossover|simplex)\s+([0-9.]+) s", out, re.MULTILINE))
    assert set(phases) == {"interior_point", "crossover", "simplex"}
    assert all(float(seconds) > 0 for seconds in phases.values())
