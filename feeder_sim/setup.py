"""Build script of the feeder_sim ament_python package."""

from setuptools import find_packages, setup

PACKAGE = "feeder_sim"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    description="Simulator nodes of the emulated feeders: MEMS field array, throwing arm, assembly fixture.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "mems_field_array = feeder_sim.nodes:mems_field_array_main",
            "throwing_arm = feeder_sim.nodes:throwing_arm_main",
            "assembly_fixture = feeder_sim.nodes:assembly_fixture_main",
            "squeeze_gripper = feeder_sim.nodes:squeeze_gripper_main",
        ],
    },
)
