"""The throwing arm's ROS message adapters: its streams from the throw cycle, and the ~/feed_part goal.

The node (``feeder_sim.nodes.throwing_arm``) publishes what these build; ``FeedPartGoal`` is the kit's
goal runner's view of the ROS-free ``throwing.feeding.FeedGoal``.
"""

from __future__ import annotations

from typing import Protocol, Sequence

from geometry_msgs.msg import PoseStamped
from rclpy.action.server import ServerGoalHandle
from rclpy.clock import Clock
from rclpy.impl.rcutils_logger import RcutilsLogger
from sensor_msgs.msg import JointState

from feeder_device.declarations import Counters
from feeder_device.device import DeviceState
from feeder_msgs.action import FeedPart
from feeder_msgs.msg import DeviceStatus, ThrowEvent
from feeder_msgs.msg import Part as PartMsg
from feeder_planner.node_kit import yaw_quaternion
from feeder_planner.node_kit.msg_parts import part_to_msg
from feeder_sim.node_kit.stamp import stamp
from feeder_sim.throwing import ThrowOutcome
from feeder_sim.throwing.cycle import Pose, Shown, ThrowCycle
from feeder_sim.throwing.feeding import FeedGoal
from feeder_sim.throwing.loading import HeldPart
from feeder_sim.throwing.station import ArmStation

__all__ = [
    "FeedPartGoal",
    "FeedingArm",
    "held_part_msg",
    "joint_state_msg",
    "part_pose_msg",
    "throw_event_msg",
]


def joint_state_msg(now_ns: int, shown: Shown) -> JointState:
    """Return the arm joint's state as shown at ``now_ns`` (node clock)."""
    joint = JointState(name=["arm_joint"], position=[shown.joint], velocity=[shown.velocity], effort=[0.0])
    joint.header.stamp = stamp(now_ns)
    return joint


def held_part_msg(held: HeldPart) -> PartMsg:
    """Return ~/part: the part the arm holds, its name, and its outline in its file's order and unit.

    The arm numbers hull edges from the file's first hull vertex (``feeder_planner.throwing.arm_part``), so
    ``arm_part(part_from_msg(msg))`` gives the edges that ThrowEvent, ~/place_part and ~/load_part name.
    """
    return part_to_msg(held.description())


def part_pose_msg(now_ns: int, frame_id: str, pose: Pose) -> PoseStamped:
    """Return the part's pose (x, y, theta) in the arm frame at ``now_ns`` (node clock)."""
    msg = PoseStamped()
    msg.header.stamp, msg.header.frame_id = stamp(now_ns), frame_id
    msg.pose.position.x, msg.pose.position.y = pose[0], pose[1]
    msg.pose.orientation = yaw_quaternion(pose[2])
    return msg


def throw_event_msg(
    now_ns: int, frame_id: str, index: int, outcome: ThrowOutcome, sensor_at_rest: bool, fidelity: str
) -> ThrowEvent:
    """Return the throw event: states before and after, kind, fault, the (true) sensor at rest."""
    ev = ThrowEvent()
    ev.header.stamp, ev.header.frame_id = stamp(now_ns), frame_id
    ev.index = index
    ev.edge_before, ev.radius_before = outcome.edge_before, outcome.radius_before
    ev.edge_after, ev.radius_after = outcome.edge_after, outcome.radius_after
    ev.kind, ev.turns, ev.rotation = outcome.kind, outcome.turns, outcome.rotation
    ev.fault, ev.fault_reason = outcome.kind == "fault", outcome.fault
    ev.sensor_at_rest = sensor_at_rest
    ev.fidelity = fidelity
    # The paper model's assumptions this throw broke (issue 14); off_arm made it a part lost.
    ev.lift_off, ev.slip = "lift_off" in outcome.flags, "slip" in outcome.flags
    ev.off_arm, ev.toe_stub = "off_arm" in outcome.flags, "toe_stub" in outcome.flags
    return ev


