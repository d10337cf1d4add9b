"""The throwing arm's counters: declared once, read by its status, diagnostics, the gateway and the plots."""

from feeder_device.declarations import CounterSpec

__all__ = ["COUNTERS"]

COUNTERS = (
    CounterSpec("throws", "throws made, by ~/command and ~/feed_part alike"),
    CounterSpec("faults", "throws that ended in a fault (the part left the arm)"),
    CounterSpec("parts_presented", "throws that landed with the true sensor bit at rest"),
    CounterSpec("feed_goals", "~/feed_part goals accepted"),
    CounterSpec("feeds_presented", "~/feed_part goals that ended PRESENTED"),
    CounterSpec("parts_loaded", "parts that replaced the arm's part (~/load_part)"),
)
