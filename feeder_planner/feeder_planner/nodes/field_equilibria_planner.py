"""ROS 2 node: the equilibria planner of the MEMS field array (thin adapter around feeder_planner.mems).

Its own service and topic are private (``~/equilibria``, ``~/predicted_poses``); it finds its array's
topics relative to its own namespace as ``<device>/field_program``, ``<device>/parts`` and
``<device>/part_states``, so a planner and its array in one namespace find each other and remappings
work. ``device`` is read-only; ``default_method`` is applied at run time; ``prediction_rate`` is
read-only.

Every program the planner receives gets its prediction, in the order received: at once when the parts
and part states are known, else as soon as they are. The timer at ``prediction_rate`` only refreshes the
prediction as the part states move. A planner that predicted from its timer alone lost a program that
held for less than its executor was held: a replay into a planner whose executor a loaded machine held
past both programs gave the second program's prediction only (ci38; tests/bags/test_replay_regression_ros.py),
and a planner on sim time that took the last program after its clock stopped with the bag never
predicted it.
"""

from __future__ import annotations

import math
from collections import deque

from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter

from feeder_msgs.msg import EquilibriaPrediction, Equilibrium, FieldProgram, MemsParts, MemsPartStates
from feeder_msgs.srv import EquilibriaCompute
from feeder_planner.drawing import part_shapes
from feeder_planner.errors import FeederError, InputError
from feeder_planner.mems import (
    METHODS,
    CombinedField,
    EquilibriaResult,
    ProgramStep,
    check_method,
    final_equilibrium,
    find_equilibria,
    holding_step,
    unpredicted_reason,
)
from feeder_planner.node_kit import (
    EVENT_DEPTH,
    LATCHED,
    LATCHED_EVENTS,
    STREAM_DEPTH,
    ParameterSpec,
    check_value,
    declare_parameters,
    one_of,
    planar_pose,
    positive,
    run_node,
    service_guard,
)
from feeder_planner.node_kit.msg_fields import program_from_msg
from feeder_planner.node_kit.msg_parts import part_from_msg
from feeder_planner.node_kit.request_limits import check_part_size
from feeder_planner.node_kit.services import REQUEST_QUEUE_PARAMETER, serve
from feeder_planner.node_kit.viz import ResultMarkers
from feeder_planner.parts import Part

__all__ = ["PARAMETERS", "FieldEquilibriaPlanner", "main"]

# The simulator's default node name: a planner beside a default array finds it without parameters.
DEFAULT_DEVICE = "mems_field_array"


def _device_name(value: object) -> str | None:
    """Check the device parameter: a node name or path, relative (to this namespace) or absolute."""
    if not isinstance(value, str) or not value.strip("/"):
        return f"must name the array node, e.g. {DEFAULT_DEVICE} or /cell/array_a/{DEFAULT_DEVICE}"
    return None


PARAMETERS = (
    ParameterSpec(
        "default_method",
        "auto",
        f"method when a request leaves it empty: {' | '.join(METHODS)} (runtime)",
        one_of(METHODS),
    ),
    ParameterSpec(
        "prediction_rate",
        2.0,
        "rate (Hz of the node clock) at which predictions are refreshed as the part states move",
        positive,
        read_only=True,
    ),
    ParameterSpec(
        "device",
        DEFAULT_DEVICE,
        "the array node whose topics are followed, as <device>/part_states etc., relative to this "
        "node's namespace (or absolute)",
        _device_name,
        read_only=True,
    ),
    REQUEST_QUEUE_PARAMETER,
)

# The service's thread and one for the subscriptions and the prediction timer.
THREADS = 3


