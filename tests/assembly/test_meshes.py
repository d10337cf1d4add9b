"""Mesh assemblies (issue 15): reading and checking meshes, contacts between meshes, the examples, the CLI."""

from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np
import pytest
from conftest import EXAMPLES

from feeder_cell.cli.main import main
from feeder_planner.assembly.broad_phase import touching_pairs
from feeder_planner.assembly.contacts import auto_contacts
from feeder_planner.assembly.generate import (
    box_profile,
    extruded_prism,
    random_assembly,
    stepped_stack,
    write_mesh,
)
from feeder_planner.assembly.meshes import body_surface
from feeder_planner.assembly.model import assembly_from_document, assembly_from_text, load_assembly
from feeder_planner.assembly.planner import prepare
from feeder_planner.errors import InputError


def _region(path: Path, mu: float | None = None):
    return prepare(load_assembly(path), mu).region


def test_the_same_stack_as_boxes_and_as_meshes_has_the_same_region() -> None:
    boxes = prepare(load_assembly(EXAMPLES / "stepped_stack_boxes.yaml"))
    meshes = prepare(load_assembly(EXAMPLES / "stepped_stack_meshes.yaml"))
    a, b = boxes.region, meshes.region
    assert a.kind == b.kind == "region"
    assert a.area_sr == pytest.approx(b.area_sr, abs=1e-9)
    assert len(a.normals) == len(b.normals)
    for n in a.normals:  # the same bounding great circles, in any order
        assert np.min(np.linalg.norm(b.normals - n, axis=1)) < 1e-9
    # Same solids, so the same masses and centres.
    for box_body, mesh_body in zip(boxes.assembly.bodies, meshes.assembly.bodies, strict=True):
        assert mesh_body.mass == pytest.approx(box_body.mass, rel=1e-12)
        assert np.allclose(mesh_body.center, box_body.center, atol=1e-12)


def test_the_generated_examples_are_what_the_script_writes(tmp_path) -> None:
    """examples/assembly holds exactly what tools/make_mesh_examples.py writes (committed, < 1 MB)."""
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tools"))
    from make_mesh_examples import write_examples

    written = write_examples(tmp_path)
    total = 0
    for path in written:
        committed = EXAMPLES / path.relative_to(tmp_path)
        assert committed.read_bytes() == path.read_bytes(), committed
        total += path.stat().st_size
    assert total < 1_000_000


def test_dovetail_interlocks_and_slides_only_along_its_slot() -> None:
    path = EXAMPLES / "dovetail_joint.yaml"
    frictionless = _region(path)
    assert frictionless.kind == "great_circle"
    assert np.allclose(np.abs(frictionless.equalities[0]), [0.0, 1.0, 0.0], atol=1e-9)
    assert _region(path, mu=0.3).kind == "sphere"  # the wedge can clamp the tail
    assembly = load_assembly(path)
    tail = assembly.bodies[1].meshes[0]
    # Non-convex: the tail's volume is less than its hull's.
    from scipy.spatial import ConvexHull

    assert tail.volume < 0.95 * ConvexHull(tail.vertices).volume
    # Mass from the volume: profile area 0.8 dm^2 ... computed exactly: (1.6 + 1.0) / 2 * 0.75 + 3 * 0.5.
    area_dm2 = (1.6 + 1.0) / 2 * 0.75 + 3.0 * 0.5
    assert assembly.bodies[1].mass == pytest.approx(0.8 * area_dm2 * 2.0 * 1e-3, rel=1e-12)


def test_pallet_of_parts_is_a_region_and_every_body_rests_on_the_deck_or_its_bracket() -> None:
    prepared = prepare(load_assembly(EXAMPLES / "mesh_pallet.yaml"))
    assert prepared.region.kind == "region" and prepared.region.contains(np.array([0.0, 0.0, -1.0]))
    names = {prepared.assembly.bodies[k].name for c in prepared.contacts for k in (c.a, c.b)} - {"deck"}
    assert names == {b.name for b in prepared.assembly.bodies if not b.grounded}
    bracket = prepared.assembly.bodies[1]
    surface = body_surface(bracket)  # what drawings use: the mesh's triangles, inside its bounds
    assert len(surface) == len(bracket.meshes[0].faces) == 20
    assert np.all(np.vstack(surface) >= bracket.meshes[0].lower - 1e-15)
    from feeder_sim.fixture.drawing import body_shapes

    # The fixture's markers draw every mesh body (3 corners per triangle).
    assert [len(s.points) for s in body_shapes(prepared.assembly)][:2] == [36, 60]


