"""Random streams of a replication: one independent numpy Generator per purpose (common random numbers).

Replication i of a scene seeded s draws each purpose from its own stream, the child

    SeedSequence(s).spawn(...)[i].spawn(...)[PURPOSES[purpose]](.spawn(...)[k] for each further key k)

made directly as ``SeedSequence(s, spawn_key=(i, PURPOSES[purpose], *keys))`` (the same state numpy's
spawn gives, without spawning every sibling first). So replication i sees the same arrivals whatever the
scenario does with its faults, and cycle k's arrival is the same whether or not an earlier cycle drew
more: a scenario that changes one purpose leaves every other stream as it was, and paired differences
between scenarios are differences of the scenario, not of the dice.
"""

from __future__ import annotations

import zlib
from typing import Final

import numpy as np

from feeder_planner.errors import InputError

__all__ = ["PURPOSES", "check_seed", "device_key", "seed_sequence", "stream"]

# Each purpose's fixed index in the spawn key: new purposes are appended, never renumbered, so a stream
# stays the same stream across versions.
PURPOSES: Final[dict[str, int]] = {
    "mems_arrival": 0,  # orientation and position of each part placed on the MEMS array, per cycle
    "arm_arrival": 1,  # resting edge and radius of the part at the arm's infeed, per cycle
    "faults": 2,  # failures and repairs, per device
}
# Seeds are 64-bit non-negative integers (numpy's SeedSequence takes any, a scene's YAML stays portable).
MAX_SEED: Final = 2**64 - 1


def check_seed(value: object, field: str) -> int:
    """Return a seed (an integer in [0, 2^64)), else an InputError naming ``field``."""
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= MAX_SEED:
        raise InputError(field, f"must be an integer in [0, 2^64), got {value!r}")
    return value


def device_key(name: str) -> int:
    """Return a stable spawn key of a device name (CRC-32): the same stream whatever the device order."""
    return zlib.crc32(name.encode("utf-8"))


def seed_sequence(seed: int, replication: int, purpose: str, *keys: int) -> np.random.SeedSequence:
    """Return the SeedSequence of ``purpose`` (and ``keys``) in replication ``replication``."""
    if purpose not in PURPOSES:
        raise ValueError(f"unknown random stream purpose {purpose!r}")
    if replication < 0 or any(k < 0 for k in keys):
        raise ValueError("replications and stream keys are >= 0")
    return np.random.SeedSequence(seed, spawn_key=(replication, PURPOSES[purpose], *keys))


def stream(seed: int, replication: int, purpose: str, *keys: int) -> np.random.Generator:
    """Return a fresh Generator (PCG64) of ``purpose`` (and ``keys``) in replication ``replication``."""
    return np.random.Generator(np.random.PCG64(seed_sequence(seed, replication, purpose, *keys)))
