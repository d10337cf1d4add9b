"""What the CLI and the nodes call: an assembly prepared once, then region, check and path as JSON-ready dicts."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from feeder_planner.assembly.contacts import Contact, assembly_contacts
from feeder_planner.assembly.model import Assembly
from feeder_planner.assembly.path import DEFAULT_STEP, safe_path
from feeder_planner.assembly.region import StableRegion, stable_region
from feeder_planner.assembly.stability import StabilityChecker, StabilityVerdict, unit_gravity
from feeder_planner.assembly.wrench import STANDARD_GRAVITY, EquilibriumSystem, build_system
from feeder_planner.errors import InputError

DEFAULT_FACETS = 4


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
        if self._region is None:
            self._region = stable_region(self.system)
        return self._region

    def check(self, g: np.ndarray) -> StabilityVerdict:
        return self.checker(g)

    def body_names(self, indices: tuple[int, ...]) -> list[str]:
        return [self.assembly.bodies[i].name for i in indices]


def validate_mu(mu: float | None, field_name: str = "mu") -> float | None:
    if mu is None:
        return None
    if isinstance(mu, bool) or not isinstance(mu, (int, float)) or not math.isfinite(mu):
        raise InputError(field_name, f"must be a finite number, got {mu!r}")
    if mu < 0:
        raise InputError(field_name, f"must be >= 0, got {mu!r}")
    return float(mu)


def prepare(assembly: Assembly, mu: float | None = None, facets: int = DEFAULT_FACETS) -> PreparedAssembly:
    """Contacts (automatic or explicit), and the LP system with ``mu`` overriding the file's coefficients."""
    mu = validate_mu(mu)
    if isinstance(facets, bool) or not isinstance(facets, (int, np.integer)) or facets < 3:
        raise InputError("facets", f"the friction pyramid needs an integer K >= 3, got {facets!r}")
    contacts = assembly_contacts(assembly, mu)
    system = build_system(assembly, contacts, int(facets))
    return PreparedAssembly(assembly, contacts, system, mu, int(facets))


def region_result(prepared: PreparedAssembly) -> dict:
    """The contract's ``stable-region --json`` object, plus the contact count and the LP count."""
    result = prepared.region.to_json()
    result.update(
        {
            "assembly": prepared.assembly.name,
            "contacts": len(prepared.contacts),
            "mu": prepared.mu if prepared.mu is not None else prepared.assembly.mu,
            "tolerance_rad": 1e-7,
        }
    )
    return result


def check_result(prepared: PreparedAssembly, g: np.ndarray, with_margin: bool = True) -> dict:
    """The contract's ``check-stability --json`` object: verdict, contact forces (N) or the bodies that move."""
    g = unit_gravity(g, "g")
    verdict = prepared.check(g)
    result: dict = {
        "stable": verdict.stable,
        "g": g.tolist(),
        "facets": prepared.facets,
        "gravity_m_s2": STANDARD_GRAVITY,
        "unbalanced_bodies": prepared.body_names(verdict.unbalanced),
    }
    if verdict.forces is not None:
        result["forces"] = [
            {
                "a": prepared.assembly.bodies[c.a].name,
                "b": prepared.assembly.bodies[c.b].name,
                "point": c.point.tolist(),
                "normal": c.normal.tolist(),
                "force": f.tolist(),
            }
            for c, f in zip(prepared.contacts, verdict.forces)
        ]
    if with_margin:
        result["margin_rad"] = prepared.region.margin(g)
    return result


def path_result(
    prepared: PreparedAssembly, g1: np.ndarray, g2: np.ndarray, step: float = DEFAULT_STEP
) -> dict:
    """A certified great-arc path (Property 2) as a list of unit gravity directions."""
    path = safe_path(prepared.region, prepared.checker, g1, g2, step)
    margins = [prepared.region.margin(g) for g in path]
    return {"path": path.tolist(), "samples": len(path), "step_rad": step, "min_margin_rad": min(margins)}
