"""The squeeze gripper's faults as the device kit declares them: one ``FaultSpec`` per gripper fault.

The model's own table (``faults.FAULT_INFO``) says what each fault does; this adds what the kit needs to
inject, label and report it. The status codes are constants of feeder_msgs/SqueezeState (the device's
own message), which this ROS-free package cannot import, so the node hands them in.
"""

from __future__ import annotations

from collections.abc import Mapping

from feeder_device.declarations import FaultSpec
from feeder_sim.squeeze.faults import FAULT_INFO

__all__ = ["fault_specs"]


def fault_specs(codes: Mapping[str, int]) -> dict[str, FaultSpec]:
    """Return the kit's spec of every gripper fault, with its status code from ``codes`` (else none)."""
    return {
        name: FaultSpec(
            name,
            info.description,
            info.value_meaning,
            # A stall and a drop stop the gripper when they act (the node raises its model fault then),
            # not on injection: an armed stall or a drop probability leaves it ready until then.
            stops_device=False,
            code=codes.get(name, 0),
        )
        for name, info in FAULT_INFO.items()
    }
