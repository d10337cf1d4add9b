"""The processes a test process started that are still alive: none may be left when its session ends.

Used by conftest's session fixture ``no_leftover_processes``: with the suite spread over workers
(pytest-xdist), each worker looks at its own descendants when its share of the tests has ended.
"""

from __future__ import annotations

from pathlib import Path


def _is_resource_tracker(entry: Path) -> bool:
    """The stdlib's multiprocessing resource tracker (started for Dask's spawned workers).

    It is not a process the suite started but the interpreter's own helper: it lives exactly as long as
    this pytest process and ends with it, so it is no leftover. Everything else the tests start counts.
    """
    try:
        command = (entry / "cmdline").read_bytes().split(b"\0")
    except OSError:
        return False
    return b"from multiprocessing.resource_tracker import main" in b" ".join(command)


def descendants(root: int) -> list[tuple[int, str]]:
    """Return (pid, name) of every live process below ``root`` (zombies and the resource tracker aside)."""
    parents: dict[int, int] = {}
    names: dict[int, str] = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            names[int(entry.name)] = (entry / "comm").read_text().strip()
        except (OSError, IndexError):
            continue  # the process ended while we looked
        if fields[0] != "Z" and not _is_resource_tracker(entry):
            parents[int(entry.name)] = int(fields[1])
    found = []
    for pid in parents:
        ancestor = parents.get(pid)
        while ancestor is not None and ancestor != root:
            ancestor = parents.get(ancestor)
        if ancestor == root:
            found.append((pid, names.get(pid, "?")))
    return found
