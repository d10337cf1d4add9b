"""Units: length units of input files, angle parsing of command-line values, and standard gravity."""

from __future__ import annotations

import math

from feeder_planner.errors import InputError
from feeder_planner.limits import quote

LENGTH_UNITS: dict[str, float] = {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "um": 1e-6}

# Standard gravity (m/s^2, CGPM 1901, exact): the one value every model that needs a weight uses (the
# assembly's contact forces in newtons, a MEMS part's normal force for Coulomb friction). The throwing
# arm's gravity is a parameter of the design instead (the paper's examples use 9.66 m/s^2).
STANDARD_GRAVITY = 9.80665


def length_scale(unit: str, field: str = "length_unit") -> float:
    """Metres per one ``unit``; raises InputError naming ``field`` for an unknown unit."""
    try:
        return LENGTH_UNITS[unit]
    except (KeyError, TypeError):
        known = ", ".join(LENGTH_UNITS)
        raise InputError(field, f"unknown length unit {quote(unit)} (expected one of {known})") from None


def parse_angle(text: str, field: str) -> float:
    """Parse radians, or degrees with a ``deg`` suffix (``320deg`` -> 5.585...)."""
    raw = str(text).strip()
    degrees = raw.endswith("deg")
    number = raw[:-3] if degrees else raw
    try:
        value = float(number)
    except ValueError:
        raise InputError(
            field, f"expected an angle in radians or with a 'deg' suffix, got {text!r}"
        ) from None
    if not math.isfinite(value):
        raise InputError(field, f"must be finite, got {text!r}")
    return math.radians(value) if degrees else value
