"""Assemblies of rigid bodies under uniform gravity: contacts, the stability LP and the stable region.

Mattikalli, Baraff and Khosla, *Finding All Stable Orientations of Assemblies with Friction*: an assembly file
(``model``) gives bodies and contacts (``contacts``), the equilibrium system of eqs. (5)-(9) (``wrench``) is
decided for one gravity direction by the stability LP (``stability``), the exact region of stable directions
is built from support LPs (``region``, ``support``, ``lp``), paths follow Property 2's great arcs (``path``),
and the exact Coulomb cone is measured against the paper's pyramid (``exact_cone``). ``planner`` is what the
CLI and the nodes call; ``tolerances`` holds every tolerance and model constant.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from feeder_planner.lazy import lazy_exports

if TYPE_CHECKING:  # the package's names; each module is imported on first use (feeder_planner.lazy)
    from feeder_planner.assembly.contacts import Contact, assembly_contacts
    from feeder_planner.assembly.default import DEFAULT_ASSEMBLY_YAML
    from feeder_planner.assembly.exact_cone import (
        ExactVerdict,
        PyramidComparison,
        check_exact,
        compare_pyramids,
    )
    from feeder_planner.assembly.model import (
        Assembly,
        assembly_from_document,
        assembly_from_text,
        load_assembly,
    )
    from feeder_planner.assembly.path import great_arc, safe_path
    from feeder_planner.assembly.planner import (
        CheckResult,
        ContactLoad,
        PathResult,
        PreparedAssembly,
        RegionResult,
        check_result,
        contact_loads,
        path_result,
        prepare,
        region_result,
        validate_mu,
    )
    from feeder_planner.assembly.region import KINDS, RegionKind, StableRegion, stable_region
    from feeder_planner.assembly.stability import StabilityChecker, StabilityVerdict, unit_gravity
    from feeder_planner.assembly.tolerances import (
        DEFAULT_FACETS,
        DEFAULT_PATH_STEP,
        MIN_DIRECTION_NORM,
        MIN_FACETS,
        STANDARD_GRAVITY,
    )
    from feeder_planner.assembly.wrench import EquilibriumSystem, build_system, validate_facets

__getattr__, __dir__ = lazy_exports(__name__, __file__)

__all__ = [
    "DEFAULT_ASSEMBLY_YAML",
    "DEFAULT_FACETS",
    "DEFAULT_PATH_STEP",
    "KINDS",
    "MIN_DIRECTION_NORM",
    "MIN_FACETS",
    "STANDARD_GRAVITY",
    "Assembly",
    "CheckResult",
    "Contact",
    "ContactLoad",
    "EquilibriumSystem",
    "ExactVerdict",
    "PathResult",
    "PreparedAssembly",
    "PyramidComparison",
    "RegionKind",
    "RegionResult",
    "StabilityChecker",
    "StabilityVerdict",
    "StableRegion",
    "assembly_contacts",
    "assembly_from_document",
    "assembly_from_text",
    "build_system",
    "check_exact",
    "check_result",
    "compare_pyramids",
    "contact_loads",
    "great_arc",
    "load_assembly",
    "path_result",
    "prepare",
    "region_result",
    "safe_path",
    "stable_region",
    "unit_gravity",
    "validate_facets",
    "validate_mu",
]
