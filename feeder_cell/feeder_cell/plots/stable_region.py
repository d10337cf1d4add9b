"""The stable region of an assembly on the unit sphere of gravity directions (paper Figs. 11-16)."""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure
from mpl_toolkits.mplot3d.axes3d import Axes3D

from feeder_cell.plots.common import HIGHLIGHT_COLOUR, PART_COLOUR, SQUARE, STABLE_COLOUR, new_figure
from feeder_planner.assembly import PathResult, RegionResult, StableRegion
from feeder_planner.assembly.drawing import great_circle

__all__ = ["VERTEX_GID", "CENTER_GID", "PATH_GID", "BOUNDARY_GID", "region_figure", "great_arc_points"]

VERTEX_GID = "vertices"
CENTER_GID = "center"
PATH_GID = "safe path"
BOUNDARY_GID = "boundary"
FILL_POINTS = 6000  # directions sampled over the sphere to shade the region (about 1.6 deg apart)
ARC_POINTS = 60
CIRCLE_POINTS = 4 * ARC_POINTS  # a whole great circle (a hemisphere's or a great circle's region)
VIEW_OFFSET_DEG = (15.0, 25.0)  # (elevation, azimuth) of the camera from the centre


def great_arc_points(a: np.ndarray, b: np.ndarray, through: np.ndarray | None = None) -> np.ndarray:
    """Return ARC_POINTS unit vectors along the shorter great arc from a to b.

    Antipodal ends have no shorter arc: the arc then passes through ``through`` (projected to the plane
    orthogonal to a), e.g. the region's centre, so that it bounds the region's side.
    """
    a = a / np.linalg.norm(a)
    b = b / np.linalg.norm(b)
    cos = float(np.clip(a @ b, -1.0, 1.0))
    if cos < -0.999 and through is not None:
        mid = through - (through @ a) * a
        mid /= np.linalg.norm(mid)
        return np.vstack([great_arc_points(a, mid), great_arc_points(mid, b)])
    angle = math.acos(cos)
    if angle < 1e-9:
        return np.vstack([a, b])
    t = np.linspace(0.0, 1.0, ARC_POINTS)[:, None]
    return (np.sin((1 - t) * angle) * a + np.sin(t * angle) * b) / math.sin(angle)


def _fibonacci_sphere(count: int) -> np.ndarray:
    """Return ``count`` nearly evenly spread unit vectors."""
    i = np.arange(count) + 0.5
    z = 1 - 2 * i / count
    phi = math.pi * (3 - math.sqrt(5)) * i
    r = np.sqrt(1 - z * z)
    return np.column_stack([r * np.cos(phi), r * np.sin(phi), z])


def _sphere_frame(ax: Axes3D) -> None:
    """Draw a faint wireframe sphere, its equator and the assembly frame's axes."""
    u = np.linspace(0, 2 * math.pi, 25)
    v = np.linspace(0, math.pi, 13)
    ax.plot_wireframe(
        np.outer(np.cos(u), np.sin(v)),
        np.outer(np.sin(u), np.sin(v)),
        np.outer(np.ones_like(u), np.cos(v)),
        color="0.85",
        lw=0.4,
    )
    for axis, label in zip(np.eye(3), "xyz", strict=True):
        ax.plot(*np.column_stack([np.zeros(3), 1.25 * axis]), color="0.4", lw=0.8)
        ax.text(*(1.32 * axis), label, color="0.3")


def region_figure(result: RegionResult, path: PathResult | None = None) -> Figure:
    """Return the stable region on the unit sphere: shaded, its boundary arcs, vertices, centre and a path.

    Parameters
    ----------
    result
        What ``region_result`` returned.
    path
        Optional ``path_result`` of a safe path between two directions of the region, drawn on it.

    Returns
    -------
    Figure
        A 3-D view looking along the region's centre: the stable directions shaded, the boundary great arcs
        (gid BOUNDARY_GID) through the vertices (one point each, gid VERTEX_GID), the centre (gid
        CENTER_GID) and the path's samples (gid PATH_GID).
    """
    region = result.region
    figure = new_figure(SQUARE)
    ax = figure.add_subplot(projection="3d", proj_type="ortho")
    _sphere_frame(ax)
    _shade_region(ax, region)
    vertices = np.asarray(region.vertices, float).reshape(-1, 3)
    center = None if region.center is None else np.asarray(region.center, float)
    _draw_boundary(ax, region, vertices, center)
    ax.scatter(
        *vertices.T, s=30, color="k", depthshade=False, label=f"vertices ({len(vertices)})", gid=VERTEX_GID
    )
    if center is not None:
        _draw_centre(ax, center)
    if path is not None:
        _draw_path(ax, path)
    _finish_axes(ax, result)
    return figure


