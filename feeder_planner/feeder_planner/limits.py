"""The stated limits of every input: file sizes, YAML shape, counts, length scales and command-line values.

One place, so that the reading layer, the readers, the planners and the README state the same numbers.
Past a limit, the input is refused with an InputError naming the field and the limit, before the work
that the limit protects allocates anything. ROS-free: the nodes check their requests against the same
numbers.
"""

from __future__ import annotations

import math
from typing import Final

from feeder_planner.errors import InputError

__all__ = [
    "MAX_FILE_BYTES",
    "MAX_YAML_NODES",
    "MAX_YAML_DEPTH",
    "MAX_NAME_CHARS",
    "QUOTE_CHARS",
    "MIN_LENGTH_M",
    "MAX_LENGTH_M",
    "MAX_PART_VERTICES",
    "MAX_ASSEMBLY_MESH_FACES",
    "MAX_ASSEMBLY_PIECES",
    "MAX_CONVEX_VERTICES",
    "MAX_CONTACTS",
    "MAX_FACETS",
    "CONTACT_DISTANCE_TOLERANCE",
    "MAX_DENSITY",
    "MAX_RELEASE_SPEED",
    "MAX_GRAVITY",
    "MAX_FLIGHT_TURNS",
    "MAX_STARTS_PER_EDGE",
    "MAX_THROWS",
    "MAX_LIMIT_SET_THROWS",
    "MAX_QUEUED_THROWS",
    "MAX_GOAL_TIMEOUT",
    "quote",
    "describe",
    "check_count",
    "check_length_scale",
    "check_limit_set_counts",
    "check_flag_length",
    "check_throw_design",
    "check_throw_flight",
]

# --- Files and YAML (the reading layer, feeder_planner.reading) -----------------------------------------
# Largest input file read: far above any part, assembly, scene or program this project describes (the
# largest example is under 2 KiB; a 10,000-vertex part is about 300 KiB), far below what fits in memory.
MAX_FILE_BYTES: Final = 16 * 1024 * 1024
# YAML nodes of a document counted with every alias expanded (what iterating the loaded value visits): a
# 10,000-vertex part has 30,000; a billion-laughs document has 10^9 and is refused before construction.
MAX_YAML_NODES: Final = 1_000_000
# Nesting of sequences and mappings: the formats nest at most 5 deep (bodies -> convex -> vertices -> point).
MAX_YAML_DEPTH: Final = 64
# A name (part, body, assembly, scene, node) is a string of at most this many characters.
MAX_NAME_CHARS: Final = 256
# Error messages quote at most this many characters of any value given by the user.
QUOTE_CHARS: Final = 40

# --- Length scale of the models ------------------------------------------------------------------------
# Parts and assemblies, in metres after the unit: the span (bounding-box side) must be at least
# MIN_LENGTH_M (below it the models' relative tolerances of 1e-12 reach the double's rounding of
# coordinates) and every coordinate's magnitude and the span at most MAX_LENGTH_M (a 10 km part is no
# part; past it the dynamics' squares and cubes leave the double's range long before a result).
MIN_LENGTH_M: Final = 1e-9
MAX_LENGTH_M: Final = 1e4
# Areal (part, kg/m^2) or volume (assembly, kg/m^3) density at most this: osmium is 2.3e4 kg/m^3.
MAX_DENSITY: Final = 1e9

# --- Counts of a file ----------------------------------------------------------------------------------
# Vertices of a part, outer boundary and holes together (the readers are linear; the planners evaluate
# every edge per step).
MAX_PART_VERTICES: Final = 10_000
# Pieces (boxes, convex polyhedra and meshes) of an assembly, all bodies together; vertices of one
# polyhedron; explicit contacts. The interpenetration check is quadratic in the pieces that overlap.
MAX_ASSEMBLY_PIECES: Final = 2_000
# Triangles of all of an assembly's meshes together (one mesh has its own limit, assembly.meshes): five
# meshes at that limit, about half a gigabyte of checked triangles.
MAX_ASSEMBLY_MESH_FACES: Final = 1_000_000
MAX_CONVEX_VERTICES: Final = 10_000
MAX_CONTACTS: Final = 10_000
# An explicit contact point must lie within this fraction of the assembly's size (its bounding-box
# diagonal) of one of its bodies' surfaces: a contact is where the bodies touch.
CONTACT_DISTANCE_TOLERANCE: Final = 1e-3

