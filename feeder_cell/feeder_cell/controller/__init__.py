"""The reference cell controller's ROS-free part: the cycle's state machine, its fault policy, its metrics.

``feeder_cell.nodes.cell_controller`` is the ROS 2 node that performs each state's work against the
devices' standard interfaces and feeds the outcomes to ``CellMachine``; its ROS side, one concern per
module (the bounded waits and calls, the stations, the squeeze gripper, fault injection, the file
parameters), is ``feeder_cell.controller_ros``. The ROS-free loop (``feeder_cell.experiment``) drives
the same machine without ROS.
"""

from feeder_cell.controller.machine import (
    ANY_CODE,
    DEVICE_OF,
    FAULT_POLICY,
    ORIENTERS,
    TRANSITIONS,
    CellMachine,
    CellMetrics,
    Outcome,
    Policy,
    State,
    Transition,
    policy_for,
    policy_table,
    transition_table,
)

__all__ = [
    "ANY_CODE",
    "DEVICE_OF",
    "FAULT_POLICY",
    "ORIENTERS",
    "TRANSITIONS",
    "CellMachine",
    "CellMetrics",
    "Outcome",
    "Policy",
    "State",
    "Transition",
    "policy_for",
    "policy_table",
    "transition_table",
]
