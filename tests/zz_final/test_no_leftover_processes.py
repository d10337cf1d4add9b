"""Runs last (directories are collected in name order): no process started by the suite is still alive."""

from __future__ import annotations

import os
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


def _descendants(root: int) -> list[tuple[int, str]]:
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


def test_no_process_started_by_the_suite_is_left_running(started_processes) -> None:
    for node in started_processes:
        node.stop()
    assert all(not node.alive() for node in started_processes)
    assert _descendants(os.getpid()) == []
