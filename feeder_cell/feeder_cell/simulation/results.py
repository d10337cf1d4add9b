"""The standard's result codes (``simulation_interfaces/msg/Result`` and per-service codes) as one error.

A request the cell refuses raises ``SimulationError(code, message)``; the node answers it in the
response's ``result`` and keeps serving. The values are the standard's (release 1.5.1); the hash test of
the interface package (tests/foundation/test_standard_interfaces.py) pins the definitions they come from.
"""

from __future__ import annotations

__all__ = [
    "FEATURE_UNSUPPORTED",
    "OK",
    "NOT_FOUND",
    "INCORRECT_STATE",
    "OPERATION_FAILED",
    "ALREADY_IN_TARGET_STATE",
    "INCORRECT_TRANSITION",
    "STATE_TRANSITION_ERROR",
    "NAME_NOT_UNIQUE",
    "NAME_INVALID",
    "UNSUPPORTED_FORMAT",
    "NO_RESOURCE",
    "NAMESPACE_INVALID",
    "RESOURCE_PARSE_ERROR",
    "SPAWN_INVALID_POSE",
    "SET_INVALID_POSE",
    "SimulationError",
]

# simulation_interfaces/msg/Result
FEATURE_UNSUPPORTED = 0
OK = 1
NOT_FOUND = 2
INCORRECT_STATE = 3
OPERATION_FAILED = 4
# SetSimulationState
ALREADY_IN_TARGET_STATE = 101
STATE_TRANSITION_ERROR = 102
INCORRECT_TRANSITION = 103
# SpawnEntity
NAME_NOT_UNIQUE = 101
NAME_INVALID = 102
UNSUPPORTED_FORMAT = 103
NO_RESOURCE = 104
NAMESPACE_INVALID = 105
RESOURCE_PARSE_ERROR = 106
SPAWN_INVALID_POSE = 109
# SetEntityState
SET_INVALID_POSE = 101


class SimulationError(Exception):
    """A refused request: the standard's result code and a one-line message naming the field."""

    def __init__(self, code: int, message: str) -> None:
        super().__init__(message)
        self.code = code
        self.message = message
