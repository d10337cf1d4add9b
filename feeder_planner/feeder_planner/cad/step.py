"""STEP solids, read with OpenCASCADE (OCP): each solid placed, checked and tessellated into triangles.

A STEP file's solids are its bodies, numbered 1, 2, ... in the file's order ("solid 2"), each with the
placement its assembly gives it (OpenCASCADE applies the product structure's locations). A file with
shells or faces but no solid is a surface model and refused; so is a solid whose shells are not closed or
that OpenCASCADE's checker finds invalid. Each solid is tessellated with a linear deflection of
``tolerance`` times the file's bounding-box diagonal (the chord tolerance of DXF and SVG; angular
deflection 0.5 rad), its triangles oriented outward by the faces' orientation, and the coincident nodes
of neighbouring faces merged. The assembly's mesh checks (closed, oriented, not degenerate) follow.

Units are the file's own: OpenCASCADE converts every length to millimetres. A file that declares no
LENGTH_UNIT is refused unless ``unit`` says what its numbers are.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from feeder_planner.errors import InputError
from feeder_planner.limits import quote
from feeder_planner.reading import read_bytes

__all__ = ["STEP_SUFFIXES", "StepSolid", "read_step_solids"]

STEP_SUFFIXES = (".step", ".stp")
_ANGULAR_DEFLECTION = 0.5  # radians between a curved face's normals at neighbouring nodes
_UNIT = re.compile(
    rb"LENGTH_UNIT\s*\(\s*\)[^;]*?(SI_UNIT\s*\([^)]*\)|CONVERSION_BASED_UNIT\s*\(\s*'[^']*')", re.S
)
_MM = 1e-3
# The longest a STEP file may take to read and tessellate (a 64 MB export takes tens of seconds).
STEP_SECONDS = 120


@dataclass(frozen=True)
class StepSolid:
    """One solid of a STEP file, tessellated: vertices (n, 3) in the file's numbers, faces (m, 3) outward."""

    label: str
    vertices: np.ndarray
    faces: np.ndarray


def read_step_solids(
    path: str | Path, tolerance: float, unit: float | None = None
) -> tuple[list[StepSolid], float, str]:
    """Return every solid of a STEP file, tessellated, metres per number and the unit's description.

    ``unit`` (metres per number) is used only when the file declares no length unit. OpenCASCADE runs in
    a child process (``feeder_planner.cad.step_child``): it crashes on some malformed files (a segfault
    found by tests/cad/test_cad_fuzz.py) and prints its diagnostics on stdout, which must stay the
    command's. A crash or STEP_SECONDS without an answer is one InputError.
    """
    with tempfile.TemporaryDirectory(prefix="feeder-step-") as folder:
        out = Path(folder) / "solids.npz"
        command = [sys.executable, "-m", "feeder_planner.cad.step_child", str(path), repr(tolerance)]
        command += [repr(unit) if unit is not None else "none", str(out)]
        try:
            child = subprocess.run(command, capture_output=True, timeout=STEP_SECONDS, check=False)
        except subprocess.TimeoutExpired:
            raise InputError(
                "<file>",
                f"OpenCASCADE took more than {STEP_SECONDS} s to read it; simplify or export it again",
            ) from None
        if child.returncode != 0 or not out.exists():
            how = f"signal {-child.returncode}" if child.returncode < 0 else f"exit {child.returncode}"
            raise InputError(
                "<file>", f"OpenCASCADE failed reading it ({how}); repair or export the model again"
            )
        with np.load(out, allow_pickle=False) as saved:
            meta = json.loads(str(saved["meta"]))
            if "error" in meta:
                raise InputError(meta["error"][0], meta["error"][1])
            solids = [
                StepSolid(label, saved[f"vertices{k}"], saved[f"faces{k}"])
                for k, label in enumerate(meta["labels"])
            ]
    return solids, float(meta["scale"]), str(meta["unit"])


