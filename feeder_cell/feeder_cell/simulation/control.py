"""Simulation states, steps and resets of the standard, mapped onto the cell clock and device lifecycles.

============  ====================================================================================
state         what the cell does
============  ====================================================================================
PLAYING       the cell clock runs (``cell_clock`` not paused); devices as their controller left them
PAUSED        the cell clock holds at a quantum boundary; a step advances it by whole quanta
STOPPED       the clock paused and set back to its start, every device reset to its configured initial
              state (spawned parts gone) and held inactive; PLAYING or PAUSED activates the devices
============  ====================================================================================

A step is one lockstep quantum of cell time (``cell_clock`` ``quantum``, 0.1 s by default): every device
ticks every instant of its rate within it, so N steps advance cell time by exactly N quanta. A reset of
time (SCOPE_DEFAULT, SCOPE_ALL, a scope with TIME and STATE, and STOPPED) sets the clock back to its start
(``cell_clock ~/rewind``) before the devices are reconfigured there; only devices follow the clock back,
so with a controller or a recorder in the lockstep time is not reset and the answer says so.
LOADING_WORLD is the state from launch until every expected lockstep participant has joined the clock.
"""

from __future__ import annotations

from dataclasses import dataclass

from feeder_cell.simulation.results import (
    ALREADY_IN_TARGET_STATE,
    FEATURE_UNSUPPORTED,
    INCORRECT_TRANSITION,
    OPERATION_FAILED,
    SimulationError,
)

__all__ = [
    "STOPPED",
    "PLAYING",
    "PAUSED",
    "STATE_NAMES",
    "MAX_STEPS",
    "SCOPE_TIME",
    "SCOPE_STATE",
    "SCOPE_SPAWNED",
    "Reset",
    "TIME_NOT_RESET",
    "LOADING_WORLD",
    "STEP_CHUNK",
    "check_steps",
    "reset_of_scope",
    "transition",
]

# simulation_interfaces/msg/SimulationState
STOPPED, PLAYING, PAUSED, QUITTING, NO_WORLD, LOADING_WORLD = 0, 1, 2, 3, 4, 5
STATE_NAMES = {
    STOPPED: "STOPPED",
    PLAYING: "PLAYING",
    PAUSED: "PAUSED",
    QUITTING: "QUITTING",
    NO_WORLD: "NO_WORLD",
    LOADING_WORLD: "LOADING_WORLD",
}
# simulation_interfaces/srv/ResetSimulation scopes (a bit field; 0 is the standard's "same as ALL")
SCOPE_DEFAULT, SCOPE_TIME, SCOPE_STATE, SCOPE_SPAWNED, SCOPE_ALL = 0, 1, 2, 4, 255

# Steps one request may ask for: 10^6 quanta is a day of cell time at the default quantum, more than a
# test harness needs, and a bound so that a hostile count cannot hold the cell for ever.
MAX_STEPS = 1_000_000
# Quanta per clock request while a StepSimulation runs: between two, a state change interrupts it.
STEP_CHUNK = 10


def transition(current: int, target: int) -> list[str]:
    """Return the actions taking the cell from ``current`` to ``target`` (SetSimulationState).

    Actions, in order: ``pause`` and ``resume`` (the cell clock), ``stop`` (reset every device to its
    configured initial state and leave it inactive), ``start`` (activate the devices ``stop`` left).
    Raises SimulationError with the standard's code for a refused transition.
    """
    if target not in STATE_NAMES:
        raise SimulationError(INCORRECT_TRANSITION, f"state.state: unknown state {target}")
    if target == QUITTING:
        raise SimulationError(
            FEATURE_UNSUPPORTED, "state.state: QUITTING is not supported: end the cell where it was launched"
        )
    if target in (NO_WORLD, LOADING_WORLD):
        raise SimulationError(
            INCORRECT_TRANSITION,
            f"state.state: {STATE_NAMES[target]} is a state the simulator reports, not one to set "
            "(the cell has one world, its scene)",
        )
    if current == LOADING_WORLD:
        raise SimulationError(
            INCORRECT_TRANSITION,
            f"state.state: the world is loading (the lockstep waits for its participants to join); "
            f"{STATE_NAMES[target]} once GetSimulationState says PLAYING or PAUSED",
        )
    if target == current:
        raise SimulationError(ALREADY_IN_TARGET_STATE, f"the simulation is already {STATE_NAMES[target]}")
    plans = {
        (PLAYING, PAUSED): ["pause"],
        (PAUSED, PLAYING): ["resume"],
        (PLAYING, STOPPED): ["pause", "stop"],
        (PAUSED, STOPPED): ["stop"],
        (STOPPED, PLAYING): ["start", "resume"],
        (STOPPED, PAUSED): ["start"],
    }
    return plans[(current, target)]


def check_steps(steps: int, state: int) -> int:
    """Return ``steps`` if the cell may step that many quanta now (StepSimulation, SimulateSteps)."""
    if state != PAUSED:
        # The standard's rule: stepping only while paused (OPERATION_FAILED otherwise).
        raise SimulationError(
            OPERATION_FAILED,
            f"steps: the simulation is {STATE_NAMES.get(state, state)}; pause it first (SetSimulationState)",
        )
    if steps < 1:
        raise SimulationError(OPERATION_FAILED, f"steps: must be >= 1, got {steps}")
    if steps > MAX_STEPS:
        raise SimulationError(OPERATION_FAILED, f"steps: at most {MAX_STEPS} per request, got {steps}")
    return int(steps)


@dataclass(frozen=True)
class Reset:
    """What a ResetSimulation scope resets: time (to the start), device state (to configured), spawned."""

    state: bool
    spawned: bool
    time: bool = False


TIME_NOT_RESET = (
    "cell time was not reset: a lockstep participant that is no device (a controller, a recorder) "
    "does not follow the clock back to its start"
)


def reset_of_scope(scope: int) -> Reset:
    """Return the reset a scope asks for.

    DEFAULT (0, the standard's "same as ALL") and ALL (255) reset everything: time, state and spawned
    entities. Time is reset with the devices' state (scopes 3 and 7) or not at all: a device's goals, fault
    windows and tick grid are in cell time, so time alone (1, 5) is FEATURE_UNSUPPORTED.
    """
    if scope in (SCOPE_DEFAULT, SCOPE_ALL):
        return Reset(state=True, spawned=True, time=True)
    unknown = scope & ~(SCOPE_TIME | SCOPE_STATE | SCOPE_SPAWNED)
    if unknown:
        raise SimulationError(FEATURE_UNSUPPORTED, f"scope: unknown scope bits {unknown:#x} in {scope}")
    if scope & SCOPE_TIME and not scope & SCOPE_STATE:
        raise SimulationError(
            FEATURE_UNSUPPORTED,
            f"scope: {scope} resets TIME without STATE: the devices' goals, faults and tick grids are in "
            f"cell time, so time goes back with their state (scope {SCOPE_TIME | SCOPE_STATE} or "
            f"{SCOPE_TIME | SCOPE_STATE | SCOPE_SPAWNED}, or 0)",
        )
    return Reset(
        state=bool(scope & SCOPE_STATE), spawned=bool(scope & SCOPE_SPAWNED), time=bool(scope & SCOPE_TIME)
    )