class FeedingArm(Protocol):
    """What ``FeedPartGoal`` needs of the throwing arm node (a protocol: no import of the node module)."""

    cycle: ThrowCycle | None
    station: ArmStation[ThrowEvent] | None
    count: Counters

    def ground_truth(self) -> tuple[int, float]:
        """Return (edge, R) of the part at rest, or (-1, NaN) when it is not on the arm."""
        ...

    def stopping_fault(self) -> tuple[int, str] | None:
        """(code, text) of the fault that stops the device, or None."""
        ...

    def state(self) -> DeviceState:
        """Return the controller-facing state."""
        ...

    def get_clock(self) -> Clock:
        """Return the node clock."""
        ...

    def get_logger(self) -> RcutilsLogger:
        """Return the node's logger."""
        ...


class FeedPartGoal:
    """The runner's view of a ``FeedGoal``: its feedback and result as FeedPart messages."""

    def __init__(self, node: FeedingArm, feed: FeedGoal[ThrowEvent], handle: ServerGoalHandle) -> None:
        self.node, self.feed, self.handle = node, feed, handle

    @property
    def done(self) -> bool:
        """Whether the feed goal has ended."""
        return self.feed.done

    def advance(self, now_ns: int) -> None:
        """Take in the tick that is over: judge the bit, end, or ask for a throw."""
        station = self.node.station
        if station is None:  # released under the goal: nothing in flight
            self.feed.tick(now_ns, self.node.stopping_fault(), False)
        else:
            station.advance_goal(self.feed, now_ns, self.node.stopping_fault())

    def cancel(self, reason: str) -> None:
        """End after the throw in flight, at once at rest (unless a ~/command stop already asked it to)."""
        if not self.feed.cancel_reason:
            self.feed.cancel(reason)
            self.advance(self.node.get_clock().now().nanoseconds)

    def halt(self) -> None:
        """Forget the throws the goal asked for (a throw in flight still lands)."""
        if self.node.cycle is not None:
            self.node.cycle.cancel_commands()

    def interrupt(self, reason: str) -> None:
        """End now: the device left active, so no throw can land."""
        state = self.node.state().name
        self.feed.end_now(
            "FAULT",
            f"device {state} (deactivated) during the goal: the physics is frozen "
            "and no throw can land; activate it and send a new goal",
            DeviceStatus.FAULT_NONE,
            f"device {state}",
        )

    def feedback(self) -> Sequence[FeedPart.Feedback]:
        """One feedback per throw the goal has judged, in order."""
        reports, self.feed.reports = self.feed.reports, []
        return [
            FeedPart.Feedback(
                throws=r.throws,
                sensor_at_rest=r.sensor_at_rest,
                edge=r.edge,
                radius=r.radius,
                event=r.event if r.event is not None else ThrowEvent(),
            )
            for r in reports
        ]

    def result(self) -> tuple[str, FeedPart.Result]:
        """Return the terminal state and result: the outcome's code and name, the arm's state now."""
        outcome = self.feed.outcome
        assert outcome is not None  # the runner asks only once the goal ended
        # The arm's state now is the ground truth after the goal's last throw, and says (-1, NaN)
        # when the part has left the arm, which the goal itself never saw land.
        edge, radius = self.node.ground_truth()
        result = FeedPart.Result(
            outcome=outcome.code,
            outcome_name=outcome.name,
            message=outcome.message,
            throws=outcome.throws,
            sensor_at_rest=outcome.sensor_at_rest,
            edge=edge,
            radius=radius,
            fault_code=outcome.fault_code,
            fault_text=outcome.fault_text,
        )
        log = self.node.get_logger()
        if outcome.name == "PRESENTED":
            self.node.count.add("feeds_presented")
            log.info(f"~/feed_part: {outcome.name}: {outcome.message}")
            return "succeed", result
        log.warning(f"~/feed_part: {outcome.name}: {outcome.message}")
        canceled = outcome.name == "CANCELED" and self.handle.is_cancel_requested
        return ("canceled" if canceled else "abort"), result
