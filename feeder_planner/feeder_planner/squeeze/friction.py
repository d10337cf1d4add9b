"""The friction coefficient between the jaws and the part, as every fidelity reads it."""

from __future__ import annotations

from feeder_planner.errors import InputError
from feeder_planner.fields_io import finite_number
from feeder_planner.squeeze.tolerances import MAX_FRICTION

__all__ = ["check_friction"]


def check_friction(value: object, field: str = "friction") -> float:
    """Return a Coulomb coefficient in [0, MAX_FRICTION]; refused naming ``field`` otherwise.

    The ideal fidelity is Goldberg's frictionless model and needs 0; the dynamic one simulates any value
    in range.
    """
    mu = finite_number(value, field)
    if not 0.0 <= mu <= MAX_FRICTION:
        raise InputError(field, f"must be in [0, {MAX_FRICTION:g}], got {mu:g}")
    return mu
