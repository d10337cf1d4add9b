"""The standard's services the cell has no use for: served, so that a harness gets FEATURE_UNSUPPORTED.

``UNSUPPORTED`` maps each service name (under the node's own name) to its type and what is not supported;
``unsupported(what)`` is the handler the node serves each with. What is supported, row by row:
``simulation.support``.
"""

from __future__ import annotations

from typing import Any, Awaitable, Callable

from simulation_interfaces.srv import (
    GetAvailableWorlds,
    GetCurrentWorld,
    GetEntityBounds,
    GetNamedPoseBounds,
    GetNamedPoses,
    LoadWorld,
    SetEntityInfo,
    SpawnEntities,
    UnloadWorld,
)

from feeder_cell.simulation.results import FEATURE_UNSUPPORTED, SimulationError

__all__ = ["UNSUPPORTED", "unsupported"]

# Standard services the cell has no use for: served, so that a harness gets FEATURE_UNSUPPORTED, not silence.
UNSUPPORTED = {
    "get_entity_bounds": (GetEntityBounds, "entity bounds"),
    "set_entity_info": (SetEntityInfo, "setting entity info"),
    "get_named_poses": (GetNamedPoses, "named poses"),
    "get_named_pose_bounds": (GetNamedPoseBounds, "named pose bounds"),
    "spawn_entities": (SpawnEntities, "spawning several entities in one call (use spawn_entity)"),
    "load_world": (LoadWorld, "worlds (the cell's one world is its scene)"),
    "unload_world": (UnloadWorld, "worlds (the cell's one world is its scene)"),
    "get_current_world": (GetCurrentWorld, "worlds (the cell's one world is its scene)"),
    "get_available_worlds": (GetAvailableWorlds, "worlds (the cell's one world is its scene)"),
}


def unsupported(what: str) -> Callable[[Any, Any], Awaitable[None]]:
    """Return a service handler that answers FEATURE_UNSUPPORTED, naming ``what`` is not supported."""

    async def handler(request: Any, response: Any) -> None:
        raise SimulationError(FEATURE_UNSUPPORTED, f"{what} is not supported by this cell")

    return handler
