"""Status and diagnostics: the device as a controller sees it, on ``~/status`` and ``/diagnostics``.

``~/status`` is published on every change and as a 1 Hz heartbeat on the steady clock; ``/diagnostics`` at
1 Hz. The state is derived (``state``), never stored: from the lifecycle, a stop, the faults and whether
the device is busy, so no path can leave a stale one behind.
"""

from __future__ import annotations

import copy
import time

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.clock import Clock, ClockType

from feeder_device.core import DeviceCore, DeviceState, P
from feeder_device.declarations import DeviceError, stopping_fault
from feeder_device.rate import RateReport
from feeder_msgs.msg import DeviceStatus

__all__ = ["HEARTBEAT_RATE", "StatusReporting"]

# Heartbeat of ~/status and /diagnostics (Hz), on the steady clock so that a paused sim clock does not
# silence a device: a controller must still see that the device is there and why it is not moving.
HEARTBEAT_RATE = 1.0


class StatusReporting(DeviceCore[P]):
    """The controller-facing state, ``~/status``, ``/diagnostics`` and their heartbeat."""

    def _start_heartbeat(self) -> None:
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(1.0 / HEARTBEAT_RATE, self._heartbeat, clock=steady)

    def state(self) -> DeviceState:
        """Return the controller-facing state, derived from lifecycle, stop, faults and business."""
        if self.internal_error:
            return DeviceState.FAULT  # unconfigured by its error path, and saying why
        if self.lifecycle != "active" and self.lifecycle != "inactive":
            return DeviceState.UNCONFIGURED
        if self.stopping_fault() is not None:
            return DeviceState.FAULT
        if self.lifecycle == "inactive":
            return DeviceState.PAUSED
        if self.stopped:
            return DeviceState.STOPPED
        return DeviceState.RUNNING if self.busy() else DeviceState.IDLE

    def stopping_fault(self) -> tuple[int, str] | None:
        """(code, text) of the fault that stops the device, or None."""
        if self.internal_error:
            return DeviceStatus.FAULT_INTERNAL, self.internal_error
        return stopping_fault(self.model_fault, self.faults.values())

    def warning_fault(self) -> tuple[int, str] | None:
        """(code, text) of an injected fault in force that has a code but does not stop the device.

        A device overrides this where a fault's code applies only once it acts (a stall that is armed).
        """
        for fault in self.faults.values():
            if fault.spec.code and not fault.spec.stops_device:
                return fault.spec.code, f"injected fault {fault.label}: {fault.spec.description}"
        return None

    def require_ready(self, what: str) -> None:
        """Raise DeviceError naming the state unless the device accepts commands."""
        state = self.state()
        if state not in (DeviceState.IDLE, DeviceState.RUNNING):
            why = ""
            fault = self.stopping_fault()
            if fault is not None:
                why = f" ({fault[1]}; ~/reset clears it)"
            elif state is DeviceState.STOPPED:
                why = " (~/reset returns it to IDLE)"
            raise DeviceError(f"{what} refused: device is {state.name}{why}")

    def record_goal_rejection(self, action: str, reason: str) -> None:
        """Log a goal refused at goal time (ROS 2 has no field for the reason) and keep it for diagnostics."""
        self.last_goal_rejection = f"{action}: {reason}"
        self.get_logger().warning(f"goal rejected: {self.last_goal_rejection}")

    def rate_report(self) -> RateReport:
        """Return the achieved figures over the monitor's window."""
        return self.monitor.report(time.monotonic(), self.sim_seconds())

    def is_behind(self, report: RateReport) -> bool:
        """Whether the device is behind the clock: never in lockstep, where the clock waits for it."""
        return self.active and not self.in_lockstep and report.behind

    def publish_status(self, force: bool = False) -> None:
        """Publish ~/status when anything a controller sees changed (or when forced: the heartbeat).

        In lockstep, not before the first announcement: until then the node clock has no cell time to
        stamp it with (the first announcement publishes it).
        """
        if self.lockstep_driver is not None and not self.lockstep_driver.started:
            return
        state = self.state()
        report = self.rate_report()
        behind = self.is_behind(report)
        fault = self.stopping_fault()
        code, text = fault if fault is not None else (0, "")
        warning = self.warning_fault() if self.lifecycle in ("inactive", "active") else None
        if not fault and self.configuration_error:
            code, text = DeviceStatus.FAULT_CONFIGURATION, self.configuration_error
        elif not fault and warning is not None:
            code, text = warning
        elif not fault and behind:
            code, text = DeviceStatus.FAULT_BEHIND_REAL_TIME, _behind_text(report)
        configured = self.lifecycle in ("inactive", "active")
        # The device's own hooks run only once it is configured: before that it has no model to ask.
        counters = self.counters() if configured else {}
        busy = self.active and self.busy()
        labels = [f.label for f in self.faults.values()]
        key = (state, busy, code, text, tuple(labels), tuple(counters.items()), behind)
        if not force and key == self._last_status:
            return
        self._last_status = key
        msg = DeviceStatus(
            state=int(state),
            state_name=state.name,
            ready=state in (DeviceState.IDLE, DeviceState.RUNNING),
            busy=busy,
            fault_code=code,
            fault_text=text,
            active_faults=labels,
            counter_names=list(counters),
            counter_values=[int(v) for v in counters.values()],
            configured_rate=report.configured_rate,
            achieved_rate=report.achieved_rate,
            configured_real_time_factor=report.configured_real_time_factor,
            achieved_real_time_factor=report.achieved_real_time_factor,
            behind_real_time=behind,
        )
        # Inside a tick, the tick's own instant: in lockstep one clock time covers several ticks.
        stamp_ns = self.tick_instant_ns or self.get_clock().now().nanoseconds
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
        # A frame id, which tf2 refuses with a leading slash: the node's name under its namespace.
        msg.header.frame_id = self.get_fully_qualified_name().lstrip("/")
        self._status_pub.publish(msg)
        self._last_status_msg = msg

    def _heartbeat(self) -> None:
        if self.in_lockstep and self._last_status_msg is not None:
            # In lockstep the wall-clock heartbeat repeats what was last said, never news: a change is
            # published at the end of the tick phase that made it, at a defined cell time. Only the
            # wall-clock figures (rate and real-time factor achieved) are fresh.
            msg = copy.copy(self._last_status_msg)
            report = self.rate_report()
            msg.achieved_rate = report.achieved_rate
            msg.achieved_real_time_factor = report.achieved_real_time_factor
            self._status_pub.publish(msg)
        else:
            self.publish_status(force=True)
        self._diagnostics_pub.publish(self._diagnostics())

    def _diagnostics(self) -> DiagnosticArray:
        state = self.state()
        report = self.rate_report()
        fault = self.stopping_fault()
        behind = self.is_behind(report)
        if fault is not None or self.configuration_error:
            level, message = DiagnosticStatus.ERROR, fault[1] if fault else self.configuration_error
        elif self.lifecycle in ("inactive", "active") and (warning := self.warning_fault()) is not None:
            level, message = DiagnosticStatus.WARN, warning[1]
        elif behind:
            level, message = DiagnosticStatus.WARN, _behind_text(report)
        elif state in (DeviceState.UNCONFIGURED, DeviceState.PAUSED):
            level, message = DiagnosticStatus.STALE, f"{state.name.lower()}: not simulating"
        elif state is DeviceState.STOPPED:
            level, message = DiagnosticStatus.WARN, "stopped (~/reset returns it to IDLE)"
        else:
            level, message = DiagnosticStatus.OK, state.name.lower()
        values = {
            "state": state.name,
            "configured_rate_hz": f"{report.configured_rate:.6g}",
            "achieved_rate_hz": f"{report.achieved_rate:.6g}",
            "configured_real_time_factor": f"{report.configured_real_time_factor:.6g}",
            "achieved_real_time_factor": f"{report.achieved_real_time_factor:.6g}",
            "keeping_pace": f"{report.keeping_pace:.6g}",
            "behind_real_time": str(behind).lower(),
            "active_faults": ", ".join(f.label for f in self.faults.values()),
            "last_goal_rejection": self.last_goal_rejection,
            **{
                name: str(value)
                for name, value in (
                    self.counters() if self.lifecycle in ("inactive", "active") else {}
                ).items()
            },
        }
        name = self.get_fully_qualified_name()
        hardware_id = str(self.p.hardware_id or f"sim:{name}")
        status = DiagnosticStatus(
            level=level,
            name=name,
            message=message,
            hardware_id=hardware_id,
            values=[KeyValue(key=k, value=v) for k, v in values.items()],
        )
        array = DiagnosticArray(status=[status])
        array.header.stamp = self.get_clock().now().to_msg()
        return array


def _behind_text(report: RateReport) -> str:
    return (
        f"behind real time: rate {report.achieved_rate:.3g} of {report.configured_rate:.3g} Hz, "
        f"simulated {report.keeping_pace:.3g} s per clock second, real-time factor "
        f"{report.achieved_real_time_factor:.3g} of {report.configured_real_time_factor:.3g}"
    )
