"""The MEMS field array device's parameters, ROS-free: one declaration for the node, the scene and the docs.

Each entry is a ``ParameterSpec`` (type by its default, meaning, check, read-only or runtime). The node
declares them to rclpy with the display parameters of the node kit; the launcher's scene validation and
the docs' parameter table read them from here without ROS.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from feeder_device.parameters import DeviceParameters
from feeder_planner.mems import DELTA_MAX, DELTA_MIN
from feeder_planner.parameter_specs import (
    in_range,
    integer,
    integer_at_least,
    non_negative,
    one_of,
    param,
    positive,
)
from feeder_sim.mems.bodies import FIDELITIES
from feeder_sim.mems.tolerances import DEFAULT_CELLS, DEFAULT_DAMPING, DEFAULT_FRICTION, DEFAULT_PITCH

__all__ = ["MemsParameters", "BASE_FRAME", "AUTO_CATCH_UP_TICKS", "NANOSECONDS", "max_steps_per_tick"]

BASE_FRAME = "mems_array"
NANOSECONDS = 1_000_000_000

# max_steps_per_tick 0 means the steps of this many periods of the node clock, times the configured
# real-time factor when it is above 1 (a fast cell clock advances in jumps of several periods): a tick
# that comes late by up to three periods (a loaded 2-core machine) still catches up in full; anything
# later is dropped and shows as steps_dropped and a lagging real-time factor.
AUTO_CATCH_UP_TICKS = 4


def _array_size(value: object) -> str | None:
    """Check the array_size parameter: two integers > 0."""
    if not isinstance(value, Sequence):  # rclpy and the launcher refuse a single value before this
        return f"must be two integers > 0 [nx, ny], got {value!r}"
    ok = len(value) == 2 and all(isinstance(v, int) and not isinstance(v, bool) and v > 0 for v in value)
    return None if ok else f"must be two integers > 0 [nx, ny], got {list(value)!r}"


def _time_step(value: object) -> str | None:
    """Check the time_step parameter: > 0 and at least one nanosecond (steps are counted in ns)."""
    problem = positive(value)
    # positive() accepts only an int or a float
    if problem is None and isinstance(value, (int, float)) and round(value * NANOSECONDS) < 1:
        problem = f"must be at least 1e-9 s, got {value!r}"
    return problem


@dataclass(frozen=True)
class MemsParameters(DeviceParameters):
    """The MEMS field array's parameters (the device kit's come with ``DeviceParameters``)."""

    array_size: list[int] = param(
        list(DEFAULT_CELLS), "number of actuator cells [nx, ny] of the array", _array_size, read_only=True
    )
    pitch: float = param(
        DEFAULT_PITCH,
        "side of one square actuator cell (m); the array is centred on the plane origin",
        positive,
        read_only=True,
    )
    fidelity: str = param(
        "ideal",
        "force model: ideal (exact field integrals, quasi-static), array (cells at "
        "the pitch, exact covered areas), dynamic (inertia, friction, collisions)",
        one_of(FIDELITIES),
        read_only=True,
    )
    directions: int = param(
        0,
        "quantise cell forces to this many actuator directions (0: exact directions)",
        integer_at_least(0),
        read_only=True,
    )
    part_files: list[str] = param(
        [""], "part files (YAML, contract section 2); empty entries are ignored", read_only=True
    )
    initial_poses: list[float] = param(
        [0.0],
        "x, y, theta (m, m, rad) per part, flattened; [] or [0.0]: random poses "
        "within placement_radius drawn with the seed",
        read_only=True,
    )
    placement_radius: float = param(
        1e-3, "radius (m) of the disc random initial positions are drawn in", positive, read_only=True
    )
    program_file: str = param(
        "",
        "field program YAML ({steps: [{field: {...}, duration: s}]}, metres); "
        "empty: combined field delta = default_delta forever",
        read_only=True,
    )
    default_delta: float = param(
        0.2,
        "delta of the default combined field (0 <= delta < 1)",
        in_range(DELTA_MIN, DELTA_MAX, include_high=False),
        read_only=True,
    )
    publish_rate: float = param(
        20.0,
        "rate (Hz of the node clock) of the physics ticks and the part state messages",
        positive,
        read_only=True,
    )
    time_step: float = param(
        2e-4,
        "integration step (s of simulated time); a tick runs the whole steps of the node-clock time elapsed",
        _time_step,
        read_only=True,
    )
    max_steps_per_tick: int = param(
        0,
        "most integration steps one tick runs (runtime); the rest of a late tick's time is dropped and "
        f"counted as steps_dropped. 0: the steps of {AUTO_CATCH_UP_TICKS} periods times "
        "max(1, real_time_factor)",
        integer_at_least(0),
    )
    damping: float = param(
        DEFAULT_DAMPING,
        "viscous surface drag per unit area (N s/m^3): v = F/(damping A); runtime: applied to the scene",
        positive,
    )
    friction: float = param(
        DEFAULT_FRICTION,
        "Coulomb friction coefficient with the surface, dynamic fidelity only (refused for the others); "
        "runtime: applied to the running scene",
        non_negative,
    )
    seed: int = param(
        0,
        "seed of the random initial poses (the simulation itself is deterministic)",
        integer,
        read_only=True,
    )
    frame_id: str = param(
        "",
        f"frame of the published poses (the plane frame); empty: {BASE_FRAME} under the node's namespace",
        read_only=True,
    )
    marker_force_stride: int = param(
        0,
        "~/markers draws the force of every k-th cell in each direction (0: no force vectors); runtime",
        integer_at_least(0),
    )


def max_steps_per_tick(p: MemsParameters, step_ns: int) -> int:
    """Return the cap on steps per tick (max_steps_per_tick, or the automatic one for 0)."""
    cap = int(p.max_steps_per_tick)
    if cap > 0:
        return cap
    factor = max(1.0, float(p.real_time_factor))
    period_ns = NANOSECONDS * factor / float(p.publish_rate)
    return max(1, math.ceil(AUTO_CATCH_UP_TICKS * period_ns / step_ns))
