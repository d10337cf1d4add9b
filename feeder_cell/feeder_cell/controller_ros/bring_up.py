"""BRING_UP: each device configured and activated through its lifecycle services, then ready."""

from __future__ import annotations

from rclpy.node import Node

from feeder_cell.controller import Outcome
from feeder_cell.controller_ros.link import DeviceLink, ShutdownError
from feeder_cell.lifecycle_client import LifecycleClient, LifecycleError, LifecycleInterruptedError
from feeder_msgs.msg import DeviceStatus

__all__ = ["BringUp"]

# A transition refused while another client moves the same device is looked at again after a moment.
BRING_UP_ATTEMPTS, BRING_UP_SETTLE_S = 3, 0.5


class BringUp:
    """The devices' lifecycle clients (one pair per device) and the BRING_UP state's work."""

    def __init__(self, node: Node, link: DeviceLink) -> None:
        self.link = link
        self.lifecycle = {
            k: LifecycleClient(node, None, n, keep_going=lambda: not link.stopping())
            for k, n in link.devices.items()
        }

    def run(self) -> Outcome:
        """Configure and activate each device (one already active is left so); wait until it is ready."""
        if not self.link.p["bring_up"]:
            return self.link.all_ready()
        for key, client in self.lifecycle.items():
            for attempt in range(BRING_UP_ATTEMPTS):
                try:
                    client.bring_to("active")
                    break
                except LifecycleInterruptedError:
                    raise ShutdownError("shutdown") from None
                except LifecycleError as error:
                    # Someone else (a launcher, an operator) may be moving the same device: look again.
                    if attempt + 1 < BRING_UP_ATTEMPTS and self._moved_elsewhere(client):
                        continue
                    status = self.link.status.get(key)
                    why = status.fault_text if status is not None and status.fault_text else ""
                    message = f"{error}{': ' + why if why else ''}"
                    return Outcome("ERROR", DeviceStatus.FAULT_CONFIGURATION, message)
        return self.link.all_ready()

    def _moved_elsewhere(self, client: LifecycleClient) -> bool:
        """Return whether a refused transition was a race (the device moved on), not a failed configure."""
        self.link.sleep(BRING_UP_SETTLE_S)
        try:
            return client.get_state() in ("inactive", "active")
        except LifecycleInterruptedError:
            raise ShutdownError("shutdown") from None
        except LifecycleError:
            return False
