"""Build script of the feeder_device ament_python package."""

from setuptools import find_packages, setup

PACKAGE = "feeder_device"

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
    description="The device kit: what every simulated device shares (lifecycle, status, faults, goals).",
    license="Apache-2.0",
)
