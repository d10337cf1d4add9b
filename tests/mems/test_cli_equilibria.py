"""`feeder equilibria` per contract section 3: JSON shape, SI units, and one-line errors with exit 2."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from feeder_cell.cli.main import main

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "mems"


def run(capsys, *argv: str) -> tuple[int, str, str]:
    try:
        code = main(list(argv))
    except SystemExit as exit_:
        code = int(exit_.code)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_json_shape_and_units(capsys) -> None:
    code, out, _ = run(capsys, "equilibria", str(EXAMPLES / "plus.yaml"), "--delta", "1e-3", "--json")
    assert code == 0
    result = json.loads(out)
    assert set(result) >= {"pivot", "area", "equilibria", "method"}
    assert abs(result["area"] - 20e-6) <= 1e-18  # 20 mm^2 in m^2
    stable = sorted(e["theta"] for e in result["equilibria"] if e["stable"])
    assert len(stable) == 4 and all(0 <= t < 2 * math.pi for t in stable)
    assert len(result["equilibria"]) == 8
    assert all(set(e) >= {"x", "y", "theta", "stable"} for e in result["equilibria"])


def test_methods_and_summary(capsys) -> None:
    code, out, _ = run(
        capsys, "equilibria", str(EXAMPLES / "bracket.yaml"), "--delta", "0.5", "--method", "numeric"
    )
    assert code == 0 and "stable" in out and "pivot" in out


@pytest.mark.parametrize(
    "content,field",
    [
        ("vertices: [[0, 0], [1, 1], [1, 0], [0, 1]]\n", "vertices"),  # self-intersecting
        ("vertices: [[0, 0], [1, 0]]\n", "vertices"),  # fewer than 3
        ("vertices: [[0, 0], [1, 0], [2, 0]]\n", "vertices"),  # degenerate
        ("vertices: [[0, 0], [1, .nan], [0, 1]]\n", "vertices"),  # NaN
    ],
)
def test_bad_parts_exit_2_naming_the_field(capsys, tmp_path: Path, content: str, field: str) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(content)
    code, out, err = run(capsys, "equilibria", str(path), "--delta", "0.1")
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and field in err and str(path) in err


@pytest.mark.parametrize("delta", ["1", "-0.5", "nan", "inf"])
def test_bad_delta_exit_2(capsys, delta: str) -> None:
    code, _, err = run(capsys, "equilibria", str(EXAMPLES / "bracket.yaml"), "--delta", delta)
    assert code == 2 and "delta" in err and "Traceback" not in err


def test_unknown_method_exit_2(capsys) -> None:
    code, _, err = run(
        capsys, "equilibria", str(EXAMPLES / "bracket.yaml"), "--delta", "0.1", "--method", "magic"
    )
    assert code == 2 and "method" in err
