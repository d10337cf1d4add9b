"""The cell clock's parameters and its time arithmetic (integer nanoseconds), free of rclpy.

``feeder_cell.nodes.cell_clock`` is the node; it re-exports these names.
"""

from __future__ import annotations

from dataclasses import dataclass

from builtin_interfaces.msg import Time

from feeder_planner.parameter_specs import non_negative, one_of, param, positive, specs_of

__all__ = ["ClockParameters", "PARAMETERS", "NANOSECONDS", "to_time", "nanoseconds_of"]

NANOSECONDS = 1_000_000_000


@dataclass(frozen=True)
class ClockParameters:
    """The cell clock's parameters (docs/cell.md)."""

    real_time_factor: float = param(
        1.0,
        "simulated seconds per wall second; may change at run time. In lockstep an upper bound on the "
        "pace, 0: as fast as the participants allow (feeder launch --real-time-factor max)",
        non_negative,
    )
    publish_rate: float = param(
        200.0,
        "free-running only: rate (Hz, wall clock) of /clock messages, the time resolution the nodes see "
        "being real_time_factor / publish_rate",
        positive,
        read_only=True,
    )
    start_time: float = param(
        0.0,
        "simulated time at start (s since the epoch); 0: the wall time at start",
        non_negative,
        read_only=True,
    )
    start_paused: bool = param(False, "hold the clock at start_time until ~/resume or ~/step", read_only=True)
    lockstep: bool = param(
        False,
        "advance by quanta, each once every lockstep participant is done (else free-running)",
        read_only=True,
    )
    quantum: float = param(
        0.1,
        "lockstep: cell seconds per advance; a device ticks every instant of its rate within it, a "
        "controller decides once per quantum",
        positive,
        read_only=True,
    )
    clock_rate: float = param(
        50.0,
        "lockstep: most /clock messages per wall second (the participants hear every quantum on their "
        "own topics; a node that does not join sees cell time at this rate and is not woken per quantum)",
        positive,
        read_only=True,
    )
    lockstep_expect: list[str] = param(
        [""],
        "lockstep: fully qualified names held for at start (the clock stays at start_time until each "
        "has joined or join_timeout passed); feeder launch lists the scene's participants",
        read_only=True,
    )
    lockstep_timeout: float = param(
        30.0,
        "lockstep: wall seconds a participant may take to answer a phase before it is dropped",
        positive,
        read_only=True,
    )
    join_timeout: float = param(
        60.0, "lockstep: wall seconds the expected participants have to join", positive, read_only=True
    )
    on_lockstep_timeout: str = param(
        "drop",
        "lockstep: what a participant's timeout does: drop (ERROR in /diagnostics, the cell goes on) or "
        "stop (ERROR, and the clock holds where it is)",
        one_of(("drop", "stop")),
        read_only=True,
    )


PARAMETERS = specs_of(ClockParameters)


def to_time(nanoseconds: int) -> Time:
    """Return a builtin_interfaces/Time of an integer number of nanoseconds."""
    return Time(sec=nanoseconds // NANOSECONDS, nanosec=nanoseconds % NANOSECONDS)


def nanoseconds_of(stamp: Time) -> int:
    """Return the integer number of nanoseconds of a builtin_interfaces/Time."""
    return int(stamp.sec) * NANOSECONDS + int(stamp.nanosec)
