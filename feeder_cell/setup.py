"""Build script of the feeder_cell ament_python package."""

from setuptools import find_packages, setup

PACKAGE = "feeder_cell"

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
            "feeder = feeder_cell.cli.main:run",
            "cell_clock = feeder_cell.nodes:cell_clock_main",
            "cell_controller = feeder_cell.nodes:cell_controller_main",
            "cell_simulation = feeder_cell.nodes:cell_simulation_main",
            "opcua_gateway = feeder_cell.nodes:opcua_gateway_main",
        ],
    },
)
