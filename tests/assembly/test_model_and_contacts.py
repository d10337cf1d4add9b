"""Assembly files: mass properties from geometry, automatic contact polygons, bad input naming the field."""

from __future__ import annotations

import math

import numpy as np
import pytest

from feeder_planner.assembly.contacts import assembly_contacts
from feeder_planner.assembly.model import assembly_from_document, assembly_from_text
from feeder_planner.errors import InputError


def _doc(*bodies, mu=0.2, **extra):
    return {"name": "t", "length_unit": "m", "mu": mu, "bodies": list(bodies), **extra}


BASE = {"name": "base", "grounded": True, "boxes": [{"min": [0, 0, 0], "max": [4, 4, 1]}]}


def test_mass_and_centre_of_a_union_of_overlapping_boxes() -> None:
    # Two overlapping boxes forming an L: volume and centroid by inclusion-exclusion, computed by hand.
    body = {
        "name": "l",
        "density": 2.0,
        "boxes": [{"min": [0, 0, 0], "max": [3, 1, 1]}, {"min": [0, 0, 0], "max": [1, 1, 2]}],
    }
    assembly = assembly_from_document(_doc(BASE | {"boxes": [{"min": [-5, -5, -1], "max": [5, 5, 0]}]}, body))
    l_shape = assembly.bodies[1]
    assert l_shape.mass == pytest.approx(2.0 * 4.0)  # 3 + 2 - 1 overlapping unit cube
    # Pieces: [0,3]x[0,1]x[0,1] (centroid 1.5, .5, .5) plus [0,1]x[0,1]x[1,2] (centroid .5, .5, 1.5).
    assert l_shape.center == pytest.approx((3 * np.array([1.5, 0.5, 0.5]) + np.array([0.5, 0.5, 1.5])) / 4)


def test_mass_of_a_convex_hull_piece_is_its_volume_times_density() -> None:
    tetra = [[0, 0, 1], [1, 0, 1], [0, 1, 1], [0, 0, 2]]
    assembly = assembly_from_document(_doc(BASE, {"name": "t", "density": 3.0, "convex": [tetra]}))
    assert assembly.bodies[1].mass == pytest.approx(3.0 / 6.0)
    assert assembly.bodies[1].center == pytest.approx([0.25, 0.25, 1.25])


def test_contact_polygon_is_the_intersection_of_the_touching_faces() -> None:
    block = {"name": "block", "boxes": [{"min": [3, 3, 1], "max": [5, 5, 2]}]}  # overhangs the base's corner
    assembly = assembly_from_document(_doc(BASE, block))
    contacts = assembly_contacts(assembly)
    points = sorted(tuple(c.point) for c in contacts)
    assert points == sorted([(3, 3, 1), (4, 3, 1), (3, 4, 1), (4, 4, 1)])
    assert all(np.allclose(c.normal, [0, 0, 1]) and c.a == 1 and c.b == 0 for c in contacts)


def test_units_scale_geometry_to_metres() -> None:
    document = _doc(BASE, {"name": "block", "boxes": [{"min": [1, 1, 1], "max": [2, 2, 2]}]})
    document["length_unit"] = "cm"
    assembly = assembly_from_document(document)
    assert assembly.bodies[1].mass == pytest.approx(1e-6)
    assert max(np.max(c.point) for c in assembly_contacts(assembly)) == pytest.approx(0.02)


def test_nearly_coplanar_faces_touch_and_a_real_gap_does_not() -> None:
    near = {"name": "near", "boxes": [{"min": [0, 0, 1 + 1e-9], "max": [1, 1, 2]}]}
    far = {"name": "far", "boxes": [{"min": [2, 2, 1 + 1e-3], "max": [3, 3, 2]}]}
    assembly = assembly_from_document(_doc(BASE, near, far))
    touching = {assembly.bodies[c.a].name for c in assembly_contacts(assembly)}
    assert touching == {"near"}


def test_edge_only_touching_gives_no_contact_polygon() -> None:
    # Two grounded-free bodies meeting only along a line (zero area): the paper assumes area > 0 (sec. II-B).
    block = {"name": "block", "boxes": [{"min": [4, 0, 1], "max": [5, 1, 2]}]}
    assembly = assembly_from_document(_doc(BASE, block))
    assert assembly_contacts(assembly) == []


