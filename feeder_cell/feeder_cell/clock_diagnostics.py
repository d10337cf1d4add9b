"""The cell clock's lockstep status as a diagnostic_msgs/DiagnosticArray (``cell_clock`` publishes it)."""

from __future__ import annotations

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

from feeder_cell.clock_parameters import NANOSECONDS, to_time
from feeder_cell.lockstep_barrier import Barrier

__all__ = ["lockstep_diagnostics"]


def lockstep_diagnostics(
    barrier: Barrier,
    *,
    name: str,
    now_ns: int,
    quantum: float,
    factor: float,
    quanta: int,
    paused: bool,
    stopped: str,
) -> DiagnosticArray:
    """Return the lockstep's status: ERROR naming the dropped (or why the clock holds), else OK."""
    if barrier.dropped or stopped:
        level = DiagnosticStatus.ERROR
        message = stopped or "; ".join(d.describe() for d in barrier.dropped)
    else:
        level, message = DiagnosticStatus.OK, f"lockstep at T = {now_ns / NANOSECONDS:.3f} s"
    waiting = barrier.waiting_for()
    values = {
        "quantum_s": f"{quantum:g}",
        "real_time_factor": "max" if factor == 0 else f"{factor:g}",
        "cell_time_s": f"{now_ns / NANOSECONDS:.9f}",
        "quanta": str(quanta),
        "phase": barrier.phase,
        "paused": str(paused).lower(),
        "participants": ", ".join(f"{m.name} ({m.role})" for m in barrier.members.values()),
        "waiting_for": ", ".join(m.name for m in waiting),
        "dropped": ", ".join(d.name for d in barrier.dropped),
    }
    status = DiagnosticStatus(
        level=level,
        name=f"{name}: lockstep",
        message=message,
        hardware_id="sim:cell_clock",
        values=[KeyValue(key=k, value=v) for k, v in values.items()],
    )
    array = DiagnosticArray(status=[status])
    array.header.stamp = to_time(now_ns)
    return array
