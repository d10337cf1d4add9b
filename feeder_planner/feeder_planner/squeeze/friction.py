"""The friction coefficient between the jaws and the part, as every fidelity reads it."""

from __future__ import annotations

import math

from feeder_planner.errors import InputError
from feeder_planner.fields_io import finite_number
from feeder_planner.squeeze.diameter import wrap
from feeder_planner.squeeze.squeeze_function import SqueezeFunction
from feeder_planner.squeeze.tolerances import MAX_FRICTION

__all__ = ["check_friction", "frictional_squeeze", "jams"]


def check_friction(value: object, field: str = "friction") -> float:
    """Return a Coulomb coefficient in [0, MAX_FRICTION]; refused naming ``field`` otherwise.

    The ideal fidelity is Goldberg's frictionless model and needs 0; the dynamic one simulates any value
    in range.
    """
    mu = finite_number(value, field)
    if not 0.0 <= mu <= MAX_FRICTION:
        raise InputError(field, f"must be in [0, {MAX_FRICTION:g}], got {mu:g}")
    return mu


def jams(squeeze: SqueezeFunction, theta: float, mu: float) -> bool:
    """Whether a squeeze from ``theta`` jams at once: the jaws hold the part by friction where they touch it.

    With both jaws on single vertices a and b the part is squeezed along the chord a - b; on the diameter
    function's piece D cos(theta - beta) the chord makes the angle theta - beta with the jaws' normal, and
    two Coulomb contacts hold the part when that angle is within the friction cone, |theta - beta| <=
    atan(mu) (the line of the two contacts inside both cones). An edge flush with a jaw is held anyway.
    """
    piece = squeeze.diameter.piece_at(theta)
    reduced = squeeze.diameter.pieces[0].start + wrap(theta - squeeze.diameter.pieces[0].start, math.pi)
    return abs(reduced - piece.phase) <= math.atan(check_friction(mu))


def frictional_squeeze(squeeze: SqueezeFunction, theta: float, mu: float) -> float:
    """Return the orientation after a quasi-static squeeze with Coulomb friction ``mu`` at both jaws.

    Descending the diameter function moves away from the crest of the piece the part starts on, and on
    into pieces whose crests lie behind it, so the chord's angle only grows: a squeeze that does not jam
    at its start (``jams``) ends where the frictionless one does (Goldberg's s), and one that jams stays.
    """
    return theta if jams(squeeze, theta, mu) else squeeze(theta)
