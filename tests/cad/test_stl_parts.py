"""STL solids as planar parts: the resting silhouette and a section of the bracket's prism give the
bracket's equilibria; no unit, or a solid that is not closed, is one line (issue 39 items 1, 4, 5)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from feeder_cell.cli.main import main

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def equilibria(capsys: pytest.CaptureFixture[str], path: Path) -> list[dict]:
    assert main(["equilibria", str(path), "--delta", "0.1", "--json"]) == 0
    return json.loads(capsys.readouterr().out)["equilibria"]


@pytest.mark.parametrize("extra", ["", ", section: 0.5"])
def test_the_bracket_prism_has_the_bracket_equilibria(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, extra: str
) -> None:
    wrapper = tmp_path / "bracket.yaml"
    wrapper.write_text(f"cad: {{file: {EXAMPLES / 'mems/bracket.stl'}, unit: mm{extra}}}\n")
    twin, expected = equilibria(capsys, wrapper), equilibria(capsys, EXAMPLES / "mems/bracket.yaml")
    assert [e["stable"] for e in twin] == [e["stable"] for e in expected]
    for a, b in zip(twin, expected, strict=True):
        assert a["theta"] == pytest.approx(b["theta"], abs=1e-9)
        assert (a["x"], a["y"]) == pytest.approx((b["x"], b["y"]), abs=1e-12)


def test_stl_without_a_unit_and_an_open_solid(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    assert main(["part-info", str(EXAMPLES / "mems/bracket.stl")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "units missing" in err and "unit:" in err
    text = (EXAMPLES / "mems/bracket.stl").read_text()
    start = text.index("facet normal")
    open_solid = tmp_path / "open.stl"
    open_solid.write_text(text[:start] + text[text.index("endfacet", start) + len("endfacet") + 1 :])
    assert main(["part-info", str(open_solid), "--unit", "mm"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "not watertight" in err and str(open_solid) in err
