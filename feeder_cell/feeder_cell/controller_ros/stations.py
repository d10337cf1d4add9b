"""The work of ORIENT on the MEMS array, INFEED, FEED, the fixture's tilts and the region planner's plans.

Each step calls the device's standard interface through the link and turns the answer into an Outcome
for the machine. With arrivals (``arrivals_file``) a cycle's parts are placed at its drawn poses: on the
array (their names from its ``~/parts``) and on the arm (the drop distribution from its ``~/part``).
"""

from __future__ import annotations

from geometry_msgs.msg import Vector3
from rclpy.node import Node
from std_srvs.srv import Trigger

from feeder_cell.controller import CellMachine, Outcome
from feeder_cell.controller_ros.link import DeviceLink
from feeder_cell.experiment.arrivals import ArrivalStream
from feeder_msgs.action import FeedPart, FollowPath, RunProgram
from feeder_msgs.msg import FieldProgram, MemsParts
from feeder_msgs.msg import Part as PartMsg
from feeder_msgs.srv import ArmPlacePart, MemsPlaceParts, StablePath
from feeder_planner.errors import FeederError
from feeder_planner.node_kit import LATCHED
from feeder_planner.node_kit.action_client import ActionClient
from feeder_planner.node_kit.msg_parts import part_from_msg
from feeder_planner.throwing.geometry import arm_part

__all__ = ["Stations", "route"]


def route(flat: list[float]) -> list[Vector3]:
    """Return the gravity waypoints a flat parameter list (x, y, z, x, y, z...) names."""
    return [Vector3(x=flat[i], y=flat[i + 1], z=flat[i + 2]) for i in range(0, len(flat), 3)]


