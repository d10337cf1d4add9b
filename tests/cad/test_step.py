"""STEP solids (OCP): the bracket's prism as a planar part, the L bracket assembly's solids as bodies, and
bad STEP as one line naming the body (issue 39 items 1, 2, 4, 5)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from feeder_cell.cli.main import main

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def run_json(capsys: pytest.CaptureFixture[str], *argv: str) -> dict:
    code = main([*argv, "--json"])
    out = capsys.readouterr()
    assert code == 0, out.err
    return json.loads(out.out)  # one JSON object: OpenCASCADE's messages stay in its child process


def refused(capsys: pytest.CaptureFixture[str], *argv: str) -> str:
    code = main(list(argv))
    out = capsys.readouterr()
    assert code == 2, out
    assert out.err.count("\n") == 1 and "Traceback" not in out.err, out.err
    return out.err


def test_the_bracket_prism_has_the_bracket_equilibria(capsys: pytest.CaptureFixture[str]) -> None:
    twin = run_json(capsys, "equilibria", str(EXAMPLES / "mems/bracket.step"), "--delta", "0.1")["equilibria"]
    expected = run_json(capsys, "equilibria", str(EXAMPLES / "mems/bracket.yaml"), "--delta", "0.1")[
        "equilibria"
    ]
    assert [e["stable"] for e in twin] == [e["stable"] for e in expected]
    for a, b in zip(twin, expected, strict=True):
        assert a["theta"] == pytest.approx(b["theta"], abs=1e-9)
        assert (a["x"], a["y"]) == pytest.approx((b["x"], b["y"]), abs=1e-12)
    info = run_json(capsys, "part-info", str(EXAMPLES / "mems/bracket.step"))
    assert info["unit"] == "SI_UNIT(.MILLI.,.METRE.)" and info["area"] == pytest.approx(6e-6, rel=1e-12)


def test_the_step_l_bracket_has_the_boxes_stable_region(capsys: pytest.CaptureFixture[str]) -> None:
    boxes = run_json(
        capsys, "stable-region", str(EXAMPLES / "assembly/block_in_l_bracket.yaml"), "--mu", "0.2"
    )
    step = run_json(
        capsys, "stable-region", str(EXAMPLES / "assembly/block_in_l_bracket_step.yaml"), "--mu", "0.2"
    )
    assert step["kind"] == boxes["kind"] == "region" and step["contacts"] == boxes["contacts"]
    assert step["area_sr"] == pytest.approx(boxes["area_sr"], rel=1e-9)
    flat = [x for vertex in sorted(map(tuple, step["vertices"])) for x in vertex]
    assert flat == pytest.approx(
        [x for vertex in sorted(map(tuple, boxes["vertices"])) for x in vertex], abs=1e-9
    )


def test_several_solids_need_a_choice(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    assembly = EXAMPLES / "assembly/meshes/block_in_l_bracket.step"
    line = refused(capsys, "part-info", str(assembly))
    assert "2 solids and no choice made" in line and "body:" in line
    wrapper = tmp_path / "block.yaml"
    wrapper.write_text(f"cad: {{file: {assembly}, body: 2}}\n")
    assert run_json(capsys, "part-info", str(wrapper))["area"] == pytest.approx(1e-4, rel=1e-9)  # 1 cm^2


def test_a_surface_model_is_not_a_closed_solid(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace, BRepBuilderAPI_MakePolygon
    from OCP.gp import gp_Pnt
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer

    polygon = BRepBuilderAPI_MakePolygon(gp_Pnt(0, 0, 0), gp_Pnt(1, 0, 0), gp_Pnt(1, 1, 0), True)
    writer = STEPControl_Writer()
    writer.Transfer(BRepBuilderAPI_MakeFace(polygon.Wire()).Face(), STEPControl_AsIs)
    path = tmp_path / "sheet.step"
    writer.Write(str(path))
    capsys.readouterr()  # the writer's messages
    line = refused(capsys, "part-info", str(path))
    assert "holds no solid" in line and "surface model" in line and "closed solids" in line


def test_units_missing_empty_and_broken(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    text = (EXAMPLES / "mems/bracket.step").read_text()
    no_unit = tmp_path / "no_unit.step"
    no_unit.write_text(text.replace("LENGTH_UNIT", "LENGTH_THING"))
    line = refused(capsys, "part-info", str(no_unit))
    assert "LENGTH_UNIT: units missing" in line and "unit:" in line
    empty = tmp_path / "empty.step"
    empty.write_text("")
    assert "is empty" in refused(capsys, "part-info", str(empty))
    broken = tmp_path / "broken.step"
    broken.write_text(text[: text.index("ENDSEC")])  # the header only: the units come later
    line = refused(capsys, "part-info", str(broken))
    assert str(broken) in line and "units missing" in line
    cut = tmp_path / "cut.step"
    cut.write_text(text.replace("ADVANCED_FACE", "ADVANCED_FACX"))  # units kept, every face unknown
    line = refused(capsys, "part-info", str(cut))
    assert str(cut) in line and ("STEP" in line or "OpenCASCADE" in line or "solid" in line)
