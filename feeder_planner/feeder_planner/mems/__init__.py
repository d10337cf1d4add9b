"""MEMS field array mechanics (Lamiroux & Kavraki): exact lifted radial potential, fields, equilibria.

The public surface the CLI, the nodes and the simulator use: fields and field programs (``fields``),
the equilibria planner (``find_equilibria`` with its methods and results), and the final-pose
prediction (``final_equilibrium``, ``unpredicted_reason``, ``holding_step``). Numerical tolerances
are in ``tolerances``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from feeder_planner.lazy import lazy_exports

if TYPE_CHECKING:  # the package's names; each module is imported on first use (feeder_planner.lazy)
    from feeder_planner.mems.equilibria import find_equilibria
    from feeder_planner.mems.fields import (
        DELTA_MAX,
        DELTA_MIN,
        FIELD_TYPES,
        CombinedField,
        ConstantField,
        Field,
        FieldType,
        ProgramStep,
        QuadraticField,
        RadialField,
        SqueezeField,
        check_delta,
        check_field_type,
        field_from_mapping,
        field_parameters,
        program_from_mapping,
    )
    from feeder_planner.mems.lifted import Edges, loop_edges, part_edges
    from feeder_planner.mems.predict import final_equilibrium, holding_start, holding_step, unpredicted_reason
    from feeder_planner.mems.result import (
        METHODS,
        AsymptoticDetails,
        AutoChoice,
        EquilibriaResult,
        Equilibrium,
        Method,
        NumericDetails,
        SolvingMethod,
        check_method,
    )

__getattr__, __dir__ = lazy_exports(__name__, __file__)

__all__ = [
    "find_equilibria",
    "METHODS",
    "Method",
    "SolvingMethod",
    "check_method",
    "check_delta",
    "DELTA_MIN",
    "DELTA_MAX",
    "EquilibriaResult",
    "Equilibrium",
    "NumericDetails",
    "AsymptoticDetails",
    "AutoChoice",
    "final_equilibrium",
    "holding_start",
    "holding_step",
    "unpredicted_reason",
    "Field",
    "FieldType",
    "FIELD_TYPES",
    "check_field_type",
    "field_parameters",
    "RadialField",
    "ConstantField",
    "CombinedField",
    "SqueezeField",
    "QuadraticField",
    "ProgramStep",
    "field_from_mapping",
    "program_from_mapping",
    "Edges",
    "loop_edges",
    "part_edges",
]
