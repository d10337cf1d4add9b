"""The parameters every node that holds an assembly declares, ROS-free, and the file they name.

The stable-region planner and the assembly fixture declare the same four: one definition for both, for the
scene validation and for the docs' parameter tables.
"""

from __future__ import annotations

from feeder_planner.assembly.default import DEFAULT_ASSEMBLY_YAML
from feeder_planner.assembly.model import Assembly, assembly_from_text, load_assembly
from feeder_planner.assembly.tolerances import DEFAULT_FACETS, MIN_FACETS
from feeder_planner.errors import InputError
from feeder_planner.parameter_specs import ParameterSpec, integer_at_least, non_negative

__all__ = ["ASSEMBLY_PARAMETERS", "load_assembly_parameter"]

ASSEMBLY_PARAMETERS = (
    ParameterSpec(
        "assembly_file",
        "",
        "assembly YAML file (contract section 2); empty = the built-in block in an L bracket "
        "(paper Figs. 12/14, mu 0.3)",
        read_only=True,
    ),
    ParameterSpec(
        "override_mu",
        False,
        "use the parameter mu for every contact instead of the file's coefficients",
        read_only=True,
    ),
    ParameterSpec(
        "mu",
        0.0,
        "Coulomb friction coefficient (>= 0) used when override_mu is true",
        non_negative,
        read_only=True,
    ),
    ParameterSpec(
        "facets",
        DEFAULT_FACETS,
        f"facets K >= {MIN_FACETS} of the friction pyramid ({DEFAULT_FACETS} is the paper's)",
        integer_at_least(MIN_FACETS),
        read_only=True,
    ),
)



def load_assembly_parameter(path: str) -> Assembly:
    """Load the assembly the ``assembly_file`` parameter names (built-in when empty); errors name it."""
    if not path:
        return assembly_from_text(DEFAULT_ASSEMBLY_YAML, "built-in assembly")
    try:
        return load_assembly(path)
    except InputError as error:
        raise InputError(f"parameter assembly_file ({error.field})", error.problem, error.source) from None
