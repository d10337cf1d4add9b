"""Typed reading of YAML documents: every failure names the field path."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from feeder_planner.errors import InputError


def load_yaml_mapping(path: str | Path) -> dict[str, Any]:
    """Read a YAML file whose top level is a mapping; errors name the file."""
    source = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise InputError("<file>", f"cannot read: {exc.strerror or exc}", source) from None
    try:
        document = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}" if mark is not None else ""
        raise InputError("<file>", f"not valid YAML{where}", source) from None
    if not isinstance(document, dict):
        raise InputError("<top level>", "expected a mapping of fields", source)
    return document


def finite_number(value: Any, field: str) -> float:
    """Return ``value`` as a finite float; bools are refused (YAML 'yes' is not a number)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(field, f"expected a number, got {type(value).__name__} {value!r}")
    number = float(value)
    if not math.isfinite(number):
        raise InputError(field, f"must be finite, got {value!r}")
    return number


def positive_number(value: Any, field: str) -> float:
    """Return ``value`` as a finite float > 0; errors name ``field``."""
    number = finite_number(value, field)
    if number <= 0.0:
        raise InputError(field, f"must be > 0, got {value!r}")
    return number


def non_negative_number(value: Any, field: str) -> float:
    """Return ``value`` as a finite float >= 0; errors name ``field``."""
    number = finite_number(value, field)
    if number < 0.0:
        raise InputError(field, f"must be >= 0, got {value!r}")
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
            raise InputError(item, f"expected a list of {dimension} numbers, got {point!r}")
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
