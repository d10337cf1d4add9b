"""Simulated throwing arm: the paper's model, the contact model and a pymunk model, with faults reported.

The public surface the throwing_arm node, the benchmark and the tests use; injected faults and their
effects are in ``faults``; tolerances and model constants live in ``tolerances``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from feeder_planner.lazy import lazy_exports

if TYPE_CHECKING:  # the package's names; each module is imported on first use (feeder_planner.lazy)
    from feeder_sim.throwing.arm import (
        ARM_COMMANDS,
        FIDELITIES,
        FIDELITY_ALIASES,
        ArmCommandName,
        Fidelity,
        ThrowingArm,
        check_fidelity,
        fidelity_throw,
        parse_command,
    )
    from feeder_sim.throwing.contact import contact_throw, contact_trace
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

__getattr__, __dir__ = lazy_exports(__name__, __file__)

__all__ = [
    "ThrowingArm",
    "Fidelity",
    "FIDELITIES",
    "FIDELITY_ALIASES",
    "check_fidelity",
    "fidelity_throw",
    "contact_throw",
    "contact_trace",
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
