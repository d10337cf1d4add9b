"""GetSpawnables: the part files in the sources a request (or the node's part_directories) names.

Only the file system and ``spawning.read_spawnable``: nothing of the cell's state, so it is apart from
the world. Both limits keep one request's work bounded whatever directory it names.
"""

from __future__ import annotations

from pathlib import Path

from feeder_cell.simulation.results import SimulationError
from feeder_cell.simulation.spawning import PART_SUFFIXES, read_spawnable

__all__ = ["MAX_SPAWNABLES", "MAX_FILES_PER_SOURCE", "spawnables"]

MAX_SPAWNABLES = 1000
# Files looked at per directory GetSpawnables is given: a huge directory is cut, not read whole.
MAX_FILES_PER_SOURCE = 5000


def spawnables(sources: list[str]) -> tuple[list[tuple[str, str]], list[str]]:
    """Return (uri, description) of every part file in ``sources``, and the sources found empty.

    A source is a directory (its part files, at most MAX_FILES_PER_SOURCE looked at) or a file.
    """
    found: list[tuple[str, str]] = []
    unrecognized: list[str] = []
    for source in filter(None, sources):
        path = Path(source.removeprefix("file://"))
        files = (
            sorted(path.iterdir())[:MAX_FILES_PER_SOURCE]
            if path.is_dir()
            else [path]
            if path.is_file()
            else []
        )
        if not files:
            unrecognized.append(source)
        for file in files:
            if len(found) >= MAX_SPAWNABLES or file.suffix.lower() not in PART_SUFFIXES:
                continue
            try:
                part = read_spawnable(str(file), "").part
            except SimulationError:
                continue  # a YAML file that is no part file (a program, a scene) is not spawnable
            found.append((f"file://{file.resolve()}", f"part {part.name} ({file.name})"))
    return found, unrecognized
