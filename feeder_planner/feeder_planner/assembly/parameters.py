"""The parameters every node that holds an assembly declares, ROS-free, and the file they name.

The stable-region planner and the assembly fixture declare the same four: one definition for both, for the
scene validation and for the docs' parameter tables.
"""

from __future__ import annotations

from dataclasses import dataclass

from feeder_planner.assembly.default import DEFAULT_ASSEMBLY_YAML
from feeder_planner.assembly.model import Assembly, assembly_from_text, load_assembly
from feeder_planner.assembly.tolerances import DEFAULT_FACETS, MIN_FACETS
from feeder_planner.errors import InputError
from feeder_planner.parameter_specs import integer_at_least, non_negative, param, specs_of

__all__ = ["AssemblyParameters", "ASSEMBLY_PARAMETERS", "load_assembly_parameter"]


@dataclass(frozen=True)
class AssemblyParameters:
    """The assembly a node holds: its file, friction and friction-pyramid facets."""

    assembly_file: str = param(
        "",
        "assembly YAML file (contract section 2); empty = the built-in block in an L bracket "
        "(paper Figs. 12/14, mu 0.3)",
        read_only=True,
    )
    override_mu: bool = param(
        False, "use the parameter mu for every contact instead of the file's coefficients", read_only=True
    )
    mu: float = param(
        0.0, "Coulomb friction coefficient (>= 0) used when override_mu is true", non_negative, read_only=True
    )
    facets: int = param(
        DEFAULT_FACETS,
        f"facets K >= {MIN_FACETS} of the friction pyramid ({DEFAULT_FACETS} is the paper's)",
        integer_at_least(MIN_FACETS),
        read_only=True,
    )


ASSEMBLY_PARAMETERS = specs_of(AssemblyParameters)


def load_assembly_parameter(path: str) -> Assembly:
    """Load the assembly the ``assembly_file`` parameter names (built-in when empty); errors name it."""
    if not path:
        return assembly_from_text(DEFAULT_ASSEMBLY_YAML, "built-in assembly")
    try:
        return load_assembly(path)
    except InputError as error:
        raise InputError(f"parameter assembly_file ({error.field})", error.problem, error.source) from None
