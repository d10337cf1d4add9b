"""The reference cell controller's ROS-free part: the cycle's state machine, its fault policy, its metrics.

``feeder_cell.nodes.cell_controller`` is the ROS 2 node that performs each state's work against the
devices' standard interfaces and feeds the outcomes to ``CellMachine``.
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
