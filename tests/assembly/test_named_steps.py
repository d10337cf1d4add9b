"""The named steps of the region, LP, exact-cone, planner and fixture code, each checked on its own."""

from __future__ import annotations

import itertools
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import EXAMPLES

from feeder_planner.assembly import KINDS, contact_loads, region_result
from feeder_planner.assembly import region as region_module
from feeder_planner.assembly.exact_cone import (
    ExactVerdict,
    _certified_stable,
    _cone_columns,
    _cone_violation,
)
from feeder_planner.assembly.lp import LP_STATUSES, WarmLP, _ColumnKinds, _complementary
from feeder_planner.assembly.planner import check_result
from feeder_planner.assembly.tolerances import REGION_TOLERANCE_RAD, SUPPORT_TOLERANCE
from feeder_planner.assembly.wrench import pyramid_edges, validate_facets
from feeder_planner.errors import InputError
from feeder_sim.fixture import TableLimits, certify, sample_waypoints
from feeder_sim.fixture.kinematics import _arrival_times, _check_sample

ROOT = Path(__file__).resolve().parents[2]
# The contract's list (../shared/spec/contract.md, "where K is one of ..."), in its order.
CONTRACT_KINDS = ("empty", "point", "antipodal_pair", "arc", "great_circle", "region", "hemisphere", "sphere")


class RayOracle:
    """Support function of conv{0, generators}: a bounded section of the cone V the generators span.

    Its facets through the origin are V's facets, which is all the region is built from.
    """

    def __init__(self, generators: np.ndarray) -> None:
        self.generators = np.asarray(generators, float).reshape(-1, 3)
        self.calls = 0

    def __call__(self, direction: np.ndarray) -> tuple[float, np.ndarray]:
        self.calls += 1
        candidates = np.vstack([np.zeros(3), self.generators])
        values = candidates @ np.asarray(direction, float)
        best = int(np.argmax(values))
        return float(values[best]), candidates[best]


def test_region_kinds_are_the_contract_list() -> None:
    assert KINDS == CONTRACT_KINDS
    assert LP_STATUSES == ("optimal", "infeasible", "limit", "failed")


@pytest.mark.parametrize(
    "generators, kind",
    [
        (np.zeros((0, 3)), "empty"),
        (np.array([[0.0, 0.0, -1.0]]), "point"),
        (np.array([[0.0, 0.0, -1.0], [0.0, 0.0, 1.0]]), "antipodal_pair"),
    ],
)
def test_linear_regions_from_a_support_oracle(generators: np.ndarray, kind: str) -> None:
    region = region_module.cone_region(RayOracle(generators), 4)
    assert region.kind == kind and region.area_sr == 0.0
    if kind == "point":
        assert region.vertices[0] == pytest.approx([0, 0, -1]) and region.contains(np.array([0, 0, -2.0]))
        assert not region.contains(np.array([0.01, 0, -1.0]))
    if kind == "antipodal_pair":
        assert region.contains(np.array([0, 0, 1.0])) and region.contains(np.array([0, 0, -1.0]))


def test_octant_from_a_support_oracle_is_the_paper_fig11_region() -> None:
    region = region_module.cone_region(RayOracle(-np.eye(3)), 4)
    assert region.kind == "region"
    assert region.area_sr == pytest.approx(math.pi / 2)
    assert region.center == pytest.approx(-np.ones(3) / math.sqrt(3))
    assert region.lp_count > 0


def test_point_off_span_finds_nothing_when_every_support_value_is_within_tolerance() -> None:
    class Flat:
        calls = 0

        def __call__(self, direction: np.ndarray) -> tuple[float, np.ndarray]:
            self.calls += 1
            return SUPPORT_TOLERANCE / 2, np.zeros(3)

    oracle = Flat()
    assert region_module._point_off_span(oracle, []) is None
    assert oracle.calls == 6  # both signs of the three frame directions


def test_hull_planes_of_a_cube_merge_qhulls_triangles_into_six_faces() -> None:
    corners = np.array(list(itertools.product((-1.0, 1.0), repeat=3)))
    normals, offsets = region_module._hull_planes(corners)
    assert len(normals) == 6
    assert offsets == pytest.approx(np.ones(6))
    assert sorted(map(tuple, np.round(normals, 12) + 0.0)) == sorted(
        map(tuple, np.vstack([np.eye(3), -np.eye(3)]))
    )


def test_unconfirmed_planes_are_those_without_a_matching_certified_plane() -> None:
    normals = np.eye(3)
    offsets = np.array([1.0, 1.0, 0.5])
    confirmed_n = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    confirmed_h = np.array([1.0, 0.5 + 1e-6])  # the second offset differs by more than the match tolerance
    assert region_module._unconfirmed(normals, offsets, confirmed_n, confirmed_h).tolist() == [1, 2]
    assert region_module._unconfirmed(normals, offsets, np.zeros((0, 3)), np.zeros(0)).tolist() == [0, 1, 2]


