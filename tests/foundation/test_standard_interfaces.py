"""Standard interface packages built in this workspace are the standard's, hash for hash.

The registry's Jazzy wheels lack some standard interface packages (``tf2_msgs``), so the workspace builds
them from the standard's definitions (``standard_interfaces/``). A full ROS 2 install must see no
difference: every type's RIHS01 hash (REP 2011: the hash of the type description, fields and nested
types included) must equal the hash of the standard's own definitions. The expected values below were
computed by building the standard's package itself, at the named repository, branch and commit, with the
rosidl generators of this workspace; a changed field, type or constant name changes them.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

STANDARD = {
    # ros2/geometry2, branch jazzy, commit 646342c6164e837d69460e3d28e7a025396544f6 (tf2_msgs 0.36.4)
    "tf2_msgs": {
        "msg/TFMessage": "e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087",
        "msg/TF2Error": "db2485e7d6a0ec75bf087e058ee45df682acc3a621ca7780503d10aac141809a",
        "srv/FrameGraph": "0d1fbc6222c018ba5f33822904a2fdd4063705289956d3fdde07cd8c50fe8067",
        "srv/FrameGraph_Request": "4cc565da6b64726d0b0be1ce20f3a3a695679b841a79abfca2fcdc94f562b08d",
        "srv/FrameGraph_Response": "e33d5473ce0fac04c66203779f2b719a9de0f8388b248852d3a47a019e62e36d",
        "action/LookupTransform": "0b8adf6bc0b5958879e3265b41a457e03558fe523890a81252c70eba97a82c5d",
        "action/LookupTransform_Goal": "815efc294ad17c813c6043cdde781ff55810d49da02ed07f9237dcd20e88d498",
        "action/LookupTransform_Result": "061d4423af5352ff5314c8effef8faab133991a78f1b2bcd1fecabad80871225",
        "action/LookupTransform_Feedback": "2da0b02f990f04404ab8c98a2a68cf5bbc773ae747f96911f2d55499cfb51542",
    },
}


def expected(package: str) -> dict[str, str]:
    """The standard's hashes of a package, by full type name."""
    return {f"{package}/{name}": f"RIHS01_{value}" for name, value in STANDARD[package].items()}


def built_hashes(package: str) -> dict[str, str]:
    """Every type hash the built package's type descriptions record, by type name."""
    from ament_index_python.packages import get_package_share_directory

    share = Path(get_package_share_directory(package))
    found: dict[str, str] = {}
    for path in sorted(share.glob("*/*.json")):
        for entry in json.loads(path.read_text())["type_hashes"]:
            found[entry["type_name"]] = entry["hash_string"]
    return found


@pytest.mark.parametrize("package", sorted(STANDARD))
def test_every_standard_type_built_here_has_the_standards_hash(package: str) -> None:
    built = built_hashes(package)
    assert built, f"{package} is not built in this workspace (make setup builds standard_interfaces/)"
    wrong = {name: built.get(name) for name, value in expected(package).items() if built.get(name) != value}
    assert wrong == {}, f"{package} differs from the standard: {wrong}"
    # and nothing of ours slipped into the standard package
    kinds = {name.split("/")[1] for name in built if name.startswith(f"{package}/")}
    assert kinds <= {"msg", "srv", "action"}
    interfaces = {name for name in built if name.startswith(package) and "_" not in name.rpartition("/")[2]}
    assert interfaces == {name for name in expected(package) if "_" not in name.rpartition("/")[2]}


@pytest.mark.ros
def test_a_tf_publisher_offers_the_standard_type_and_hash_on_the_wire() -> None:
    import rclpy
    from rclpy.node import Node

    from feeder_planner.node_kit.tf import TFMessage

    assert TFMessage.__module__.startswith("tf2_msgs"), "node_kit.tf publishes the standard tf2_msgs type"
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        node = Node("standard_interface_probe", context=context)
        node.create_publisher(TFMessage, "/standard_interface_probe_tf", 1)
        (info,) = node.get_publishers_info_by_topic("/standard_interface_probe_tf")
        assert info.topic_type == "tf2_msgs/msg/TFMessage"
        assert str(info.topic_type_hash) == expected("tf2_msgs")["tf2_msgs/msg/TFMessage"]
        node.destroy_node()
    finally:
        rclpy.shutdown(context=context)
