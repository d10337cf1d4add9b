"""The MEMS field array's ROS message adapters: its streams from the scene, and the ~/run_program goal.

The node (``feeder_sim.nodes.mems_field_array``) publishes what these build; ``RunProgramGoal`` is the
kit's goal runner's view of the ROS-free ``mems.program_goal.ProgramGoal``.
"""

from __future__ import annotations

from typing import Any, Protocol, Sequence

import numpy as np
from geometry_msgs.msg import PoseArray
from rclpy.clock import Clock
from rclpy.impl.rcutils_logger import RcutilsLogger

from feeder_device.device import DeviceState
from feeder_msgs.action import RunProgram
from feeder_msgs.msg import FieldProgram, FieldSpec, MemsCellForces, MemsParts, MemsPartState, MemsPartStates
from feeder_planner.mems import ProgramStep
from feeder_planner.node_kit import planar_pose
from feeder_planner.node_kit.msg_fields import fill_field_spec
from feeder_planner.node_kit.msg_parts import part_to_msg
from feeder_sim.mems import Body
from feeder_sim.mems.program_goal import ProgramGoal
from feeder_sim.mems.settling import Prediction, equilibrium_summary, match
from feeder_sim.node_kit.stamp import stamp

__all__ = [
    "ProgramArray",
    "RunProgramGoal",
    "cell_forces_msg",
    "field_program_msg",
    "part_state_msgs",
    "part_states_msgs",
    "parts_msg",
]


def field_program_msg(program: Sequence[ProgramStep], started_ns: int, frame_id: str) -> FieldProgram:
    """Return the field program, stamped with its node-clock start time."""
    msg = FieldProgram(name="program", steps=[fill_field_spec(FieldSpec(), s) for s in program])
    msg.header.frame_id = frame_id
    msg.header.stamp = stamp(started_ns)
    return msg


def cell_forces_msg(
    cells: tuple[int, int], pitch: float, grid_forces: np.ndarray, now_ns: int, frame_id: str
) -> MemsCellForces:
    """Return what the cells push with, (nx, ny, 2) forces, stamped at ``now_ns`` (node clock)."""
    nx, ny = cells
    msg = MemsCellForces(
        nx=nx,
        ny=ny,
        pitch=pitch,
        fx=grid_forces[..., 0].ravel().tolist(),
        fy=grid_forces[..., 1].ravel().tolist(),
    )
    msg.header.stamp = stamp(now_ns)
    msg.header.frame_id = frame_id
    return msg


def parts_msg(documents: Sequence[dict[str, Any]]) -> MemsParts:
    """Return ~/parts: each part's document (its name the part's name on the array), in the array's order."""
    return MemsParts(parts=[part_to_msg(document) for document in documents])


def part_state_msgs(names: Sequence[str], bodies: Sequence[Body]) -> list[MemsPartState]:
    """Return every part's state: pose, twist, field wrench."""
    states = []
    for name, body in zip(names, bodies, strict=True):
        state = MemsPartState(name=name, theta=float(body.pose[2]))
        state.pose = planar_pose(body.pose[0], body.pose[1], body.pose[2])
        state.twist.linear.x, state.twist.linear.y = float(body.velocity[0]), float(body.velocity[1])
        state.twist.angular.z = float(body.velocity[2])
        state.wrench.force.x, state.wrench.force.y = float(body.wrench[0]), float(body.wrench[1])
        state.wrench.torque.z = float(body.wrench[2])
        states.append(state)
    return states


def part_states_msgs(
    names: Sequence[str], bodies: Sequence[Body], now_ns: int, frame_id: str
) -> tuple[MemsPartStates, PoseArray]:
    """Return ~/part_states and ~/part_poses at ``now_ns`` (node clock): one header, the same poses."""
    states = MemsPartStates(parts=part_state_msgs(names, bodies))
    states.header.stamp = stamp(now_ns)
    states.header.frame_id = frame_id
    poses = PoseArray(poses=[state.pose for state in states.parts])
    poses.header = states.header
    return states, poses


class ProgramArray(Protocol):
    """What ``RunProgramGoal`` needs of the MEMS node (a protocol: no import of the node module)."""

    stopped: bool

    def time_step_warning(self) -> tuple[int, str] | None:
        """Return (FAULT_TIME_STEP, why) when the present program or drag has had stiff ideal steps."""
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


class RunProgramGoal:
    """The runner's view of a ``ProgramGoal``: feedback and result as RunProgram messages."""

    def __init__(self, node: ProgramArray, machine: ProgramGoal, predictions: list[Prediction]) -> None:
        self.node, self.machine, self.predictions = node, machine, predictions
        self.pending: list[RunProgram.Feedback] = []
        self.ended: RunProgram.Result | None = None

    @property
    def done(self) -> bool:
        """Whether the goal has ended."""
        return self.machine.done

    def advance(self, now_ns: int) -> None:
        """Decide after the tick; feedback and result are built now, from the scene this tick left."""
        node = self.node
        warning = node.time_step_warning()
        self.machine.advance(now_ns, node.stopping_fault(), node.stopped, warning)
        if self.machine.feedback_due:
            # The scene and names the goal started with: a cleanup may have released the node's.
            scene = self.machine.scene
            matches = [match(p, b.pose) for p, b in zip(self.predictions, scene.bodies, strict=True)]
            self.pending.append(
                RunProgram.Feedback(
                    time=self.machine.elapsed,
                    parts=part_state_msgs(self.machine.names, scene.bodies),
                    settled=list(self.machine.flags),
                    equilibrium_distance=[m.distance for m in matches],
                )
            )
        self._result()

    def cancel(self, reason: str) -> None:
        """End now, where the parts are (the program stays on)."""
        self.machine.cancel(reason)
        self.advance(self.node.get_clock().now().nanoseconds)

    def halt(self) -> None:
        """Nothing to stop: the program stays on, as a cancel leaves it."""

    def interrupt(self, reason: str) -> None:
        """End now: the device left active."""
        self.machine.interrupt(self.node.state().name)
        self._result()

    def feedback(self) -> Sequence[RunProgram.Feedback]:
        """Return the feedback built since the last call."""
        pending, self.pending = self.pending, []
        return pending

    def result(self) -> tuple[str, RunProgram.Result]:
        """Return the terminal state and the result built when the goal ended."""
        result = self._result()
        assert result is not None  # the runner asks only once the goal ended
        self.node.get_logger().info(f"run_program {result.outcome_name}: {result.message}")
        terminal = {"SETTLED": "succeed", "CANCELED": "canceled"}.get(result.outcome_name, "abort")
        return terminal, result

    def _result(self) -> RunProgram.Result | None:
        """Build the result once the machine ends: final states, the equilibrium each part reached."""
        outcome = self.machine.outcome
        if outcome is None or self.ended is not None:
            return self.ended
        scene, names = self.machine.scene, self.machine.names
        matches = [match(p, b.pose) for p, b in zip(self.predictions, scene.bodies, strict=True)]
        summary = [
            equilibrium_summary(name, prediction, found)
            for name, prediction, found in zip(names, self.predictions, matches, strict=True)
        ]
        self.ended = RunProgram.Result(
            outcome=outcome.code,
            outcome_name=outcome.name,
            message="; ".join([outcome.message, *summary]),
            settled=outcome.settled,
            parts=part_state_msgs(names, scene.bodies),
            equilibrium=[m.index for m in matches],
            equilibrium_theta=[m.theta for m in matches],
            equilibrium_distance=[m.distance for m in matches],
            fault_code=int(outcome.fault[0]),
            fault_text=outcome.fault[1],
        )
        return self.ended
