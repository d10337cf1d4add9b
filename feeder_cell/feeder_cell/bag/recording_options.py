"""What a recording's numeric and named options may be: checked before anything is created.

One line per refused option, naming it (``InputError``), in this order: flush_interval, compression,
max_bag_size, max_bag_duration, post_fault. Apart from the recorder so that its construction reads as
what it builds; the snapshot cache checks its own bounds (``snapshot.check_cache_limits``).
"""

from __future__ import annotations

import math

from feeder_cell.bag.writer import CHUNK_COMPRESSIONS
from feeder_planner.errors import InputError

__all__ = ["COMPRESSIONS", "check_recording_options"]

# MCAP chunk compressions the recorder writes (the names MCAP readers know).
COMPRESSIONS = CHUNK_COMPRESSIONS


def check_recording_options(
    flush_interval: float, compression: str, max_bag_size: int, max_bag_duration: float, post_fault: float
) -> None:
    """Raise InputError naming the first option out of its range."""
    if not (math.isfinite(flush_interval) and flush_interval > 0):
        raise InputError("flush_interval", f"must be a finite number of seconds > 0, got {flush_interval}")
    if compression not in COMPRESSIONS:
        raise InputError("compression", f"must be one of {', '.join(COMPRESSIONS)}, got {compression!r}")
    if not (isinstance(max_bag_size, int) and max_bag_size >= 0):
        raise InputError("max_bag_size", f"must be a whole number of bytes >= 0, got {max_bag_size!r}")
    if not (math.isfinite(max_bag_duration) and max_bag_duration >= 0):
        raise InputError(
            "max_bag_duration", f"must be a finite number of seconds >= 0, got {max_bag_duration}"
        )
    if not (math.isfinite(post_fault) and post_fault >= 0):
        raise InputError("post_fault", f"must be a finite number of seconds >= 0, got {post_fault}")
