"""Faults and the services around them: ``~/stop``, ``~/reset``, ``~/abort``, ``~/clear``, ``~/inject_fault``.

A fault is injected (``~/inject_fault``, or the ``inject_faults`` parameter at configure) or raised by the
model itself (``raise_model_fault``). A stopping fault puts the device in FAULT until ``~/reset`` (or
``~/clear``, PackML's, which leaves it STOPPED); the device's ``apply_fault`` and ``clear_fault`` put an
injected fault into its model and take it out. What a fault is (its code, whether it stops the device) is
the device's ``FAULTS`` table (``declarations.FaultSpec``).
"""

from __future__ import annotations

from std_srvs.srv import Trigger

from feeder_device.core import P
from feeder_device.declarations import ActiveFault, DeviceError, parse_fault_parameter, unknown_fault
from feeder_device.ticks import TickLoop
from feeder_msgs.msg import DeviceStatus
from feeder_msgs.srv import InjectFault
from feeder_planner.errors import FeederError, InputError
from feeder_planner.node_kit.services import serve

__all__ = ["FaultServices"]


class FaultServices(TickLoop[P]):
    """Stop, reset, PackML's abort and clear, fault injection, and the faults the model raises."""

    def _serve_fault_services(self) -> None:
        serve(self, Trigger, "~/stop", self._on_stop)
        serve(self, Trigger, "~/reset", self._on_reset)
        serve(self, Trigger, "~/abort", self._on_abort)
        serve(self, Trigger, "~/clear", self._on_clear)
        serve(self, InjectFault, "~/inject_fault", self._on_inject_fault)

    def raise_model_fault(self, code: int, text: str) -> None:
        """Enter FAULT because of the model itself (not an injection); ~/reset clears it."""
        self.model_fault = (code, text)
        self.get_logger().error(f"FAULT {code}: {text}")
        self.publish_status()

    def _on_stop(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        if self.lifecycle != "active":
            response.success, response.message = False, f"stop refused: device is {self.state().name}"
            return response
        self.stop_device()
        self.stopped = True
        self.publish_status()
        response.success, response.message = True, "stopped"
        return response

    def _on_reset(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        if self.lifecycle not in ("active", "inactive"):
            why = f" ({self.internal_error})" if self.internal_error else ""
            response.success, response.message = False, f"reset refused: device is {self.state().name}{why}"
            return response
        self._clear_every_fault()
        self.stopped = False
        self.reset_device()
        self.publish_status()
        response.success, response.message = True, f"reset: {self.state().name}"
        return response

    def _clear_every_fault(self) -> None:
        """Clear the injected faults (each hook told) and the model's own: what reset and clear share."""
        for name in list(self.faults):
            self.clear_fault(name)
        self.faults.clear()
        self.model_fault = None

    def _on_abort(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        """PackML Abort: halt at once and enter FAULT (code FAULT_ABORTED) until ~/clear or ~/reset."""
        if self.lifecycle != "active":
            response.success, response.message = False, f"abort refused: device is {self.state().name}"
            return response
        self.stop_device()
        self.model_fault = (
            DeviceStatus.FAULT_ABORTED,
            "aborted by command (~/abort); ~/clear stops it, ~/reset returns it to IDLE",
        )
        self.get_logger().warning("aborted by command")
        self.publish_status()
        response.success, response.message = True, "aborted"
        return response

    def _on_clear(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        """PackML Clear (Aborted -> Clearing -> Stopped): clear every fault and leave the device STOPPED.

        Unlike ~/reset, which goes on to IDLE, so that a PLC that clears a fault still resets the machine
        before it runs again, as PackML's state machine has it.
        """
        if self.lifecycle != "active" or self.stopping_fault() is None:
            response.success = False
            response.message = f"clear refused: device is {self.state().name} (clear applies in FAULT)"
            return response
        self._clear_every_fault()
        self.stopped = True
        self.publish_status()
        response.success, response.message = True, f"cleared: {self.state().name}"
        return response

    def _on_inject_fault(
        self, request: InjectFault.Request, response: InjectFault.Response
    ) -> InjectFault.Response:
        try:
            self._inject(request)
            response.ok, response.error = True, ""
        except FeederError as error:
            response.ok, response.error = False, f"bad request: {error}"
            self.get_logger().warning(f"inject_fault: {response.error}")
        response.active_faults = [f.label for f in self.faults.values()]
        self.publish_status()
        return response

    def _inject(self, request: InjectFault.Request) -> None:
        name = request.fault.strip()
        if request.clear:
            names = [name] if name else list(self.faults)
            if name and name not in self.FAULTS:
                raise InputError("fault", unknown_fault(name, self.FAULTS))
            for each in names:
                if each in self.faults:
                    self.clear_fault(each)
                    del self.faults[each]
            return
        if name not in self.FAULTS:
            raise InputError("fault", unknown_fault(name, self.FAULTS))
        if self.lifecycle not in ("active", "inactive"):
            raise DeviceError(f"inject_fault refused: device is {self.state().name} (configure it first)")
        fault = ActiveFault(
            self.FAULTS[name],
            float(request.value),
            bool(request.state),
            tuple(int(i) for i in request.indices),
            float(request.angle),
            int(request.seed) or int(self.p.fault_seed),
        )
        self.apply_fault(fault)  # validates the magnitudes (InputError naming value/indices/angle)
        self.faults[name] = fault

    def _inject_configured_faults(self) -> None:
        """Inject the ``inject_faults`` parameter's entries at configure; a bad entry fails it, naming it."""
        self.faults.clear()
        for index, entry in enumerate(e for e in self.p.inject_faults if e):
            parsed = parse_fault_parameter(entry, index)
            if parsed.name not in self.FAULTS:
                raise InputError(f"parameter inject_faults[{index}]", unknown_fault(parsed.name, self.FAULTS))
            spec = self.FAULTS[parsed.name]
            name = parsed.name
            fault = ActiveFault(
                spec,
                parsed.value,
                parsed.state,
                parsed.indices,
                parsed.angle,
                int(self.p.fault_seed),
            )
            try:
                self.apply_fault(fault)
            except InputError as error:
                raise InputError(f"parameter inject_faults[{index}] ({error.field})", error.problem) from None
            self.faults[name] = fault