def _run(capsys, *argv: str) -> tuple[int, str, str]:
    try:
        code = main(list(argv))
    except SystemExit as exit_:
        code = exit_.code
    out, err = capsys.readouterr()
    return code, out, err


def test_cli_stable_region_and_check_stability_on_mesh_examples(capsys) -> None:
    code, out, err = _run(capsys, "stable-region", str(EXAMPLES / "mesh_pallet.yaml"), "--json")
    assert code == 0 and err == "" and json.loads(out)["kind"] == "region"
    code, out, _ = _run(
        capsys, "check-stability", str(EXAMPLES / "dovetail_joint.yaml"), "--g", "1", "0", "-1"
    )
    assert code == 0 and out.startswith("stable")
    code, out, _ = _run(
        capsys, "check-stability", str(EXAMPLES / "dovetail_joint.yaml"), "--g", "0", "1", "-1"
    )
    assert code == 0 and "NOT stable" in out and "tail" in out


def test_cli_names_the_file_and_field_of_a_bad_mesh(capsys, tmp_path) -> None:
    assembly = tmp_path / "bad.yaml"
    assembly.write_text(
        "bodies:\n  - {name: floor, grounded: true, boxes: [{min: [0, 0, -1], max: [1, 1, 0]}]}\n"
        "  - {name: part, meshes: [{file: parts/gone.stl}]}\n"
    )
    code, out, err = _run(capsys, "stable-region", str(assembly), "--json")
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1
    assert (
        str(assembly) in err
        and "bodies[1].meshes[0].file" in err
        and "gone.stl" in err
        and "does not exist" in err
    )


def _box_mesh(path: Path, lower=(0.0, 0.0, 0.0), upper=(1.0, 1.0, 1.0)) -> tuple[np.ndarray, np.ndarray]:
    vertices, faces = extruded_prism(box_profile(lower[0], lower[2], upper[0], upper[2]), lower[1], upper[1])
    write_mesh(path, vertices, faces)
    return vertices, faces


def _document(file: str, **extra) -> dict:
    return {
        "bodies": [
            {"name": "floor", "grounded": True, "boxes": [{"min": [-2, -2, -1], "max": [3, 3, 0]}]},
            {"name": "part", "meshes": [{"file": file, **extra}]},
        ]
    }


def _error(document: dict, base: Path) -> InputError:
    with pytest.raises(InputError) as caught:
        assembly_from_document(document, "test", base)
    return caught.value


def test_bad_meshes_are_refused_naming_file_field_and_problem(tmp_path) -> None:
    vertices, faces = _box_mesh(tmp_path / "cube.stl")
    cases: dict[str, tuple[np.ndarray, np.ndarray]] = {
        "open.stl": (vertices, faces[:-1]),
        "flipped_one.obj": (vertices, np.vstack([faces[:-1], faces[-1:, ::-1]])),
        "inward.ply": (vertices, faces[:, ::-1]),
        "flat.obj": (vertices * [1.0, 1.0, 0.0], faces),
    }
    expected = {
        "open.stl": "not watertight: 3 open edge(s)",
        "flipped_one.obj": "inconsistently oriented",
        "inward.ply": "the faces point inward",
        "flat.obj": "degenerate face(s) of zero area",
    }
    for name, (v, f) in cases.items():
        import trimesh

        (tmp_path / name).write_bytes(
            trimesh.Trimesh(v, f, process=False).export(file_type=Path(name).suffix[1:])
            if name.endswith((".stl", ".ply"))
            else trimesh.Trimesh(v, f, process=False).export(file_type="obj").encode()
        )
        error = _error(_document(name), tmp_path)
        assert error.field == "bodies[1].meshes[0].file" and name in error.problem, error
        assert expected[name] in error.problem, error
    (tmp_path / "nan.obj").write_text(
        "v 0 0 0\nv 1 0 0\nv nan 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n"
    )
    assert "is not finite" in _error(_document("nan.obj"), tmp_path).problem
    missing = _error(_document("missing.stl"), tmp_path)
    assert "does not exist" in missing.problem and missing.field == "bodies[1].meshes[0].file"
    assert "unknown mesh format" in _error(_document("cube.igs"), tmp_path).problem
    (tmp_path / "garbage.ply").write_bytes(b"ply\nformat binary_little_endian 1.0\nend_header\n\x00\x01")
    assert "cannot read the mesh" in _error(_document("garbage.ply"), tmp_path).problem
    # Two million faces: refused from the declared count before parsing (a sparse 100 MB binary STL).
    huge = tmp_path / "huge.stl"
    with huge.open("wb") as handle:
        handle.write(b"\0" * 80 + struct.pack("<I", 2_000_000))
        handle.truncate(84 + 50 * 2_000_000)
    error = _error(_document("huge.stl"), tmp_path)
    assert "2000000 faces is more than the limit of 200000" in error.problem


