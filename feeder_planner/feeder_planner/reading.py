"""The one reading layer of input files: bounded size, regular files only, strict UTF-8, bounded YAML.

Every input file (parts, assemblies, scenes, programs, gateway users, meshes) is read through
``read_text`` or ``read_bytes`` and, when it is YAML, parsed by ``parse_yaml``:

- the path is refused by kind before it is opened for reading (a FIFO would block the open, a device
  such as /dev/zero never ends, a directory is no file), then by size (``MAX_FILE_BYTES``);
- text must be UTF-8; an error names the byte offset of the first bad byte;
- YAML is first walked as a stream of events (libyaml, no recursion), counting the nodes of the document
  with every alias expanded and the nesting depth; past ``MAX_YAML_NODES`` or ``MAX_YAML_DEPTH`` the
  document is refused before anything is constructed, so an alias bomb costs the size of its text.

Every failure is an InputError naming the file; messages never quote more than a short prefix of a value.
"""

from __future__ import annotations

import os
import stat
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from feeder_planner.errors import InputError
from feeder_planner.limits import MAX_FILE_BYTES, MAX_YAML_DEPTH, MAX_YAML_NODES

__all__ = ["check_input_file", "read_bytes", "read_text", "parse_yaml", "load_yaml_file"]

# libyaml when it is built (about ten times faster); the pure-Python parser gives the same events.
_LOADER: type[yaml.CSafeLoader] | type[yaml.SafeLoader] = getattr(yaml, "CSafeLoader", yaml.SafeLoader)

