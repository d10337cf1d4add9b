"""ROS 2 node: the squeeze planner (thin adapter around feeder_planner.squeeze, Goldberg 1993).

``~/plan`` answers Goldberg's shortest squeeze plan for a part, with its completeness certificate (the
initial intervals over [first_angle, first_angle + 2 pi) and where each ends), and ``~/functions`` the
part's diameter and squeeze functions sampled, with their exact extrema. A plan it answers can be sent
as is to a squeeze_gripper's ``~/run_plan``. The planner has no state: each request is planned alone.
"""

from __future__ import annotations

import math

import numpy as np
from rclpy.node import Node

from feeder_msgs.srv import SqueezeFunctions, SqueezePlanCompute
from feeder_planner.errors import InputError
from feeder_planner.node_kit import declare_parameters, run_node, service_guard
from feeder_planner.node_kit.msg_parts import part_from_msg
from feeder_planner.node_kit.request_limits import check_part_size
from feeder_planner.node_kit.services import REQUEST_QUEUE_PARAMETER, serve
from feeder_planner.squeeze import check_angle, check_certificate, plan_squeezes, squeeze_function
from feeder_planner.squeeze.diameter import TWO_PI, wrap
from feeder_planner.squeeze.squeeze_function import SqueezeFunction

__all__ = ["MAX_SAMPLES", "NODE", "PARAMETERS", "SqueezePlanner", "main"]

PARAMETERS = (REQUEST_QUEUE_PARAMETER,)
# Samples of the functions one request may ask for: a plot needs a few thousand.
MAX_SAMPLES = 100_000
DEFAULT_SAMPLES = 360
THREADS = 2


def _squeeze_of(msg: object) -> SqueezeFunction:
    """Read a request's part and build its squeeze function (a degenerate hull names part.outer)."""
    check_part_size(msg)
    part = part_from_msg(msg, "part")
    return squeeze_function(part.outer, "part.outer")


class SqueezePlanner(Node):
    """Serves ~/plan and ~/functions."""

    def __init__(self) -> None:
        super().__init__("squeeze_planner")
        self.p = declare_parameters(self, PARAMETERS)
        guard = service_guard(self)
        serve(self, SqueezePlanCompute, "~/plan", guard(self.on_plan), own_group=True)
        serve(self, SqueezeFunctions, "~/functions", guard(self.on_functions), own_group=True)

    def on_plan(
        self, request: SqueezePlanCompute.Request, response: SqueezePlanCompute.Response
    ) -> SqueezePlanCompute.Response:
        """Answer the shortest plan with its certificate (checked before it is answered)."""
        first = check_angle(request.first_angle, "first_angle")
        squeeze = _squeeze_of(request.part)
        plan = plan_squeezes(squeeze, first)
        check_certificate(squeeze, plan)
        c = plan.certificate
        response.angles = [float(a) for a in plan.angles]
        response.final_orientation = float(c.final)
        response.symmetry_period = float(c.period)
        response.margin = float(c.margin) if math.isfinite(c.margin) else math.nan
        response.steps_per_period = squeeze.steps_per_period()
        response.interval_starts = [float(s) for s in c.starts]
        response.interval_finals = [float(f) for f in c.finals]
        return response

    def on_functions(
        self, request: SqueezeFunctions.Request, response: SqueezeFunctions.Response
    ) -> SqueezeFunctions.Response:
        """Answer d and s sampled over [0, 2 pi), and the exact extrema."""
        samples = int(request.samples) or DEFAULT_SAMPLES
        if samples > MAX_SAMPLES:
            raise InputError("samples", f"{samples} samples; the limit per request is {MAX_SAMPLES}")
        squeeze = _squeeze_of(request.part)
        thetas = np.linspace(0.0, TWO_PI, samples, endpoint=False)
        response.symmetry_period = float(squeeze.period)
        response.theta = thetas.tolist()
        response.width = [float(squeeze.diameter(float(t))) for t in thetas]
        response.squeezed = [wrap(squeeze(float(t)), TWO_PI) for t in thetas]
        response.minima_angle = [m.angle for m in squeeze.diameter.minima]
        response.minima_width = [m.width for m in squeeze.diameter.minima]
        response.maxima_angle = [m.angle for m in squeeze.diameter.maxima]
        response.maxima_width = [m.width for m in squeeze.diameter.maxima]
        return response


NODE = SqueezePlanner  # what a cell host builds (feeder_cell.host)


def main(args: list[str] | None = None) -> None:
    """Run the node until shut down."""
    run_node(SqueezePlanner, "squeeze_planner", args, threads=THREADS)


if __name__ == "__main__":
    main()