def test_explicit_contacts_are_used_as_given() -> None:
    document = _doc(
        BASE,
        {"name": "block", "boxes": [{"min": [1, 1, 1], "max": [2, 2, 2]}]},
        contacts=[{"a": "block", "b": "base", "point": [1.5, 1.5, 1], "normal": [0, 0, 1], "mu": 0.0}],
    )
    contacts = assembly_contacts(assembly_from_document(document))
    assert len(contacts) == 1 and contacts[0].mu == 0.0


@pytest.mark.parametrize(
    "document, field, words",
    [
        (_doc({"name": "a", "boxes": [{"min": [0, 0, 0], "max": [1, 1, 1]}]}), "bodies", "no grounded body"),
        (
            _doc(BASE, {"name": "b", "boxes": [{"min": [1, 1, 0.5], "max": [2, 2, 2]}]}),
            "bodies",
            "interpenetrate",
        ),
        (
            _doc(BASE, {"name": "b", "boxes": [{"min": [1, 1, 1], "max": [1, 2, 2]}]}),
            "bodies[1].boxes[0]",
            "degenerate box",
        ),
        (
            _doc(BASE, {"name": "b", "convex": [[[0, 0, 1], [1, 0, 1], [0, 1, 1], [1, 1, 1]]]}),
            "bodies[1].convex[0]",
            "coplanar",
        ),
        (
            _doc(
                BASE,
                {
                    "name": "b",
                    "convex": [
                        {
                            "vertices": [[0, 0, 1], [1, 0, 1], [0, 1, 1], [0, 0, 2]],
                            "faces": [[0, 1, 2], [0, 1, 3], [1, 2, 3]],
                        }
                    ],
                },
            ),
            "bodies[1].convex[0].faces",
            "open polyhedron",
        ),
        (_doc(BASE, {"name": "b", "boxes": [{"min": [1, 1, 1], "max": [2, 2, 2]}]}, mu=-0.1), "mu", ">= 0"),
        (
            _doc(BASE, {"name": "b", "boxes": [{"min": [1, 1, float("nan")], "max": [2, 2, 2]}]}),
            "bodies[1].boxes[0].min[0]",
            "finite",
        ),
        (
            _doc(BASE, {"name": "base", "boxes": [{"min": [1, 1, 1], "max": [2, 2, 2]}]}),
            "bodies[1].name",
            "duplicate",
        ),
        (
            _doc(BASE, {"name": "b", "density": 0, "boxes": [{"min": [1, 1, 1], "max": [2, 2, 2]}]}),
            "bodies[1].density",
            "> 0",
        ),
    ],
)
def test_bad_assemblies_name_the_field(document: dict, field: str, words: str) -> None:
    with pytest.raises(InputError) as caught:
        assembly_from_document(document)
    assert caught.value.field == field
    assert words in str(caught.value)


def test_interpenetration_error_names_both_bodies() -> None:
    with pytest.raises(InputError, match="'base'.*'intruder'"):
        assembly_from_document(
            _doc(BASE, {"name": "intruder", "boxes": [{"min": [1, 1, 0.9], "max": [2, 2, 2]}]})
        )


def test_yaml_text_errors_name_the_source() -> None:
    with pytest.raises(InputError, match="assembly_yaml: <yaml>: not valid YAML"):
        assembly_from_text("bodies: [", "assembly_yaml")
    with pytest.raises(InputError, match="assembly_yaml: bodies"):
        assembly_from_text("name: x\n", "assembly_yaml")


def test_interpenetrating_convex_pieces_are_detected_by_separating_axes() -> None:
    wedge = [[0, 0, 1], [2, 0, 1], [0, 2, 1], [0, 0, 3]]
    cube = {
        "name": "cube",
        "convex": [[[x, y, z] for x in (0.2, 0.6) for y in (0.2, 0.6) for z in (1.2, 1.6)]],
    }
    with pytest.raises(InputError, match="interpenetrate"):
        assembly_from_document(_doc(BASE, {"name": "wedge", "convex": [wedge]}, cube))
    assert math.isfinite(
        assembly_from_document(_doc(BASE, {"name": "wedge", "convex": [wedge]})).bodies[1].mass
    )
