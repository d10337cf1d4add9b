"""ROS 2 node: the cell's one clock source, publishing /clock at a real-time factor, with pause and step.

`feeder launch SCENE --real-time-factor F` starts it and sets ``use_sim_time`` on every node, so every
device simulates, times and stamps on this one timeline: F > 1 runs a shift in minutes, F < 1 slows the
cell down for a debugger. A test can hold the whole cell still (``~/pause``) and advance it in lockstep
(``~/step`` by a duration). The clock itself runs on the wall (steady) clock.
"""

from __future__ import annotations

import time

from builtin_interfaces.msg import Time
from rcl_interfaces.msg import SetParametersResult
from rclpy.clock import Clock as RclClock
from rclpy.clock import ClockType
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from std_srvs.srv import Trigger

from feeder_msgs.srv import StepClock
from feeder_planner.errors import InputError
from feeder_planner.node_kit import ParameterSpec, check_value, declare_parameters, positive, run_node

PARAMETERS = (
    ParameterSpec(
        "real_time_factor", 1.0, "simulated seconds per wall second (> 0); may change at run time", positive
    ),
    ParameterSpec(
        "publish_rate",
        200.0,
        "rate (Hz, wall clock) of /clock messages: the time resolution the "
        "nodes see is real_time_factor / publish_rate",
        positive,
        read_only=True,
    ),
    ParameterSpec(
        "start_time",
        0.0,
        "simulated time at start (s since the epoch); 0: the wall time at start",
        lambda v: None if isinstance(v, float) and v >= 0 else f"must be >= 0 s, got {v!r}",
        read_only=True,
    ),
    ParameterSpec(
        "start_paused", False, "hold the clock at start_time until ~/resume or ~/step", read_only=True
    ),
)

# rclpy's time source subscribes to /clock best effort with depth 1; a reliable publisher matches it.
CLOCK_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)

NANOSECONDS = 1_000_000_000


def to_time(nanoseconds: int) -> Time:
    """Return a builtin_interfaces/Time of an integer number of nanoseconds."""
    return Time(sec=nanoseconds // NANOSECONDS, nanosec=nanoseconds % NANOSECONDS)


class CellClock(Node):
    """Publishes /clock; serves ~/pause, ~/resume (std_srvs/Trigger) and ~/step (feeder_msgs/StepClock)."""

    def __init__(self) -> None:
        super().__init__("cell_clock")
        self.p = declare_parameters(self, PARAMETERS)
        start = self.p["start_time"] or time.time()
        # Integer nanoseconds: a long run at a high factor must not drift by float rounding.
        self.now_ns = int(round(start * NANOSECONDS))
        self.factor = float(self.p["real_time_factor"])
        self.paused = bool(self.p["start_paused"])
        self.last_wall = time.monotonic()
        self.pub = self.create_publisher(Clock, "/clock", CLOCK_QOS)
        self.create_service(Trigger, "~/pause", self.on_pause)
        self.create_service(Trigger, "~/resume", self.on_resume)
        self.create_service(StepClock, "~/step", self.on_step)
        self.add_on_set_parameters_callback(self.on_parameters)
        steady = RclClock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(1.0 / self.p["publish_rate"], self.tick, clock=steady)
        self.publish()
        paused = " (paused)" if self.paused else ""
        self.get_logger().info(f"/clock at real-time factor {self.factor:g}{paused}")

    def publish(self) -> None:
        """Publish the present simulated time."""
        self.pub.publish(Clock(clock=to_time(self.now_ns)))

    def tick(self) -> None:
        """Advance by the wall time since the last tick times the factor (nothing while paused)."""
        wall = time.monotonic()
        elapsed, self.last_wall = wall - self.last_wall, wall
        if not self.paused:
            self.now_ns += int(round(elapsed * self.factor * NANOSECONDS))
        self.publish()

    def on_pause(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        """Hold the clock where it is."""
        self.tick()
        self.paused = True
        response.success, response.message = True, f"paused at {self.now_ns / NANOSECONDS:.9f} s"
        return response

    def on_resume(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        """Run the clock again from where it was held."""
        self.last_wall = time.monotonic()
        self.paused = False
        response.success, response.message = True, f"running at real-time factor {self.factor:g}"
        return response

    def on_step(self, request: StepClock.Request, response: StepClock.Response) -> StepClock.Response:
        """Advance a paused clock by the requested duration and publish it at once."""
        step_ns = int(request.duration.sec) * NANOSECONDS + int(request.duration.nanosec)
        if not self.paused:
            response.ok = False
            response.error = "bad request: duration: the clock is running; ~/pause it first"
        elif step_ns <= 0:
            response.ok, response.error = False, f"bad request: duration: must be > 0, got {step_ns} ns"
        else:
            self.now_ns += step_ns
            self.publish()
            response.ok, response.error = True, ""
        response.now = to_time(self.now_ns)
        return response

    def on_parameters(self, changes: list[Parameter]) -> SetParametersResult:
        """Apply a new real-time factor at once (the clock continues from where it is)."""
        for change in changes:
            if change.name == "real_time_factor":
                try:
                    check_value(PARAMETERS[0], change.value)
                except InputError as error:
                    return SetParametersResult(successful=False, reason=str(error))
                self.tick()
                self.factor = float(change.value)
        return SetParametersResult(successful=True)


def main(args: list[str] | None = None) -> None:
    """Run the cell clock node."""
    run_node(CellClock, "cell_clock", args)


if __name__ == "__main__":
    main()