def save_step_solids(path: str, tolerance: float, unit: float | None, out: str) -> None:
    """Read a STEP file here and save its solids, or its InputError, into ``out`` (the child's side)."""
    try:
        solids, scale, unit_name = _read_in_process(path, tolerance, unit)
        meta: dict[str, object] = {"labels": [s.label for s in solids], "scale": scale, "unit": unit_name}
        arrays: dict[str, np.ndarray] = {f"vertices{k}": s.vertices for k, s in enumerate(solids)}
        arrays |= {f"faces{k}": s.faces for k, s in enumerate(solids)}
    except InputError as error:
        meta, arrays = {"error": [error.field, error.problem]}, {}
    arrays["meta"] = np.array(json.dumps(meta))
    np.savez(out, allow_pickle=False, **arrays)


def _read_in_process(
    path: str | Path, tolerance: float, unit: float | None
) -> tuple[list[StepSolid], float, str]:
    """Return every solid of a STEP file, tessellated, metres per number and the unit (in this process)."""
    data = read_bytes(path)
    if not data.strip():
        raise InputError("<file>", "is empty; export the model again")
    scale, numbers, unit_name = _unit(data, unit)
    shape = _shape(path)
    solids = _solids(shape)
    diagonal = _diagonal(shape)
    deflection = tolerance * diagonal if diagonal > 0 else 1e-6
    tessellated = [_tessellated(solid, k + 1, deflection) for k, solid in enumerate(solids)]
    # Back to the file's own unit, so that lengths on the command line are in it (contract section 1).
    in_file_unit = [StepSolid(s.label, s.vertices * numbers, s.faces) for s in tessellated]
    return in_file_unit, scale, unit_name


# A STEP length unit: SI prefixes of the metre, and the conversion-based units of CAD exports.
_PREFIXES = {
    b"": 1.0,
    b"$": 1.0,
    b".MILLI.": 1e-3,
    b".CENTI.": 1e-2,
    b".DECI.": 0.1,
    b".MICRO.": 1e-6,
    b".KILO.": 1e3,
}
_NAMED = {b"INCH": 0.0254, b"FOOT": 0.3048, b"MILLIMETRE": 1e-3, b"CENTIMETRE": 1e-2, b"METRE": 1.0}


def _unit(data: bytes, unit: float | None) -> tuple[float, float, str]:
    """Return metres per file unit, file units per OpenCASCADE number and the file's unit as written.

    OpenCASCADE converts every length to millimetres; a unit it converts but this table does not know
    stays in millimetres.
    """
    match = _UNIT.search(data)
    if match:
        written = match.group(1)
        si = re.match(rb"SI_UNIT\s*\(\s*([^,]*),\s*\.METRE\.", written)
        named = re.match(rb"CONVERSION_BASED_UNIT\s*\(\s*'([^']*)'", written)
        metres = (
            _PREFIXES.get(si.group(1).strip())
            if si
            else _NAMED.get(named.group(1).upper())
            if named
            else None
        )
        metres = metres or _MM
        return metres, _MM / metres, written.decode("ascii", "replace")
    if unit is None:
        raise InputError(
            "LENGTH_UNIT",
            "units missing: the file declares no length unit; export it with units, or give unit: in the "
            "part YAML's cad: mapping",
        )
    return unit, 1.0, "given by unit (the file declares none)"


def _shape(path: str | Path) -> object:
    """Read and transfer the file's roots into one shape; a failure is one InputError."""
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.STEPControl import STEPControl_Reader

    reader = STEPControl_Reader()
    try:
        status = reader.ReadFile(str(path))
        if status != IFSelect_RetDone:
            raise InputError("<file>", f"is not a readable STEP file ({status}); export it again")
        reader.TransferRoots()
        shape = reader.OneShape()
    except InputError:
        raise
    except Exception as exc:  # OCP raises Standard_Failure and others on broken entities
        raise InputError(
            "<file>",
            f"is not a readable STEP file ({type(exc).__name__}: {quote(str(exc))}); export it again",
        ) from None
    if shape is None or shape.IsNull():
        raise InputError("<file>", "holds no shape; export the solids again")
    return shape