# Facets K of the friction pyramids (the paper's is 4; `--exact-cone` compares up to 32): the LP has K
# columns per contact point.
MAX_FACETS: Final = 256

# --- The throwing planner's flags ------------------------------------------------------------------------
# |W| (rad/s): the paper's designs release at about 5.6 rad/s; 1000 rad/s is 160 turns a second.
MAX_RELEASE_SPEED: Final = 1000.0
# |G| (m/s^2): a thousand times the Earth's.
MAX_GRAVITY: Final = 1e4
# Whole turns of the part in one flight: the impact search keeps a few values per turn (about 1 KiB), so
# this bounds one throw to about 100 MB.
MAX_FLIGHT_TURNS: Final = 100_000
# `feeder limit-set`: starts per stable edge, throws per start, and their product (the trajectories
# stored, tens of bytes per throw and edge: 10^6 is under 200 MB).
MAX_STARTS_PER_EDGE: Final = 10_000
MAX_THROWS: Final = 100_000
MAX_LIMIT_SET_THROWS: Final = 1_000_000


# Throws an arm keeps queued (ArmCommand count and its uint32 pending reply): refused past it, never wrapped.
MAX_QUEUED_THROWS = 100_000
# A device goal's timeout (s of node clock): a year is past any production cycle, and keeps the deadline
# an exact integer of nanoseconds (1e308 s would overflow it; the goal would fail at its first tick).
MAX_GOAL_TIMEOUT = 365 * 24 * 3600.0


def quote(value: object, limit: int = QUOTE_CHARS) -> str:
    """Return a short description of a user's value for an error message: never an unbounded repr.

    Parameters
    ----------
    value
        Any value read from a file, a flag or a request.
    limit
        Most characters of a string (or of a scalar's repr) quoted.

    Returns
    -------
    str
        The repr of a short scalar, a prefix of a long string with its length, or a container's type
        and length.
    """
    if isinstance(value, str):
        if len(value) <= limit:
            return repr(value)
        return f"{value[:limit]!r}... ({len(value)} characters)"
    if isinstance(value, (list, tuple)):
        return f"a list of {len(value)} item(s)"
    if isinstance(value, dict):
        return f"a mapping of {len(value)} key(s)"
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 64:
        return f"an integer of {len(str(abs(value)))} digits"
    text = repr(value)
    return text if len(text) <= limit else f"{text[:limit]}... ({type(value).__name__})"


def describe(value: object) -> str:
    """Return the type and a short quote of a value (``quote``), e.g. "str 'abc'" or "a list of 3 item(s)"."""
    if isinstance(value, (list, tuple, dict)):
        return quote(value)
    return f"{type(value).__name__} {quote(value)}"


def check_count(count: int, limit: int, field: str, what: str) -> None:
    """Refuse ``count`` items of ``what`` above ``limit``, naming ``field`` and the limit."""
    if count > limit:
        raise InputError(field, f"{count} {what} exceed the limit of {limit}")


def check_length_scale(magnitude: float, span: float, field: str) -> None:
    """Refuse coordinates (metres) whose largest magnitude or span leaves [MIN_LENGTH_M, MAX_LENGTH_M].

    Parameters
    ----------
    magnitude
        Largest absolute coordinate, metres.
    span
        Largest side of the bounding box, metres.
    field
        The field named in the error.
    """
    if not (math.isfinite(magnitude) and magnitude <= MAX_LENGTH_M):
        raise InputError(
            field,
            f"coordinates up to {magnitude:.3g} m are outside the models' length range "
            f"[{MIN_LENGTH_M:g} m, {MAX_LENGTH_M:g} m]",
        )
    if not (math.isfinite(span) and MIN_LENGTH_M <= span <= MAX_LENGTH_M):
        raise InputError(
            field,
            f"size {span:.3g} m is outside the models' length range [{MIN_LENGTH_M:g} m, {MAX_LENGTH_M:g} m]",
        )


