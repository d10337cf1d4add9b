"""The throwing arm's faults as the device kit declares them: one ``FaultSpec`` per model fault.

The model's own table (``faults.FAULT_INFO``) says what each fault does; this adds what the kit needs
to inject, label and report it. The status codes are constants of feeder_msgs/DeviceStatus, which this
ROS-free package cannot import, so the node hands them in.
"""

from __future__ import annotations

from collections.abc import Mapping

from feeder_device.declarations import FaultSpec
from feeder_sim.throwing.faults import FAULT_INFO

__all__ = ["fault_specs"]

# The request's state is part of the fault: the stuck bit; a fixed e rather than a drawn one.
SHOWS_STATE = ("sensor_stuck", "release_speed_error")


def fault_specs(codes: Mapping[str, int]) -> dict[str, FaultSpec]:
    """Return the kit's spec of every model fault, with its status code from ``codes`` (else none)."""
    return {
        name: FaultSpec(
            name,
            info.description,
            info.value_meaning,
            info.stops,
            codes.get(name, 0),
            shows_state=name in SHOWS_STATE,
        )
        for name, info in FAULT_INFO.items()
    }