def test_transforms_must_be_rigid_and_fields_are_named(tmp_path) -> None:
    _box_mesh(tmp_path / "cube.stl")
    stretch = [[2, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]
    mirror = [[-1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]
    projective = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0.5, 1]]
    assert "not a rigid transform" in _error(_document("cube.stl", transform=stretch), tmp_path).problem
    assert "reflection" in _error(_document("cube.stl", transform=mirror), tmp_path).problem
    assert _error(_document("cube.stl", transform=projective), tmp_path).field.endswith("transform[3]")
    assert _error(_document("cube.stl", transform=[[1, 0]]), tmp_path).field.endswith("transform")
    assert _error(_document("cube.stl", scale=0), tmp_path).field == "bodies[1].meshes[0].scale"
    assert _error(_document("cube.stl", colour=1), tmp_path).field == "bodies[1].meshes[0].colour"
    # A rotation about z by 90 degrees and a translation: accepted, vertices moved rigidly.
    turn = [[0, -1, 0, 0.5], [1, 0, 0, 0.0], [0, 0, 1, 0.0], [0, 0, 0, 1]]
    assembly = assembly_from_document(_document("cube.stl", transform=turn, scale=0.5), "t", tmp_path)
    mesh = assembly.bodies[1].meshes[0]
    assert np.allclose(mesh.lower, [0.0, 0.0, 0.0]) and np.allclose(mesh.upper, [0.5, 0.5, 0.5])
    assert assembly.bodies[1].mass == pytest.approx(0.125)
    assert np.allclose(assembly.bodies[1].center, [0.25, 0.25, 0.25])


def test_relative_paths_need_a_base_and_absolute_ones_do_not(tmp_path) -> None:
    _box_mesh(tmp_path / "cube.stl")
    text = json.dumps(_document("cube.stl"))
    with pytest.raises(InputError, match="needs a base directory"):
        assembly_from_text(text, "assembly_yaml")
    assert assembly_from_text(text, "assembly_yaml", tmp_path).bodies[1].meshes
    absolute = json.dumps(_document(str(tmp_path / "cube.stl")))
    assert assembly_from_text(absolute, "assembly_yaml").bodies[1].meshes


def test_interpenetrating_meshes_are_named_with_their_depth(tmp_path) -> None:
    _box_mesh(tmp_path / "cube.stl")
    document = _document("cube.stl")
    # 'other' stands beside 'part' on the floor, overlapping it by 0.25 m along x.
    document["bodies"].append({"name": "other", "meshes": [{"file": "cube.stl"}]})
    document["bodies"][1]["meshes"][0]["transform"] = [
        [1, 0, 0, 0.75],
        [0, 1, 0, 0],
        [0, 0, 1, 0],
        [0, 0, 0, 1],
    ]
    error = _error(document, tmp_path)
    assert (
        "'part'" in error.problem
        and "'other'" in error.problem
        and "interpenetrate by 0.25 m" in error.problem
    )
    # Resting on the floor (touching, not overlapping): accepted, with the four corners as contact points.
    assembly = assembly_from_document(_document("cube.stl"), "t", tmp_path)
    contacts = auto_contacts(assembly)
    assert len(contacts) == 4 and all(np.allclose(c.normal, [0, 0, 1]) for c in contacts)


