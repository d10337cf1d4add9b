"""The squeeze gripper's counters: declared once, read by its status, diagnostics, the gateway and plots."""

from feeder_device.declarations import CounterSpec

__all__ = ["COUNTERS"]

COUNTERS = (
    CounterSpec("squeezes", "squeezes completed (the jaws closed on the part and read its width)"),
    CounterSpec("squeeze_goals", "~/squeeze goals accepted"),
    CounterSpec("plan_goals", "~/run_plan goals accepted"),
    CounterSpec("plans_done", "~/run_plan goals that completed every squeeze"),
    CounterSpec("parts_placed", "parts placed between the jaws (~/place_part)"),
    CounterSpec("jaw_stalls", "squeezes stopped by a jaw stall (fault jaw_stall acting)"),
    CounterSpec("parts_dropped", "parts dropped from the jaws (fault part_dropped acting)"),
    CounterSpec("capped_ticks", "ticks whose gap was longer than max_advance_per_tick, not simulated"),
)