def _shade_region(ax: Axes3D, region: StableRegion) -> None:
    """Shade the stable directions of a region, hemisphere or sphere with sampled points of the sphere.

    A sampled direction g is shaded when normals @ g <= 0 for every normal of the region (all of them
    when it has none, the sphere); other kinds have no area to shade.
    """
    if region.kind in ("region", "hemisphere", "sphere"):
        points = _fibonacci_sphere(FILL_POINTS)
        inside = (
            np.all(points @ region.normals.T <= 0.0, axis=1)
            if len(region.normals)
            else np.ones(len(points), bool)
        )
        ax.scatter(*points[inside].T, s=2, color=STABLE_COLOUR, alpha=0.35, depthshade=False)


def _draw_boundary(ax: Axes3D, region: StableRegion, vertices: np.ndarray, center: np.ndarray | None) -> None:
    """Draw the region's boundary (gid BOUNDARY_GID) as its kind has one.

    A region: the great arcs between consecutive vertices, bulging towards the centre; an arc: its one
    arc; a hemisphere or a great circle: the whole great circle of its normal or equality.
    """
    if region.kind == "region":
        ring = np.vstack([vertices, vertices[:1]])
        for a, b in zip(ring[:-1], ring[1:], strict=True):
            ax.plot(*great_arc_points(a, b, center).T, color=STABLE_COLOUR, lw=2, gid=BOUNDARY_GID)
    elif region.kind == "arc" and len(vertices) == 2:
        ax.plot(
            *great_arc_points(vertices[0], vertices[1], center).T, color=STABLE_COLOUR, lw=3, gid=BOUNDARY_GID
        )
    elif region.kind == "hemisphere" and len(region.normals):
        ax.plot(
            *great_circle(region.normals[0], CIRCLE_POINTS).T, color=STABLE_COLOUR, lw=2, gid=BOUNDARY_GID
        )
    elif region.kind == "great_circle" and len(region.equalities):
        ax.plot(
            *great_circle(region.equalities[0], CIRCLE_POINTS).T, color=STABLE_COLOUR, lw=3, gid=BOUNDARY_GID
        )


def _draw_centre(ax: Axes3D, center: np.ndarray) -> None:
    """Mark the region's centre (gid CENTER_GID) and turn the camera towards it."""
    ax.scatter(
        *center,
        s=120,
        marker="*",
        color=HIGHLIGHT_COLOUR,
        depthshade=False,
        label="centre",
        gid=CENTER_GID,
    )
    # The camera sits a little off the centre's direction: the region faces the reader, seen in 3-D.
    elev = math.degrees(math.asin(float(np.clip(center[2], -1, 1)))) + VIEW_OFFSET_DEG[0]
    azim = math.degrees(math.atan2(center[1], center[0])) + VIEW_OFFSET_DEG[1]
    ax.view_init(elev=float(np.clip(elev, -89.0, 89.0)), azim=azim)


def _draw_path(ax: Axes3D, path: PathResult) -> None:
    """Draw a safe path's samples (gid PATH_GID), joined, over the region."""
    ax.plot(
        *np.asarray(path.path).T,
        color=PART_COLOUR,
        lw=1.5,
        marker=".",
        ms=4,
        label=f"safe path ({path.samples} samples)",
        gid=PATH_GID,
    )


def _finish_axes(ax: Axes3D, result: RegionResult) -> None:
    """Make the view a bare unit cube (no ticks, no axes), then add the title and the legend.

    The title names the assembly, the region's kind, mu, the facet count K and the region's area.
    """
    region = result.region
    ax.set_box_aspect((1, 1, 1))
    lim = 1.1
    ax.set(xlim=(-lim, lim), ylim=(-lim, lim), zlim=(-lim, lim), xticks=[], yticks=[], zticks=[])
    ax.set_axis_off()
    ax.set_title(
        f"{result.assembly}: stable gravity directions ({region.kind}, mu = {result.mu:g}, "
        f"K = {region.facets})\n"
        f"area {region.area_sr:.4g} sr ({region.area_sr / (4 * math.pi):.2%} of the sphere)",
        fontsize="medium",
    )
    ax.legend(loc="lower left", fontsize="small")