def test_broad_phase_matches_all_pairs_and_stays_linear_on_1000_bodies() -> None:
    """The sweep finds exactly the brute-force pairs; on 1,000 bodies it yields O(n) candidates (the time is
    a bench row: bench_assembly.py, 'contacts of 1,000 bodies')."""
    rng = np.random.default_rng(3)
    lower = rng.uniform(0, 10, (150, 3))
    upper = lower + rng.uniform(0.1, 3.0, (150, 3))
    brute = [
        (i, j)
        for i in range(150)
        for j in range(i + 1, 150)
        if np.all(np.minimum(upper[i], upper[j]) - np.maximum(lower[i], lower[j]) >= -0.01)
    ]
    assert touching_pairs(lower, upper, 0.01).tolist() == [list(p) for p in brute]
    assembly = assembly_from_document(random_assembly(1, 1000, walls=True))
    parts = [p for b in assembly.bodies for p in b.pieces]
    assert len(parts) > 1000
    pairs = touching_pairs([p.lower for p in parts], [p.upper for p in parts], 1e-7 * assembly.size)
    assert len(pairs) < 4 * len(parts)
    assert len(auto_contacts(assembly)) >= 4 * 900


def test_stepped_stack_generator_matches_between_boxes_and_meshes_in_volume(tmp_path) -> None:
    boxes = assembly_from_document(stepped_stack(None))
    meshes = assembly_from_document(stepped_stack(tmp_path / "m"), "t", tmp_path)
    assert [b.mass for b in boxes.bodies] == pytest.approx([b.mass for b in meshes.bodies], rel=1e-12)


def test_mesh_surface_distance_is_exact_at_faces_edges_and_corners() -> None:
    stack = load_assembly(EXAMPLES / "stepped_stack_meshes.yaml")
    (cube,) = stack.bodies[stack.index["block"]].meshes  # the unit cube [1, 2] x [0, 1] x [1, 2]
    for point, expected in (
        ((1.5, 0.5, 1.5), 0.5),  # inside: the nearest faces
        ((1.5, 0.5, 2.3), 0.3),  # above the top face
        ((2.3, 1.4, 1.5), np.hypot(0.3, 0.4)),  # beside an edge
        ((2.3, 1.4, 2.3), np.sqrt(0.09 + 0.16 + 0.09)),  # beyond a corner
        ((1.25, 0.0, 1.75), 0.0),  # on a face
    ):
        assert cube.surface_distance(np.array(point)) == pytest.approx(expected, abs=1e-12), point


@pytest.mark.parametrize(("z", "accepted"), [(1.0, True), (5.0, False)])
def test_explicit_contacts_on_mesh_bodies_are_checked_against_the_mesh_surface(
    z: float, accepted: bool
) -> None:
    text = (
        (EXAMPLES / "stepped_stack_meshes.yaml")
        .read_text()
        .replace(
            "contacts: auto",
            f"contacts:\n- {{a: block, b: l_shape, point: [1.5, 0.5, {z}], normal: [0, 0, 1]}}",
        )
    )
    if accepted:
        (contact,) = assembly_from_text(text, "stack", base_dir=EXAMPLES).explicit_contacts or ()
        assert contact.point[2] == z
    else:
        with pytest.raises(InputError, match=r"contacts\[0\]\.point.*from the surface of body 'block'"):
            assembly_from_text(text, "stack", base_dir=EXAMPLES)


def test_mesh_triangles_of_a_whole_assembly_are_limited_as_they_are_read(monkeypatch) -> None:
    import feeder_planner.assembly.model as model

    stack = (EXAMPLES / "stepped_stack_meshes.yaml").read_text()
    monkeypatch.setattr(model, "MAX_ASSEMBLY_MESH_FACES", 30)  # the floor alone has 12, the L shape more
    with pytest.raises(
        InputError, match=r"bodies\[\d\]\.meshes: \d+ mesh triangles in all exceed the limit of 30"
    ):
        assembly_from_text(stack, "stack", base_dir=EXAMPLES)