class FieldEquilibriaPlanner(Node):
    """Serves ~/equilibria and publishes ~/predicted_poses for the last field of its device's program."""

    def __init__(self) -> None:
        super().__init__("field_equilibria_planner")
        self.p = declare_parameters(self, PARAMETERS)
        device = self.p["device"].rstrip("/")
        self.add_on_set_parameters_callback(self.on_parameters)
        serve(self, EquilibriaCompute, "~/equilibria", service_guard(self)(self.on_compute), own_group=True)
        self.prediction_pub = self.create_publisher(EquilibriaPrediction, "~/predicted_poses", LATCHED_EVENTS)
        self.markers = ResultMarkers(self)  # the predicted final poses as ghosts, in the array's frame
        try:
            self.create_subscription(FieldProgram, f"{device}/field_program", self.on_program, LATCHED_EVENTS)
            self.create_subscription(MemsParts, f"{device}/parts", self.on_parts, LATCHED)
            self.create_subscription(MemsPartStates, f"{device}/part_states", self.on_states, STREAM_DEPTH)
        except Exception as error:  # rclpy's invalid-name exceptions share no base class of ours
            raise InputError("parameter device", f"not a valid node name: {error}") from None
        self.program: tuple[ProgramStep, ...] | None = None
        # Received, not yet predicted, oldest first; as many as the program reader keeps.
        self.owed: deque[tuple[ProgramStep, ...]] = deque(maxlen=EVENT_DEPTH)
        self.parts: list[Part] = []
        self.states: MemsPartStates | None = None
        self.results: dict[int, EquilibriaResult] = {}
        self.last_published: list[tuple[float, float, float]] | None = None
        self.create_timer(1.0 / self.p["prediction_rate"], self.predict)

    def on_parameters(self, changes: list[Parameter]) -> SetParametersResult:
        """Validate and apply default_method at once (the others are read-only)."""
        specs = {spec.name: spec for spec in PARAMETERS}
        for change in changes:
            if change.name in specs:
                try:
                    check_value(specs[change.name], change.value)
                except InputError as error:
                    return SetParametersResult(successful=False, reason=str(error))
        for change in changes:
            if change.name in specs:
                self.p[change.name] = change.value
                if change.name == "default_method":
                    self.results.clear()  # predictions are recomputed by the new method
        return SetParametersResult(successful=True)

    def on_compute(
        self, request: EquilibriaCompute.Request, response: EquilibriaCompute.Response
    ) -> EquilibriaCompute.Response:
        """Answer an equilibria request with the mechanics' result (method, certified, pivot, area, all)."""
        check_part_size(request.part)
        part = part_from_msg(request.part, "part")
        method = check_method(request.method or self.p["default_method"])
        result = find_equilibria(part, request.delta, method)
        response.method = result.method
        response.certified = result.certified
        response.pivot_x, response.pivot_y = result.pivot
        response.area = result.area
        response.equilibria = [
            Equilibrium(x=e.x, y=e.y, theta=e.theta % (2 * math.pi), stable=e.stable)
            for e in result.equilibria
        ]
        return response

    def on_program(self, msg: FieldProgram) -> None:
        """Take the array's next field program and predict for it (a bad one is logged and ignored)."""
        try:
            self.owed.append(program_from_msg(msg))
        except InputError as error:
            self.get_logger().warning(f"ignoring field program: {error}")
            return
        self.settle_owed()

    def on_parts(self, msg: MemsParts) -> None:
        """Keep the array's parts (a bad one is logged and ignored)."""
        try:
            self.parts = [part_from_msg(p, f"parts[{i}]") for i, p in enumerate(msg.parts)]
        except InputError as error:
            self.get_logger().warning(f"ignoring parts: {error}")
            return
        self.results.clear()
        self.settle_owed()

    def on_states(self, msg: MemsPartStates) -> None:
        """Keep the latest part states."""
        self.states = msg
        self.settle_owed()

    def settle_owed(self) -> None:
        """Predict for each program not yet predicted, oldest first, once parts and states are known."""
        if not self.parts or self.states is None:
            return
        while self.owed:
            self.program = self.owed.popleft()
            self.results.clear()
            self.predict()

    def predict(self) -> None:
        """Publish each part's predicted final pose in the field the program holds, when it changed."""
        if self.program is None or not self.parts or self.states is None:
            return
        field = self.program[holding_step(self.program)].field
        if unpredicted_reason(field) is not None or not isinstance(field, CombinedField):
            return
        out = EquilibriaPrediction(field_type=CombinedField.kind, delta=field.delta)
        out.header.stamp = self.get_clock().now().to_msg()
        out.header.frame_id = self.states.header.frame_id
        summary = []
        # zip stops at the shorter: states may arrive before or after a change of the parts
        for i, (part, state) in enumerate(zip(self.parts, self.states.parts, strict=False)):
            try:
                if i not in self.results:
                    self.results[i] = find_equilibria(part, field.delta, self.p["default_method"])
            except FeederError as error:
                self.get_logger().warning(f"no prediction for {state.name}: {error}")
                return
            # equilibria are computed for the field centred at the origin; the field's centre translates them
            e = final_equilibrium(self.results[i], state.theta)
            x, y = e.x + field.center[0], e.y + field.center[1]
            pose = planar_pose(x, y, e.theta)
            out.names.append(state.name)
            out.poses.append(pose)
            out.theta.append(e.theta)
            summary.append((round(x, 12), round(y, 12), round(e.theta, 9)))
        if summary != self.last_published:
            self.prediction_pub.publish(out)
            ghosts = [
                shape
                for part, pose in zip(self.parts, summary, strict=False)  # as above: parts may lead states
                for shape in part_shapes(part, pose, "equilibria", "ghost")
            ]
            self.markers.publish(ghosts, out.header.frame_id)
            self.last_published = summary


# What a cell host builds (feeder_cell.host) when a scene asks for it: there its services share the host's
# one thread, so a long request holds the host's other nodes (alone, THREADS serve beside each other).
NODE = FieldEquilibriaPlanner


def main(args: list[str] | None = None) -> None:
    """Run the node until shut down."""
    run_node(FieldEquilibriaPlanner, "field_equilibria_planner", args, threads=THREADS)


if __name__ == "__main__":
    main()
