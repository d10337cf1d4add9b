"""What the CLI and the nodes call: an assembly prepared once, then region, check and path results.

Each result has ``to_json()`` giving the contract's JSON object (SI units); the nodes convert the same results
to messages (``node_kit.msg_assembly``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from feeder_planner.assembly.contacts import Contact, assembly_contacts
from feeder_planner.assembly.exact_cone import ExactVerdict, PyramidComparison, check_exact, compare_pyramids
from feeder_planner.assembly.model import Assembly
from feeder_planner.assembly.path import safe_path
from feeder_planner.assembly.region import StableRegion, stable_region
from feeder_planner.assembly.stability import StabilityChecker, StabilityVerdict, unit_gravity
from feeder_planner.assembly.tolerances import (
    DEFAULT_FACETS,
    DEFAULT_PATH_STEP,
    REGION_TOLERANCE_RAD,
    STANDARD_GRAVITY,
)
from feeder_planner.assembly.wrench import EquilibriumSystem, build_system, validate_facets
from feeder_planner.errors import InputError

__all__ = [
    "DEFAULT_FACETS",
    "CheckResult",
    "ContactLoad",
    "PathResult",
    "PreparedAssembly",
    "RegionResult",
    "check_result",
    "contact_loads",
    "path_result",
    "prepare",
    "region_result",
    "validate_mu",
]


@dataclass
class PreparedAssembly:
    """An assembly with its contacts and eq. (9) system for one mu and K; the region is computed on demand."""

    assembly: Assembly
    contacts: list[Contact]
    system: EquilibriumSystem
    mu: float | None
    facets: int
    _checker: StabilityChecker | None = field(default=None, repr=False)
    _region: StableRegion | None = field(default=None, repr=False)

    @property
    def checker(self) -> StabilityChecker:
        """The warm-started single-direction LP (built on first use)."""
        if self._checker is None:
            self._checker = StabilityChecker(self.system)
        return self._checker

    @property
    def region(self) -> StableRegion:
        """The exact stable region (computed on first use)."""
        if self._region is None:
            self._region = stable_region(self.system)
        return self._region

    def check(self, g: np.ndarray) -> StabilityVerdict:
        """Return the stability LP's verdict for gravity direction g (eq. 9)."""
        return self.checker(g)

    def body_names(self, indices: tuple[int, ...]) -> list[str]:
        """Return the names of the bodies with the given indices."""
        return [self.assembly.bodies[i].name for i in indices]


def validate_mu(mu: float | None, field_name: str = "mu") -> float | None:
    """Return ``mu`` as a float (None stays None); InputError naming ``field_name`` unless finite and >= 0."""
    if mu is None:
        return None
    if isinstance(mu, bool) or not isinstance(mu, (int, float)) or not math.isfinite(mu):
        raise InputError(field_name, f"must be a finite number, got {mu!r}")
    if mu < 0:
        raise InputError(field_name, f"must be >= 0, got {mu!r}")
    return float(mu)


def prepare(assembly: Assembly, mu: float | None = None, facets: int = DEFAULT_FACETS) -> PreparedAssembly:
    """Find the contacts and build the LP system of eq. (9), ``mu`` overriding the file's coefficients."""
    mu = validate_mu(mu)
    facets = validate_facets(facets)
    contacts = assembly_contacts(assembly, mu)
    system = build_system(assembly, contacts, facets)
    return PreparedAssembly(assembly, contacts, system, mu, facets)


@dataclass(frozen=True)
class ContactLoad:
    """The force (N) on body ``a`` at one contact point, along with the contact's bodies, point and normal."""

    a: str
    b: str
    point: np.ndarray
    normal: np.ndarray
    force: np.ndarray

    def to_json(self) -> dict[str, Any]:
        """Return one row of the ``forces`` list of ``check-stability --json``."""
        return {
            "a": self.a,
            "b": self.b,
            "point": self.point.tolist(),
            "normal": self.normal.tolist(),
            "force": self.force.tolist(),
        }


def contact_loads(prepared: PreparedAssembly, forces: np.ndarray) -> tuple[ContactLoad, ...]:
    """Name the rows of a certified force distribution: one row of ``forces`` per prepared contact."""
    bodies = prepared.assembly.bodies
    return tuple(
        ContactLoad(bodies[c.a].name, bodies[c.b].name, c.point, c.normal, np.asarray(f))
        for c, f in zip(prepared.contacts, forces, strict=True)
    )


