"""Write the CAD twins of the examples from their YAML parts: `python tools/make_cad_examples.py`.

Each twin draws the same outline in the same vertex order (the throwing arm numbers hull edges in the
file's order) and the same unit, so that the planners give the same results (tests/cad). The filleted
bracket has arcs and a circular hole: the part that the chord tolerance is measured on.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
# $INSUNITS code of each YAML length unit.
_INSUNITS = {"m": 6, "cm": 5, "mm": 4, "um": 13}


def _new_drawing(unit: str) -> Any:
    import ezdxf

    doc = ezdxf.new("R2010", units=_INSUNITS[unit])
    doc.layers.add("PART")
    return doc


def polyline_twin(source: Path, target: Path) -> None:
    """A closed LWPOLYLINE (holes as more closed LWPOLYLINEs) on layer PART, from a YAML part."""
    document = yaml.safe_load(source.read_text())
    doc = _new_drawing(document.get("length_unit", "m"))
    space = doc.modelspace()
    for loop in [document["vertices"], *document.get("holes", [])]:
        space.add_lwpolyline([tuple(p) for p in loop], close=True, dxfattribs={"layer": "PART"})
    doc.saveas(target)


def line_chain_twin(source: Path, target: Path) -> None:
    """The outline as a chain of LINE entities, in the YAML's vertex order, from a YAML part."""
    document = yaml.safe_load(source.read_text())
    doc = _new_drawing(document.get("length_unit", "m"))
    space = doc.modelspace()
    vertices = [tuple(p) for p in document["vertices"]]
    for a, b in zip(vertices, vertices[1:] + vertices[:1], strict=False):
        space.add_line(a, b, dxfattribs={"layer": "PART"})
    doc.saveas(target)


def svg_twin(source: Path, target: Path) -> None:
    """One SVG path (a subpath per loop) in the YAML's unit and vertex order; SVG's y axis points down,
    so y is negated, and the viewBox is the part's box."""
    document = yaml.safe_load(source.read_text())
    unit = document.get("length_unit", "m")
    loops = [document["vertices"], *document.get("holes", [])]
    xs = [p[0] for p in document["vertices"]]
    ys = [-p[1] for p in document["vertices"]]
    width, height = max(xs) - min(xs), max(ys) - min(ys)
    data = " ".join("M " + " L ".join(f"{x:g} {-y:g}" for x, y in loop) + " Z" for loop in loops)
    target.write_text(
        '<svg xmlns="http://www.w3.org/2000/svg" '
        f'width="{width:g}{unit}" height="{height:g}{unit}" '
        f'viewBox="{min(xs):g} {min(ys):g} {width:g} {height:g}">\n'
        f'  <path id="{document.get("name", "part")}" d="{data}" '
        'fill="none" stroke="black" stroke-width="0.01"/>\n'
        "</svg>\n"
    )


def stl_prism(source: Path, target: Path, thickness: float = 1.0) -> None:
    """The bracket as a solid 1 unit thick (ASCII STL, outward normals): its caps fanned from vertex 3,
    the reflex corner, from which every other vertex is seen."""
    document = yaml.safe_load(source.read_text())
    base = [(float(x), float(y)) for x, y in document["vertices"]]
    n = len(base)
    triangles = []
    for k in range(1, n - 1):  # fan from vertex 3 (index order rotated so it is first)
        a, b, c = base[3], base[(3 + k) % n], base[(3 + k + 1) % n]
        triangles.append(((*a, thickness), (*b, thickness), (*c, thickness)))
        triangles.append(((*a, 0.0), (*c, 0.0), (*b, 0.0)))
    for k in range(n):
        a, b = base[k], base[(k + 1) % n]
        triangles.append(((*a, 0.0), (*b, 0.0), (*b, thickness)))
        triangles.append(((*a, 0.0), (*b, thickness), (*a, thickness)))
    lines = ["solid part"]
    for triangle in triangles:
        lines += ["facet normal 0 0 0", "outer loop", *(f"vertex {x:g} {y:g} {z:g}" for x, y, z in triangle)]
        lines += ["endloop", "endfacet"]
    target.write_text("\n".join([*lines, "endsolid part", ""]))


def _step_write(shapes: list[object], target: Path, unit: str = "mm") -> None:
    """Write solids (built in millimetres) into one STEP file in ``unit``, in the list's order."""
    from OCP.BRep import BRep_Builder
    from OCP.Interface import Interface_Static
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer
    from OCP.TopoDS import TopoDS_Compound

    builder, compound = BRep_Builder(), TopoDS_Compound()
    builder.MakeCompound(compound)
    for shape in shapes:
        builder.Add(compound, shape)
    Interface_Static.SetCVal_s("write.step.unit", unit.upper())
    writer = STEPControl_Writer()
    writer.Transfer(compound, STEPControl_AsIs)
    writer.Write(str(target))