_KINDS = (
    (stat.S_ISDIR, "a directory"),
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


def check_input_file(path: str | Path, max_bytes: int = MAX_FILE_BYTES) -> int:
    """Return the size of ``path`` after refusing what is not a regular file of at most ``max_bytes``.

    Parameters
    ----------
    path
        The file named by the user.
    max_bytes
        The size limit (default ``MAX_FILE_BYTES``).

    Returns
    -------
    int
        The file's size in bytes.

    Raises
    ------
    InputError
        Naming the file: missing, unreadable, not a regular file (by kind, from ``os.stat``, before any
        open) or larger than the limit.
    """
    source = str(path)
    try:
        info = os.stat(path)
    except OSError as exc:
        raise InputError("<file>", f"cannot read: {exc.strerror or exc}", source) from None
    for is_kind, kind in _KINDS:
        if is_kind(info.st_mode):
            raise InputError("<file>", f"is {kind}, not a regular file", source)
    if not stat.S_ISREG(info.st_mode):
        raise InputError("<file>", "is not a regular file", source)
    if info.st_size > max_bytes:
        raise InputError(
            "<file>", f"is {info.st_size} bytes, larger than the limit of {max_bytes} bytes", source
        )
    return int(info.st_size)


def read_bytes(path: str | Path, max_bytes: int = MAX_FILE_BYTES) -> bytes:
    """Return the bytes of a regular file of at most ``max_bytes`` (see ``check_input_file``)."""
    source = str(path)
    check_input_file(path, max_bytes)
    try:
        # O_NONBLOCK: should the path be swapped for a FIFO after the check, the open does not block.
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    except OSError as exc:
        raise InputError("<file>", f"cannot read: {exc.strerror or exc}", source) from None
    with os.fdopen(fd, "rb") as handle:
        if not stat.S_ISREG(os.fstat(handle.fileno()).st_mode):
            raise InputError("<file>", "is not a regular file", source)
        # One byte past the limit tells a file that grew after the check from one that did not.
        data = handle.read(max_bytes + 1)
    if len(data) > max_bytes:
        raise InputError("<file>", f"is larger than the limit of {max_bytes} bytes", source)
    return data


def decode_utf8(data: bytes, source: str) -> str:
    """Decode UTF-8 (a UTF-8 byte-order mark is allowed); an error names the offset of the first bad byte."""
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(
            "<file>",
            f"not UTF-8 text: byte 0x{data[exc.start]:02x} at offset {exc.start} ({exc.reason})",
            source,
        ) from None


def read_text(path: str | Path, max_bytes: int = MAX_FILE_BYTES) -> str:
    """Return the UTF-8 text of a regular file of at most ``max_bytes``; errors name the file."""
    return decode_utf8(read_bytes(path, max_bytes), str(path))


def _line(event: yaml.Event) -> int:
    """Return the 1-based line where a YAML event starts (0 when the parser gave no mark)."""
    mark = getattr(event, "start_mark", None)
    return int(mark.line) + 1 if mark is not None else 0


@dataclass(slots=True)
class _Open:
    """A collection whose end event is still to come: its anchor and its expanded node count so far."""

    anchor: str | None
    count: int = 1


def _check_events(text: str, source: str, field: str, max_nodes: int = MAX_YAML_NODES) -> None:
    """Walk the YAML events: refuse nesting past MAX_YAML_DEPTH and expanded size past ``max_nodes``."""
    total = 0
    sizes: dict[str, int] = {}  # expanded node count of each anchor seen so far
    open_nodes: list[_Open] = []
    for event in yaml.parse(text, Loader=_LOADER):
        if isinstance(event, (yaml.SequenceStartEvent, yaml.MappingStartEvent)):
            if len(open_nodes) >= MAX_YAML_DEPTH:
                raise InputError(
                    field,
                    f"nested deeper than the limit of {MAX_YAML_DEPTH} levels at line {_line(event)}",
                    source,
                )
            open_nodes.append(_Open(event.anchor))
            total += 1
            continue
        if isinstance(event, (yaml.SequenceEndEvent, yaml.MappingEndEvent)):
            closed = open_nodes.pop()
            if closed.anchor is not None:
                sizes[closed.anchor] = closed.count
            if open_nodes:
                open_nodes[-1].count += closed.count
            continue
        if isinstance(event, yaml.ScalarEvent):
            count = 1
            if event.anchor is not None:
                sizes[event.anchor] = 1
        elif isinstance(event, yaml.AliasEvent):
            # An alias inside the collection it names makes a recursive value, which no field can be
            # and which would recurse forever in whatever walks it.
            if any(node.anchor == event.anchor for node in open_nodes):
                raise InputError(
                    field,
                    f"an alias refers to its own ancestor at line {_line(event)} (a recursive value)",
                    source,
                )
            count = sizes.get(event.anchor or "", 1)  # an unknown anchor is the composer's error, below
        else:
            continue
        total += count
        if open_nodes:
            open_nodes[-1].count += count
        if total > max_nodes:
            raise InputError(
                field,
                f"more than {max_nodes} YAML nodes with aliases expanded (at line {_line(event)}): "
                "refused (an alias bomb, or a file past the limit)",
                source,
            )


def parse_yaml(text: str, source: str, field: str = "<file>", max_nodes: int = MAX_YAML_NODES) -> Any:
    """Parse one YAML document (safe types only) with bounded expansion and depth; errors name ``source``.

    Parameters
    ----------
    text
        The document.
    source
        What the text came from (a file path or a request field), named in errors.
    field
        The field named in errors about the document as a whole.
    max_nodes
        The expanded-size bound (a request may state a smaller one than a file's).

    Returns
    -------
    Any
        The document's value.
    """
    try:
        _check_events(text, source, field, max_nodes)
        return yaml.load(text, Loader=_LOADER)  # noqa: S506 -- a SafeLoader: safe types only
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None)
        detail = f": {str(problem)[:80]}" if problem else ""
        raise InputError(field, f"not valid YAML{where}{detail}", source) from None
    except RecursionError:  # only if MAX_YAML_DEPTH were raised past what the constructor can recurse
        raise InputError(field, "nested too deeply", source) from None


def load_yaml_file(path: str | Path, max_bytes: int = MAX_FILE_BYTES) -> Any:
    """Read a YAML file through the reading layer and return its value."""
    return parse_yaml(read_text(path, max_bytes), str(path))
