"""Engineering units of the gateway's physical variables: UN/CEFACT (UNECE Recommendation 20) common codes.

ROS-free and asyncua-free. OPC 10000-8 (Data Access, 5.6.4.4 "Mapping of UN/CEFACT to EUInformation")
says how a common code becomes an ``EUInformation``: the namespaceUri is ``UNECE_NAMESPACE``, the unitId
is the code's characters as the bytes of an Int32 (big-endian, the first character most significant:
"MTR" is 0x4D5452 = 5067858), displayName the unit's symbol and description its name. A variable names
its unit by the common code (``VariableSpec.unit``); the server adds it as the variable's
``EngineeringUnits`` property.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["UNECE_NAMESPACE", "Unit", "UNITS", "unit_id"]

UNECE_NAMESPACE = "http://www.opcfoundation.org/UA/units/un/cefact"


@dataclass(frozen=True)
class Unit:
    """One unit: its UNECE common code, symbol (EUInformation displayName) and name (description)."""

    code: str
    symbol: str
    name: str


def unit_id(code: str) -> int:
    """Return the EUInformation unitId of a UNECE common code (its ASCII characters, big-endian)."""
    if not 2 <= len(code) <= 3 or not code.isascii() or not code.isalnum() or code.upper() != code:
        raise ValueError(f"not a UNECE common code: {code!r}")
    value = 0
    for char in code:
        value = (value << 8) | ord(char)
    return value


# The units the gateway's variables use, by common code.
UNITS: dict[str, Unit] = {
    unit.code: unit
    for unit in (
        Unit("C81", "rad", "radian"),
        Unit("MTR", "m", "metre"),
        Unit("SEC", "s", "second"),
        Unit("HTZ", "Hz", "hertz"),
        Unit("C62", "1", "one (a ratio of two quantities of the same kind)"),
    )
}
