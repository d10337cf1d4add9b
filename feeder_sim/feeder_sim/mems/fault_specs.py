"""The MEMS field array's faults as the device kit declares them: one ``FaultSpec`` per injectable fault.

The force model (``faults``) checks the magnitudes and puts each fault into effect; this is what the kit
needs to inject, label and report it. The status codes are constants of feeder_msgs/DeviceStatus, which
this ROS-free package cannot import, so the node hands them in.
"""

from __future__ import annotations

from collections.abc import Mapping

from feeder_device.declarations import FaultSpec

__all__ = ["fault_specs"]


def fault_specs(codes: Mapping[str, int]) -> dict[str, FaultSpec]:
    """Return the kit's spec of every array fault, with its status code from ``codes`` (else none)."""
    return {
        "dead_cells": FaultSpec(
            "dead_cells",
            "cells that push with no force (array fidelity)",
            "fraction of the cells in (0, 1], drawn with the seed; or explicit indices (i * ny + j)",
            indices_label="cells",
            code=codes.get("dead_cells", 0),
        ),
        "stuck_cells": FaultSpec(
            "stuck_cells",
            "cells stuck pushing in direction angle (rad) at the field's magnitude (array fidelity)",
            "fraction of the cells in (0, 1], drawn with the seed; or explicit indices; angle: the direction",
            indices_label="cells",
            code=codes.get("stuck_cells", 0),
        ),
        "field_strength_error": FaultSpec(
            "field_strength_error",
            "every cell force scaled by 1 + e",
            "relative error e (> -1, nonzero)",
            code=codes.get("field_strength_error", 0),
        ),
        "power_loss": FaultSpec(
            "power_loss",
            "the array has lost power: no field at all",
            stops_device=True,
            code=codes.get("power_loss", 0),
        ),
    }
