"""DXF, SVG and STEP twins of the YAML examples give the planners' same answers (issue 39 item 4).

Through the CLI. The twins (tools/make_cad_examples.py) are polygonal, so they agree to rounding; the
filleted bracket measures the chord tolerance against a 100 times finer flattening.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from feeder_cell.cli.main import main
from feeder_planner.cad import CadOptions
from feeder_planner.mems import find_equilibria
from feeder_planner.parts import cad_part, load_part

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
LIMIT_SET = [
    "--offset",
    "-0.5",
    "--release-speed",
    "320deg",
    "--gravity",
    "-966",
    "--mu",
    "0.5",
    "--goal-edge",
    "1",
]


def feeder_json(capsys: pytest.CaptureFixture[str], *argv: str) -> dict:
    code = main([*argv, "--json"])
    out = capsys.readouterr()
    assert code == 0, out.err
    return json.loads(out.out)


def assert_same(left: object, right: object, path: str = "") -> None:
    """Equal structure and strings; numbers within 1e-9 relative (rounding of the DXF's doubles)."""
    if isinstance(left, dict) and isinstance(right, dict):
        assert sorted(left) == sorted(right), path
        for key in left:
            assert_same(left[key], right[key], f"{path}.{key}")
    elif isinstance(left, list) and isinstance(right, list):
        assert len(left) == len(right), path
        for k, (a, b) in enumerate(zip(left, right, strict=True)):
            assert_same(a, b, f"{path}[{k}]")
    elif isinstance(left, float) or isinstance(right, float):
        assert right == pytest.approx(left, rel=1e-9, abs=1e-15), path
    else:
        assert left == right, path


@pytest.mark.parametrize("suffix", ["dxf", "svg", "step"])
@pytest.mark.parametrize("name", ["bracket", "washer"])
def test_mems_twin_has_the_same_equilibria(
    capsys: pytest.CaptureFixture[str], name: str, suffix: str
) -> None:
    yaml_result = feeder_json(capsys, "equilibria", str(EXAMPLES / f"mems/{name}.yaml"), "--delta", "0.1")
    dxf_result = feeder_json(capsys, "equilibria", str(EXAMPLES / f"mems/{name}.{suffix}"), "--delta", "0.1")
    assert any(e["stable"] for e in dxf_result["equilibria"])
    assert_same(yaml_result, dxf_result)


@pytest.mark.parametrize("suffix", ["dxf", "svg", "step"])
def test_triangle_twin_has_the_same_limit_set_and_grasp_radii(
    capsys: pytest.CaptureFixture[str], suffix: str
) -> None:
    yaml_result = feeder_json(capsys, "limit-set", str(EXAMPLES / "throwing/triangle.yaml"), *LIMIT_SET)
    twin = feeder_json(capsys, "limit-set", str(EXAMPLES / f"throwing/triangle.{suffix}"), *LIMIT_SET)
    assert twin["cycle"]["edges"] == [1, 0, 2]  # the README's cycle: the edges are numbered alike
    # Set by the geometry alone: equal to rounding.
    for key in ("stable_edges", "grasp_radius", "flip_radius", "max_radius", "invariant", "unique"):
        assert_same(yaml_result[key], twin[key], key)
    # Sampled from the orbits, which are chaotic: a vertex moved by 1e-18 m (the SVG twin's viewBox
    # rounding) moves a range's ends by up to 2.3 % (measured). The attractor is the same.
    assert twin["cycle"]["edges"] == yaml_result["cycle"]["edges"]
    assert twin["trigger"]["goal_edge"] == yaml_result["trigger"]["goal_edge"]
    for edge, (low, high) in yaml_result["edge_radius_ranges"].items():
        assert twin["edge_radius_ranges"][edge] == pytest.approx([low, high], rel=0.05)
    assert twin["trigger"]["radius_range"] == pytest.approx(yaml_result["trigger"]["radius_range"], rel=0.05)


def test_a_yaml_cad_mapping_names_the_dxf_with_name_and_density(tmp_path: Path) -> None:
    wrapper = tmp_path / "bracket.yaml"
    wrapper.write_text(
        f"name: steel_bracket\ndensity: 7.8\ncad: {{file: {EXAMPLES / 'mems/bracket.dxf'}, layer: PART}}\n"
    )
    part, twin = load_part(wrapper), load_part(EXAMPLES / "mems/bracket.yaml")
    assert part.name == "steel_bracket"
    assert part.mass == pytest.approx(7.8 * twin.area, rel=1e-12)
    np.testing.assert_allclose(part.file_vertices, twin.file_vertices, rtol=0, atol=1e-15)


def test_chord_tolerance_moves_equilibria_of_the_filleted_bracket_by_less_than_stated() -> None:
    """The stated default (1e-4 of the diagonal) against 1e-6: angles within 2e-3 rad (1.3e-3 measured),
    positions within 1e-3 of the part's size (docs/cli.md states the measured numbers)."""
    path = EXAMPLES / "mems/bracket_filleted.dxf"
    coarse, fine = cad_part(path), cad_part(path, CadOptions(chord_tolerance=1e-6))
    assert len(fine.outer) > 5 * len(coarse.outer)  # the finer flattening is really finer
    assert abs(coarse.area - fine.area) < 3e-4 * fine.area
    left, right = find_equilibria(coarse, 0.1), find_equilibria(fine, 0.1)
    assert [e.stable for e in left.equilibria] == [e.stable for e in right.equilibria]
    size = 2 * fine.radius
    for a, b in zip(left.equilibria, right.equilibria, strict=True):
        assert abs(a.theta - b.theta) < 2e-3
        assert np.hypot(a.x - b.x, a.y - b.y) < 1e-3 * size
