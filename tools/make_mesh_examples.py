"""Write the mesh assemblies of examples/assembly/ (issue 15): meshes made here, no downloaded models.

``python tools/make_mesh_examples.py`` (re)writes examples/assembly/meshes/*.stl|obj|ply and the assembly
files dovetail_joint.yaml, mesh_pallet.yaml, stepped_stack_boxes.yaml and stepped_stack_meshes.yaml (the
same stack as boxes and as meshes: the same stable region). The output is deterministic.
"""

from __future__ import annotations

import sys
from pathlib import Path

import yaml

from feeder_planner.assembly.generate import dovetail_joint, mesh_pallet, stepped_stack

ROOT = Path(__file__).resolve().parents[1]
HEADERS = {
    "dovetail_joint": (
        "# An interlocking dovetail joint (issue 15): a grounded base with a dovetail slot (binary STL)\n"
        "# and a tail piece (OBJ), both non-convex meshes. With mu = 0 the tail can only slide along the\n"
        "# slot: the region is the great circle of directions across it; --mu 0.3 lets the wedge clamp it\n"
        "# (every direction stable).\n"
    ),
    "mesh_pallet": (
        "# A pallet of parts (issue 15): a grounded deck (PLY) carrying 3 x 2 L-brackets (one STL placed by\n"
        "# rigid transforms) with a block in each bracket's corner (PLY). Every body is a mesh.\n"
    ),
    "stepped_stack_boxes": (
        "# A stack with a non-convex L-shaped body, written as boxes; stepped_stack_meshes.yaml is the same\n"
        "# stack written as meshes and has the same stable region (tests/assembly/test_meshes.py).\n"
    ),
    "stepped_stack_meshes": (
        "# The stack of stepped_stack_boxes.yaml written as meshes (STL, OBJ, PLY): the same stable region.\n"
    ),
}


def write_examples(folder: Path) -> list[Path]:
    """Write the mesh files under ``folder``/meshes and the assembly files in ``folder``; return the paths."""
    meshes = folder / "meshes"
    documents = {
        "dovetail_joint": dovetail_joint(meshes),
        "mesh_pallet": mesh_pallet(meshes),
        "stepped_stack_boxes": stepped_stack(None),
        "stepped_stack_meshes": stepped_stack(meshes),
    }
    written = []
    for name, document in documents.items():
        path = folder / f"{name}.yaml"
        path.write_text(HEADERS[name] + yaml.safe_dump(document, sort_keys=False, default_flow_style=None))
        written.append(path)
    return written + sorted(meshes.iterdir())


def main() -> int:
    """Write the examples into examples/assembly (or the folder given as the only argument)."""
    folder = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "examples" / "assembly"
    for path in write_examples(folder):
        print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
