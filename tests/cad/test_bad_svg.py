"""SVG parts: the unit rule, curves within the chord tolerance, and bad SVG as one line naming the element."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from feeder_cell.cli.main import main
from feeder_planner.cad import CadOptions
from feeder_planner.parts import cad_part

HEAD = '<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="10mm" viewBox="0 0 10 10">'


def svg(tmp_path: Path, body: str, width: str = "10mm", name: str = "part.svg") -> Path:
    path = tmp_path / name
    path.write_text(HEAD.format(w=width) + body + "</svg>\n")
    return path


def refused(capsys: pytest.CaptureFixture[str], path: Path, *flags: str) -> str:
    code = main(["part-info", str(path), *flags])
    out = capsys.readouterr()
    assert code == 2, out
    assert out.err.count("\n") == 1 and "Traceback" not in out.err and str(path) in out.err, out.err
    return out.err


def test_units_from_width_and_viewbox_and_y_up(tmp_path: Path) -> None:
    """10mm over a viewBox 10 wide: one user unit is 1 mm; SVG's y down becomes the file frame's y up."""
    part = cad_part(svg(tmp_path, '<rect x="1" y="1" width="4" height="2"/>'))
    assert part.area == pytest.approx(8e-6, rel=1e-12)
    assert part.offset.tolist() == pytest.approx([3e-3, -2e-3], abs=1e-15)


def test_a_circle_hole_is_flattened_within_the_chord_tolerance(tmp_path: Path) -> None:
    path = svg(tmp_path, '<path d="M0 0 H10 V10 H0 Z"/><circle cx="5" cy="5" r="2"/>')
    part = cad_part(path)
    diagonal = 10 * 2**0.5
    radii = (part.holes[0] + part.offset - [5e-3, -5e-3]) * 1e3
    assert abs(((radii**2).sum(axis=1) ** 0.5).max() - 2.0) < 1e-12  # vertices on the circle
    # The chords' midpoints are inside by at most the tolerance.
    mids = (radii + __import__("numpy").roll(radii, -1, axis=0)) / 2
    sagitta = 2.0 - ((mids**2).sum(axis=1) ** 0.5)
    assert 0 < sagitta.max() <= 1e-4 * diagonal
    finer = cad_part(path, CadOptions(chord_tolerance=1e-6))
    assert len(finer.holes[0]) > 5 * len(part.holes[0])


def test_cubic_curves_become_chords_within_the_tolerance(tmp_path: Path) -> None:
    path = svg(tmp_path, '<path d="M0 0 H10 V5 C7 10 3 10 0 5 Z"/>')
    coarse, fine = cad_part(path), cad_part(path, CadOptions(chord_tolerance=1e-7))
    assert len(fine.outer) > 10 * len(coarse.outer)
    assert abs(coarse.area - fine.area) / fine.area < 3e-4  # chords within 1e-4 of the diagonal


def test_units_missing_without_an_absolute_width(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    path = svg(tmp_path, '<rect x="1" y="1" width="4" height="2"/>', width="100")
    line = refused(capsys, path)
    assert "units missing" in line and "mm" in line and "unit:" in line
    assert main(["part-info", str(path), "--unit", "cm", "--json"]) == 0  # one user unit is 1 cm
    assert json.loads(capsys.readouterr().out)["area"] == pytest.approx(8e-4, rel=1e-12)


def test_open_path(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    line = refused(capsys, svg(tmp_path, '<path id="edge" d="M0 0 H10 V10 H0"/>'))
    assert "open contour" in line and "<path> id='edge'" in line


def test_self_intersection(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    line = refused(capsys, svg(tmp_path, '<polygon id="bow" points="0,0 10,10 10,0 0,10"/>'))
    assert "self-intersecting" in line and "<polygon> id='bow'" in line


def test_disjoint_outlines_and_the_element_choice(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    path = svg(
        tmp_path,
        '<rect id="a" x="0" y="0" width="2" height="2"/><rect id="b" x="5" y="5" width="2" height="3"/>',
    )
    line = refused(capsys, path)
    assert "2 disjoint outlines" in line and "element:" in line
    assert main(["part-info", str(path), "--element", "b", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["area"] == pytest.approx(6e-6, rel=1e-12)
    assert "no element with id 'c'; ids here: a, b" in refused(capsys, path, "--element", "c")


def test_zero_area(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    line = refused(capsys, svg(tmp_path, '<polygon id="flat" points="0,0 5,0 10,0"/>'))
    assert "<polygon> id='flat'" in line and ("zero area" in line or "fold back" in line)


def test_empty_and_shapeless_and_broken(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    empty = tmp_path / "empty.svg"
    empty.write_text("")
    assert "is empty" in refused(capsys, empty)
    assert "no shape" in refused(capsys, svg(tmp_path, "<text>bracket</text>", name="text.svg"))
    broken = tmp_path / "broken.svg"
    broken.write_text("<svg><path d='M0 0 L1")
    assert "not a readable SVG file" in refused(capsys, broken)
