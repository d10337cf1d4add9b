"""Standard interface packages built in this workspace are the standard's, hash for hash.

The registry's Jazzy wheels lack some standard interface packages (``tf2_msgs``, ``simulation_interfaces``),
so the workspace builds them from the standard's definitions (``standard_interfaces/``). A full ROS 2
install must see no difference: every type's RIHS01 hash (REP 2011: the hash of the type description, fields
and nested types included) must equal the hash of the standard's own definitions. The expected values below
were computed by building the standard's package itself, at the named repository, branch and commit, with
the rosidl generators of this workspace; a changed field, type or constant name changes them.
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
    # ros-simulation/simulation_interfaces, branch jazzy (tag 1.5.1), commit
    # a3c60ff2715dbe5e9d5cddce410d9a7ffe771960 (simulation_interfaces 1.5.1)
    "simulation_interfaces": {
        "msg/Bounds": "e8624fe51f0f5548197542697d924c5699ac7198f1e4c68e50c3ca2af73f5b3f",
        "msg/EntityCategory": "43bdf7933fddf75f6970f7a8fe7078524355d821d390b3954bb46ac36c03dfe1",
        "msg/EntityFilters": "8e7b12e8ea062f14c55de4877221fe1b7cd9749665a7ad8a4ab855fc4b148303",
        "msg/EntityInfo": "3b9a2e7fa00f9a59d325b6e47904044c421561a385682027c7fc06c359806319",
        "msg/EntityState": "2e0464a85eb80a939025075d6c20761eca6a4cb9d6baf2c0ba373467c8b598d0",
        "msg/NamedPose": "b32da2a039b1840f605ec025b7991a18efacac662fac272818d1ae6e2b12bc27",
        "msg/Resource": "2bb1939cf80f8d2f284afba53cbec60b5ff33759bd39b714128ea8867a34c51a",
        "msg/Result": "cf43a306adff3337a0a47143d8f5689933bc70a30478f13b077dc1fe3bc5ad17",
        "msg/SimulationState": "bb9f87ccdd98fba113052a512d9801e84ce732d0a2b3c2b0cb281828de36e415",
        "msg/SimulatorFeatures": "8b101c8529bc0ea3dcf056078254768f39832b9ef0adaf93bd5cea96c0de3305",
        "msg/SpawnEntity": "94a349a865ccf673c18c080520299c88c3d8d5f4842ecf1482d6c997ac4b69f9",
        "msg/SpawnResult": "dbc277304b6c24bfb2a631cea8f52e2b005d583ec0a6c86b11613f5ce6486da1",
        "msg/Spawnable": "8c22025d840e7a05ab31ba56f998b06458b549a9744b4695be25b778829fc176",
        "msg/TagsFilter": "5c3efc51e8ed04c266c09cb4691ec95b964cd410558e01d8c83646b038826b45",
        "msg/WorldResource": "e3b65ecf904b9b115673e4a343c6aa3d28c19e185a71228faa64b783afcf2403",
        "srv/DeleteEntity": "ff7e96a5b83dc8e2bb34b8b034480028b3a24d9f8376b2c0590bac3704be3e28",
        "srv/DeleteEntity_Request": "4b41b2ebdc313a0c98c7c2218849edc8b7b905fd759a23b68c576496a47dc792",
        "srv/DeleteEntity_Response": "2f68929b527a3bbee03637a1c8192f2aa2982807738389aa0781f8e785673ca7",
        "srv/DeleteEntity_Event": "6850423be1d45755566343794fb56be8ff3c90fc87706b7ea939764499a9d773",
        "srv/GetAvailableWorlds": "ce5589b5523f2732d1969a3c5a7e6b17a387091df8190c62f78d7fdd1109e3e3",
        "srv/GetAvailableWorlds_Request": "6335180e35038ba62eb2bae3d1c1bacd4b7791209137eacbddfee12629bf6c3a",
        "srv/GetAvailableWorlds_Response": "0ce98a1547f1852fd6d95f794ae4bae8b1d97b9cfa83ea22b80f634999234a18",
        "srv/GetAvailableWorlds_Event": "d3ddd4cef845a1d6fbe402a376963b1fbcedd066fdd9b7afccd32fac73ec9135",
        "srv/GetCurrentWorld": "79ed4e910e1b7a1c9f7950ff758bfba3535bf0dec669054e8af115a099724ddd",
        "srv/GetCurrentWorld_Request": "414ac6e1c5fd5f8be0b828ca7ff8cbee7166297809de31a36129f1d0913cd877",
        "srv/GetCurrentWorld_Response": "039f99eb4e156ac597efed7598249921f8e47e5bff8c299d86ab081983a3a52a",
        "srv/GetCurrentWorld_Event": "902c9e9dbb35203e71f734410d7b8c0ec94fa8191fb04287a936a72dd713d5c0",
        "srv/GetEntities": "cb90004c48cd50f37732fb008e22c34c261dd680a723bf0f85d8437ea4498bf7",
        "srv/GetEntities_Request": "f0a4c6c0c39c87f84cbd1ea31956b9f39b3fa538ae9c4aa7fc243a32360e8c70",
        "srv/GetEntities_Response": "dd1916edbdc659d355e77980b16ed6eb4d41d5ff445557931ed65c58b00f7b2c",
        "srv/GetEntities_Event": "c26cff3c94ca0df967f9f223af89340dcb6becb05b9d32544eb84cac0e85ca8d",
        "srv/GetEntitiesStates": "0a76170d0c1c90e1eaf805cfab78ea801d1f82df309a28c1f0fae4b570f19754",
        "srv/GetEntitiesStates_Request": "0af5302d3526834e83bd9861fbcc5214af2b9a4b0c93a965840fb1a6c2891724",
        "srv/GetEntitiesStates_Response": "b651848f4d93a2b0ec5ec3f36659297ca30547c499f933eb279b60f8be434315",
        "srv/GetEntitiesStates_Event": "3bfcf28a7087002f7f5be3539f5d069b660227c3f81e0e3195981e13a56d8b3d",
        "srv/GetEntityBounds": "17be8d36231178a5eed0de0344b55c19975581627a9aec30a4fee9926a35deed",
        "srv/GetEntityBounds_Request": "41766afd481abfa03a9dface86a487e317da516333af3f5b017df248dd5d7fee",
        "srv/GetEntityBounds_Response": "728d414a3be6d7689fad9d3218c8378c68fbe08c2cfbf9878ac14de713fcf4c1",
        "srv/GetEntityBounds_Event": "12525654c3c1271da06ce976dd1ab72920fbe3879768c4b53f1074b9b98f05bb",
        "srv/GetEntityInfo": "953b7ab6bfc35063f5c9a72463c6ce489baa10249a7fa510926d342a34b0d29e",
        "srv/GetEntityInfo_Request": "9bdd2628d931108734e304ae1fac80d268a46783fa0060d4a43831c54c30f3b3",
        "srv/GetEntityInfo_Response": "eaa358f007b09b06645f93b5a1c6ae0389f27bee7747e760122994ab1308e1c8",
        "srv/GetEntityInfo_Event": "925bdd1efc19b29c5548add7ffa4a7821b5533d90f25d73673d8978f9f0ad206",
        "srv/GetEntityState": "749c91f2a2353d98367b64f2995a0f5842ce92a08ec1ffb3e185540a91557fb5",
        "srv/GetEntityState_Request": "580141cc957c4ee99a7e46bc545db351ab9ce6c3099d4092b1186ddc6a38bd5a",
        "srv/GetEntityState_Response": "125f1ca9dc2fc072443deb28587bbb1026fa34db4dfaf59e9a6b7128e0c81331",
        "srv/GetEntityState_Event": "5c4a353980893294fce5fca5a1359ec0c821578acc263f56db8042b35ced68e6",
        "srv/GetNamedPoseBounds": "59fa8dd2c68ba6771160cc66a628ac99fa95e2748fa0a43c2cc62a2e5f3f6fdc",
        "srv/GetNamedPoseBounds_Request": "4a62596dff6478d6424267da8933b1446992f61c70c2c196aa36258a1f1d133f",
        "srv/GetNamedPoseBounds_Response": "db03610df68de520b420ccc9dc8826a92547ab9e791ac2a36a7dc86e8f2aa180",
        "srv/GetNamedPoseBounds_Event": "b3e0f071e2350276bc9f5ac23a19b0a7dcaea7add138439ccd986b22db4aad0a",
        "srv/GetNamedPoses": "c3d12ab920115bfd4733f6d20516adc3968fb438538540997c37e200e02b04e3",
        "srv/GetNamedPoses_Request": "3d85f7553c5fcb491256b6eab66204ee590edbd0ad2dd53bb4ddf8a95f16af6e",
        "srv/GetNamedPoses_Response": "d0459c9da6adb831b3755778bc348cc88ad2b22fe864a11062df20610a12c320",
        "srv/GetNamedPoses_Event": "721dfb79239fd5585b94ec7f18046c7d08f8aa97d0755bbad3b27ac32a165393",
        "srv/GetSimulationState": "3362dcebee4b1afebbf9c4beee5c79c1455385aded62092a892d61fde8644f30",
        "srv/GetSimulationState_Request": "c6d65bc5c0a95ca2886bc57f146f803e01722c84ddb5acd5f32a4417f55eecfb",
        "srv/GetSimulationState_Response": "dc80ce852a5ab04c2b23cdd47910cee1bcc46e0f1931cac85825e6916b15517f",
        "srv/GetSimulationState_Event": "34cdb4f06989af235d3403650bae196550a928870b69740899fadc922899748f",
        "srv/GetSimulatorFeatures": "abb9439c8cf196722a469fb6c68b44b484f198c2a1356ac38849a29c2a20a794",
        "srv/GetSimulatorFeatures_Request": "982b8c1adef1d556f6ecdc019d1269fc39413626a9222d73b4fc874bd798b7db",  # noqa: E501
        "srv/GetSimulatorFeatures_Response": "ede4dc8227cbb2f86a24612c999dcaa67d17dab21dab566cefdc233e7a2a65d1",  # noqa: E501
        "srv/GetSimulatorFeatures_Event": "2716384dc5445ebe9e7eda1021e5739b8c62ab985dccc3c506ba840c67e810b8",
        "srv/GetSpawnables": "3bc0266bf8236058ff589c44512e013afe4f295427c39d44cff363d1c956bf36",
        "srv/GetSpawnables_Request": "3e1d1577446a80da956db3e82363c2d66364f9802f6e9572d89497933207d921",
        "srv/GetSpawnables_Response": "4e532ac531e2d0bb495a8b53409a8025551f55329250537a3d5a28c5d7ce36af",
        "srv/GetSpawnables_Event": "e80a5cad9a3792e0a068c0d9782647cc26d3701e77af0743a757e1c264b0f58b",
        "srv/LoadWorld": "f210682338f195f6f06191b46b20ec4992bddf485d33e2cffab2dd15341b4e3e",
        "srv/LoadWorld_Request": "f683da497d911d5b8d8191c457d4dd90b39ceb1a7c3ec8e2f2adf89ee6721851",
        "srv/LoadWorld_Response": "7bab3265c2461d98a44dd04830c5dc997b3d8605c50861824066246c96a7716e",
        "srv/LoadWorld_Event": "1b36da46dafd603502b9945ff4f01b1154d639d8d475da00e3b4227233b2b172",
        "srv/ResetSimulation": "4ce285d7ff9b8ac70dcc95161f32bf54c05a6f4b13427990e41ab40c36c39646",
        "srv/ResetSimulation_Request": "2c766d09c3aa30f01fadc55a42fd760b63db358c7d1d3b6a64ea9978225ffbc7",
        "srv/ResetSimulation_Response": "718428121e0f1755720878d3c28f1688da7581ee5a5d56d26d10d941a28a50a0",
        "srv/ResetSimulation_Event": "dd7cbcb886e466ab23216c7033f25e8534e5255a73877944338bb301e7b29626",
        "srv/SetEntityInfo": "867fe2b6812f3e021859171f9b788560d66bb7079d640030baf6c0bb2dd2631e",
        "srv/SetEntityInfo_Request": "d80ba71f092c702485bdffcd35713793866df4e1a16ace6632c6d4a15bb1eb55",
        "srv/SetEntityInfo_Response": "d17b31f0f6db0146ceb0b711d47dbf81c9c11c87ca4f64cfa671a95d9723c3d6",
        "srv/SetEntityInfo_Event": "02fa040f4ae8a026ed9f8b9dbd09c589fbce019f9e3623b3c90e076e8ee9fe75",
        "srv/SetEntityState": "ca210e7d2b66629ae133c8e1edf5246e618106d75c78ed0556c0e7a33c59ee5e",
        "srv/SetEntityState_Request": "95cdfbffcd9c4d0133b2079bdcadd4420ce86dd255c11a3dfed7f9f907fd304d",
        "srv/SetEntityState_Response": "bbd9bcb2def000f1ed8cb9482abff46c5a11cfe4184203f336b920f249d757f4",
        "srv/SetEntityState_Event": "4dbb2f7b3b12af1b7b3cf68402e09994422fe76008b1efa7580a3a9386fa40d0",
        "srv/SetSimulationState": "a868b916dce49974f637ba252141258c4b07b0c06858b88af560e3eb6bfbcb30",
        "srv/SetSimulationState_Request": "73283477d36ba619db2ac37a3e599077ca244502c9d8ca2a7183afcb2224f476",
        "srv/SetSimulationState_Response": "6351aebf2bbf06e2993977918b944240f7403b532a9e4a344c53e71a56afd174",
        "srv/SetSimulationState_Event": "aea08cbc96bd8c6c88ba9ab79f98a73bf3028c35ea8e1f47bf5fc9d82cbc6b9a",
        "srv/SpawnEntities": "41703a359ee032bf4fc230f144f531705ba039a2e97edeae1f7997dd83b04857",
        "srv/SpawnEntities_Request": "03f070057ac2ab26d723fe9f07c7d57bd39ace34ad34bb043cdbca36825c98d9",
        "srv/SpawnEntities_Response": "85df56d44250220df64762bf3e769cce45f84730eff8b9823093ca3041ecbbf5",
        "srv/SpawnEntities_Event": "2ad607727595abd8bd06e3eab4a425615c44b370837a266b3d654994dfa87ee0",
        "srv/SpawnEntity": "d4c086345d4194a5fc4c9ae45095736ca4062b5cdac4d06a42dec93d683e03cf",
        "srv/SpawnEntity_Request": "fdcf97087f59eed1ad0b75696ea97ffbb44d104f62f177fcd5a31ab67c6fc923",
        "srv/SpawnEntity_Response": "be8c9fc03b6faaf95570949c80195c8ca75dd99f7efc23262309d497b2923982",
        "srv/SpawnEntity_Event": "05e6108bc39b5953a6163952541a1cec1991a74558a128c65b03b27b3ec34c61",
        "srv/StepSimulation": "913fe0653690ce6bf8f09f316e6a626747012e9fca31e26719910d417aa8565c",
        "srv/StepSimulation_Request": "cda33f6887815f3dce0f90e61fd8efd39bda13ae264ddede15c33fbad890630e",
        "srv/StepSimulation_Response": "5b4acf2d0ce7c3fc125d0bef2acb9b5a81377e80db6b696b81beeffb9824fb5c",
        "srv/StepSimulation_Event": "1796fda54ba381a56d32c10784cabf78e14d6c8a1912a515a47d6597ad431d90",
        "srv/UnloadWorld": "ac7f9a73df1b5b15015d854c5ac552b7726506e22f886c6792804f0b7f88b30b",
        "srv/UnloadWorld_Request": "22b41a53aecd3cd180a218b16d9428cddc10b9e592ae16eaa434be873387e972",
        "srv/UnloadWorld_Response": "68d4ea5721903837edd7c7e90d86e62aafb861c1ace33b7c805931974a652d9e",
        "srv/UnloadWorld_Event": "3162d5a68097988260c3a9a65cfd99f788a4a0b00d164bff67a5e7230cbff829",
        "action/SimulateSteps": "f0837c898e1219cd73bf4c041feab41e8c533e8e1057e982744dba7b093467eb",
        "action/SimulateSteps_Goal": "3f02c5df1dcdc7c08efee7f47c953c42c11686e0df8f8bbfb2d7e901f0d440d2",
        "action/SimulateSteps_Result": "a1384eaee4ca7ae9238e612dfe26939dd0922cae664be1b5886cf773718823dc",
        "action/SimulateSteps_Feedback": "735661ca01115eb9bca068c3f2cb79bd790cd46962317ce7ee9081a5915c9a77",
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
