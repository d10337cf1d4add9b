"""`feeder squeeze-plan`: the plan as JSON, the picture, and bad input as one line (exit 2)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from feeder_cell.cli.main import main

ROOT = Path(__file__).resolve().parents[2]


def test_rectangle_plan_as_json_and_its_picture(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    plot = tmp_path / "rectangle.png"
    code = main(
        ["squeeze-plan", str(ROOT / "examples/squeeze/rectangle.yaml"), "--json", "--plot", str(plot)]
    )
    out = capsys.readouterr()
    assert code == 0, out.err
    result = json.loads(out.out)
    assert result["squeezes"] == 2 and len(result["angles"]) == 2
    assert result["symmetry_period"] == pytest.approx(math.pi)
    assert sorted(s["width"] for s in result["stable_orientations"]) == pytest.approx([0.01, 0.02])
    assert len(result["sensor_groups"]) == 2 and result["margin"] > 0.3
    assert result["friction_tolerance"] == pytest.approx(1.0 / 3.0)
    assert plot.stat().st_size > 10_000 and plot.read_bytes()[:4] == b"\x89PNG"


def test_square_summary_says_one_squeeze_up_to_a_quarter_turn(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["squeeze-plan", str(ROOT / "examples/mems/square.yaml"), "--first-angle", "30deg"]) == 0
    text = capsys.readouterr().out
    assert "plan: 1 squeezes at 0.523599 rad" in text and "(90.000 deg)" in text
    assert "friction tolerance: any (one squeeze)" in text


@pytest.mark.parametrize(
    ("flags", "names"),
    [
        (["--first-angle", "nan"], "--first-angle"),
        (["--resolution", "0"], "--resolution"),
        (["--resolution", "inf"], "--resolution"),
    ],
)
def test_bad_flags_are_one_line_naming_the_flag(
    flags: list[str], names: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as ended:
        main(["squeeze-plan", str(ROOT / "examples/squeeze/rectangle.yaml"), *flags])
    err = capsys.readouterr().err
    assert ended.value.code == 2 and err.count("\n") == 1 and names in err, err


def test_degenerate_part_is_refused_naming_its_vertices(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "sliver.yaml"
    path.write_text("name: sliver\nvertices: [[0, 0], [1, 0], [2, 0.00000000001]]\n")
    code = main(["squeeze-plan", str(path)])
    err = capsys.readouterr().err
    assert (
        code == 2
        and err.count("\n") == 1
        and f"{path}: vertices: the convex hull is degenerate" in err
        and "Traceback" not in err
    ), err
