"""Simulated throwing arm: the paper's analytic model and a pymunk dynamic model, with faults reported.

The public surface the throwing_arm node, the benchmark and the tests use; tolerances and model
constants of the pymunk model live in ``tolerances``.
"""

from feeder_sim.throwing.arm import (
    ARM_COMMANDS,
    FIDELITIES,
    ArmCommandName,
    Fidelity,
    ThrowingArm,
    check_fidelity,
    parse_command,
)
from feeder_sim.throwing.dynamic import dynamic_throw, rest_outcome
from feeder_sim.throwing.outcome import OUTCOME_KINDS, OutcomeKind, PathPoint, ThrowOutcome
from feeder_sim.throwing.tolerances import DEFAULT_STEP

__all__ = [
    "ThrowingArm",
    "Fidelity",
    "FIDELITIES",
    "check_fidelity",
    "ArmCommandName",
    "ARM_COMMANDS",
    "parse_command",
    "dynamic_throw",
    "rest_outcome",
    "ThrowOutcome",
    "OutcomeKind",
    "OUTCOME_KINDS",
    "PathPoint",
    "DEFAULT_STEP",
]