def test_centre_candidates_enumerate_every_one_two_and_three_set_of_circles() -> None:
    n = np.random.default_rng(4).normal(size=(7, 3))
    count = sum(len(c) for c in region_module._center_candidates(n))
    assert count == 7 + math.comb(7, 2) + math.comb(7, 3)
    octant = [np.eye(3)[i] for i in range(3)]
    assert region_module._center(octant, [-v for v in octant]) == pytest.approx(-np.ones(3) / math.sqrt(3))


def test_column_kinds_partition_the_columns() -> None:
    lower = np.array([-np.inf, 0.0, -np.inf, -1.0, 2.0])
    upper = np.array([np.inf, np.inf, 3.0, 1.0, 2.0])
    kinds = _ColumnKinds.of(lower, upper)
    masks = np.vstack([kinds.free, kinds.lower_only, kinds.upper_only, kinds.boxed, kinds.fixed])
    assert masks.sum(axis=0).tolist() == [1, 1, 1, 1, 1]
    assert np.argmax(masks, axis=0).tolist() == [0, 1, 2, 3, 4]
    assert kinds.counts.tolist() == [0, 1, 2, 3, 4]


def test_complementary_start_puts_each_variable_at_a_bound_or_at_zero_reduced_cost() -> None:
    rng = np.random.default_rng(2)
    lower = np.where(rng.random(50) < 0.8, 0.0, -np.inf)
    upper = np.where(rng.random(50) < 0.5, 1.0, np.inf)
    x = rng.uniform(-0.5, 1.5, 50)
    reduced = rng.normal(size=50)
    x, reduced = _complementary(x, reduced, lower, upper)
    assert np.all(x >= lower) and np.all(x <= upper)
    at_lower, at_upper = x == lower, x == upper
    assert np.all(reduced[at_lower & ~at_upper] >= 0) and np.all(reduced[at_upper & ~at_lower] <= 0)
    assert np.all(reduced[~(at_lower | at_upper)] == 0)


def test_a_never_run_model_is_run_once_without_a_pivot_before_a_crossover() -> None:
    from scipy import sparse

    lp = WarmLP(sparse.csc_matrix(np.array([[1.0, 1.0]])), np.array([1.0]), np.zeros(2), np.full(2, np.inf))
    assert not lp._has_run
    assert lp._ensure_has_run()
    assert lp._has_run and lp.solves == 1 and lp.pivots == 0
    assert lp._ensure_has_run() and lp.solves == 1  # only the first time


def test_the_highs_binding_prints_nothing_on_stdout() -> None:
    """HiGHS prints its banner on the process's stdout (not sys.stdout) once, unless silenced first: it would
    break `--json`'s one object. Only a fresh process shows it, so the solve runs in one."""
    script = (
        "import numpy as np\n"
        "from scipy import sparse\n"
        "from feeder_planner.assembly.lp import WarmLP\n"
        "lp = WarmLP(sparse.csc_matrix(np.eye(2)), np.ones(2), np.zeros(2), np.full(2, np.inf))\n"
        "lp.set_cost(np.arange(2), np.ones(2))\n"
        "assert lp.solve().status == 'optimal'\n"
        "assert lp.solve_by_interior_point().status == 'optimal'\n"
    )
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stdout == ""


def test_stable_region_json_is_exactly_one_object_on_the_process_stdout() -> None:
    script = "from feeder_cell.cli.main import main; raise SystemExit(main())"
    corner = str(EXAMPLES / "cube_in_corner.yaml")
    result = subprocess.run(
        [sys.executable, "-c", script, "stable-region", corner, "--json"],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=ROOT,
    )
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert len(lines) == 1
    assert json.loads(lines[0])["tolerance_rad"] == REGION_TOLERANCE_RAD


def test_pyramid_edges_for_k4_are_the_papers_square_pyramid() -> None:
    """Eq. (9): K = 4 is |f_x|, |f_y| <= mu f_n / sqrt(2) in the contact's (u, v) axes."""
    mu = 0.6
    edges = pyramid_edges(np.array([[0.0, 0.0, 1.0]]), np.array([mu]), 4)[0]
    assert edges[:, 2] == pytest.approx(np.ones(4))
    assert np.abs(edges[:, :2]) == pytest.approx(np.full((4, 2), mu / math.sqrt(2)))
    outer = pyramid_edges(np.array([[0.0, 0.0, 1.0]]), np.array([mu]), 4, circumscribed=True)[0]
    assert np.abs(outer[:, :2]) == pytest.approx(np.full((4, 2), mu))  # the square around the circle


@pytest.mark.parametrize("value", [2, True, 4.0, "4"])
def test_validate_facets_refuses_naming_the_field(value: object) -> None:
    with pytest.raises(InputError) as caught:
        validate_facets(value, "--facets")
    assert caught.value.field == "--facets"
    assert validate_facets(np.int64(5)) == 5


def _slab(mu: float, contacts: list[dict]) -> dict:
    return {
        "name": "slab",
        "mu": mu,
        "bodies": [
            {"name": "ground", "grounded": True, "boxes": [{"min": [-2, -2, -1], "max": [2, 2, 0]}]},
            {"name": "slab", "boxes": [{"min": [-1, -1, 0], "max": [1, 1, 0.2]}]},
        ],
        "contacts": contacts,
    }


