"""Regenerate the three pictures the README shows into docs/pictures/ (one per device's planner).

Run from the repository with the environment sourced: ``python tools/readme_pictures.py``. The pictures
are drawn by the same plot functions as ``--plot`` from the example files, so they change only when a
planner's result or a plot changes; each must stay below MAX_BYTES to keep the repository small.
"""

from __future__ import annotations

import io
import math
import sys
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from PIL import Image

from feeder_cell.plots.common import DPI
from feeder_cell.plots.equilibria import equilibria_figure
from feeder_cell.plots.limit_set import limit_set_figure
from feeder_cell.plots.stable_region import region_figure
from feeder_planner.assembly import load_assembly, path_result, prepare, region_result
from feeder_planner.mems import find_equilibria
from feeder_planner.parts import load_part
from feeder_planner.throwing import ThrowParams, arm_part, limit_set

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "pictures"
MAX_BYTES = 150_000
# The README's limit set uses fewer starts than the CLI's default: the picture reads the same and stays small.
README_STARTS_PER_EDGE = 8
PALETTE_COLOURS = 128  # a palette PNG: the plots have few colours, and it is a third of the RGBA size


def write_figure(figure: Figure, path: Path) -> Path:
    """Save ``figure`` as a palette PNG (smaller than matplotlib's RGBA one, same look)."""
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=DPI)
    buffer.seek(0)
    with Image.open(buffer) as image:
        image.convert("RGB").quantize(PALETTE_COLOURS).save(path, optimize=True)
    return path


def mems() -> Path:
    """The bracket's equilibria at delta = 0.1 (feeder equilibria examples/mems/bracket.yaml --delta 0.1)."""
    part = load_part(ROOT / "examples/mems/bracket.yaml")
    result = find_equilibria(part, 0.1, "auto")
    return write_figure(equilibria_figure(part, result), OUT / "mems_bracket_equilibria.png")


def throwing() -> Path:
    """The paper's triangle, h = -0.5 cm, W = 320 deg/s, g = -966 cm/s^2, mu = 0.5, goal edge 1 (Fig. 7)."""
    part = load_part(ROOT / "examples/throwing/triangle.yaml")
    s = part.unit_scale
    params = ThrowParams(-0.5 * s, math.radians(320), -966 * s, 0.5)
    result = limit_set(arm_part(part), params, 1, README_STARTS_PER_EDGE, keep_trajectories=True)
    return write_figure(limit_set_figure(result, s, part.name), OUT / "throwing_triangle_limit_set.png")


def assembly() -> Path:
    """The block in the L bracket with mu = 0.2 (Fig. 14) and a safe path across its region."""
    prepared = prepare(load_assembly(ROOT / "examples/assembly/block_in_l_bracket.yaml"), 0.2)
    result = region_result(prepared)
    region = prepared.region
    if region.center is None or len(region.vertices) < 3:
        raise SystemExit(f"the L bracket's region is {region.kind}: no path to draw across it")
    centre = np.asarray(region.center)
    # From halfway towards one vertex to halfway towards the opposite one: both ends deep inside.
    start = centre + 0.5 * (region.vertices[0] - centre)
    end = centre + 0.5 * (region.vertices[len(region.vertices) // 2] - centre)
    path = path_result(prepared, start, end)
    return write_figure(region_figure(result, path), OUT / "assembly_l_bracket_region.png")


def main() -> int:
    """Write the three pictures; exit 1 if one is larger than MAX_BYTES."""
    OUT.mkdir(parents=True, exist_ok=True)
    ok = True
    for make in (mems, throwing, assembly):
        path = make()
        size = path.stat().st_size
        ok &= size < MAX_BYTES
        print(f"{path.relative_to(ROOT)}: {size / 1000:.0f} kB{'' if size < MAX_BYTES else ' (TOO LARGE)'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