def _solids(shape: object) -> list[object]:
    """Return the solids, refusing a surface model and an open or invalid solid, naming it."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepCheck import BRepCheck_Analyzer
    from OCP.TopAbs import TopAbs_FACE, TopAbs_SHELL, TopAbs_SOLID
    from OCP.TopExp import TopExp_Explorer

    def each(of: object, kind: object) -> list[object]:
        found, explorer = [], TopExp_Explorer(of, kind)
        while explorer.More():
            found.append(explorer.Current())
            explorer.Next()
        return found

    solids = each(shape, TopAbs_SOLID)
    if not solids:
        faces, shells = each(shape, TopAbs_FACE), each(shape, TopAbs_SHELL)
        raise InputError(
            "<file>",
            f"holds no solid ({len(shells)} shells, {len(faces)} faces: a surface model); "
            "export the bodies as closed solids",
        )
    for k, solid in enumerate(solids):
        for shell in each(solid, TopAbs_SHELL):
            if not BRep_Tool.IsClosed_s(shell):
                raise InputError(
                    f"solid {k + 1}",
                    "is not a closed solid (a shell is open); close or sew it in the CAD tool",
                )
        if not BRepCheck_Analyzer(solid).IsValid():
            raise InputError(
                f"solid {k + 1}", "is not a valid solid (OpenCASCADE's check); repair it in the CAD tool"
            )
    return solids


def _diagonal(shape: object) -> float:
    """Return the diagonal of the shape's bounding box (OpenCASCADE's numbers)."""
    from OCP.Bnd import Bnd_Box
    from OCP.BRepBndLib import BRepBndLib

    box = Bnd_Box()
    BRepBndLib.Add_s(shape, box)
    if box.IsVoid():
        return 0.0
    low, high = box.CornerMin(), box.CornerMax()
    return float(np.linalg.norm([high.X() - low.X(), high.Y() - low.Y(), high.Z() - low.Z()]))


def _tessellated(solid: object, number: int, deflection: float) -> StepSolid:
    """Tessellate one solid; return its merged, outward triangles."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepMesh import BRepMesh_IncrementalMesh
    from OCP.TopAbs import TopAbs_FACE, TopAbs_REVERSED
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS

    label = f"solid {number}"
    BRepMesh_IncrementalMesh(solid, deflection, False, _ANGULAR_DEFLECTION, True)
    points: list[np.ndarray] = []
    triangles: list[np.ndarray] = []
    offset = 0
    explorer = TopExp_Explorer(solid, TopAbs_FACE)
    while explorer.More():
        face = TopoDS.Face(explorer.Current())
        explorer.Next()
        location = TopLoc_Location()
        mesh = BRep_Tool.Triangulation_s(face, location)
        if mesh is None:
            raise InputError(label, "a face could not be tessellated; repair the solid in the CAD tool")
        moved = location.Transformation()
        nodes = np.array(
            [
                [p.X(), p.Y(), p.Z()]
                for p in (mesh.Node(i).Transformed(moved) for i in range(1, mesh.NbNodes() + 1))
            ]
        )
        corners = (
            np.array([mesh.Triangle(i).Get() for i in range(1, mesh.NbTriangles() + 1)], dtype=np.int64) - 1
        )
        if face.Orientation() == TopAbs_REVERSED:
            corners = corners[:, ::-1]
        points.append(nodes)
        triangles.append(corners + offset)
        offset += len(nodes)
    vertices = np.concatenate(points)
    faces = np.concatenate(triangles)
    return StepSolid(label, *_merged(vertices, faces))


def _merged(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Merge nodes that neighbouring faces repeat (equal to 1e-9 of the solid's size); drop unused ones."""
    size = float(np.ptp(vertices, axis=0).max()) or 1.0
    keys = np.round(vertices / (1e-9 * size)).astype(np.int64)
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    faces = inverse.reshape(-1)[faces]
    faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 2] != faces[:, 0])]
    used, remap = np.unique(faces, return_inverse=True)
    return vertices[first][used], remap.reshape(-1, 3)