@dataclass(frozen=True)
class RegionResult:
    """The stable region of a prepared assembly, with what the contract's JSON adds to it."""

    region: StableRegion
    assembly: str
    contacts: int
    mu: float
    tolerance_rad: float = REGION_TOLERANCE_RAD
    exact_cone: PyramidComparison | None = None

    def to_json(self) -> dict[str, Any]:
        """Return the ``stable-region --json`` object: the contract's region fields, then ours."""
        result = self.region.to_json()
        result.update(
            {
                "assembly": self.assembly,
                "contacts": self.contacts,
                "mu": self.mu,
                "tolerance_rad": self.tolerance_rad,
            }
        )
        if self.exact_cone is not None:
            result["exact_cone"] = self.exact_cone.to_json()
        return result


def region_result(prepared: PreparedAssembly, exact_cone: bool = False) -> RegionResult:
    """Return the region, contact count and mu; with ``exact_cone`` also the pyramids vs the exact cone."""
    return RegionResult(
        region=prepared.region,
        assembly=prepared.assembly.name,
        contacts=len(prepared.contacts),
        mu=prepared.mu if prepared.mu is not None else prepared.assembly.mu,
        exact_cone=compare_pyramids(prepared.assembly, prepared.contacts) if exact_cone else None,
    )


@dataclass(frozen=True)
class CheckResult:
    """One direction's verdict: contact loads when stable, else the bodies the LP cannot balance; margin."""

    stable: bool
    g: np.ndarray
    facets: int
    unbalanced_bodies: tuple[str, ...]
    forces: tuple[ContactLoad, ...] | None
    margin_rad: float | None
    exact_cone: ExactVerdict | None = None
    gravity_m_s2: float = STANDARD_GRAVITY

    def to_json(self) -> dict[str, Any]:
        """Return the ``check-stability --json`` object (forces in N for |g| = ``gravity_m_s2``)."""
        result: dict[str, Any] = {
            "stable": self.stable,
            "g": self.g.tolist(),
            "facets": self.facets,
            "gravity_m_s2": self.gravity_m_s2,
            "unbalanced_bodies": list(self.unbalanced_bodies),
        }
        if self.forces is not None:
            result["forces"] = [load.to_json() for load in self.forces]
        if self.margin_rad is not None:
            result["margin_rad"] = self.margin_rad
        if self.exact_cone is not None:
            result["exact_cone"] = self.exact_cone.to_json()
        return result


def check_result(
    prepared: PreparedAssembly, g: np.ndarray, with_margin: bool = True, exact_cone: bool = False
) -> CheckResult:
    """Decide g by the stability LP; with ``with_margin`` its margin, with ``exact_cone`` the exact cone."""
    g = unit_gravity(g, "g")
    verdict = prepared.check(g)
    return CheckResult(
        stable=verdict.stable,
        g=g,
        facets=prepared.facets,
        unbalanced_bodies=tuple(prepared.body_names(verdict.unbalanced)),
        forces=None if verdict.forces is None else contact_loads(prepared, verdict.forces),
        margin_rad=prepared.region.margin(g) if with_margin else None,
        exact_cone=check_exact(prepared.assembly, prepared.contacts, g) if exact_cone else None,
    )


@dataclass(frozen=True)
class PathResult:
    """A certified great-arc path (Property 2): unit gravity directions at most ``step_rad`` apart."""

    path: np.ndarray
    step_rad: float
    min_margin_rad: float

    @property
    def samples(self) -> int:
        """Number of directions on the path, both ends included."""
        return len(self.path)

    def to_json(self) -> dict[str, Any]:
        """Return the path as a JSON object (directions, their count, the step and the smallest margin)."""
        return {
            "path": self.path.tolist(),
            "samples": self.samples,
            "step_rad": self.step_rad,
            "min_margin_rad": self.min_margin_rad,
        }


def path_result(
    prepared: PreparedAssembly, g1: np.ndarray, g2: np.ndarray, step: float = DEFAULT_PATH_STEP
) -> PathResult:
    """Plan the great arc from g1 to g2 with every sample certified stable, and its smallest margin."""
    path = safe_path(prepared.region, prepared.checker, g1, g2, step)
    margins = [prepared.region.margin(g) for g in path]
    return PathResult(path, step, min(margins))
