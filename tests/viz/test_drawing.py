"""ROS-free (no process, no DDS): the shapes the devices and planners draw, against their models.

A part's outline at a known pose is exactly the model's ``Part.placed`` and its triangles cover exactly its
area (holes left out); the fixture's drawn tilt takes the model's gravity to -z; the stable region's
boundary lies in the region the planner certifies; the marker messages carry the shapes' points and the
ids, colours and deletions of one definition.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from visualization_msgs.msg import Marker

from feeder_planner.assembly import load_assembly, prepare
from feeder_planner.assembly.drawing import boundary_points, path_shape, region_shapes
from feeder_planner.drawing import Shape, part_shapes, triangulate_loops
from feeder_planner.node_kit.msg_markers import STYLES, MarkerBook, marker_array
from feeder_planner.node_kit.tf import (
    check_cell_pose,
    quaternion_from_matrix,
    quaternion_from_rpy,
)
from feeder_planner.node_kit.viz import MARKER_RATE
from feeder_planner.parts import load_part
from feeder_planner.polygon import point_in_polygon
from feeder_planner.throwing import ThrowParams, arm_part
from feeder_planner.throwing.drawing import limit_set_shapes
from feeder_planner.throwing.limit_set import limit_set
from feeder_sim.fixture import gravity_of
from feeder_sim.fixture.drawing import body_shapes, gravity_shape, table_rotation, table_shapes
from feeder_sim.mems.coverage import Grid
from feeder_sim.mems.drawing import array_shapes, force_shapes, parts_shapes
from feeder_sim.throwing import ThrowingArm
from feeder_sim.throwing.drawing import arm_shapes, display_length, sensor_shapes

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
WASHER = EXAMPLES / "mems" / "washer.yaml"  # a part with a hole
POSE = (1.5e-3, -0.7e-3, 0.6)


def triangle_areas(points: np.ndarray) -> np.ndarray:
    t = points.reshape(-1, 3, 3)
    return 0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1)


def rotate(q: tuple[float, float, float, float], v: np.ndarray) -> np.ndarray:
    x, y, z, w = q
    u = np.array([x, y, z])
    return v + 2 * np.cross(u, np.cross(u, v) + w * v)


# --- parts -----------------------------------------------------------------------------------------
def test_part_outline_at_a_pose_is_the_models_placement() -> None:
    part = load_part(WASHER)
    assert len(part.holes) == 1
    shapes = part_shapes(part, POSE, "parts", "part")
    outlines = [s for s in shapes if s.kind == "line_strip"]
    placed = part.placed(*POSE)
    assert len(outlines) == len(placed) == 2  # the outer loop and the hole
    for outline, loop in zip(outlines, placed, strict=True):
        assert np.array_equal(outline.points[:-1, :2], loop)  # exactly the model's vertices
        assert np.array_equal(outline.points[-1], outline.points[0])  # closed
        assert np.all(outline.points[:, 2] == 0.0)


def test_part_fill_covers_its_area_and_not_its_hole() -> None:
    part = load_part(WASHER)
    fill = next(s for s in part_shapes(part, POSE, "parts", "part") if s.kind == "triangles")
    areas = triangle_areas(fill.points)
    assert areas.sum() == pytest.approx(part.area, rel=1e-12)
    centroid = (fill.points.reshape(-1, 3, 3).mean(axis=1) * areas[:, None]).sum(axis=0) / areas.sum()
    assert centroid[:2] == pytest.approx(POSE[:2], abs=1e-12)  # the pose's position is the centroid
    # Every triangle lies in the part and none in its hole (their centroids, by the model's own test).
    outer, hole = part.placed(*POSE)
    for c in fill.points.reshape(-1, 3, 3).mean(axis=1)[:, :2]:
        assert point_in_polygon(c, outer) and not point_in_polygon(c, hole)


def test_mems_parts_shapes_use_given_triangles() -> None:
    part = load_part(EXAMPLES / "mems" / "bracket.yaml")
    triangles = triangulate_loops(part.loops())
    shapes = parts_shapes([part, part], [POSE, (0.0, 0.0, 0.0)], [triangles, triangles])
    fills = [s for s in shapes if s.kind == "triangles"]
    assert len(fills) == 2
    assert triangle_areas(fills[1].points).sum() == pytest.approx(part.area, rel=1e-12)


# --- the MEMS array ----------------------------------------------------------------------------------
def test_array_outline_is_the_grid_extent() -> None:
    grid = Grid(40, 30, 1e-4)
    surface, outline = array_shapes(grid)
    assert outline.points[:, :2].min(axis=0) == pytest.approx([-2e-3, -1.5e-3])
    assert outline.points[:, :2].max(axis=0) == pytest.approx([2e-3, 1.5e-3])
    assert triangle_areas(surface.points).sum() == pytest.approx(4e-3 * 3e-3)


def test_force_arrows_point_along_the_cell_forces() -> None:
    grid = Grid(6, 4, 1e-4)
    forces = np.zeros((6, 4, 2))
    forces[..., 0], forces[..., 1] = 1.0, -2.0
    forces[0, 0] = (3.0, 0.0)
    (arrows,) = force_shapes(grid, forces, 2)
    segments = arrows.points.reshape(-1, 2, 3)
    shafts = segments[: 3 * 2]  # every 2nd cell each way: 3 x 2 arrows, shafts first
    assert np.allclose(shafts[:, 0, :2], grid.centers()[::2, ::2].reshape(-1, 2))
    directions = shafts[:, 1, :2] - shafts[:, 0, :2]
    expected = forces[::2, ::2].reshape(-1, 2)
    cross = directions[:, 0] * expected[:, 1] - directions[:, 1] * expected[:, 0]
    assert np.allclose(cross, 0.0, atol=1e-18) and np.all(np.sum(directions * expected, axis=1) > 0)
    assert force_shapes(grid, forces, 0) == [] and force_shapes(grid, np.zeros((6, 4, 2)), 1) == []


# --- the throwing arm --------------------------------------------------------------------------------
def test_arm_sensor_and_part_on_the_arm() -> None:
    part = arm_part(load_part(EXAMPLES / "throwing" / "triangle.yaml"))
    arm = ThrowingArm(part, ThrowParams(-0.005, math.radians(320), -9.66, 0.5), 1, 0.12)
    pose = arm.rest_pose()
    fill, outer = part_shapes(part.part, pose, "part", "part")
    assert np.array_equal(outer.points[:-1, :2], part.part.placed(*pose)[0])
    # At rest the part lies on the arm surface y = h: its lowest point is there.
    assert outer.points[:, 1].min() == pytest.approx(-0.005, abs=1e-12)
    length = display_length(math.inf, 0.12, part.radius, 0.35)
    assert length > 0.35
    bar, pivot = arm_shapes(length, -0.005, 0.0, 0.001)
    assert bar.points[:, :2].tolist() == [[0.0, -0.005], [length, -0.005]]
    turned, _ = arm_shapes(length, 0.0, math.pi / 2, 0.001)
    assert turned.points[1, :2] == pytest.approx([0.0, length])  # rotates with the joint
    on = sensor_shapes(0.12, -0.005, 0.001, True, 0.001)
    off = sensor_shapes(0.12, -0.005, 0.001, False, 0.001)
    assert on[0].style == "sensor_on" and off[0].style == "sensor_off"
    assert on[0].points[:, :2].tolist() == [[0.12, -0.005], [0.12, -0.004]]


# --- the fixture ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("joints", [(0.0, 0.0), (0.4, -0.3), (-1.2, 2.5), (math.pi / 2, 0.7)])
def test_table_rotation_takes_the_models_gravity_down(joints: tuple[float, float]) -> None:
    rotation = table_rotation(np.array(joints))
    assert rotation @ gravity_of(np.array(joints)) == pytest.approx([0.0, 0.0, -1.0], abs=1e-12)
    q = quaternion_from_matrix(rotation)
    assert rotate(q, gravity_of(np.array(joints))) == pytest.approx([0.0, 0.0, -1.0], abs=1e-12)


def test_bodies_are_meshes_of_their_pieces_and_unbalanced_ones_are_marked() -> None:
    assembly = load_assembly(EXAMPLES / "assembly" / "block_in_l_bracket.yaml")
    free = [b.name for b in assembly.bodies if not b.grounded]
    shapes = body_shapes(assembly, unbalanced=free[:1])
    by_name = {s.namespace.removeprefix("body/"): s for s in shapes}
    assert set(by_name) == {b.name for b in assembly.bodies}
    for body in assembly.bodies:
        mesh = by_name[body.name]
        # A closed convex mesh: its surface area is the pieces' faces' areas.
        face_area = sum(
            0.5
            * np.linalg.norm(
                np.cross(f.polygon - f.polygon[0], np.roll(f.polygon, -1, axis=0) - f.polygon[0]).sum(0)
            )
            for piece in body.pieces
            for f in piece.faces
        )
        assert triangle_areas(mesh.points).sum() == pytest.approx(face_area, rel=1e-9)
        expected = "grounded" if body.grounded else ("unbalanced" if body.name == free[0] else "body")
        assert mesh.style == expected
    (plate,) = table_shapes(assembly)
    lowest = min(p.lower[2] for b in assembly.bodies for p in b.pieces)
    assert np.all(plate.points[:, 2] == lowest)
    arrow = gravity_shape(assembly, np.array([0.0, 0.0, -2.0]))
    direction = arrow.points[1] - arrow.points[0]
    assert direction / np.linalg.norm(direction) == pytest.approx([0.0, 0.0, -1.0])


# --- the stable region -----------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["cube_in_corner", "block_in_l_bracket"])  # a 2-D region, an arc
def test_region_boundary_lies_on_the_region_and_the_path_on_the_sphere(name: str) -> None:
    region = prepare(load_assembly(EXAMPLES / "assembly" / f"{name}.yaml")).region
    assert region.kind in ("region", "arc")
    arcs = [a for a in boundary_points(region) if len(a)]
    assert arcs, "a region or an arc has a boundary to draw"
    for arc in arcs:
        for g in arc.reshape(-1, 3):
            assert region.contains(g, tolerance=1e-6)
            if region.kind == "region":
                assert abs(region.margin(g)) < 1e-6  # on the boundary, not inside
    radius = 0.1
    shapes = region_shapes(region, radius)
    kinds = {s.namespace: s for s in shapes}
    assert kinds["sphere"].size == pytest.approx(2 * radius)
    if region.center is not None:
        assert kinds["center"].points[0] == pytest.approx(np.asarray(region.center) * radius)
    path = path_shape(np.array([[0.0, 0.0, -2.0], [0.0, 0.1, -1.0]]), radius)
    assert np.linalg.norm(path.points, axis=1) == pytest.approx([radius, radius])


# --- messages ----------------------------------------------------------------------------------------
def test_marker_messages_carry_the_shapes() -> None:
    part = load_part(WASHER)
    shapes = part_shapes(part, POSE, "parts", "part")
    array = marker_array(shapes, "cell/array/mems_array", Marker().header.stamp)
    fill, outer, hole = array.markers
    assert (fill.type, outer.type) == (Marker.TRIANGLE_LIST, Marker.LINE_STRIP)
    assert (outer.ns, outer.id, hole.ns, hole.id) == ("parts_outline", 0, "parts_outline", 1)
    assert all(m.header.frame_id == "cell/array/mems_array" for m in array.markers)
    placed = part.placed(*POSE)[0]
    assert [(p.x, p.y) for p in outer.points[:-1]] == [tuple(v) for v in placed]
    assert (fill.color.r, fill.color.g, fill.color.b, fill.color.a) == pytest.approx(STYLES["part"])


def test_marker_book_deletes_what_an_update_no_longer_has() -> None:
    book = MarkerBook()
    two = [Shape("sphere", np.zeros((1, 3)), "parts", "part", 1.0)] * 2
    stamp = Marker().header.stamp
    first = book.update(two, "f", stamp)
    assert [m.action for m in first.markers] == [Marker.ADD, Marker.ADD]
    second = book.update(two[:1], "f", stamp)
    assert [(m.action, m.id) for m in second.markers] == [(Marker.ADD, 0), (Marker.DELETE, 1)]
    cleared = book.clear(stamp)
    assert [(m.action, m.ns, m.id) for m in cleared.markers] == [(Marker.DELETE, "parts", 0)]


# --- frames and parameters -------------------------------------------------------------------------
def test_rpy_quaternion_rolls_the_arm_plane_upright() -> None:
    q = quaternion_from_rpy(math.pi / 2, 0.0, 0.0)
    assert rotate(q, np.array([0.0, 1.0, 0.0])) == pytest.approx([0.0, 0.0, 1.0], abs=1e-15)
    assert rotate(quaternion_from_rpy(0.0, 0.0, math.pi / 2), np.array([1.0, 0.0, 0.0])) == pytest.approx(
        [0.0, 1.0, 0.0], abs=1e-15
    )


@pytest.mark.parametrize(
    "value", [[0.0] * 5, [0.0] * 7, [0.0, 0.0, math.nan, 0.0, 0.0, 0.0], [True] * 6, "0 0 0 0 0 0"]
)
def test_cell_pose_refuses_bad_values(value: object) -> None:
    problem = check_cell_pose(value)
    assert problem is not None and "six finite numbers" in problem


@pytest.mark.parametrize("value", [-1.0, 31.0, math.inf, math.nan, True, "5"])
def test_marker_rate_refuses_bad_values(value: object) -> None:
    assert MARKER_RATE.check is not None
    problem = MARKER_RATE.check(value)
    assert problem is not None and "[0, 30]" in problem


def test_marker_rate_accepts_off_and_its_range() -> None:
    assert MARKER_RATE.check is not None
    assert all(MARKER_RATE.check(v) is None for v in (0.0, 0.5, 30.0, 5))


# --- the throw planner's limit set --------------------------------------------------------------------
def test_limit_set_segments_are_its_edges_ranges_and_its_trigger_range() -> None:
    part = arm_part(load_part(EXAMPLES / "throwing" / "triangle.yaml"))
    ls = limit_set(part, ThrowParams(-0.005, math.radians(320), -9.66, 0.5), 1, 5, 200)
    assert ls.trigger is not None and ls.edge_radius_ranges
    shapes = limit_set_shapes(ls, -0.005)
    ranges = [s for s in shapes if s.namespace == "limit_set"]
    assert len(ranges) == len(ls.edge_radius_ranges)
    expected = [ls.edge_radius_ranges[e] for e in sorted(ls.edge_radius_ranges)]
    for segment, (low, high) in zip(ranges, expected, strict=True):
        assert segment.points[:, 0].tolist() == [low, high] and np.all(segment.points[:, 1] == -0.005)
    labels = [s.text for s in shapes if s.kind == "text"]
    assert labels == [f"edge {e}" for e in sorted(ls.edge_radius_ranges)]
    (trigger,) = [s for s in shapes if s.namespace == "trigger_range"]
    assert trigger.points[:, 0].tolist() == list(ls.trigger) and trigger.style == "sensor_on"
