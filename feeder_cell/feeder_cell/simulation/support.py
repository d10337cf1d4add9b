"""What the cell supports of the standard: one row per SimulatorFeatures value, and why where it does not.

``SUPPORT`` is the one list: GetSimulatorFeatures answers its supported values as ``features`` and its
reasons as ``custom_info``; docs/cell.md's feature table has the same rows (a test compares them).
The values are the standard's (``simulation_interfaces/msg/SimulatorFeatures``, release 1.5.1).
``VELOCITY`` states, per entity category, whether SetEntityState applies a twist.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Support", "SUPPORT", "FEATURES", "VELOCITY", "custom_info"]


@dataclass(frozen=True)
class Support:
    """One feature of the standard: its name and value, whether the cell supports it, and how or why not."""

    name: str
    value: int
    supported: bool
    note: str


WORLDS = "the cell has one world, its scene (feeder launch SCENE)"
SUPPORT = (
    Support("SPAWNING", 0, True, "a part onto the MEMS array, the device the initial pose's frame names"),
    Support("DELETING", 1, True, "a part on the array; devices, the arm's part and fixture bodies are not"),
    Support("NAMED_POSES", 2, False, "the cell defines no named poses"),
    Support("POSE_BOUNDS", 3, False, "the cell defines no named poses"),
    Support("ENTITY_TAGS", 4, False, "entities carry no tags"),
    Support("ENTITY_BOUNDS", 5, False, "GetEntityBounds: entities are filtered as points (sphere filter)"),
    Support("ENTITY_BOUNDS_BOX", 6, False, "filters: only the sphere (TYPE_SPHERE), which is supported"),
    Support("ENTITY_BOUNDS_CONVEX", 7, False, "filters: only the sphere (TYPE_SPHERE), which is supported"),
    Support("ENTITY_CATEGORIES", 8, True, "ROBOT (devices), OBJECT (parts, free bodies), STATIC_OBJECT"),
    Support("SPAWNING_RESOURCE_STRING", 9, True, "inline part YAML"),
    Support("ENTITY_STATE_GETTING", 10, True, "in the world frame (the fixture's bodies: its tilting frame)"),
    Support("ENTITY_STATE_SETTING", 11, True, "a part's pose, at rest; see velocity"),
    Support("ENTITY_INFO_GETTING", 12, True, "category and description"),
    Support("ENTITY_INFO_SETTING", 13, False, "categories and descriptions follow from the scene"),
    Support("SPAWNABLES", 14, True, "part files in the scene's part directories and in sources"),
    Support("SIMULATION_RESET", 20, True, "scopes DEFAULT and ALL reset time, state and spawned"),
    Support(
        "SIMULATION_RESET_TIME",
        21,
        True,
        "the clock back to its start, with STATE; not with a controller or recorder in the lockstep",
    ),
    Support("SIMULATION_RESET_STATE", 22, True, "every device reconfigured, spawned parts spawned again"),
    Support("SIMULATION_RESET_SPAWNED", 23, True, "spawned parts removed"),
    Support("SIMULATION_STATE_GETTING", 24, True, "LOADING_WORLD until every lockstep participant joined"),
    Support("SIMULATION_STATE_SETTING", 25, True, "PLAYING, PAUSED, STOPPED (QUITTING is not)"),
    Support("SIMULATION_STATE_PAUSE", 26, True, "the clock holds at a quantum boundary"),
    Support("STEP_SIMULATION_SINGLE", 31, True, "a step is one lockstep quantum"),
    Support("STEP_SIMULATION_MULTIPLE", 32, True, "1 to 10^6 steps; a state change interrupts them"),
    Support("STEP_SIMULATION_ACTION", 33, True, "feedback per step; cancel or a state change between steps"),
    Support("WORLD_LOADING", 40, False, WORLDS),
    Support("WORLD_RESOURCE_STRING", 41, False, WORLDS),
    Support("WORLD_TAGS", 42, False, WORLDS),
    Support("WORLD_UNLOADING", 43, False, WORLDS),
    Support("WORLD_INFO_GETTING", 44, False, WORLDS),
    Support("AVAILABLE_WORLDS", 45, False, WORLDS),
    Support("SPAWNING_ENTITIES", 50, False, "one entity per call: SpawnEntity"),
)
FEATURES = tuple(row.value for row in SUPPORT if row.supported)

# SetEntityState's twist, per entity (kind: category, and why a non-zero twist is or is not applied).
VELOCITY = {
    "array_part": (
        "OBJECT on the MEMS array",
        "refused: in the ideal and array fidelities the model is quasi-static (the velocity follows from "
        "the field's force, v = F / (damping A): no velocity state); the dynamic fidelity has one, but "
        "the array's ~/place_parts sets a pose only",
    ),
    "arm_part": ("OBJECT on the throwing arm", "refused: the part rests on the arm, which moves it"),
    "fixture_body": ("OBJECT or STATIC_OBJECT of the fixture", "refused: the fixture holds it"),
    "device": ("ROBOT", "refused: a device is fixed in the cell (its cell_pose)"),
}


def custom_info(quantum_s: float) -> str:
    """Return GetSimulatorFeatures' custom_info: units, what is not supported and why, velocity."""
    unsupported = "; ".join(f"{row.name}: {row.note}" for row in SUPPORT if not row.supported)
    velocity = "; ".join(f"{what}: {why}" for what, why in VELOCITY.values())
    return (
        f"feeder cell (docs/cell.md). A step is one lockstep quantum of cell time ({quantum_s:g} s); "
        "spawn format feeder_part_yaml is a part file (contract section 2); frame 'world' (or '') is the "
        "cell's root frame. Not supported: "
        f"{unsupported}. Velocity (SetEntityState twist) per entity: {velocity}; acceleration is ignored."
    )
