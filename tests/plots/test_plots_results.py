"""Plots of the planners' results (no ROS): each figure is written, has its size and draws the result."""

from __future__ import annotations

import math
import struct
from pathlib import Path

import numpy as np
import pytest
from matplotlib.figure import Figure
from matplotlib.image import imread

from feeder_cell.plots.common import DPI, write_figure
from feeder_cell.plots.equilibria import MAX_POSES, STABLE_LABEL, UNSTABLE_LABEL, equilibria_figure
from feeder_cell.plots.limit_set import START_GID, TRIGGER_GID, limit_set_figure
from feeder_cell.plots.stability import FORCE_GID, drawn_forces, stability_figure
from feeder_cell.plots.stable_region import BOUNDARY_GID, CENTER_GID, PATH_GID, VERTEX_GID, region_figure
from feeder_cell.plots.throw_design import BEST_GID, UNIQUE_GID, design_figure
from feeder_planner.assembly import check_result, load_assembly, path_result, prepare, region_result
from feeder_planner.mems import find_equilibria
from feeder_planner.parts import load_part
from feeder_planner.throwing import DesignRow, DesignSearch, ThrowParams, arm_part, limit_set

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"


def png_size(path: Path) -> tuple[int, int]:
    """Return (width, height) in pixels from a PNG's IHDR chunk."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", f"{path} is not a PNG"
    return struct.unpack(">II", data[16:24])


def assert_picture(figure: Figure, path: Path) -> None:
    """Write the figure and check the file: the figure's pixel size, and more than a blank canvas."""
    write_figure(figure, path)
    width, height = figure.get_size_inches() * DPI
    assert png_size(path) == (round(width), round(height))
    pixels = imread(path)[..., :3].reshape(-1, 3)
    colours = np.unique((pixels * 255).astype(np.uint8), axis=0)
    assert len(colours) > 20, f"{path} has only {len(colours)} colours: nothing drawn"
    assert (pixels < 0.95).any(axis=1).mean() > 0.02, f"{path} is almost all white"


def points_3d(collection: object) -> np.ndarray:
    """Return the (N, 3) data coordinates of a 3-D scatter (mplot3d keeps them as masked arrays)."""
    return np.column_stack([np.ma.getdata(c) for c in collection._offsets3d])  # type: ignore[attr-defined]


def by_gid(figure: Figure, gid: str) -> list:
    """Return every artist of the figure with the given gid."""
    return list(figure.findobj(lambda artist: artist.get_gid() == gid))


@pytest.mark.parametrize(("name", "delta"), [("plus", 0.01), ("bracket", 0.1)])
def test_equilibria_plot_marks_every_equilibrium_and_draws_stable_poses(
    tmp_path: Path, name: str, delta: float
) -> None:
    part = load_part(EXAMPLES / "mems" / f"{name}.yaml")
    result = find_equilibria(part, delta, "auto")
    figure = equilibria_figure(part, result)
    (stable,) = by_gid(figure, STABLE_LABEL)
    (unstable,) = by_gid(figure, UNSTABLE_LABEL)
    assert len(stable.get_xdata()) == len(result.stable)
    assert len(unstable.get_xdata()) == len(result.equilibria) - len(result.stable)
    assert sorted(stable.get_xdata()) == pytest.approx(
        sorted(math.degrees(e.theta % (2 * math.pi)) for e in result.stable)
    )
    pose_axes = figure.axes[1:]
    assert len(pose_axes) == min(len(result.stable), MAX_POSES)
    for ax, e in zip(pose_axes, result.stable, strict=False):
        (patch,) = ax.patches
        drawn = patch.get_path().vertices
        outer = part.placed(e.x, e.y, e.theta)[0]
        assert drawn[: len(outer)] == pytest.approx(outer)  # the part's outline at the stable pose
    assert_picture(figure, tmp_path / f"{name}.png")


@pytest.fixture(scope="module")
def triangle_limit_set() -> tuple:
    part = load_part(EXAMPLES / "throwing" / "triangle.yaml")
    s = part.unit_scale
    params = ThrowParams(-0.5 * s, math.radians(320), -966 * s, 0.5)
    return part, limit_set(arm_part(part), params, 1, 4, keep_trajectories=True)


def test_limit_set_plot_draws_one_line_per_start_and_the_trigger_range(
    tmp_path: Path, triangle_limit_set: tuple
) -> None:
    part, result = triangle_limit_set
    figure = limit_set_figure(result, part.unit_scale, part.name)
    lines = by_gid(figure, START_GID)
    assert len(lines) == result.starts == 4 * len(result.stable_edges)
    radius = result.trajectories.radius / part.unit_scale
    for line, row in zip(lines, radius, strict=True):
        y = np.asarray(line.get_ydata())
        assert y[np.isfinite(y)] == pytest.approx(row[: len(y)][np.isfinite(row[: len(y)])])
    assert result.trigger is not None
    spans = by_gid(figure, TRIGGER_GID)
    assert len(spans) == 2  # both axes shade it
    lo, hi = (v / part.unit_scale for v in result.trigger)
    for span in spans:
        assert (span.get_y(), span.get_y() + span.get_height()) == pytest.approx((lo, hi))
    labels = figure.axes[0].get_legend_handles_labels()[1]
    assert {f"edge {e} (in the cycle)" for e in result.cycle.edges} <= set(labels)
    assert_picture(figure, tmp_path / "limit_set.png")


