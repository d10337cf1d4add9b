"""Typed reading of YAML documents: every failure names the field path."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from feeder_planner.errors import InputError
from feeder_planner.limits import MAX_NAME_CHARS, MAX_YAML_NODES, describe, quote
from feeder_planner.reading import load_yaml_file, parse_yaml


def load_yaml_mapping(path: str | Path) -> dict[str, Any]:
    """Read a YAML file whose top level is a mapping (bounded reading layer); errors name the file."""
    document = load_yaml_file(path)
    if not isinstance(document, dict):
        raise InputError("<top level>", "expected a mapping of fields", str(path))
    return document


def yaml_mapping_from_text(
    text: str, source: str, field: str = "<yaml>", max_nodes: int = MAX_YAML_NODES
) -> dict[str, Any]:
    """Parse YAML text (a request field) whose top level is a mapping, with the file reader's bounds."""
    document = parse_yaml(text, source, field, max_nodes)
    if not isinstance(document, dict):
        raise InputError("<top level>", "expected a mapping of fields", source)
    return document


def finite_number(value: Any, field: str) -> float:
    """Return ``value`` as a finite float; bools are refused (YAML 'yes' is not a number).

    An integer too large for a double is refused by name, not with an OverflowError.
    """
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(field, f"expected a number, got {describe(value)}")
    try:
        number = float(value)
    except OverflowError:
        raise InputError(field, f"{quote(value)} is too large for a double") from None
    if not math.isfinite(number):
        raise InputError(field, f"must be finite, got {quote(value)}")
    return number


def positive_number(value: Any, field: str) -> float:
    """Return ``value`` as a finite float > 0; errors name ``field``."""
    number = finite_number(value, field)
    if number <= 0.0:
        raise InputError(field, f"must be > 0, got {quote(value)}")
    return number


def non_negative_number(value: Any, field: str) -> float:
    """Return ``value`` as a finite float >= 0; errors name ``field``."""
    number = finite_number(value, field)
    if number < 0.0:
        raise InputError(field, f"must be >= 0, got {quote(value)}")
    return number


def point_array(value: Any, field: str, dimension: int, min_points: int = 1) -> np.ndarray:
    """Return a list of points, each ``dimension`` finite numbers, as an (n, dimension) array."""
    if not isinstance(value, (list, tuple)):
        raise InputError(field, f"expected a list of {dimension}-D points, got {type(value).__name__}")
    if len(value) < min_points:
        raise InputError(field, f"needs at least {min_points} points, got {len(value)}")
    rows = []
    for index, point in enumerate(value):
        item = f"{field}[{index}]"
        if not isinstance(point, (list, tuple)) or len(point) != dimension:
            raise InputError(item, f"expected a list of {dimension} numbers, got {quote(point)}")
        rows.append([finite_number(coordinate, item) for coordinate in point])
    return np.asarray(rows, dtype=float).reshape(-1, dimension)


def optional(document: dict[str, Any], key: str, default: Any) -> Any:
    """Return ``document[key]``, or ``default`` when the key is absent or null."""
    value = document.get(key, default)
    return default if value is None else value


def required(document: dict[str, Any], key: str, field: str | None = None) -> Any:
    """Return ``document[key]``; a missing key is an InputError naming ``field`` (default: the key)."""
    if key not in document or document[key] is None:
        raise InputError(field or key, "is required but missing")
    return document[key]


def short_string(value: Any, field: str, what: str = "a name") -> str:
    """Return ``value`` if it is a non-empty string of at most MAX_NAME_CHARS characters on one line."""
    if not isinstance(value, str):
        raise InputError(field, f"expected {what} (a string), got {describe(value)}")
    if not value or len(value) > MAX_NAME_CHARS or "\n" in value or "\r" in value:
        raise InputError(
            field, f"expected {what}: one line of 1 to {MAX_NAME_CHARS} characters, got {quote(value)}"
        )
    return value
