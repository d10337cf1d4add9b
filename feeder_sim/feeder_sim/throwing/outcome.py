"""The result of one simulated throw, shared by both fidelities and the arm: states, kind, fault, path."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Literal, get_args

__all__ = ["OutcomeKind", "OUTCOME_KINDS", "PathPoint", "ThrowOutcome"]

OutcomeKind = Literal["jog", "flip", "fault"]
OUTCOME_KINDS: tuple[OutcomeKind, ...] = get_args(OutcomeKind)
PathPoint = tuple[float, float, float, float]  # (t, x, y, theta) of the centre of mass, arm frame


@dataclass(frozen=True)
class ThrowOutcome:
    """One throw: before/after states, jog, flip or fault (with its reason), and the part's path."""

    edge_before: int
    radius_before: float
    edge_after: int
    radius_after: float
    kind: OutcomeKind
    turns: int
    rotation: float
    fault: str = ""  # why the throw is a fault; empty otherwise
    path: tuple[PathPoint, ...] = ()
    lost: bool = False  # the part left the arm (a fault): it is no longer on the arm at all
    flags: tuple[str, ...] = ()  # the paper model's assumptions this throw breaks (ThrowResult.violations)

    @classmethod
    def failure(
        cls, edge: int, radius: float, reason: str, path: tuple[PathPoint, ...] = (), lost: bool = False
    ) -> ThrowOutcome:
        """Return the fault of a throw from (edge, radius) that reached no resting state (edge_after -1)."""
        return cls(edge, radius, -1, math.nan, "fault", 0, 0.0, reason, path, lost)

    def with_fault(self, reason: str, lost: bool = False) -> ThrowOutcome:
        """Return this outcome turned into a fault, keeping where the part came to rest."""
        return replace(self, kind="fault", fault=reason, lost=lost)