def test_limit_set_plot_refuses_a_result_without_trajectories(triangle_limit_set: tuple) -> None:
    from dataclasses import replace

    from feeder_planner.errors import InputError

    _, result = triangle_limit_set
    with pytest.raises(InputError, match="trajectories"):
        limit_set_figure(replace(result, trajectories=None))


def test_design_plot_marks_unique_designs_and_the_best(tmp_path: Path) -> None:
    rows = [
        DesignRow(-0.005, 5.0, True, [1, 0, 2], (0.20, 0.23), ""),
        DesignRow(0.0, 5.0, True, [1, 0, 2], (0.19, 0.22), ""),
        DesignRow(-0.005, 5.5, False, None, None, "starts reach different cycles"),
        DesignRow(0.0, 5.5, True, [1, 2], None, "the goal edge is not singled out"),
        DesignRow(0.005, 5.5, False, None, None, "no invariant set"),
    ]
    result = DesignSearch(goal_edge=1, best=rows[0], designs=rows)
    figure = design_figure(result, 0.01, "triangle")
    (unique,) = by_gid(figure, UNIQUE_GID)
    assert len(unique.get_xdata()) == 3
    (best,) = by_gid(figure, BEST_GID)
    assert (best.get_xdata()[0], best.get_ydata()[0]) == (0.5, 0.5)  # h = -0.5 cm, W = 5 rad/s: first cell
    (mesh,) = figure.axes[0].collections
    widths = np.ma.getdata(mesh.get_array()).reshape(2, 3)
    mask = np.ma.getmaskarray(mesh.get_array()).reshape(2, 3)
    assert widths[0, :2] == pytest.approx([3.0, 3.0])  # widths in cm
    assert mask.tolist() == [[False, False, True], [True, True, True]]
    assert_picture(figure, tmp_path / "design.png")


@pytest.mark.parametrize(
    ("name", "mu", "kind", "vertices"),
    [
        ("cube_in_corner", 0.0, "region", 3),
        ("block_in_l_bracket", 0.2, "region", 4),
        ("block_in_l_bracket", 0.0, "arc", 2),
        ("block_between_parallel_faces", 0.3, "sphere", 0),
    ],
)
def test_region_plot_draws_the_vertices_and_centre(
    tmp_path: Path, name: str, mu: float, kind: str, vertices: int
) -> None:
    result = region_result(prepare(load_assembly(EXAMPLES / "assembly" / f"{name}.yaml"), mu))
    assert result.region.kind == kind
    figure = region_figure(result)
    (points,) = by_gid(figure, VERTEX_GID)
    drawn = points_3d(points)
    assert len(drawn) == vertices
    assert drawn == pytest.approx(result.region.vertices.reshape(-1, 3))
    (centre,) = by_gid(figure, CENTER_GID)
    assert points_3d(centre)[0] == pytest.approx(result.region.center)
    arcs = by_gid(figure, BOUNDARY_GID)
    assert len(arcs) == {"region": vertices, "arc": 1, "sphere": 0}[kind]
    for arc in arcs:  # boundary arcs lie on the unit sphere
        assert np.linalg.norm(np.column_stack(arc.get_data_3d()), axis=1) == pytest.approx(1.0)
    if kind == "region" and mu > 0:  # one picture written suffices: the drawing code is the same
        assert_picture(figure, tmp_path / f"{name}.png")


def test_region_plot_draws_the_safe_path() -> None:
    prepared = prepare(load_assembly(EXAMPLES / "assembly" / "block_in_l_bracket.yaml"), 0.2)
    region = prepared.region
    c = region.center
    path = path_result(prepared, c + 0.5 * (region.vertices[0] - c), c + 0.5 * (region.vertices[2] - c))
    figure = region_figure(region_result(prepared), path)
    (line,) = by_gid(figure, PATH_GID)
    assert np.column_stack(line.get_data_3d()) == pytest.approx(path.path)


def test_stability_plot_draws_one_arrow_per_contact_force(tmp_path: Path) -> None:
    assembly = load_assembly(EXAMPLES / "assembly" / "block_in_l_bracket.yaml")
    prepared = prepare(assembly, 0.2)
    result = check_result(prepared, np.array([-1.0, 0.0, -1.0]))
    assert result.stable
    figure = stability_figure(assembly, result)
    loads = drawn_forces(result)
    assert 0 < len(loads) <= len(result.forces)
    assert len(loads) == sum(np.linalg.norm(f.force) > 1e-12 for f in result.forces)
    (quiver,) = by_gid(figure, FORCE_GID)
    assert_picture(figure, tmp_path / "forces.png")
    assert len(quiver.get_segments()) == 3 * len(loads)  # drawn: a shaft and two head strokes per arrow
    shafts = quiver._segments3d[: len(loads)]  # type: ignore[attr-defined]  -- (tip, tail) per arrow
    points = np.array([f.point for f in loads]) / assembly.unit_scale
    assert np.array([shaft[1] for shaft in shafts]) == pytest.approx(points)
    tips = np.array([shaft[0] - shaft[1] for shaft in shafts])
    forces = np.array([f.force for f in loads])
    ratio = np.linalg.norm(tips, axis=1) / np.linalg.norm(forces, axis=1)
    assert ratio == pytest.approx(ratio[0])  # one scale for every arrow
    assert tips / ratio[:, None] == pytest.approx(forces)  # each along its force
    unstable = check_result(prepared, np.array([1.0, 0.0, 0.0]))
    assert not unstable.stable
    figure = stability_figure(assembly, unstable)
    assert by_gid(figure, FORCE_GID) == []
    assert "NOT stable" in figure.axes[0].get_title()
