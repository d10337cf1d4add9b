"""Bad DXF gets one clear line naming the entity and what to do (issue 39 item 5), exit 2, no traceback."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import ezdxf
import numpy as np
import pytest

from feeder_cell.cli.main import main

SQUARE = [(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)]


def drawing(tmp_path: Path, draw: Callable[[Any], None], units: int = 4, name: str = "part.dxf") -> Path:
    doc = ezdxf.new("R2010", units=units)
    draw(doc.modelspace())
    path = tmp_path / name
    doc.saveas(path)
    return path


def refused(capsys: pytest.CaptureFixture[str], path: Path, *flags: str) -> str:
    """Run part-info (with ``flags``) and, without flags, equilibria: exit 2, one stderr line naming the file.

    Return part-info's line.
    """
    lines = []
    runs = [["part-info", str(path), *flags]] + (
        [] if flags else [["equilibria", str(path), "--delta", "0.1"]]
    )
    for argv in runs:
        code = main(argv)
        out = capsys.readouterr()
        assert code == 2, out
        assert out.err.count("\n") == 1 and "Traceback" not in out.err, out.err
        assert str(path) in out.err
        lines.append(out.err)
    return lines[0]


def test_open_contour_names_the_dangling_entity(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    def draw(space: Any) -> None:
        for a, b in zip(SQUARE[:3], SQUARE[1:4], strict=True):  # the fourth side is missing
            space.add_line(a, b)

    line = refused(capsys, drawing(tmp_path, draw))
    assert "open contour" in line and "LINE #" in line and "on layer 0" in line and "close the gap" in line


def test_an_open_polyline_is_an_open_contour(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    path = drawing(tmp_path, lambda space: space.add_lwpolyline(SQUARE, close=False))
    line = refused(capsys, path)
    assert "open contour" in line and "LWPOLYLINE #" in line


def test_self_intersection_names_the_polyline(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    bowtie = [(0.0, 0.0), (10.0, 10.0), (10.0, 0.0), (0.0, 10.0)]
    line = refused(capsys, drawing(tmp_path, lambda space: space.add_lwpolyline(bowtie, close=True)))
    assert "self-intersecting" in line and "LWPOLYLINE #" in line and "redraw" in line


def test_branch_point_names_the_entities(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    def draw(space: Any) -> None:
        for a, b in zip(SQUARE, SQUARE[1:] + SQUARE[:1], strict=True):
            space.add_line(a, b)
        space.add_line((0.0, 0.0), (-5.0, -5.0))

    line = refused(capsys, drawing(tmp_path, draw))
    assert "branch" in line and "3 entities meet at (0, 0)" in line


def test_disjoint_outlines_without_a_choice_name_the_layers(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    def draw(space: Any) -> None:
        space.add_lwpolyline(SQUARE, close=True, dxfattribs={"layer": "A"})
        space.add_lwpolyline([(x + 20.0, y) for x, y in SQUARE], close=True, dxfattribs={"layer": "B"})

    path = drawing(tmp_path, draw)
    line = refused(capsys, path)
    assert "2 disjoint outlines" in line and "no choice made" in line and "layers: A, B" in line
    assert main(["part-info", str(path), "--layer", "B", "--json"]) == 0  # the choice the line asks for
    assert json.loads(capsys.readouterr().out)["centre_of_mass"] == pytest.approx([0.025, 0.005], abs=1e-15)


def test_an_island_in_a_hole_is_another_part(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    def draw(space: Any) -> None:
        space.add_lwpolyline(SQUARE, close=True)
        space.add_circle((5.0, 5.0), 4.0)
        space.add_circle((5.0, 5.0), 1.0)

    line = refused(capsys, drawing(tmp_path, draw))
    assert "CIRCLE #" in line and "inside a hole" in line


def test_zero_area_names_the_polyline(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    flat = [(0.0, 0.0), (5.0, 0.0), (10.0, 0.0)]
    line = refused(capsys, drawing(tmp_path, lambda space: space.add_lwpolyline(flat, close=True)))
    assert "LWPOLYLINE #" in line and ("zero area" in line or "fold back" in line)


@pytest.mark.parametrize(
    ("units", "words"), [(0, "units missing"), (3, "unknown or unsupported unit code 3")]
)
def test_missing_or_unknown_units(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, units: int, words: str
) -> None:
    path = drawing(tmp_path, lambda space: space.add_lwpolyline(SQUARE, close=True), units=units)
    line = refused(capsys, path)
    assert "$INSUNITS" in line and words in line and "unit:" in line
    assert main(["part-info", str(path), "--unit", "mm", "--json"]) == 0  # the override the line names
    assert json.loads(capsys.readouterr().out)["area"] == pytest.approx(1e-4, rel=1e-12)


def test_empty_file_and_a_drawing_without_outline(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    empty = tmp_path / "empty.dxf"
    empty.write_bytes(b"")
    assert "is empty" in refused(capsys, empty)
    text_only = drawing(tmp_path, lambda space: space.add_text("bracket"), name="text.dxf")
    line = refused(capsys, text_only)
    assert "no outline entity" in line and "1 TEXT" in line


def test_a_layer_or_block_that_does_not_exist(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    path = drawing(
        tmp_path, lambda space: space.add_lwpolyline(SQUARE, close=True, dxfattribs={"layer": "P"})
    )
    assert "no entity on layer 'Q'; the layers used: P" in refused(capsys, path, "--layer", "Q")
    assert "no block 'B'" in refused(capsys, path, "--block", "B")


def test_not_a_dxf_file(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    path = tmp_path / "notes.dxf"
    path.write_text("this is a text file, not a drawing\n")
    assert "not a readable DXF file" in refused(capsys, path)


def test_a_block_is_chosen_and_an_insert_is_placed(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    doc = ezdxf.new("R2010", units=4)
    block = doc.blocks.new("BRACKET")
    block.add_lwpolyline([(0, 0), (4, 0), (4, 1), (1, 1), (1, 3), (0, 3)], close=True)
    space = doc.modelspace()
    space.add_lwpolyline(SQUARE, close=True, dxfattribs={"layer": "FRAME"})
    space.add_blockref("BRACKET", (20.0, 5.0), dxfattribs={"layer": "PARTS"})
    path = tmp_path / "sheet.dxf"
    doc.saveas(path)
    assert main(["part-info", str(path), "--block", "BRACKET", "--json"]) == 0  # the block's own frame
    read = json.loads(capsys.readouterr().out)
    assert read["centre_of_mass"] == pytest.approx([1.5e-3, 1e-3], abs=1e-15)
    assert main(["part-info", str(path), "--layer", "PARTS", "--json"]) == 0  # the insert, placed
    read = json.loads(capsys.readouterr().out)
    assert read["centre_of_mass"] == pytest.approx([21.5e-3, 6e-3], abs=1e-15)
    assert read["entities"]["outer"][0].startswith("INSERT #")


def test_ellipse_hole_and_spline_outline_within_the_chord_tolerance(tmp_path: Path) -> None:
    from feeder_planner.cad import CadOptions
    from feeder_planner.parts import cad_part

    def draw(space: Any) -> None:
        space.add_spline_control_frame([(0, 0), (10, -2), (20, 0), (22, 10), (10, 14), (-2, 10), (0, 0)])
        space.add_ellipse((10.0, 5.0), major_axis=(3.0, 0.0), ratio=0.5)

    path = drawing(tmp_path, draw)
    coarse, fine = cad_part(path), cad_part(path, CadOptions(chord_tolerance=1e-6))
    assert len(coarse.holes) == 1 and len(fine.outer) > 5 * len(coarse.outer)
    hole_area = 3.0 * 1.5 * 3.141592653589793 * 1e-6  # pi a b, mm^2 in m^2
    assert abs(coarse.area - fine.area) < 3e-4 * fine.area
    # The ellipse's polygon lies inside it: the hole is smaller than pi a b by less than the tolerance allows.
    hole = abs(
        sum(
            x0 * y1 - x1 * y0
            for (x0, y0), (x1, y1) in zip(fine.holes[0], np.roll(fine.holes[0], -1, 0), strict=True)
        )
        / 2
    )
    assert 0 < hole_area - hole < 1e-4 * hole_area
