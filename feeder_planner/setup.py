"""Build script of the feeder_planner ament_python package."""

from setuptools import find_packages, setup

PACKAGE = "feeder_planner"

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
    description=(
        "The exact mechanics of the emulated feeders (numpy/scipy, no rclpy), "
        "the node kit every node shares, and the planner nodes."
    ),
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "field_equilibria_planner = feeder_planner.nodes:field_equilibria_planner_main",
            "throw_planner = feeder_planner.nodes:throw_planner_main",
            "stable_region_planner = feeder_planner.nodes:stable_region_planner_main",
            "squeeze_planner = feeder_planner.nodes:squeeze_planner_main",
        ],
    },
)
