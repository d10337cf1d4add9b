"""Planar parts from CAD files: DXF and SVG outlines, STEP and STL solids (docs/cli.md, "Importing parts").

``read_outline`` returns what a file gave (``Outline``: the loops, the unit, the source entities);
``feeder_planner.parts.cad_part`` makes it a ``Part`` as a YAML part file would be, and
``feeder_planner.parts.load_part`` calls it for a CAD file, or for a part YAML with a ``cad:`` mapping that
names one with its options. (The parts module imports this package, never the other way round.)
"""

from __future__ import annotations

from pathlib import Path

from feeder_planner.cad.options import CHORD_TOLERANCE, CadOptions, options_from_mapping
from feeder_planner.cad.outline import Outline
from feeder_planner.errors import InputError

__all__ = [
    "CAD_SUFFIXES",
    "CHORD_TOLERANCE",
    "CadOptions",
    "Outline",
    "is_cad_file",
    "options_from_mapping",
    "read_outline",
]

CAD_SUFFIXES = (".dxf", ".svg", ".stl", ".step", ".stp")
"""File name endings read as CAD parts (lower case)."""


def is_cad_file(path: str | Path) -> bool:
    """Whether ``path`` is read as a CAD file, by its extension."""
    return Path(path).suffix.lower() in CAD_SUFFIXES


def read_outline(path: str | Path, options: CadOptions | None = None) -> Outline:
    """Read a CAD file's outline and holes; every InputError names the file and the entity."""
    options = options or CadOptions()
    suffix = Path(path).suffix.lower()
    try:
        if suffix == ".dxf":
            from feeder_planner.cad.dxf import read_dxf

            return read_dxf(path, options)
        if suffix == ".svg":
            from feeder_planner.cad.svg import read_svg

            return read_svg(path, options)
        if suffix in (".step", ".stp"):
            from feeder_planner.cad.step_part import read_step_part

            return read_step_part(path, options)
        if suffix == ".stl":
            from feeder_planner.cad.stl import read_stl

            return read_stl(path, options)
        raise InputError(
            "<file>", f"unknown CAD format {suffix!r}; expected one of {', '.join(CAD_SUFFIXES)}"
        )
    except InputError as error:
        raise (error if error.source else error.with_source(str(path))) from None
