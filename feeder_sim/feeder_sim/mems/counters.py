"""The MEMS field array's counters: declared once, read by its status, diagnostics, the gateway and plots."""

from feeder_device.declarations import CounterSpec

__all__ = ["COUNTERS"]

COUNTERS = (
    CounterSpec("steps", "ideal or dynamic model steps simulated"),
    CounterSpec("steps_dropped", "steps a tick owed beyond max_steps_per_tick, not simulated"),
    CounterSpec("programs", "field programs installed (~/set_program and ~/run_program)"),
    CounterSpec("placements", "parts placed (~/place_parts)"),
    CounterSpec("parts_settled", "parts at rest now (derived from the model)"),
    CounterSpec("program_goals", "~/run_program goals accepted"),
    CounterSpec(
        "stiff_steps", "time_steps the ideal model had to cut for stability (derived from the model)"
    ),
    CounterSpec("spawned", "parts added at runtime (~/spawn_part)"),
    CounterSpec("removed", "parts taken off the array (~/remove_part)"),
)
