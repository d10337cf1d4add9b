"""Simulation states, steps and resets of the standard, mapped onto the cell clock and device lifecycles.

============  ====================================================================================
state         what the cell does
============  ====================================================================================
PLAYING       the cell clock runs (``cell_clock`` not paused); devices as their controller left them
PAUSED        the cell clock holds at a quantum boundary; a step advances it by whole quanta
STOPPED       the clock paused, every device reset to its configured initial state (spawned parts
              gone) and held inactive; PLAYING or PAUSED activates the devices again
============  ====================================================================================

A step is one lockstep quantum of cell time (``cell_clock`` ``quantum``, 0.1 s by default): every device
ticks every instant of its rate within it, so N steps advance cell time by exactly N quanta. Cell time
never goes back: every lockstep participant (``feeder_planner.node_kit.lockstep.Participant``, a device's
``LockstepDriver``) takes an earlier time as one already seen, so a rewound clock would hold the cell
(measured in tests/cell/test_simulation_time_reset_ros.py). A scope naming TIME is answered
FEATURE_UNSUPPORTED; SCOPE_DEFAULT and SCOPE_ALL reset state and spawned entities and say time was not.
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
    """What a ResetSimulation scope resets: device state (to configured), spawned entities (removed).

    ``time_left``: the scope asked for everything (DEFAULT, ALL), time included, which the cell does not
    reset; the rest is done and the answer says so.
    """

    state: bool
    spawned: bool
    time_left: bool = False


TIME_NOT_RESET = (
    "cell time was not reset (SIMULATION_RESET_TIME is not a feature: every lockstep participant, the "
    "devices, the controller and the recorder, takes a cell time earlier than one it has taken as already "
    "seen, so a rewound clock would wait for answers that never come; docs/cell.md, Reset)"
)


def reset_of_scope(scope: int) -> Reset:
    """Return the reset a scope asks for.

    DEFAULT (0, the standard's "same as ALL") and ALL (255) reset state and spawned entities, all the cell
    can reset, and say that time was not; a scope naming TIME by its bit (1, 3, 5, 7) is FEATURE_UNSUPPORTED.
    """
    if scope in (SCOPE_DEFAULT, SCOPE_ALL):
        return Reset(state=True, spawned=True, time_left=True)
    if scope & SCOPE_TIME:
        raise SimulationError(
            FEATURE_UNSUPPORTED,
            f"scope: {scope} includes TIME: {TIME_NOT_RESET}; reset STATE and SPAWNED "
            f"(scope {SCOPE_STATE | SCOPE_SPAWNED}) or everything else (scope 0)",
        )
    unknown = scope & ~(SCOPE_STATE | SCOPE_SPAWNED)
    if unknown:
        raise SimulationError(FEATURE_UNSUPPORTED, f"scope: unknown scope bits {unknown:#x} in {scope}")
    return Reset(state=bool(scope & SCOPE_STATE), spawned=bool(scope & SCOPE_SPAWNED))
