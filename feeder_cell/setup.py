"""Build script of the feeder_cell ament_python package."""

from pathlib import Path

from setuptools import find_packages, setup

PACKAGE = "feeder_cell"
# Every node module is an executable of its own name (docs/devices.md); its entry NAME_main is made on
# demand by feeder_cell.nodes (feeder_planner.entry_points.node_main), so a new node adds no line here.
NODES = sorted(p.stem for p in (Path(__file__).resolve().parent / PACKAGE / "nodes").glob("[a-z]*.py"))
NODE_SCRIPTS = [f"{node} = {PACKAGE}.nodes:{node}_main" for node in NODES]

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
        (f"share/{PACKAGE}/scenes", ["scenes/demo.yaml", "scenes/mems_only.yaml", "scenes/cell.yaml"]),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    description=(
        "What serves the whole feeder cell rather than one device: the feeder command, "
        "the scene launcher and scenes, the bag recorder and player, feeder doctor."
    ),
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            *NODE_SCRIPTS,
            "feeder = feeder_cell.cli.program:run",
        ],
    },
)
