"""Over DDS: the region planner and the fixture take mesh assemblies (files, and YAML text in requests)."""

from __future__ import annotations

import pytest
import ros_harness
from conftest import EXAMPLES

pytestmark = pytest.mark.ros

PALLET = str(EXAMPLES / "mesh_pallet.yaml")
REGION = "/stable_region_planner/stable_region"


@pytest.fixture(scope="module")
def nodes(launch_module_node):
    launch_module_node(
        "feeder_planner",
        "stable_region_planner",
        parameters={"assembly_file": PALLET, "mesh_base_dir": str(EXAMPLES)},
        wait_services=(REGION,),
        wait_topics=("/stable_region_planner/region",),
    )
    launch_module_node(
        "feeder_sim",
        "assembly_fixture",
        parameters={"assembly_file": PALLET},  # every body a mesh; its markers draw them
        wait_topics=("/assembly_fixture/stability",),
    )
    return True


def _region(ros_client, text: str):
    from feeder_msgs.srv import StableRegion

    return ros_harness.call_service(
        ros_client, StableRegion, REGION, StableRegion.Request(assembly_yaml=text)
    )


def test_planner_and_fixture_load_a_mesh_assembly_file(nodes, ros_client) -> None:
    from feeder_msgs.msg import StabilityRegion, StabilityStatus
    from feeder_planner.assembly.model import load_assembly
    from feeder_planner.assembly.planner import prepare
    from feeder_planner.node_kit import LATCHED

    expected = prepare(load_assembly(PALLET)).region
    (latched,) = ros_harness.collect(
        ros_client, StabilityRegion, "/stable_region_planner/region", count=1, qos=LATCHED
    )
    assert latched.kind == "region" and latched.area_sr == pytest.approx(expected.area_sr, abs=1e-12)
    status = ros_harness.collect(ros_client, StabilityStatus, "/assembly_fixture/stability", count=1)[0]
    # The fixture starts level: gravity straight down, inside the pallet's region.
    assert status.stable and status.margin > 0 and status.forces


def test_request_meshes_resolve_against_the_base_directory_and_bad_paths_are_named(nodes, ros_client) -> None:
    from feeder_planner.assembly.model import load_assembly
    from feeder_planner.assembly.planner import prepare

    boxes = prepare(load_assembly(EXAMPLES / "stepped_stack_boxes.yaml")).region
    response = _region(ros_client, (EXAMPLES / "stepped_stack_meshes.yaml").read_text())
    assert response.ok, response.error
    assert response.region.kind == "region" and response.region.area_sr == pytest.approx(
        boxes.area_sr, abs=1e-9
    )
    missing = (EXAMPLES / "stepped_stack_meshes.yaml").read_text().replace("steps_block.obj", "no_block.obj")
    response = _region(ros_client, missing)
    assert not response.ok
    assert "assembly_yaml (bodies[2].meshes[0].file)" in response.error and "does not exist" in response.error
    not_rigid = (
        (EXAMPLES / "stepped_stack_meshes.yaml")
        .read_text()
        .replace(
            "file: meshes/steps_bar.stl",
            "file: meshes/steps_bar.stl, transform: [[2,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]",
        )
    )
    response = _region(ros_client, not_rigid)
    assert not response.ok and "bodies[3].meshes[0].transform" in response.error and "rigid" in response.error
    # Still serving after the refusals.
    assert _region(ros_client, (EXAMPLES / "dovetail_joint.yaml").read_text()).region.kind == "great_circle"