def step_prism(source: Path, target: Path) -> None:
    """The YAML part extruded 1 unit along z (holes through), one STEP solid in millimetres."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace, BRepBuilderAPI_MakePolygon
    from OCP.BRepPrimAPI import BRepPrimAPI_MakePrism
    from OCP.gp import gp_Pnt, gp_Vec

    document = yaml.safe_load(source.read_text())
    per_mm = {"mm": 1.0, "cm": 10.0, "m": 1000.0}[document.get("length_unit", "m")]

    def wire(loop: list[list[float]]) -> object:
        polygon = BRepBuilderAPI_MakePolygon()
        for x, y in loop:
            polygon.Add(gp_Pnt(float(x) * per_mm, float(y) * per_mm, 0.0))
        polygon.Close()
        return polygon.Wire()

    maker = BRepBuilderAPI_MakeFace(wire(document["vertices"]))
    for hole in document.get("holes", []):
        maker.Add(wire(hole[::-1]))  # a hole's wire runs against the outline's
    prism = BRepPrimAPI_MakePrism(maker.Face(), gp_Vec(0.0, 0.0, per_mm)).Shape()
    _step_write([prism], target, document.get("length_unit", "m"))


def step_assembly(source: Path, target: Path, assembly: Path) -> None:
    """Each body of a box assembly as one STEP solid (its boxes fused, coplanar faces merged), in the
    bodies' order, and the assembly YAML that places them as meshes (body: 1, 2, ...)."""
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Fuse
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
    from OCP.gp import gp_Pnt
    from OCP.ShapeUpgrade import ShapeUpgrade_UnifySameDomain

    document = yaml.safe_load(source.read_text())
    per_mm = {"mm": 1.0, "cm": 10.0, "m": 1000.0}[document.get("length_unit", "m")]
    solids = []
    for body in document["bodies"]:
        shape = None
        for box in body["boxes"]:
            low, high = (np.array(box["min"]) * per_mm), (np.array(box["max"]) * per_mm)
            made = BRepPrimAPI_MakeBox(gp_Pnt(*low), gp_Pnt(*high)).Shape()
            shape = made if shape is None else BRepAlgoAPI_Fuse(shape, made).Shape()
        unify = ShapeUpgrade_UnifySameDomain(shape, True, True, True)
        unify.Build()
        solids.append(unify.Shape())
    _step_write(solids, target, document.get("length_unit", "m"))
    twin = {
        "name": f"{document['name']}_step",
        "length_unit": document.get("length_unit", "m"),
        "mu": document.get("mu", 0.0),
        "bodies": [
            {
                "name": body["name"],
                **({"grounded": True} if body.get("grounded") else {}),
                "meshes": [{"file": str(target.relative_to(assembly.parent)), "body": k + 1}],
            }
            for k, body in enumerate(document["bodies"])
        ],
        "contacts": "auto",
    }
    header = (
        f"# {source.name} as one STEP file (tools/make_cad_examples.py): each body is a solid of\n"
        "# meshes/block_in_l_bracket.step, placed by the file, tessellated into the mesh path.\n"
    )
    assembly.write_text(header + yaml.safe_dump(twin, sort_keys=False))


def filleted_bracket(target: Path) -> None:
    """The bracket (mm) with a 0.5 mm fillet in its inner corner, drawn as LINEs and an ARC, and a
    CIRCLE hole of radius 0.3 mm: arcs whose flattening the chord tolerance bounds."""
    doc = _new_drawing("mm")
    space = doc.modelspace()
    attribs = {"layer": "PART"}
    r = 0.5
    points = [(1.0, 3.0), (0.0, 3.0), (0.0, 0.0), (4.0, 0.0), (4.0, 1.0), (1.0 + r, 1.0)]
    for a, b in zip(points, points[1:], strict=False):
        space.add_line(a, b, dxfattribs=attribs)
    # The fillet from (1.5, 1) to (1, 1.5) about (1.5, 1.5): clockwise in the outline's order, so the
    # ARC (always counter-clockwise in DXF) runs from 180 to 270 degrees and the chain reverses it.
    space.add_arc((1.0 + r, 1.0 + r), r, 180.0, 270.0, dxfattribs=attribs)
    space.add_line((1.0, 1.0 + r), (1.0, 3.0), dxfattribs=attribs)
    space.add_circle((0.5, 0.5), 0.3, dxfattribs=attribs)
    doc.saveas(target)


def main() -> int:
    """Write every twin; print the paths."""
    written = []
    for source, target, make in (
        (EXAMPLES / "mems/bracket.yaml", EXAMPLES / "mems/bracket.dxf", polyline_twin),
        (EXAMPLES / "mems/washer.yaml", EXAMPLES / "mems/washer.dxf", polyline_twin),
        (EXAMPLES / "throwing/triangle.yaml", EXAMPLES / "throwing/triangle.dxf", line_chain_twin),
        (EXAMPLES / "mems/bracket.yaml", EXAMPLES / "mems/bracket.svg", svg_twin),
        (EXAMPLES / "mems/washer.yaml", EXAMPLES / "mems/washer.svg", svg_twin),
        (EXAMPLES / "throwing/triangle.yaml", EXAMPLES / "throwing/triangle.svg", svg_twin),
    ):
        make(source, target)
        written.append(target)
    stl_prism(EXAMPLES / "mems/bracket.yaml", EXAMPLES / "mems/bracket.stl")
    step_prism(EXAMPLES / "mems/bracket.yaml", EXAMPLES / "mems/bracket.step")
    step_prism(EXAMPLES / "mems/washer.yaml", EXAMPLES / "mems/washer.step")
    step_prism(EXAMPLES / "throwing/triangle.yaml", EXAMPLES / "throwing/triangle.step")
    written += [
        EXAMPLES / "mems/bracket.step",
        EXAMPLES / "mems/washer.step",
        EXAMPLES / "throwing/triangle.step",
    ]
    step_assembly(
        EXAMPLES / "assembly/block_in_l_bracket.yaml",
        EXAMPLES / "assembly/meshes/block_in_l_bracket.step",
        EXAMPLES / "assembly/block_in_l_bracket_step.yaml",
    )
    written += [
        EXAMPLES / "assembly/meshes/block_in_l_bracket.step",
        EXAMPLES / "assembly/block_in_l_bracket_step.yaml",
    ]
    written.append(EXAMPLES / "mems/bracket.stl")
    filleted_bracket(EXAMPLES / "mems/bracket_filleted.dxf")
    written.append(EXAMPLES / "mems/bracket_filleted.dxf")
    for path in written:
        print(path.relative_to(ROOT))
    return 0


if __name__ == "__main__":
    sys.exit(main())
