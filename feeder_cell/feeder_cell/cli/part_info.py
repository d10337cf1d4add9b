"""`feeder part-info FILE`: what a part file (YAML, or CAD: docs/cli.md "Importing parts") was read as."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from feeder_cell.cli.common import add_json_flag, emit, finite_float
from feeder_cell.plots.flag import add_plot_flag
from feeder_planner import cad, parts, polygon
from feeder_planner.cad.options import CAD_UNITS, CHORD_TOLERANCE, CadOptions
from feeder_planner.errors import InputError
from feeder_planner.fields_io import load_yaml_mapping
from feeder_planner.parts import Part, load_part
from feeder_planner.units import LENGTH_UNITS

__all__ = ["HELP", "register", "run"]

HELP = f"""Print what a part file was read as: its outline and holes, area, centre of mass, convex hull,
units and the source entities (CAD). FILE is a part YAML (contract section 2), a YAML whose cad:
mapping names a CAD file with its options, or a CAD file itself ({", ".join(cad.CAD_SUFFIXES)}).
Coordinates are in the file's frame, in metres (the part frame is this frame translated so that the
centre of mass is the origin). The flags give a CAD file's options, as the cad: mapping would; they
override that mapping's. Curves are flattened with chords within --chord-tolerance times the drawing's
bounding-box diagonal (default {CHORD_TOLERANCE:g}). Exit 2 on bad input, naming the entity."""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``part-info`` to the feeder parser."""
    parser = subparsers.add_parser(
        "part-info",
        help="what a part file (YAML, DXF...) was read as: outline, holes, area, hull, units, sources",
        description=HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("file", metavar="FILE", help="part file: YAML or CAD")
    parser.add_argument("--layer", help="DXF: only the entities on this layer")
    parser.add_argument("--block", help="DXF: the entities of this block definition")
    parser.add_argument("--element", help="SVG: only the element with this id (and its children)")
    parser.add_argument(
        "--face", choices=["-z", "+z", "-x", "+x", "-y", "+y"], help="STL: the face it rests on"
    )
    parser.add_argument(
        "--section", type=finite_float, help="STL: the section at this level across --face's axis"
    )
    parser.add_argument("--body", type=int, help="STEP: the solid to read (1, 2, ... in the file's order)")
    parser.add_argument("--unit", choices=list(CAD_UNITS), help="the file's length unit, overriding its own")
    parser.add_argument(
        "--chord-tolerance",
        type=finite_float,
        default=None,
        metavar="T",
        help="chord tolerance of curve flattening, relative to the drawing's diagonal "
        f"(default {CHORD_TOLERANCE:g})",
    )
    add_json_flag(parser)
    add_plot_flag(parser)
    parser.set_defaults(handler=run)


def _options(args: argparse.Namespace, base: dict[str, Any]) -> CadOptions:
    """Return the CAD options: a YAML cad: mapping's (``base``), then the flags given."""
    raw = dict(base)
    for key in ("layer", "block", "element", "unit", "chord_tolerance", "face", "section", "body"):
        value = getattr(args, key, None)
        if value is not None:
            raw[key] = value
    return cad.options_from_mapping(raw, "cad")


def read(args: argparse.Namespace) -> tuple[Part, cad.Outline | None, str]:
    """Return the part, the CAD outline it came from (None for YAML vertices) and the CAD file's path."""
    path = Path(args.file)
    if cad.is_cad_file(path):
        options = _options(args, {})
        outline = cad.read_outline(path, options)
        return parts.part_from_outline(outline, path), outline, str(path)
    part = load_part(path)  # checks the whole YAML, its cad: mapping and the CAD file it names
    mapping = load_yaml_mapping(path).get("cad")
    if not isinstance(mapping, dict):
        return part, None, str(path)
    target = Path(str(mapping["file"])).expanduser()
    target = target if target.is_absolute() else path.parent / target
    try:
        options = _options(args, mapping)
    except InputError as error:
        raise error.with_source(str(path)) from None
    outline = cad.read_outline(target, options)
    if options != cad.options_from_mapping(mapping, "cad"):  # a flag changed the reading
        part = parts.part_from_outline(outline, target, part.name, part.density)
    return part, outline, str(target)


def describe(part: Part, outline: cad.Outline | None, source: str) -> dict[str, Any]:
    """Return the JSON object of part-info (SI units, the file's frame)."""
    hull = part.file_vertices[polygon.convex_hull_indices(part.file_vertices)]
    holes = [hole + part.offset for hole in part.holes]
    result: dict[str, Any] = {
        "name": part.name,
        "source": source,
        "unit": outline.unit_name if outline else _yaml_unit(part.unit_scale),
        "unit_scale": part.unit_scale,
        "area": part.area,
        "mass": part.mass,
        "centre_of_mass": part.offset.tolist(),
        "outer": part.file_vertices.tolist(),
        "holes": [hole.tolist() for hole in holes],
        "hull": hull.tolist(),
        "entities": [],
        "notes": [],
    }
    if outline is not None:
        result["entities"] = {
            "outer": list(outline.outer.labels),
            "holes": [list(hole.labels) for hole in outline.holes],
        }
        result["notes"] = list(outline.notes)
    return result


def _yaml_unit(scale: float) -> str:
    """Return the name of a YAML part's length unit from its scale."""
    names = [name for name, value in LENGTH_UNITS.items() if value == scale]
    return f"{names[0] if names else scale} (length_unit)"


def _summary(result: dict[str, Any]) -> str:
    """Return the human summary of part-info."""
    cx, cy = result["centre_of_mass"]
    lines = [
        f"{result['name']}: from {result['source']}, unit {result['unit']}",
        f"  area {result['area']:.6g} m^2, mass {result['mass']:.6g} kg, "
        f"centre of mass ({cx:.6g}, {cy:.6g}) m",
        f"  outline: {len(result['outer'])} vertices; holes: {len(result['holes'])}"
        + (f" ({', '.join(str(len(h)) for h in result['holes'])} vertices)" if result["holes"] else ""),
        "  hull: " + ", ".join(f"({x:.6g}, {y:.6g})" for x, y in result["hull"]) + " m",
    ]
    entities = result["entities"]
    if entities:
        lines.append("  outline from: " + "; ".join(entities["outer"]))
        for k, labels in enumerate(entities["holes"]):
            lines.append(f"  hole {k} from: " + "; ".join(labels))
    lines.extend(f"  {note}" for note in result["notes"])
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    """Print what FILE was read as; draw it over its source geometry with --plot."""
    part, outline, source = read(args)
    result = describe(part, outline, source)
    emit(args, result, _summary)
    if args.plot is not None:
        from feeder_cell.cli.part_info_plot import part_info_figure
        from feeder_cell.plots.common import write_figure

        path = write_figure(part_info_figure(part, outline), args.plot)
        if not args.json:
            print(f"plot: {path}")
    return 0
