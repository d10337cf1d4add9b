"""`feeder part-info`: what a part file was read as, for every example format, and its drawing."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from feeder_cell.cli.main import main

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.mark.parametrize("name", ["washer.yaml", "washer.dxf", "washer.svg", "washer.step"])
def test_every_format_reads_the_washer_with_its_hole(capsys: pytest.CaptureFixture[str], name: str) -> None:
    assert main(["part-info", str(EXAMPLES / "mems" / name), "--json"]) == 0
    read = json.loads(capsys.readouterr().out)
    assert read["area"] == pytest.approx(14e-6, rel=1e-12)  # 5 x 4 mm less its 2 x 2 notch and 1 x 2 hole
    assert read["centre_of_mass"] == pytest.approx([0.0022142857, 0.0017142857], abs=1e-10)
    assert len(read["holes"]) == 1 and len(read["holes"][0]) == 4
    assert read["hull"][0] == pytest.approx([0.0, 0.0], abs=1e-15)
    assert read["unit"] and read["mass"] == pytest.approx(read["area"], rel=1e-12)  # default density 1


def test_the_plot_and_the_summary(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    picture = tmp_path / "filleted.png"
    assert main(["part-info", str(EXAMPLES / "mems/bracket_filleted.dxf"), "--plot", str(picture)]) == 0
    out = capsys.readouterr().out
    assert picture.stat().st_size > 10_000 and f"plot: {picture}" in out
    assert "unit mm ($INSUNITS 4)" in out and "ARC #" in out and "hole 0 from: CIRCLE #" in out
