"""The cell clock's services: ~/pause, ~/resume, ~/is_paused, ~/step and ~/rewind.

``ClockServices`` is the base of ``feeder_cell.nodes.cell_clock.CellClock``, which creates the services
and holds the state they read and change (declared here for the type checker). The four clock methods the
handlers call are the node's, declared abstract: a node that lacks one (a rename) cannot be built (a
TypeError naming it at construction, not when a service call first reaches the handler).
"""

from __future__ import annotations

import time
from abc import ABCMeta, abstractmethod

from rclpy.node import Node
from rclpy.task import Future
from std_srvs.srv import Trigger

from feeder_cell.clock_parameters import NANOSECONDS, ClockParameters, to_time
from feeder_cell.lockstep_barrier import REWIND_REFUSED, REWOUND_TO, Barrier
from feeder_msgs.srv import IsPaused, StepClock
from feeder_planner.node_kit.lockstep import ROLES

__all__ = ["ClockServices"]


class ClockServices(Node, metaclass=ABCMeta):
    """The service handlers of the cell clock node (its state and its clock methods are the node's)."""

    p: ClockParameters
    now_ns: int
    start_ns: int
    factor: float
    paused: bool
    last_wall: float
    barrier: Barrier | None
    stopped: str
    steps_left: int
    step_waiters: list[Future]
    join_waiters: list[Future]

    @abstractmethod
    def tick(self) -> None:
        """Free-running: advance by the wall time since the last tick (the node's)."""

    @abstractmethod
    def publish(self) -> None:
        """Publish the present simulated time (the node's)."""

    @abstractmethod
    def _pump(self) -> None:
        """Lockstep: run the phases as far as the answers allow (the node's)."""

    @abstractmethod
    def _announce(self, role: str) -> None:
        """Lockstep: announce a phase to a role (the node's)."""

    def on_pause(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        """Hold the clock where it is (in lockstep: once the present quantum is complete)."""
        if self.barrier is None:
            self.tick()
        self.paused = True
        response.success, response.message = True, f"paused at {self.now_ns / NANOSECONDS:.9f} s"
        return response

    def on_resume(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        """Run the clock again from where it was held."""
        self.last_wall = time.monotonic()
        self.paused = False
        self.steps_left = 0
        response.success, response.message = True, f"running at real-time factor {self.factor:g}"
        if self.barrier is not None:
            self._pump()
        return response

    def on_is_paused(self, request: IsPaused.Request, response: IsPaused.Response) -> IsPaused.Response:
        """Whether the clock is held (a step in progress still counts as paused: it ends held)."""
        response.paused = self.paused
        return response

    async def on_step(self, request: StepClock.Request, response: StepClock.Response) -> StepClock.Response:
        """Advance a paused clock by the duration asked (in lockstep: whole quanta, answered once there)."""
        step_ns = int(request.duration.sec) * NANOSECONDS + int(request.duration.nanosec)
        response.ok, response.error = False, ""
        if not self.paused:
            response.error = "bad request: duration: the clock is running; ~/pause it first"
        elif step_ns <= 0:
            response.error = f"bad request: duration: must be > 0, got {step_ns} ns"
        elif self.barrier is None:
            self.now_ns += step_ns
            self.publish()
            response.ok = True
        elif step_ns % self.barrier.quantum_ns:
            response.error = (
                f"bad request: duration: must be a whole number of quanta ({self.p.quantum:g} s) "
                f"in lockstep, got {step_ns / NANOSECONDS:g} s"
            )
        elif self.stopped:
            response.error = f"bad request: the clock is {self.stopped}"
        else:
            done = Future()
            self.step_waiters.append(done)
            self.steps_left += step_ns // self.barrier.quantum_ns
            self._pump()
            await done
            response.ok = True
        response.now = to_time(self.now_ns)
        return response

    async def on_rewind(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        """Set a paused clock back to its start time (a ResetSimulation of time); answered once there.

        In lockstep the present quantum ends first; then every participant is announced the start time
        again (an earlier time is a rewind: its node clock jumps back, ``Participant.rewind``), and the
        answer comes once every tick participant has answered it. The start's react and observe phases
        run at the next step or resume, as after a paused start. Only tick participants follow a rewind
        (devices reconfigured by the caller): with a react or observe participant (a controller, a
        recorder) it is refused, naming them.
        """
        response.success = False
        if not self.paused:
            response.message = "bad request: the clock is running; ~/pause it first"
            return response
        if self.barrier is None:
            self.now_ns = self.start_ns
            self.publish()
            response.success, response.message = True, f"{REWOUND_TO} {self.now_ns} ns"
            return response
        barrier = self.barrier
        others = sorted(f"{m.name} ({m.role})" for m in barrier.members.values() if m.role != ROLES[0])
        if others:
            response.message = f"bad request: {', '.join(others)} {REWIND_REFUSED}"
            return response
        if self.stopped or self.steps_left:
            response.message = f"bad request: the clock is {self.stopped or 'stepping'}"
            return response
        if barrier.phase not in ("join", "done"):
            done = Future()
            self.step_waiters.append(done)  # the present quantum ends: woken with the steps
            await done
        if barrier.phase == "done":
            self.get_logger().info(f"rewind from {self.now_ns / NANOSECONDS:.3f} s to the start")
            barrier.rewind(self.start_ns, time.monotonic())
            self.now_ns = self.start_ns
            self.publish()
            arrived = Future()
            self.join_waiters.append(arrived)
            self._announce("tick")
            self._pump()
            await arrived
        response.success, response.message = True, f"{REWOUND_TO} {self.now_ns} ns"
        return response
