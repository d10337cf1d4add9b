"""The parameters every device has, ROS-free: the base of each device's parameters dataclass.

A device declares its parameters once, as a frozen dataclass deriving from ``DeviceParameters`` whose
fields are ``param(...)`` (``feeder_planner.parameter_specs``); the kit declares them to rclpy, the
launcher validates a scene against them and the docs' tables are read from them, so the three cannot
disagree. The node reads typed values (``self.p.sensor_rate``), replaced whole when a runtime
parameter changes.
"""

from __future__ import annotations

from dataclasses import dataclass

from feeder_planner.parameter_specs import non_negative, param

__all__ = ["DeviceParameters"]


@dataclass(frozen=True)
class DeviceParameters:
    """What the device kit reads of every device: faults, their seed, the pace, the hardware id, lockstep."""

    inject_faults: list[str] = param(
        [""],
        "faults injected at configure, each NAME or NAME=VALUE (docs/cell.md lists each device's faults)",
        read_only=True,
    )
    fault_seed: int = param(0, "seed of the injected faults' random draws", read_only=True)
    real_time_factor: float = param(
        1.0,
        "real-time factor of the cell clock this device must keep up with (feeder launch --real-time-factor "
        "sets it with use_sim_time; 0: no pace, the lockstep at max); the configured figure in status and "
        "diagnostics",
        non_negative,
        read_only=True,
    )
    hardware_id: str = param(
        "", "hardware_id in /diagnostics (empty: sim:<fully qualified node name>)", read_only=True
    )
    lockstep: bool = param(
        False,
        "hold the cell clock until every tick up to its time is done (a tick participant of the cell "
        "clock's lockstep, docs/cell.md; feeder launch --real-time-factor sets it with use_sim_time)",
        read_only=True,
    )