def test_cone_columns_and_violation_of_mixed_frictional_and_frictionless_contacts(from_doc) -> None:
    contacts = [
        {"a": "slab", "b": "ground", "point": [1, 1, 0], "normal": [0, 0, 1], "mu": 0.5},
        {"a": "slab", "b": "ground", "point": [-1, 1, 0], "normal": [0, 0, 1], "mu": 0.0},
        {"a": "slab", "b": "ground", "point": [0, -1, 0], "normal": [0, 0, 1], "mu": 0.5},
    ]
    prepared = from_doc(_slab(0.5, contacts))
    columns = _cone_columns(prepared.assembly, prepared.contacts)
    assert columns.owners.tolist() == [0, 0, 0, 1, 2, 2, 2]
    assert columns.first.tolist() == [0, 3, 4]
    assert columns.cone_first.tolist() == [0, 4] and columns.nonneg.tolist() == [3]
    inside = np.array([1.0, 0.3, 0.4, 0.5, 1.0, 0.0, 0.0])  # |(0.3, 0.4)| = 0.5 = mu f_n: on the cone
    assert _cone_violation(columns, inside) == pytest.approx(0.0, abs=1e-15)
    outside = inside.copy()
    outside[1], outside[3] = 0.6, -0.2  # tangential 0.72 > 0.5; a frictionless contact pulling
    assert _cone_violation(columns, outside) == pytest.approx(max(math.hypot(0.6, 0.4) - 0.5, 0.2))
    g = np.array([0.0, 0.0, -1.0])
    assert not _certified_stable(columns, inside, -columns.system.B @ g)  # forces that balance nothing
    assert _certified_stable(columns, np.zeros(7), np.zeros(columns.system.A.shape[0]))
    assert not _certified_stable(columns, outside, columns.system.A @ outside)  # balanced, outside the cone


def test_check_result_json_keys_and_their_order(example) -> None:
    prepared = example("cube_in_corner")
    stable = check_result(prepared, np.array([-1.0, -2.0, -3.0]), exact_cone=True).to_json()
    assert list(stable) == [
        "stable",
        "g",
        "facets",
        "gravity_m_s2",
        "unbalanced_bodies",
        "forces",
        "margin_rad",
        "exact_cone",
    ]
    assert stable["exact_cone"] == ExactVerdict(True, 0, "socp").to_json()
    unstable = check_result(prepared, np.array([1.0, 0.0, -1.0]), with_margin=False).to_json()
    assert list(unstable) == ["stable", "g", "facets", "gravity_m_s2", "unbalanced_bodies"]
    assert unstable["unbalanced_bodies"] == ["cube"]


def test_region_result_json_adds_ours_after_the_contracts_fields(example) -> None:
    prepared = example("cube_in_corner")
    result = region_result(prepared).to_json()
    assert list(result)[:7] == ["kind", "normals", "equalities", "vertices", "area_sr", "center", "facets"]
    assert list(result)[7:] == ["lp_count", "assembly", "contacts", "mu", "tolerance_rad"]


def test_contact_loads_need_one_force_row_per_contact(example) -> None:
    prepared = example("cube_in_corner")
    loads = contact_loads(prepared, np.ones((len(prepared.contacts), 3)))
    assert [load.a for load in loads] == ["cube"] * len(prepared.contacts)
    with pytest.raises(ValueError):
        contact_loads(prepared, np.ones((len(prepared.contacts) - 1, 3)))


def test_table_start_outside_the_range_names_the_parameter() -> None:
    limits = TableLimits(x_min=-0.5, x_max=0.5).validate()
    limits.check_start(np.array([0.5, math.pi]))
    with pytest.raises(InputError) as caught:
        limits.check_start(np.array([0.6, 0.0]))
    assert caught.value.field == "parameter initial_tilt_x"
    with pytest.raises(InputError, match=r"tilt_y = -3\.2") as caught:
        _check_sample(np.array([0.0, -3.2]), limits, 4, "gravity_waypoints")
    assert caught.value.field == "gravity_waypoints (sample 4)"  # the request's field and the sample
    _check_sample(np.array([0.5 + 1e-13, 0.0]), limits, 0, "waypoints")  # rounding past a limit is inside


def test_interlock_verdict_names_the_sample_and_the_falling_body(example) -> None:
    prepared = example("block_in_l_bracket", mu=0.3)
    samples = sample_waypoints(np.array([0, 0, -1.0]), [np.array([1.0, 0.0, -0.3])], math.radians(1))
    verdict = certify(prepared, samples)
    assert verdict.problem().startswith(f"path sample {verdict.first_unstable} of {len(samples)} (g = [")
    assert verdict.problem().endswith("is not stable: block would lose equilibrium")
    assert certify(prepared, samples[:1]).problem() == ""


def test_arrival_times_follow_the_slower_joint() -> None:
    limits = TableLimits(rate_x=0.5, rate_y=2.0)
    joints = np.array([[0.0, 0.0], [0.1, 0.1], [0.1, 1.1]])
    assert _arrival_times(joints, limits) == pytest.approx([0.0, 0.2, 0.7])
