"""A CAD part file as the devices' part_file: the throwing arm configures from a DXF or SVG as from its
YAML twin and publishes the outline as read, which rebuilds the same part (issue 39 item 3)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from feeder_planner.parts import load_part, part_document, part_from_mapping
from feeder_sim.throwing.loading import configured_part
from feeder_sim.throwing.parameters import ArmParameters, configure_arm

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.mark.parametrize("suffix", ["dxf", "svg"])
def test_the_arm_configures_from_a_cad_twin_as_from_its_yaml(suffix: str) -> None:
    yaml_arm = configure_arm(ArmParameters(part_file=str(EXAMPLES / "throwing/triangle.yaml")))
    p = ArmParameters(part_file=str(EXAMPLES / f"throwing/triangle.{suffix}"))
    cad_arm = configure_arm(p)
    assert (cad_arm.edge, cad_arm.radius) == pytest.approx((yaml_arm.edge, yaml_arm.radius), rel=1e-12)
    held = configured_part(p, cad_arm.part)
    assert held.name == "triangle" and held.document["length_unit"] == "m"
    rebuilt = part_from_mapping(held.description())
    np.testing.assert_allclose(rebuilt.file_vertices, cad_arm.part.part.file_vertices, rtol=0, atol=1e-18)


def test_a_plain_yaml_document_is_returned_as_written() -> None:
    document = part_document(EXAMPLES / "mems/washer.yaml")
    assert document["length_unit"] == "mm" and document["vertices"][1] == [5, 0]


def test_the_washer_twin_document_keeps_its_hole() -> None:
    document = part_document(EXAMPLES / "mems/washer.dxf")
    twin = load_part(EXAMPLES / "mems/washer.yaml")
    rebuilt = part_from_mapping(document)
    assert len(rebuilt.holes) == 1
    assert rebuilt.area == pytest.approx(twin.area, rel=1e-12)


@pytest.mark.parametrize("suffix", ["dxf", "svg"])
def test_the_mems_array_configures_from_a_cad_twin_as_from_its_yaml(suffix: str) -> None:
    import dataclasses

    from feeder_sim.mems.configure import configure_scene
    from feeder_sim.mems.parameters import MemsParameters

    path = EXAMPLES / "mems" / f"washer.{suffix}"
    scene = configure_scene(dataclasses.replace(MemsParameters(), part_files=[str(path)]))
    # What the array publishes on ~/parts: the outline and the hole as read, which rebuild the same part.
    (document,) = scene.documents
    assert document["holes"], "the washer's hole was lost"
    rebuilt, original = part_from_mapping(document), load_part(EXAMPLES / "mems" / "washer.yaml")
    assert len(rebuilt.loops()) == len(original.loops()) == 2
    assert np.isclose(rebuilt.mass, original.mass, rtol=1e-3)
