"""The device kinds the gateway knows: one profile per kind, one module per kind, and this registry.

A kind's module holds its ``PROFILE`` (``spec.KindProfile``): its ``Signals`` variables and the topics that
set them, its action method with the argument check and the goal, feedback and result it maps, and the
counters it shows, taken from the device's own declaration. A new kind is one module here and one line in
``KINDS``; nothing else in the gateway names a kind. The key is the kind's name: the simulator's
executable (and default node name), and the ``KIND`` of a ``devices`` entry.
"""

from __future__ import annotations

from feeder_cell.gateway.kinds import assembly_fixture, mems_field_array, squeeze_gripper, throwing_arm
from feeder_cell.gateway.spec import KindProfile

__all__ = ["KINDS"]

# In this order the gateway lists them (the Kind variable's description, a bad devices entry's message).
KINDS: dict[str, KindProfile] = {
    "throwing_arm": throwing_arm.PROFILE,
    "mems_field_array": mems_field_array.PROFILE,
    "assembly_fixture": assembly_fixture.PROFILE,
    "squeeze_gripper": squeeze_gripper.PROFILE,
}
