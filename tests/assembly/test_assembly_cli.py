"""`feeder stable-region` and `feeder check-stability`: contract JSON, summaries, one-line input errors."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import EXAMPLES

from feeder_cell.cli.main import main

CORNER = str(EXAMPLES / "cube_in_corner.yaml")


def _run(capsys, *argv: str) -> tuple[int, str, str]:
    try:
        code = main(list(argv))
    except SystemExit as exit_:  # argparse rejects a bad flag value itself
        code = exit_.code
    out, err = capsys.readouterr()
    return code, out, err


def test_stable_region_json_follows_the_contract(capsys) -> None:
    code, out, err = _run(capsys, "stable-region", CORNER, "--json")
    assert code == 0 and err == ""
    result = json.loads(out)
    assert {"kind", "normals", "equalities", "vertices", "area_sr", "center", "facets"} <= set(result)
    assert result["kind"] == "region" and result["facets"] == 4
    assert result["area_sr"] == pytest.approx(math.pi / 2)
    center = np.array(result["center"])
    assert all(np.dot(n, center) < 0 for n in result["normals"])


def test_mu_and_facets_flags_override_the_file(capsys) -> None:
    bracket = str(EXAMPLES / "block_in_l_bracket.yaml")
    arc = json.loads(_run(capsys, "stable-region", bracket, "--json")[1])
    patch = json.loads(_run(capsys, "stable-region", bracket, "--mu", "0.3", "--facets", "8", "--json")[1])
    assert arc["kind"] == "arc" and patch["kind"] == "region" and patch["facets"] == 8


def test_check_stability_json_and_summary(capsys) -> None:
    code, out, _ = _run(capsys, "check-stability", CORNER, "--g", "-1", "-2", "-3", "--json")
    result = json.loads(out)
    assert code == 0 and result["stable"] is True and result["margin_rad"] > 0
    total = np.sum([f["force"] for f in result["forces"]], axis=0)
    cube_mass = 1e-6  # 1 cm cube at density 1 kg/m^3
    assert total == pytest.approx(-cube_mass * 9.80665 * np.array([-1, -2, -3]) / math.sqrt(14), abs=1e-15)
    code, out, _ = _run(capsys, "check-stability", CORNER, "--g", "1", "0", "-1")
    assert code == 0 and "NOT stable" in out and "cube" in out


def test_check_stability_exact_cone_flag(capsys, tmp_path) -> None:
    """A slab on the ground tilted along a tangent axis by tan(alpha) = 0.8 mu: the inscribed 4-facet pyramid
    (half-width mu / sqrt 2 along that axis) lets it slide, the exact circular cone holds it."""
    slab = tmp_path / "slab.yaml"
    slab.write_text(
        "name: slab\nmu: 0.5\nbodies:\n"
        "  - {name: ground, grounded: true, boxes: [{min: [-2, -2, -1], max: [2, 2, 0]}]}\n"
        "  - {name: slab, boxes: [{min: [-1, -1, 0], max: [1, 1, 0.2]}]}\n"
    )
    alpha = math.atan(0.8 * 0.5)
    g = ["--g", f"{math.sin(alpha)}", "0", f"{-math.cos(alpha)}"]
    code, out, _ = _run(capsys, "check-stability", str(slab), *g, "--exact-cone", "--json")
    result = json.loads(out)
    assert code == 0 and result["stable"] is False
    assert result["exact_cone"] == {"stable": True, "method": "socp"}
    code, out, _ = _run(capsys, "check-stability", str(slab), *g, "--exact-cone")
    assert code == 0 and "NOT stable" in out and "exact circular friction cone: stable" in out


def test_human_summary_of_the_region(capsys) -> None:
    code, out, _ = _run(capsys, "stable-region", CORNER)
    assert code == 0 and "region" in out and "sr" in out and not out.lstrip().startswith("{")


@pytest.mark.parametrize(
    "argv, words",
    [
        (["stable-region", "/nonexistent/a.yaml"], "cannot read"),
        (["stable-region", CORNER, "--mu", "-0.5"], "--mu: must be >= 0"),
        (["stable-region", CORNER, "--mu", "nan"], "must be finite"),
        (["stable-region", CORNER, "--facets", "2"], "--facets"),
        (["check-stability", CORNER, "--g", "0", "0", "0"], "--g: must be a non-zero direction"),
        (["check-stability", CORNER, "--g", "1", "inf", "0"], "must be finite"),
    ],
)
def test_bad_flags_exit_2_with_one_line(capsys, argv: list[str], words: str) -> None:
    code, out, err = _run(capsys, *argv)
    assert code == 2 and out == ""
    assert words in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err


@pytest.mark.parametrize(
    "text, words",
    [
        ("name: x\nbodies:\n  - {name: a, boxes: [{min: [0,0,0], max: [1,1,1]}]}\n", "no grounded body"),
        (
            "bodies:\n  - {name: g, grounded: true, boxes: [{min: [0,0,0], max: [2,2,1]}]}\n"
            "  - {name: b, boxes: [{min: [0,0,0.5], max: [1,1,2]}]}\n",
            "interpenetrate",
        ),
        (
            "mu: -1\nbodies:\n  - {name: g, grounded: true, boxes: [{min: [0,0,0], max: [2,2,1]}]}\n",
            "mu: must be >= 0",
        ),
        ("bodies:\n  - {name: g, grounded: true, boxes: [{min: [0,0,.nan], max: [2,2,1]}]}\n", "finite"),
        ("bodies: [\n", "not valid YAML"),
    ],
)
def test_bad_files_exit_2_naming_file_and_field(capsys, tmp_path: Path, text: str, words: str) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    code, out, err = _run(capsys, "stable-region", str(path), "--json")
    assert code == 2 and out == ""
    assert str(path) in err and words in err and len(err.strip().splitlines()) == 1