class Stations:
    """The clients of the MEMS array (``orienter: mems``), the arm, the fixture and the region planner.

    Made in the order the MEMS cell's entities always were (the node's ``__init__`` says why).
    """

    def __init__(
        self,
        node: Node,
        link: DeviceLink,
        machine: CellMachine,
        program: FieldProgram,
        arrivals: ArrivalStream | None,
    ) -> None:
        self.node = node
        self.link = link
        self.machine = machine
        self.program = program
        self.arrivals = arrivals
        devices = link.devices
        mems = "mems" in devices
        # What the arrivals need of the devices: the names of the array's parts, the arm's part.
        self.mems_names: list[str] | None = None
        self.arm_part: PartMsg | None = None
        if arrivals is not None:
            if mems:
                node.create_subscription(MemsParts, f"{devices['mems']}/parts", self._on_mems_parts, LATCHED)
            node.create_subscription(PartMsg, f"{devices['arm']}/part", self._on_arm_part, LATCHED)
        self.run_program = ActionClient(node, RunProgram, f"{devices['mems']}/run_program") if mems else None
        self.feed_part = ActionClient(node, FeedPart, f"{devices['arm']}/feed_part")
        self.follow_path = ActionClient(node, FollowPath, f"{devices['fixture']}/follow_path")
        self.place_parts = (
            node.create_client(MemsPlaceParts, f"{devices['mems']}/place_parts") if mems else None
        )
        self.place_part = node.create_client(ArmPlacePart, f"{devices['arm']}/place_part")
        self.resets = {k: node.create_client(Trigger, f"{n}/reset") for k, n in devices.items()}
        self.safe_path = node.create_client(StablePath, f"{link.p['region_planner']}/safe_path")
        self.stood = Vector3()  # where the fixture stands (gravity), from its last follow_path result
        self.safe: list[Vector3] = []  # the planner's last path
        self.throws = 0  # throws the feeds of this cycle used

    def orient(self) -> Outcome:
        """Place a new batch on the MEMS array and run the field program until every part has settled."""
        assert self.place_parts is not None and self.run_program is not None  # made for orienter mems
        p = self.link.p
        if p["new_batch"] and self.machine.attempts == 0:  # a retry goes on from where they are
            response = self.link.call("mems", self.place_parts, MemsPlaceParts.Request(reset=True))
            if isinstance(response, Outcome):
                return response
        if (
            self.arrivals is not None
            and self.arrivals.arrivals.mems is not None
            and self.machine.attempts == 0
        ):
            placed = self._place_arrivals()
            if placed is not None:
                return placed
        goal = RunProgram.Goal(
            program=self.program,
            timeout=p["orient_timeout"],
            tolerance=p["orient_tolerance"],
            dwell=p["orient_dwell"],
        )
        result = self.link.action("mems", self.run_program, "run_program", goal, p["orient_timeout"])
        return (
            result
            if isinstance(result, Outcome)
            else Outcome(result.outcome_name, result.fault_code, result.message)
        )

    def infeed(self) -> Outcome:
        """Put a new part on the arm at the infeed pose (the presented one was taken).

        With arrivals, the cycle's drawn edge and radius (the same part again after a reset: the draw is
        the cycle's, whatever the retries).
        """
        p = self.link.p
        request = ArmPlacePart.Request(edge=p["infeed_edge"], radius=p["infeed_radius"])
        if self.arrivals is not None and self.arrivals.arrivals.arm is not None:
            if self.arrivals.drop is None:
                problem = self._arm_drop()
                if problem is not None:
                    return problem
            arrival = self.arrivals.arm(self.machine.cycle)
            request = ArmPlacePart.Request(edge=arrival.edge, radius=arrival.radius)
            self.node.get_logger().info(
                f"cycle {self.machine.cycle}: part arrives on edge {arrival.edge} at R {arrival.radius:.6g} m"
            )
        response = self.link.call("arm", self.place_part, request)
        return response if isinstance(response, Outcome) else Outcome("DONE")

    def _place_arrivals(self) -> Outcome | None:
        """Place every part on the array at this cycle's drawn pose; an Outcome if that failed."""
        assert self.arrivals is not None and self.place_parts is not None
        if not self.link.wait_until(lambda: self.mems_names is not None) or not self.mems_names:
            return Outcome("ERROR", 0, f"arrivals: no part names from {self.link.devices['mems']}/parts")
        names = list(self.mems_names)
        poses = self.arrivals.mems(self.machine.cycle, len(names))
        request = MemsPlaceParts.Request(
            reset=False,
            names=names,
            x=[p[0] for p in poses],
            y=[p[1] for p in poses],
            theta=[p[2] for p in poses],
        )
        response = self.link.call("mems", self.place_parts, request)
        if isinstance(response, Outcome):
            return response
        placed = ", ".join(
            f"{n} ({x:.6g}, {y:.6g}, {t:.6g})" for n, (x, y, t) in zip(names, poses, strict=True)
        )
        self.node.get_logger().info(f"cycle {self.machine.cycle}: parts placed on the array at {placed}")
        return None

    def _arm_drop(self) -> Outcome | None:
        """Compute the arm part's drop distribution from its ~/part; an Outcome if it cannot be had."""
        assert self.arrivals is not None
        if not self.link.wait_until(lambda: self.arm_part is not None) or self.arm_part is None:
            return Outcome("ERROR", 0, f"arrivals: no part from {self.link.devices['arm']}/part")
        try:
            drop = self.arrivals.set_part(arm_part(part_from_msg(self.arm_part, "part")))
        except FeederError as error:
            return Outcome("ERROR", 0, f"arrivals: the arm part's drop distribution: {error}")
        shares = ", ".join(f"{p:.4f}" for p in drop.probabilities)
        self.node.get_logger().info(
            f"arrivals: {drop.fidelity} drop distribution of the arm part by edge: {shares}"
        )
        return None

    def feed(self) -> Outcome:
        """Throw until the arm's sensor says the part is presented (or max throws, timeout, a fault)."""
        p = self.link.p
        goal = FeedPart.Goal(max_throws=p["feed_max_throws"], timeout=p["feed_timeout"])
        result = self.link.action("arm", self.feed_part, "feed_part", goal, p["feed_timeout"])
        if isinstance(result, Outcome):
            return result
        self.throws += result.throws
        return Outcome(result.outcome_name, result.fault_code, f"{result.throws} throws; {result.message}")

    def tilt(self, waypoints: list[Vector3]) -> Outcome:
        """Follow gravity waypoints; a refusal names the first unstable sample and its bodies."""
        goal = FollowPath.Goal(gravity_waypoints=waypoints)
        result = self.link.action("fixture", self.follow_path, "follow_path", goal, 0.0)
        if isinstance(result, Outcome):
            return result
        self.stood = result.gravity
        message = result.message
        if result.outcome_name == "REFUSED":
            bodies = ", ".join(result.unbalanced_bodies) or "none named"
            message = f"sample {result.first_unstable_sample} unstable ({bodies}); {result.message}"
        return Outcome(result.outcome_name, result.fault_code, message)

    def plan(self, goal: Vector3) -> Outcome:
        """Ask the region planner for a certified path from where the fixture stands to ``goal``."""
        request = StablePath.Request(start=self.stood, goal=goal, step=self.link.p["path_step"])
        response = self.link.call("planner", self.safe_path, request)
        if isinstance(response, Outcome):
            return Outcome("NO_PATH", 0, response.message) if response.event == "ERROR" else response
        self.safe = list(response.path[1:]) or [goal]
        return Outcome(
            "PLANNED", 0, f"{len(response.path)} samples, min margin {response.min_margin:.3f} rad"
        )

    def _on_mems_parts(self, msg: MemsParts) -> None:
        self.mems_names = [part.name for part in msg.parts]

    def _on_arm_part(self, msg: PartMsg) -> None:
        self.arm_part = msg

    def tilt_route(self, parameter: str) -> Outcome:
        """Follow the route a parameter names (``fixture_route``, ``fixture_home``)."""
        return self.tilt(route(self.link.p[parameter]))

    def plan_to_end_of(self, parameter: str) -> Outcome:
        """Plan to the last waypoint of the route a parameter names."""
        return self.plan(route(self.link.p[parameter])[-1])
