"""The fault processes' injections: each device's failures sent through its ``~/inject_fault``.

The schedule (``feeder_cell.controller.fault_schedule``, ROS-free) says what is due when; this sends it.
The controller looks at it before each state's work and between the quanta of every wait.
"""

from __future__ import annotations

from rclpy.node import Node

from feeder_cell.controller import CellMachine, State
from feeder_cell.controller.fault_schedule import FaultAction, FaultSchedule
from feeder_cell.controller_ros.link import DeviceLink
from feeder_msgs.srv import InjectFault

__all__ = ["FaultInjector"]


class FaultInjector:
    """Inject the schedule's failures and repairs when their cell time has come (never in BRING_UP)."""

    def __init__(self, node: Node, link: DeviceLink, schedule: FaultSchedule, machine: CellMachine) -> None:
        self.node = node
        self.link = link
        self.schedule = schedule
        self.machine = machine
        self.injections = {
            s.device: node.create_client(InjectFault, f"{s.device}/inject_fault") for s in schedule.specs
        }

    def inject_due(self) -> None:
        """Inject every failure whose time has come, and clear every one whose repair time has come.

        Each request is answered before the controller goes on (``send``); its effect shows in the
        step's outcome, which the fault policy handles. A clear at the repair time ends a fault the device
        keeps until then (a stuck sensor); one the controller's ~/reset already cleared answers that it is
        not active, which is fine.
        """
        if self.machine.state is State.BRING_UP:
            return
        for action in self.schedule.due(self.link.now()):
            self.send(action)

    def send(self, action: FaultAction) -> None:
        """Send ~/inject_fault (or its clear), log it, and wait for the answer; a refusal is logged."""
        spec, event, clear = action.spec, action.event, action.clear
        client = self.injections[spec.device]
        request = InjectFault.Request(fault=spec.fault, clear=clear, value=spec.value, state=spec.state)
        what = "repaired (cleared)" if clear else "injected"
        at = self.link.now() - self.schedule.origin
        log = self.node.get_logger()
        log.info(
            f"fault process: {spec.fault} {what} in {spec.device} at +{at:.3f} s "
            f"(failure +{event.start:.3f} s to +{event.end:.3f} s)"
        )
        if not client.service_is_ready():
            log.warning(f"fault process: {client.srv_name} is not available")
            return

        # Waited for: in lockstep the controller holds the clock meanwhile, so the device takes the fault
        # in at the cell time it is due, before its next tick (as the ROS-free loop applies it). Sent and
        # left, it landed in that quantum or the next as the device's executor happened to order its
        # callbacks: the fresh-clone CI run's loop-equivalence and squeeze-cell runs differed so.
        future = client.call_async(request)
        if not self.link.wait_wall(future):
            log.warning(
                f"fault process: {client.srv_name} did not answer in {self.link.p['answer_timeout']:g} s"
            )
            return
        response = future.result()
        if response is not None and not response.ok and not clear:
            log.warning(f"fault process: {client.srv_name}: {response.error}")