def check_limit_set_counts(starts_per_edge: int, throws: int, starts_flag: str, throws_flag: str) -> None:
    """Refuse limit-set grids past MAX_STARTS_PER_EDGE, MAX_THROWS or their product, before allocating."""
    if starts_per_edge > MAX_STARTS_PER_EDGE:
        raise InputError(starts_flag, f"{starts_per_edge} exceeds the limit of {MAX_STARTS_PER_EDGE}")
    if throws > MAX_THROWS:
        raise InputError(throws_flag, f"{throws} exceeds the limit of {MAX_THROWS}")
    if starts_per_edge * throws > MAX_LIMIT_SET_THROWS:
        raise InputError(
            throws_flag,
            f"{throws} throws from each of {starts_per_edge} starts per edge ({starts_per_edge * throws}) "
            f"exceed the limit of {MAX_LIMIT_SET_THROWS} per edge",
        )


def check_flag_length(value: float, field: str) -> None:
    """Refuse a length flag (metres) of magnitude above MAX_LENGTH_M, naming ``field`` and the limit."""
    if not abs(value) <= MAX_LENGTH_M:
        raise InputError(field, f"|{value:.3g}| m exceeds the limit of {MAX_LENGTH_M:g} m")


def check_throw_design(
    speed: float, gravity: float, offset: float, speed_field: str, offset_field: str
) -> None:
    """Refuse a release speed, gravity or offset (SI) past MAX_RELEASE_SPEED, MAX_GRAVITY or MAX_LENGTH_M."""
    check_flag_length(offset, offset_field)
    if not 0.0 < abs(gravity) <= MAX_GRAVITY:
        raise InputError("--gravity", f"|G| = {abs(gravity):.3g} m/s^2 must be in (0, {MAX_GRAVITY:g}]")
    if not abs(speed) <= MAX_RELEASE_SPEED:
        raise InputError(
            speed_field, f"|W| = {abs(speed):.3g} rad/s exceeds the limit of {MAX_RELEASE_SPEED:g}"
        )


def check_throw_flight(
    radius: float, speed: float, gravity: float, height: float, radius_field: str, speed_field: str
) -> None:
    """Refuse a throw whose flight would turn the part more than MAX_FLIGHT_TURNS times.

    The centre of mass leaves at height ``height`` (m, above the pivot; at most the offset plus the part's
    size) with vertical speed at most ``|speed| * |radius|``; it is back at that level within
    T = (v + sqrt(v^2 + 2 |g| |height|)) / |g|, turning ``|speed| T / 2 pi`` times. An upper bound, so
    that no throw the limit allows is refused by mistake.
    """
    check_flag_length(radius, radius_field)
    if not 0.0 < abs(gravity) <= MAX_GRAVITY:
        raise InputError("--gravity", f"|G| = {abs(gravity):.3g} m/s^2 must be in (0, {MAX_GRAVITY:g}]")
    if not abs(speed) <= MAX_RELEASE_SPEED:
        raise InputError(
            speed_field, f"|W| = {abs(speed):.3g} rad/s exceeds the limit of {MAX_RELEASE_SPEED:g}"
        )
    v = abs(speed) * abs(radius)
    g = abs(gravity)
    flight = (v + math.sqrt(v * v + 2.0 * g * abs(height))) / g
    turns = abs(speed) * flight / (2.0 * math.pi)
    if turns > MAX_FLIGHT_TURNS:
        raise InputError(
            speed_field,
            f"the part would turn about {turns:.3g} times in flight (W = {speed:.3g} rad/s, "
            f"R = {radius:.3g} m, G = {gravity:.3g} m/s^2); the limit is {MAX_FLIGHT_TURNS} turns",
        )
