"""Simulated throwing arm: the paper's analytic model and a pymunk dynamic model, with faults reported.

The public surface the throwing_arm node, the benchmark and the tests use; injected faults and their
effects are in ``faults``; tolerances and model constants live in ``tolerances``.
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
from feeder_sim.throwing.faults import (
    ARM_FAULTS,
    FAULT_INFO,
    ArmFaultName,
    ArmFaults,
    FaultInfo,
    MotorFaultError,
)
from feeder_sim.throwing.outcome import OUTCOME_KINDS, OutcomeKind, PathPoint, ThrowOutcome
from feeder_sim.throwing.tolerances import DEFAULT_STEP, MAX_TICK_PERIODS

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
    "MAX_TICK_PERIODS",
    "ArmFaults",
    "ArmFaultName",
    "ARM_FAULTS",
    "FaultInfo",
    "FAULT_INFO",
    "MotorFaultError",
]
