"""A device kind's service methods (LoadProgram, InjectFault, ...) called on the device.

Separate from the PackML commands and the goals because here the device's one answer decides the call:
done, or refused for its state (Bad_InvalidState) or for the arguments (Bad_InvalidArgument), told apart
by the device's latest status read under the link's lock (``spec.Availability``), not by its words.
``call_service`` runs in the executor's thread (``in_ros``).
"""

from __future__ import annotations

from feeder_cell.gateway.device_link import DeviceLink
from feeder_cell.gateway.spec import Goal

__all__ = ["call_service", "refused_for_state"]


async def call_service(link: DeviceLink, method: str, call: Goal | None) -> tuple[str, str]:
    """Call a service method's device service; the device's answer decides the status (executor)."""
    client = link.services[method]
    if call is None:
        raise TypeError(f"{method}: not a checked call")
    if not client.service_is_ready():
        return (
            "BadCommunicationError",
            f"{method}: {client.srv_name} is not available (is the device running?)",
        )
    response = await client.call_async(call.message())
    ok = bool(getattr(response, "ok", getattr(response, "success", False)))
    text = str(getattr(response, "error", "") or getattr(response, "message", ""))
    if ok:
        faults = getattr(response, "active_faults", None)
        extra = f"; active faults: {', '.join(faults) or 'none'}" if faults is not None else ""
        return "Good", f"{method}: done{extra}"
    code = "BadInvalidState" if refused_for_state(link, method) else "BadInvalidArgument"
    return code, f"{method} refused by the device: {text}"


def refused_for_state(link: DeviceLink, method: str) -> bool:
    """Whether the device's latest status (and its goals) is why it refused a service method."""
    with link.lock:
        state = link.state if link.online else None
        fault_code = link.fault_code
        goal_active = link.goal is not None or link.goals_active
    return link.availability[method].refuses(state, fault_code, goal_active)
