"""What the reference controller reports: its ~/status and its /diagnostics entry, from the machine.

Message building only (no node, no rclpy): the node stamps, publishes and decides when.
"""

from __future__ import annotations

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue

from feeder_cell.controller.machine import CellMachine, State, Transition
from feeder_msgs.msg import CellStatus

__all__ = ["cell_status", "diagnostic_entry"]


def cell_status(machine: CellMachine, last: Transition | None, stamp: Time, now: float) -> CellStatus:
    """Return the controller's status: the machine's state, last transition and metrics at ``now`` (s)."""
    m = machine.metrics
    msg = CellStatus()
    msg.header.stamp = stamp
    msg.state = machine.state.value
    msg.previous_state = last.source.value if last else ""
    msg.device = machine.device
    msg.last_outcome = last.outcome.label() if last else ""
    msg.last_policy = last.policy.value if last and last.policy else ""
    msg.cycle, msg.cycles = machine.cycle, machine.cycles
    msg.cycles_completed, msg.parts_presented = m.cycles_completed, m.parts_presented
    msg.faults_seen, msg.faults_handled = m.faults_seen, m.faults_handled
    msg.retries, msg.reroutes = m.retries, m.reroutes
    msg.last_cycle_time, msg.mean_cycle_time = m.last_cycle_time, m.mean_cycle_time
    msg.parts_per_minute = m.parts_per_minute(now)
    msg.last_fault = m.last_fault
    msg.finished = machine.finished
    msg.stopped = machine.state is State.STOPPED
    msg.stop_reason = machine.stop_reason
    msg.fault_code = last.outcome.fault_code if msg.stopped and last else 0
    return msg


def diagnostic_entry(msg: CellStatus, name: str, hardware_id: str) -> DiagnosticStatus:
    """Return the /diagnostics entry for the status ``msg``: ERROR stopped, WARN after a fault."""
    entry = DiagnosticStatus(name=name, hardware_id=hardware_id)
    if msg.stopped:
        entry.level, entry.message = DiagnosticStatus.ERROR, f"STOPPED: {msg.stop_reason}"
    elif msg.last_policy:
        entry.level, entry.message = DiagnosticStatus.WARN, f"{msg.state}: {msg.last_outcome}"
    else:
        entry.level, entry.message = DiagnosticStatus.OK, msg.state
    values = {
        "state": msg.state,
        "cycle": msg.cycle,
        "cycles_completed": msg.cycles_completed,
        "parts_presented": msg.parts_presented,
        "faults_seen": msg.faults_seen,
        "faults_handled": msg.faults_handled,
        "retries": msg.retries,
        "reroutes": msg.reroutes,
        "last_cycle_time": f"{msg.last_cycle_time:.6g}",
        "parts_per_minute": f"{msg.parts_per_minute:.6g}",
        "last_fault": msg.last_fault,
    }
    entry.values = [KeyValue(key=k, value=str(v)) for k, v in values.items()]
    return entry
