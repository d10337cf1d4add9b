"""Over DDS: the conformance suite every managed device runs (docs/cell.md, the device kit ``feeder_device``).

One entry of ``DEVICES`` per device: how to start it, a runtime parameter that fails configure and its fix,
a runtime parameter and a bad value, its services (a harmless request each, and hostile ones naming their
field), its action (a short goal, hostile goals), how to inject each of its faults, and bad read-only
configurations. Every test below runs for every entry; adding a device is adding its entry.

What each device is held to:

- lifecycle over the lifecycle_msgs services: a bad parameter fails configure naming it, the node keeps
  answering and configures once fixed; configure, activate, deactivate, cleanup and shutdown each publish a
  status at once (and a transition event), and the status is also a 1 Hz heartbeat; every bad read-only
  configuration of the table fails configure naming its parameter, each in its own process;
- status and /diagnostics: the kit's keys and every counter the device declares;
- ~/stop and ~/reset, and commands refused naming the state unless the device is ready;
- every fault the node module declares (``FAULTS``), injected through ~/inject_fault, seen by a subscriber of
  ~/status (and its code and FAULT state where it stops the device or has a code) and cleared;
- read-only parameters refused with the reason, runtime ones applied, a bad runtime value refused naming it;
- the namespace move: every private name under the node's namespaced name;
- hostile requests to every service and the action, refused naming the field, the node serving on;
- the kit's guard: a goal whose machine raises ends ABORTED with "internal error" and the device serves on.

All devices run at once under ``/conformance`` (one process per device for the module, and one per bad
configuration); the guard runs the devices' own node classes in this process, under ``/guard``.
"""

from __future__ import annotations

import importlib
import math
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator, Mapping

import numpy as np
import pytest
import ros_harness
from action_msgs.msg import GoalStatus
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import Vector3
from lifecycle_msgs.msg import Transition, TransitionEvent
from lifecycle_msgs.srv import ChangeState, GetAvailableTransitions
from rcl_interfaces.msg import Log
from rcl_interfaces.msg import Parameter as ParameterMsg
from rcl_interfaces.srv import DescribeParameters, GetParameters, ListParameters, SetParameters
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_srvs.srv import Trigger

from feeder_cell import launcher
from feeder_cell.lifecycle_client import LifecycleClient, LifecycleError
from feeder_msgs.action import FeedPart, FollowPath, RunPlan, RunProgram
from feeder_msgs.msg import DeviceStatus, FieldProgram, FieldSpec
from feeder_msgs.srv import (
    ArmCommand,
    ArmPlacePart,
    FieldSetProgram,
    FixtureMove,
    InjectFault,
    MemsPlaceParts,
    SqueezePlacePart,
)
from feeder_planner.node_kit.request_limits import MAX_MOVE_SAMPLES
from feeder_sim.fixture import gravity_of

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]
NAMESPACE = "/conformance"
GUARD_NAMESPACE = "/guard"
# Names a device may use outside its node's private names (docs/cell.md, "Names").
ABSOLUTE = {"/diagnostics", "/rosout", "/parameter_events", "/tf", "/tf_static", "/clock"}
# The kit's diagnostics keys (besides one per declared counter).
DIAGNOSTICS_KEYS = {
    "state",
    "configured_rate_hz",
    "achieved_rate_hz",
    "configured_real_time_factor",
    "achieved_real_time_factor",
    "keeping_pace",
    "behind_real_time",
    "active_faults",
    "last_goal_rejection",
}
READY = ("IDLE", "RUNNING")
# The transition state each lifecycle transition passes through (lifecycle_msgs/State).
TRANSITION_STATES = {
    "configure": "configuring",
    "activate": "activating",
    "deactivate": "deactivating",
    "cleanup": "cleaningup",
    "shutdown": "shuttingdown",
}


# --- what a device is -----------------------------------------------------------------------------------
@dataclass(frozen=True)
class Hostile:
    """A request (or goal) the device must refuse; every string of ``named`` is in the refusal.

    ``within`` (s): refused that fast, before the work the request asks for (a bound checked first).
    """

    request: Any
    named: tuple[str, ...]
    within: float | None = None


def hostile(request: Any, *named: str, within: float | None = None) -> Hostile:
    return Hostile(request, named, within)


@dataclass(frozen=True)
class Call:
    """A request to one of the device's services: its type, its private name, the request."""

    srv: Any
    name: str
    request: Any


@dataclass(frozen=True)
class Service:
    """A device service: a harmless request it answers ok when ready (refused naming the state when not)."""

    srv: Any
    name: str
    good: Any
    hostile: tuple[Hostile, ...]
    answer: Mapping[str, Any] = field(default_factory=dict)  # fields of the good request's response


@dataclass(frozen=True)
class Action:
    """The action: a goal that ends soon with ``outcome``, its counter, goals refused at goal time."""

    action: Any
    name: str
    good: Any
    outcome: str
    counter: str
    hostile: tuple[Hostile, ...]


@dataclass(frozen=True)
class Goal:
    """A goal to the device's action: what makes a fault act that acts only in motion (a squeeze)."""

    request: Any


@dataclass(frozen=True)
class Fault:
    """How to inject one declared fault: InjectFault fields, a bad magnitude, what makes it act or undoes it.

    ``act`` is a request after which a fault that is armed (not acting on injection) acts, and ``stops``
    says it then stops the device (FAULT, with its code); ``restore`` is what a controller must do after
    clearing it (a lost part placed again).
    """

    fields: Mapping[str, Any] = field(default_factory=dict)
    bad: Hostile | None = None
    act: Call | Goal | None = None
    stops: bool = False
    restore: Call | None = None


@dataclass(frozen=True)
class DeviceCase:
    """One managed device as the suite drives it (see the module docstring)."""

    package: str
    executable: str
    parameters: Mapping[str, Any]
    broken: tuple[str, Any, Any]  # a runtime parameter: a value that fails configure, and its fix
    runtime: tuple[str, Any, Any]  # a runtime parameter: a value applied at run time, and a refused one
    services: tuple[Service, ...]
    action: Action
    faults: Mapping[str, Fault]
    bad_configurations: tuple[tuple[Mapping[str, Any], tuple[str, ...]], ...]  # (parameters, named)

    @property
    def name(self) -> str:
        """The device's node under the suite's namespace."""
        return f"{NAMESPACE}/{self.executable}"

    def module(self) -> Any:
        """The node module: its ``FAULTS``, ``PARAMETERS`` and device class."""
        return importlib.import_module(f"{self.package}.nodes.{self.executable}")

    def device_class(self) -> Any:
        """The node module's ManagedDevice subclass: its ``NODE``, what the cell host builds."""
        from feeder_device.device import ManagedDevice

        module = self.module()
        node = getattr(module, "NODE", None)
        assert isinstance(node, type) and issubclass(node, ManagedDevice), (
            f"{module.__name__}.NODE is {node!r}"
        )
        assert node.__module__ == module.__name__, f"{module.__name__}.NODE is defined in {node.__module__}"
        return node


def vec(x: float, y: float, z: float) -> Vector3:
    return Vector3(x=float(x), y=float(y), z=float(z))


def tilt(tilt_x: float, tilt_y: float) -> Vector3:
    """The gravity direction of the fixture's joint angles (rad)."""
    return vec(*gravity_of(np.array([tilt_x, tilt_y])).tolist())


def program(*steps: Mapping[str, Any]) -> FieldProgram:
    return FieldProgram(steps=[FieldSpec(**step) for step in steps])


STILL = {"type": "constant", "force_x": 0.0, "force_y": 0.0}  # a MEMS field that moves nothing


def run_goal(
    *steps: Mapping[str, Any], timeout: float = 5.0, tolerance: float = 0.0, dwell: float = 0.0
) -> Any:
    steps = steps or (STILL,)
    return RunProgram.Goal(program=program(*steps), timeout=timeout, tolerance=tolerance, dwell=dwell)


TRIANGLE = str(ROOT / "examples" / "throwing" / "triangle.yaml")
SQUEEZE_RECTANGLE = str(ROOT / "examples" / "squeeze" / "rectangle.yaml")
BRACKET = str(ROOT / "examples" / "mems" / "bracket.yaml")
ARM_TIMEOUT = "timeout: must be finite and >= 0 s (0: no limit), got"
RUN_TIMEOUT = "timeout: must be a finite number > 0"
SWING = [vec(1.0, 0.0, -1.0), vec(0.0, 0.0, -1.0)] * 50  # 100 quarter turns: 18,001 path samples

DEVICES = (
    DeviceCase(
        "feeder_sim",
        "throwing_arm",
        # The paper's triangle at rest on edge 1 at R = 12 cm; the sensor at 35 cm never sees it.
        {
            "part_file": TRIANGLE,
            "offset": -0.005,
            "release_speed": math.radians(320),
            "gravity": -9.66,
            "mu": 0.5,
            "initial_edge": 1,
            "initial_radius": 0.12,
            "sensor_rate": 50.0,
            "period": 0.2,
            "sensor_radius": 0.35,
            "sensing_height": 0.001,
            "fault_seed": 3,
        },
        ("period", -1.0, 0.2),
        ("release_speed", 5.8, 0.0),
        (
            Service(
                ArmCommand,
                "command",
                ArmCommand.Request(command="stop"),
                (
                    hostile(ArmCommand.Request(command=""), "command"),
                    hostile(ArmCommand.Request(command="juggle"), "command"),
                    hostile(ArmCommand.Request(command="throw", count=0), "count"),
                    hostile(ArmCommand.Request(command="throw", count=2**32 - 1), "count"),
                ),
                {"pending": 0},
            ),
            Service(
                ArmPlacePart,
                "place_part",
                ArmPlacePart.Request(edge=1, radius=0.12),
                tuple(
                    hostile(ArmPlacePart.Request(edge=1, radius=r), "radius", "arm_length")
                    for r in (10.0, 1e308, -10.0)
                )
                + (
                    hostile(ArmPlacePart.Request(edge=1, radius=math.nan), "radius", "finite"),
                    hostile(ArmPlacePart.Request(edge=1, radius=0.001), "radius"),
                ),
            ),
        ),
        Action(
            FeedPart,
            "feed_part",
            FeedPart.Goal(max_throws=1),
            "MAX_THROWS",  # one throw, and the sensor at 35 cm never sees the part
            "feed_goals",
            (
                hostile(FeedPart.Goal(max_throws=0), "max_throws: must be an integer >= 1, got 0"),
                hostile(FeedPart.Goal(max_throws=3, timeout=math.nan), f"{ARM_TIMEOUT} nan"),
                hostile(FeedPart.Goal(max_throws=3, timeout=-1.0), f"{ARM_TIMEOUT} -1.0"),
                hostile(FeedPart.Goal(max_throws=3, timeout=math.inf), f"{ARM_TIMEOUT} inf"),
            ),
        ),
        {
            "sensor_stuck": Fault({"state": True}),
            "sensor_dropout": Fault({"value": 0.5}, hostile({"value": 1.5}, "value")),
            "sensor_bit_flip": Fault({"value": 0.3}, hostile({"indices": [4]}, "indices")),
            "release_speed_error": Fault({"value": 0.05}, hostile({"value": -1.0, "state": True}, "value")),
            "motor_fault": Fault(),
            "part_lost": Fault(
                restore=Call(ArmPlacePart, "place_part", ArmPlacePart.Request(edge=1, radius=0.12))
            ),
        },
        (
            ({"part_file": "/nonexistent/part.yaml"}, ("parameter part_file",)),
            ({"initial_edge": 7}, ("parameter initial_edge",)),
            ({"initial_radius": 0.001}, ("parameter initial_radius",)),
            ({"inject_faults": ["sensor_dropout=2"]}, ("parameter inject_faults[0] (value)",)),
            ({"inject_faults": ["wobble"]}, ("parameter inject_faults[0]",)),
            (
                {"inject_faults": ["sensor_stuck", "sensor_bit_flip,indices=2"]},
                ("parameter inject_faults[1] (indices)",),
            ),
            (
                {"inject_faults": ["release_speed_error=0.9,state=false"]},
                ("parameter inject_faults[0] (value)",),
            ),
        ),
    ),
    DeviceCase(
        "feeder_sim",
        "mems_field_array",
        # The array fidelity (the cell faults need it) on a 6 mm array under the 4 x 3 mm bracket, a drag so
        # strong that the part creeps at microns per second (the tests hold it still with a zero field), and
        # 10 ms steps: cheap ticks, also in this process (the guard's device).
        {
            "part_files": [BRACKET],
            "initial_poses": [0.0, 0.0, 0.0],
            "fidelity": "array",
            "array_size": [60, 60],
            "damping": 1e6,
            "time_step": 1e-2,
            "publish_rate": 20.0,
            "fault_seed": 9,
        },
        ("damping", -1.0, 1e6),
        ("damping", 2e6, -1.0),
        (
            Service(
                MemsPlaceParts,
                "place_parts",
                MemsPlaceParts.Request(reset=True),
                (
                    hostile(
                        MemsPlaceParts.Request(names=["nobody"], x=[0.0], y=[0.0], theta=[0.0]), "names[0]"
                    ),
                    hostile(
                        MemsPlaceParts.Request(names=["bracket"], x=[math.nan], y=[0.0], theta=[0.0]), "x[0]"
                    ),
                    hostile(
                        MemsPlaceParts.Request(names=["bracket"], x=[1e308], y=[0.0], theta=[0.0]), "x[0]"
                    ),
                    hostile(
                        MemsPlaceParts.Request(names=["bracket"], x=[0.0], y=[1e308], theta=[0.0]), "y[0]"
                    ),
                    hostile(
                        MemsPlaceParts.Request(names=["bracket"], x=[0.0], y=[0.0], theta=[math.inf]),
                        "theta[0]",
                    ),
                    hostile(MemsPlaceParts.Request(names=["p"] * 20_000), "names"),
                ),
            ),
            Service(
                FieldSetProgram,
                "set_program",
                FieldSetProgram.Request(program=program(STILL)),
                (
                    hostile(
                        FieldSetProgram.Request(program=program()), "program.steps: a field program needs"
                    ),
                    hostile(
                        FieldSetProgram.Request(program=program({"type": "combined", "delta": math.nan})),
                        "program.steps[0].delta",
                    ),
                    hostile(
                        FieldSetProgram.Request(program=program({"type": "combined", "delta": 2.0})),
                        "program.steps[0].delta",
                    ),
                    hostile(
                        FieldSetProgram.Request(
                            program=program(
                                {"type": "radial", "duration": 1.0}, {"type": "squeeze", "center_x": math.nan}
                            )
                        ),
                        "program.steps[1].center[0]",
                    ),
                    hostile(
                        FieldSetProgram.Request(program=program({"type": "vortex"})),
                        "program.steps[0].type: unknown field 'vortex'",
                    ),
                ),
            ),
        ),
        Action(
            RunProgram,
            "run_program",
            run_goal(),
            "SETTLED",
            "program_goals",
            (
                hostile(
                    RunProgram.Goal(program=program(), timeout=30.0),
                    "program.steps: a field program needs at least one step",
                ),
                hostile(run_goal({"type": "combined", "delta": math.nan}), "program.steps[0].delta"),
                hostile(
                    run_goal({"type": "radial", "duration": 1.0}, {"type": "squeeze", "center_x": math.nan}),
                    "program.steps[1].center[0]",
                ),
                hostile(run_goal({"type": "vortex"}), "program.steps[0].type: unknown field 'vortex'"),
                hostile(run_goal(timeout=0.0), RUN_TIMEOUT),
                hostile(run_goal(timeout=-1.0), RUN_TIMEOUT),
                hostile(run_goal(timeout=math.inf), RUN_TIMEOUT),
                hostile(run_goal(tolerance=math.nan), "tolerance: must be a finite number >= 0"),
                hostile(run_goal(dwell=-0.5), "dwell: must be a finite number >= 0"),
            ),
        ),
        {
            "dead_cells": Fault({"value": 0.3}, hostile({"indices": [3600]}, "indices[0]")),
            "stuck_cells": Fault(
                {"value": 0.1, "angle": 0.0}, hostile({"value": 0.1, "angle": math.inf}, "angle")
            ),
            "field_strength_error": Fault({"value": 0.25}, hostile({"value": -1.5}, "value")),
            "power_loss": Fault(),
        },
        (
            ({"fidelity": "psychic"}, ("parameter fidelity",)),
            ({"part_files": ["/nonexistent/part.yaml"]}, ("parameter part_files[0]",)),
            ({"time_step": -1e-3}, ("parameter time_step",)),
            (
                {"fidelity": "ideal", "inject_faults": ["dead_cells=0.2"]},
                ("parameter inject_faults[0]", "'ideal'"),
            ),
        ),
    ),
    DeviceCase(
        "feeder_sim",
        "assembly_fixture",
        # The built-in block in an L bracket; tilting tilt_y alone down to -0.9 rad keeps it stable.
        {"fault_seed": 5},
        ("max_rate_y", -1.0, 1.0),
        ("max_rate_x", 0.5, -1.0),
        (
            Service(
                FixtureMove,
                "move",
                FixtureMove.Request(waypoints=[tilt(0.0, 0.0)]),
                (
                    hostile(FixtureMove.Request(waypoints=[]), "waypoints"),
                    hostile(
                        FixtureMove.Request(waypoints=[vec(math.nan, 0.0, -1.0)]), "waypoints[0]", "finite"
                    ),
                    hostile(FixtureMove.Request(waypoints=[vec(0.0, 0.0, 0.0)]), "waypoints[0]", "non-zero"),
                    hostile(
                        FixtureMove.Request(waypoints=SWING),
                        "bad request: waypoints:",
                        "path samples",
                        f"limit per request is {MAX_MOVE_SAMPLES}",
                        within=3.0,  # counted before any sample is made (each is an LP)
                    ),
                ),
                {"samples": 1},  # from where it stands, level: one sample
            ),
        ),
        Action(
            FollowPath,
            "follow_path",
            FollowPath.Goal(tilt_waypoints=[0.0, 0.0]),  # to where it stands: level
            "REACHED",
            "path_goals",
            (
                hostile(FollowPath.Goal(), "needs at least one waypoint"),
                hostile(
                    FollowPath.Goal(gravity_waypoints=[vec(0.0, 0.0, -1.0)], tilt_waypoints=[0.0, -0.1]),
                    "gravity_waypoints/tilt_waypoints: give one kind",
                ),
                hostile(
                    FollowPath.Goal(gravity_waypoints=[vec(0.0, math.nan, -1.0)]),
                    "gravity_waypoints[0]: must be finite",
                ),
                hostile(
                    FollowPath.Goal(gravity_waypoints=[vec(0.0, 0.0, -1.0), vec(0.0, 0.0, 0.0)]),
                    "gravity_waypoints[1]: must be a non-zero direction",
                ),
                hostile(
                    FollowPath.Goal(tilt_waypoints=[0.0, -0.1, 0.2]),
                    "tilt_waypoints: needs (tilt_x, tilt_y) pairs",
                ),
                hostile(
                    FollowPath.Goal(tilt_waypoints=[0.0, -0.1, 2.0, 0.0]),
                    "tilt_waypoints[2] (tilt_x of waypoint 1): 2 rad is outside",
                ),
                hostile(
                    FollowPath.Goal(tilt_waypoints=[1.5, 0.0, 0.0, 0.0] * 50),
                    "tilt_waypoints:",
                    "path samples",
                    f"limit per request is {MAX_MOVE_SAMPLES}",
                ),
            ),
        ),
        {
            # Armed at -0.15 rad of tilt_y: the move to -0.3 stalls there (FAULT 301).
            "axis_stall": Fault(
                {"indices": [1], "angle": -0.15},
                hostile({"indices": [0], "angle": 2.0}, "angle"),
                act=Call(FixtureMove, "move", FixtureMove.Request(waypoints=[tilt(0.0, -0.3)])),
                stops=True,
            ),
            "encoder_offset": Fault(
                {"indices": [0], "value": 0.05}, hostile({"indices": [0], "value": 0.0}, "value")
            ),
            "encoder_noise": Fault(
                {"indices": [1], "value": 0.01}, hostile({"indices": [2], "value": 0.01}, "indices")
            ),
            "rate_limit": Fault(
                {"indices": [1], "value": 0.25}, hostile({"indices": [1], "value": 1.5}, "value")
            ),
        },
        (
            ({"assembly_file": "/nonexistent/assembly.yaml"}, ("parameter assembly_file",)),
            ({"tilt_x_min": 0.5, "tilt_x_max": 0.2}, ("parameter tilt_x_min/tilt_x_max",)),
            ({"tilt_y_max": 0.5, "initial_tilt_y": 0.8}, ("parameter initial_tilt_y",)),
            ({"publish_rate": -5.0}, ("parameter publish_rate",)),
            ({"inject_faults": ["rate_limit=1.5"]}, ("parameter inject_faults[0] (value)",)),
        ),
    ),
    DeviceCase(
        "feeder_sim",
        "squeeze_gripper",
        # The 2 x 1 cm rectangle between the jaws; Goldberg's plan of two squeezes orients it.
        {"part_file": SQUEEZE_RECTANGLE, "jaw_speed": 0.2, "turn_speed": 20.0, "fault_seed": 3},
        ("jaw_speed", -1.0, 0.2),
        ("friction", 0.3, 5.0),
        (
            Service(
                SqueezePlacePart,
                "place_part",
                SqueezePlacePart.Request(orientation=0.3),
                (
                    hostile(SqueezePlacePart.Request(orientation=math.nan), "orientation", "finite"),
                    hostile(SqueezePlacePart.Request(orientation=math.inf), "orientation", "finite"),
                ),
                {"orientation": 0.3},
            ),
        ),
        Action(
            RunPlan,
            "run_plan",
            RunPlan.Goal(angles=[0.0, math.pi / 4]),
            "DONE",
            "plan_goals",
            (
                hostile(RunPlan.Goal(), "angles: a plan needs at least one squeeze"),
                hostile(RunPlan.Goal(angles=[0.0, math.nan]), "angles[1]: must be finite"),
                hostile(RunPlan.Goal(angles=[0.0], timeout=-1.0), "timeout: must be finite and >= 0 s"),
                hostile(RunPlan.Goal(angles=[0.0] * 1001), "angles: 1001 squeezes", "limit per goal is 1000"),
            ),
        ),
        {
            # Armed: the jaws stall at the next squeeze (FAULT 401); clearing it opens them.
            "jaw_stall": Fault(act=Goal(RunPlan.Goal(angles=[0.0])), stops=True),
            # Certain to drop at the next squeeze (FAULT 402); the part must be placed again.
            "part_dropped": Fault(
                {"value": 1.0},
                hostile({"value": 1.5}, "value", "probability"),
                act=Goal(RunPlan.Goal(angles=[0.0])),
                stops=True,
                restore=Call(SqueezePlacePart, "place_part", SqueezePlacePart.Request(orientation=0.3)),
            ),
            "jaw_worn": Fault({"value": 0.4}, hostile({"value": 0.0}, "value", "friction increase")),
        },
        (
            ({"part_file": "/nonexistent/part.yaml"}, ("parameter part_file",)),
            ({"fidelity": "paper"}, ("parameter fidelity",)),
            ({"open_width": 0.001}, ("parameter open_width",)),
            ({"inject_faults": ["part_dropped=1.5"]}, ("parameter inject_faults[0] (value)",)),
        ),
    ),
)
IDS = [case.executable for case in DEVICES]
FAULT_CASES = [(case, name) for case in DEVICES for name in case.faults]
FAULT_IDS = [f"{case.executable}-{name}" for case, name in FAULT_CASES]


# --- the running devices --------------------------------------------------------------------------------
def history_qos() -> QoSProfile:
    """Transient local and deep: the current status of a latched topic, and every later one kept in order."""
    return QoSProfile(
        depth=100, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
    )


def since(
    listener: ros_harness.Listener, mark: int, accept: Callable[[Any], bool], timeout: float = 30.0
) -> Any:
    """Return the first message after ``mark`` (arrived, or arriving within ``timeout``) ``accept`` takes."""
    deadline = time.monotonic() + timeout
    while True:
        found = next((m for m in listener.since(mark) if accept(m)), None)
        if found is not None:
            return found
        assert time.monotonic() < deadline, (
            f"nothing accepted on {listener.topic}: {listener.since(mark)[-3:]}"
        )
        time.sleep(0.01)


def wait_future(future: Any, timeout: float, what: str) -> Any:
    """Return a future's result, waiting at most ``timeout`` s (the client's executor runs elsewhere)."""
    done = threading.Event()
    future.add_done_callback(lambda _: done.set())
    if not done.wait(timeout):
        raise AssertionError(f"no {what} within {timeout:.0f} s")
    return future.result()


@dataclass
class Cell:
    """The devices of the module: their processes, their clients, all that was heard from them.

    Every client and subscription is made before the processes start: a server that has not matched its
    caller's reply reader drops the reply, and a late subscriber misses the first statuses.
    """

    caller: Any
    processes: dict[str, launcher.NodeProcess]
    lifecycles: dict[str, LifecycleClient]  # by node name
    statuses: dict[str, ros_harness.Listener]  # by node name
    transitions: dict[str, ros_harness.Listener]
    diagnostics: ros_harness.Listener
    rosout: ros_harness.Listener

    @property
    def client(self) -> Any:
        return self.caller.node

    def status(
        self, case: DeviceCase, accept: Callable[[Any], bool] = lambda s: True, timeout: float = 30.0
    ) -> Any:
        """Return the latest status, or the first later one, that ``accept`` takes."""
        return self.statuses[case.name].wait(accept, timeout, current=True)

    def diagnostic(self, case: DeviceCase, mark: int, accept: Callable[[Any], bool] = lambda d: True) -> Any:
        """Return the device's first DiagnosticStatus since ``mark`` that ``accept`` takes."""

        def mine(message: Any) -> Any:
            return next((s for s in message.status if s.name == case.name), None)

        return mine(since(self.diagnostics, mark, lambda m: mine(m) is not None and accept(mine(m))))

    def logged(self, case: DeviceCase, mark: int, *texts: str) -> Any:
        """Return the device's first /rosout line since ``mark`` that holds every one of ``texts``."""
        logger = case.name.strip("/").replace("/", ".")
        return since(
            self.rosout, mark, lambda line: line.name == logger and all(t in line.msg for t in texts)
        )

    def call(self, case: DeviceCase, srv: Any, service: str, request: Any) -> Any:
        return self.caller.call(srv, f"{case.name}/{service}", request)

    def trigger(self, case: DeviceCase, service: str) -> Any:
        return self.call(case, Trigger, service, Trigger.Request())

    def inject(self, case: DeviceCase, fault: str, **fields: Any) -> Any:
        return self.call(case, InjectFault, "inject_fault", InjectFault.Request(fault=fault, **fields))

    def set_parameters(self, case: DeviceCase, values: Mapping[str, Any]) -> list[Any]:
        request = SetParameters.Request(
            parameters=[Parameter(k, value=v).to_parameter_msg() for k, v in values.items()]
        )
        return list(self.call(case, SetParameters, "set_parameters", request).results)

    def get_parameters(self, case: DeviceCase, names: list[str]) -> dict[str, Any]:
        response = self.call(case, GetParameters, "get_parameters", GetParameters.Request(names=names))
        return {
            name: Parameter.from_parameter_msg(ParameterMsg(name=name, value=value)).value
            for name, value in zip(names, response.values, strict=True)
        }

    def send_goal(self, case: DeviceCase, goal: Any, resend: bool = False) -> Any:
        return self.caller.send_goal(case.action.action, f"{case.name}/{case.action.name}", goal, resend)


# The kit's services and the standard ones every device serves, as (type, private name).
KIT_SERVICES = (
    (Trigger, "stop"),
    (Trigger, "reset"),
    (Trigger, "abort"),
    (Trigger, "clear"),
    (InjectFault, "inject_fault"),
    (SetParameters, "set_parameters"),
    (GetParameters, "get_parameters"),
    (ListParameters, "list_parameters"),
    (DescribeParameters, "describe_parameters"),
    (GetAvailableTransitions, "get_available_transitions"),
)


def prepare_device(
    caller: Any, case: DeviceCase, name: str, kit: tuple[tuple[Any, str], ...] = KIT_SERVICES
) -> tuple[LifecycleClient, ros_harness.Listener]:
    """Make the clients of the device ``name`` before it starts; return its lifecycle client and status."""
    for service in case.services:
        caller.prepare(service.srv, f"{name}/{service.name}")
    for srv, service_name in kit:
        caller.prepare(srv, f"{name}/{service_name}")
    status = ros_harness.Listener(caller.node, DeviceStatus, f"{name}/status", history_qos())
    return LifecycleClient(caller.node, None, name), status


LAYOUTS = ("alone", "hosted")


@pytest.fixture(scope="module", params=LAYOUTS)
def cell(caller: Any, start_together: Any, request: pytest.FixtureRequest) -> Iterator[Cell]:
    """Every device, started at once and left unconfigured with its ``broken`` runtime parameter.

    So the first test can fail its configure, fix it and configure it. Every test runs twice: with each
    device a process of its own ("alone"), and with the three in one cell host ("hosted",
    ``feeder_cell.host``), where a client must see the same devices.
    """
    client = caller.node
    lifecycles, statuses = {}, {}
    for case in DEVICES:
        lifecycles[case.name], statuses[case.name] = prepare_device(caller, case, case.name)
        caller.prepare_action(case.action.action, f"{case.name}/{case.action.name}")
    transitions = {
        case.name: ros_harness.Listener(client, TransitionEvent, f"{case.name}/transition_event", 50)
        for case in DEVICES
    }
    diagnostics = ros_harness.Listener(client, DiagnosticArray, "/diagnostics", 500)
    rosout = ros_harness.Listener(client, Log, "/rosout", 1000)
    specs = [
        launcher.NodeSpec(
            case.package,
            case.executable,
            {**case.parameters, case.broken[0]: case.broken[1]},
            namespace=NAMESPACE,
            lifecycle="unconfigured",
        )
        for case in DEVICES
    ]
    host = "conformance_host" if request.param == "hosted" else ""
    processes = dict(zip(IDS, start_together(specs, host), strict=True))
    yield Cell(caller, processes, lifecycles, statuses, transitions, diagnostics, rosout)
    for lifecycle in lifecycles.values():
        lifecycle.close()
    for process in processes.values():  # the next layout's devices take the same names
        process.stop()


def assert_ended_by_pid(process: launcher.NodeProcess) -> None:
    """The process is gone, and its exit was a clean ROS shutdown (0, or the SIGINT it did not catch)."""
    import os

    assert not process.alive()
    with pytest.raises(ProcessLookupError):
        os.kill(process.pid, 0)
    code = process.process.returncode
    assert code in (0, -2, 130), (
        f"{process.spec.fully_qualified_name} exited with {code}:\n{process.output()[-2000:]}"
    )


def no_fault(status: Any) -> bool:
    """No fault but perhaps the warning that the device is behind real time (a loaded machine)."""
    return status.fault_code in (DeviceStatus.FAULT_NONE, DeviceStatus.FAULT_BEHIND_REAL_TIME)


def healthy_status(status: Any) -> bool:
    return status.state_name in READY and status.ready and no_fault(status) and not status.active_faults


def labelled(name: str, labels: Any) -> bool:
    """Whether a fault's label (``name`` or ``name(magnitudes)``) is among ``labels``."""
    return any(label == name or label.startswith(f"{name}(") for label in labels)


def counters(status: Any) -> dict[str, int]:
    return ros_harness.counters(status)


def values(entry: Any) -> dict[str, str]:
    """A DiagnosticStatus's key values as a mapping."""
    return {kv.key: kv.value for kv in entry.values}


@pytest.fixture
def healthy(cell: Cell, request: pytest.FixtureRequest) -> Cell:
    """The device active, ready, without faults: cleared, reset and, if need be, commanded back."""
    case = request.node.callspec.params["case"]
    lifecycle = cell.lifecycles[case.name]
    if lifecycle.get_state() == "unconfigured":  # the failed-configure test did not run, or failed
        broken, _, fix = case.broken
        assert cell.set_parameters(case, {broken: fix})[0].successful
    assert lifecycle.bring_to("active") == "active"
    assert cell.inject(case, "", clear=True).ok
    assert cell.trigger(case, "reset").success
    for fault in case.faults.values():  # what clearing a fault leaves to be undone (a part placed again)
        if fault.restore is not None:
            cell.call(case, fault.restore.srv, fault.restore.name, fault.restore.request)
    for service in case.services:  # the harmless requests: the device at rest, where the table starts
        assert cell.call(case, service.srv, service.name, service.good).ok
    cell.status(case, lambda s: healthy_status(s) and not s.busy)  # nothing commanded still under way
    return cell


def refused_naming_the_state(
    cell: Cell, case: DeviceCase, state: str, name: str = "", caller: Any = None, remedy: str = ""
) -> None:
    """Every service's harmless request and the action's goal are refused, naming ``state``.

    ``name`` another node of the device's kind (a bad configuration), called through ``caller``; the
    service ``remedy`` is the one that ends the state (it is not refused).
    """
    name, caller = name or case.name, caller or cell.caller
    mark = cell.rosout.count()
    for service in case.services:
        if service.name == remedy:
            continue
        response = caller.call(service.srv, f"{name}/{service.name}", service.good)
        assert not response.ok and f"device is {state}" in response.error, (service.name, response.error)
    if name == case.name:
        assert not cell.send_goal(case, case.action.good, resend=True).accepted
        cell.logged(case, mark, f"goal rejected: ~/{case.action.name}", f"device is {state}")


# --- the table itself -----------------------------------------------------------------------------------
@pytest.mark.parametrize("case", DEVICES, ids=IDS)
def test_the_table_names_every_fault_the_node_module_declares(case: DeviceCase) -> None:
    from feeder_device.declarations import FaultSpec

    declared = case.module().FAULTS
    assert sorted(case.faults) == sorted(declared), "add each declared fault to the device's entry"
    assert all(isinstance(spec, FaultSpec) and spec.name == name for name, spec in declared.items())
    assert dict(case.device_class().FAULTS) == dict(declared)
    assert case.action.counter in [c.name for c in case.device_class().COUNTERS]


# --- lifecycle ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("case", DEVICES, ids=IDS)
def test_each_bad_read_only_configuration_fails_configure_naming_it_and_the_node_keeps_answering(
    case: DeviceCase, cell: Cell, start_together: Any, stop_together: Any, side_caller: Any
) -> None:
    """One process per bad configuration (a read-only parameter cannot be fixed in place), all at once."""
    specs = [
        launcher.NodeSpec(
            case.package,
            case.executable,
            {**case.parameters, **bad},
            namespace=f"{NAMESPACE}/bad{index}",
            lifecycle="unconfigured",
        )
        for index, (bad, _) in enumerate(case.bad_configurations)
    ]
    prepared = {
        spec.fully_qualified_name: prepare_device(
            side_caller, case, spec.fully_qualified_name, ((InjectFault, "inject_fault"),)
        )
        for spec in specs
    }
    processes = start_together(specs)
    try:
        for process, (_, named) in zip(processes, case.bad_configurations, strict=True):
            name = process.spec.fully_qualified_name
            lifecycle, statuses = prepared[name]
            for _ in range(2):  # and a second configure fails the same way
                with pytest.raises(LifecycleError, match="configure refused"):
                    lifecycle.change("configure")
                assert lifecycle.get_state() == "unconfigured" and process.alive()
            report = statuses.wait(lambda s: s.fault_code == DeviceStatus.FAULT_CONFIGURATION, current=True)
            assert report.state_name == "UNCONFIGURED" and not report.ready
            assert all(text in report.fault_text for text in named), report.fault_text
            refused_naming_the_state(cell, case, "UNCONFIGURED", name, side_caller)
            first = next(iter(case.faults))
            response = side_caller.call(InjectFault, f"{name}/inject_fault", InjectFault.Request(fault=first))
            assert not response.ok and "UNCONFIGURED" in response.error, response.error
            assert process.alive(), process.output()[-2000:]
    finally:
        stop_together(processes)
        for lifecycle, _ in prepared.values():
            lifecycle.close()
    for process in processes:  # ended by pid: SIGINT is a clean shutdown for a ROS node
        assert_ended_by_pid(process)


@pytest.mark.parametrize("case", DEVICES, ids=IDS)
def test_a_bad_runtime_parameter_fails_configure_naming_it_and_once_fixed_the_device_configures(
    case: DeviceCase, cell: Cell
) -> None:
    broken, value, fix = case.broken
    lifecycle = cell.lifecycles[case.name]
    assert lifecycle.get_state() == "unconfigured"
    # Unconfigured since it started: status at 1 Hz (the heartbeat: nothing changes), commands refused.
    history = cell.statuses[case.name]
    while history.count() < 4:
        history.next(1, timeout=5.0)
    beats = history.since(0)
    assert all(s.state_name == "UNCONFIGURED" and not s.ready and s.fault_code == 0 for s in beats)
    assert all(s.header.frame_id.strip("/") == case.name.strip("/") for s in beats)
    stamps = [ros_harness.stamp_ns(s) * 1e-9 for s in beats]
    rate = (len(stamps) - 1) / (stamps[-1] - stamps[0])
    assert 0.6 < rate < 1.5 and max(np.diff(stamps)) < 3.0, (rate, np.diff(stamps))
    refused_naming_the_state(cell, case, "UNCONFIGURED")
    for service in ("stop", "reset", "abort", "clear"):
        response = cell.trigger(case, service)
        assert not response.success and "UNCONFIGURED" in response.message, response.message
    response = cell.inject(case, next(iter(case.faults)))
    assert not response.ok and "configure it first" in response.error, response.error
    # configure validates every parameter: the bad one fails it, named; the node answers on
    mark = cell.diagnostics.count()
    with pytest.raises(LifecycleError, match="configure refused"):
        lifecycle.change("configure")
    assert lifecycle.get_state() == "unconfigured" and cell.processes[case.executable].alive()
    failed = cell.status(case, lambda s: s.fault_code == DeviceStatus.FAULT_CONFIGURATION)
    assert failed.state_name == "UNCONFIGURED" and not failed.ready
    assert f"parameter {broken}" in failed.fault_text, failed.fault_text
    entry = cell.diagnostic(case, mark, lambda d: d.level == DiagnosticStatus.ERROR)
    assert f"parameter {broken}" in entry.message
    # still checked when set; then fixed, configured and activated
    refused = cell.set_parameters(case, {broken: value})[0]
    assert not refused.successful and f"parameter {broken}" in refused.reason, refused.reason
    assert cell.set_parameters(case, {broken: fix})[0].successful
    assert cell.get_parameters(case, [broken]) == {broken: fix}
    assert lifecycle.change("configure") == "inactive"
    assert cell.status(case, lambda s: s.state_name == "PAUSED").fault_code == 0
    assert lifecycle.change("activate") == "active"
    assert cell.status(case, lambda s: s.state_name in READY).ready


@pytest.mark.parametrize("case", DEVICES, ids=IDS)
def test_each_lifecycle_transition_is_served_and_published_at_once(healthy: Cell, case: DeviceCase) -> None:
    """deactivate, cleanup, configure, activate: each publishes the new state, stamped before its reply."""
    cell = healthy
    statuses, events = cell.statuses[case.name], cell.transitions[case.name]
    lifecycle = cell.lifecycles[case.name]
    counter = case.action.counter
    handle = cell.send_goal(case, case.action.good)  # a goal run before, to be forgotten by cleanup
    assert handle.accepted
    wait_future(handle.get_result_async(), 60.0, f"the result of {case.action.name}")
    assert counters(cell.status(case, lambda s: counters(s)[counter] >= 1))[counter] >= 1
    for transition, primary, shown in [
        ("deactivate", "inactive", ("PAUSED",)),
        ("cleanup", "unconfigured", ("UNCONFIGURED",)),
        ("configure", "inactive", ("PAUSED",)),
        ("activate", "active", READY),
    ]:
        status_mark, event_mark = statuses.count(), events.count()
        sent = time.time_ns()
        assert lifecycle.change(transition) == primary
        answered = time.time_ns()
        changed = since(statuses, status_mark, lambda s, shown=shown: s.state_name in shown)
        # Published by the transition, not by the next heartbeat: stamped before the reply came.
        stamp = ros_harness.stamp_ns(changed)
        assert sent <= stamp <= answered, (transition, sent, stamp, answered)
        event = since(events, event_mark, lambda e, primary=primary: e.goal_state.label == primary)
        assert event.start_state.label == TRANSITION_STATES[transition], event
        # Each event carries its stamp and its transition (rcl_lifecycle's own carry neither).
        assert sent <= event.timestamp <= answered and event.transition.label == "transition_success", event
        started = since(events, event_mark, lambda e, t=transition: e.transition.label == t)
        assert started.goal_state.label == TRANSITION_STATES[transition] and started.transition.id > 0
        if primary == "inactive":
            assert not changed.ready and not changed.busy
            response = cell.trigger(case, "stop")
            assert not response.success and "PAUSED" in response.message
            for service in case.services:
                response = cell.call(case, service.srv, service.name, service.good)
                assert not response.ok and "device is PAUSED" in response.error, response.error
        if primary == "unconfigured":
            assert changed.fault_code == 0 and list(changed.counter_names) == []
            available = cell.call(
                case, GetAvailableTransitions, "get_available_transitions", GetAvailableTransitions.Request()
            )
            labels = {t.transition.label for t in available.available_transitions}
            assert {"configure", "shutdown"} <= labels and "activate" not in labels, labels
            # A transition the state does not have is refused, and the device lives on (rclpy raised out
            # of its callback and ended the process: ros2/rclpy#1209); the next transition proves it.
            invalid = ChangeState.Request(transition=Transition(id=Transition.TRANSITION_ACTIVATE))
            assert not cell.call(case, ChangeState, "change_state", invalid).success
    fresh = cell.status(case, lambda s: s.state_name in READY)
    assert list(fresh.counter_names) == [c.name for c in case.device_class().COUNTERS]
    assert counters(fresh)[counter] == 0  # a new run: the goal before the cleanup is forgotten


# --- status and diagnostics -----------------------------------------------------------------------------
@pytest.mark.parametrize("case", DEVICES, ids=IDS)
def test_status_and_diagnostics_carry_the_kits_keys_and_every_declared_counter(
    healthy: Cell, case: DeviceCase
) -> None:
    cell = healthy
    declared = [c.name for c in case.device_class().COUNTERS]
    status = cell.status(case)
    assert list(status.counter_names) == declared and len(status.counter_values) == len(declared)
    assert status.header.frame_id.strip("/") == case.name.strip("/") and status.configured_rate > 0
    assert status.configured_real_time_factor == 1.0
    entry = cell.diagnostic(case, cell.diagnostics.count())
    found = values(entry)
    assert DIAGNOSTICS_KEYS | set(declared) <= set(found), sorted(
        DIAGNOSTICS_KEYS | set(declared) - set(found)
    )
    assert entry.name == case.name and entry.hardware_id == f"sim:{case.name}"
    assert found["state"] in READY and found["active_faults"] == ""
    assert float(found["configured_rate_hz"]) == status.configured_rate
    assert found["behind_real_time"] in ("true", "false")
    assert all(found[name].isdigit() for name in declared)
    if found["behind_real_time"] == "false":
        assert entry.level == DiagnosticStatus.OK and entry.message == found["state"].lower()


# --- stop and reset -------------------------------------------------------------------------------------
@pytest.mark.parametrize("case", DEVICES, ids=IDS)
def test_stop_halts_the_device_and_reset_returns_it_to_ready_clearing_every_fault(
    healthy: Cell, case: DeviceCase
) -> None:
    cell = healthy
    mark = cell.diagnostics.count()
    response = cell.trigger(case, "stop")
    assert response.success, response.message
    stopped = cell.status(case, lambda s: s.state_name == "STOPPED")
    assert not stopped.ready and not stopped.busy
    refused_naming_the_state(cell, case, "STOPPED")
    for service in case.services:
        response = cell.call(case, service.srv, service.name, service.good)
        assert "~/reset" in response.error, response.error
    entry = cell.diagnostic(case, mark, lambda d: values(d)["state"] == "STOPPED")
    assert entry.level == DiagnosticStatus.WARN
    response = cell.trigger(case, "reset")
    assert response.success and response.message.startswith("reset: "), response.message
    assert response.message[len("reset: ") :] in READY
    assert cell.status(case, lambda s: s.state_name in READY).ready
    # PackML's Abort and Clear: ~/abort halts into FAULT (code 4), ~/clear leaves it STOPPED, not ready
    response = cell.trigger(case, "clear")
    assert not response.success and "applies in FAULT" in response.message, response.message
    assert cell.trigger(case, "abort").success
    aborted = cell.status(case, lambda s: s.state_name == "FAULT")
    assert aborted.fault_code == DeviceStatus.FAULT_ABORTED and not aborted.ready
    refused_naming_the_state(cell, case, "FAULT")
    assert cell.trigger(case, "clear").success
    cleared = cell.status(case, lambda s: s.state_name == "STOPPED")
    # No stopping fault is left (a loaded host may still report the non-stopping code 2, behind real time).
    assert cleared.fault_code != DeviceStatus.FAULT_ABORTED and not cleared.ready
    assert cell.trigger(case, "reset").success
    assert cell.status(case, lambda s: s.state_name in READY).ready
    # ~/reset clears every injected fault too, a stopping one included
    for name, fault in case.faults.items():
        assert cell.inject(case, name, **fault.fields).ok
    faulted = cell.status(case, lambda s: len(s.active_faults) == len(case.faults))
    assert all(labelled(name, faulted.active_faults) for name in case.faults)
    assert cell.trigger(case, "reset").success
    for fault in case.faults.values():
        if fault.restore is not None:
            assert cell.call(case, fault.restore.srv, fault.restore.name, fault.restore.request).ok
    cell.status(case, healthy_status)


# --- injected faults ------------------------------------------------------------------------------------
@pytest.mark.parametrize("case,fault", FAULT_CASES, ids=FAULT_IDS)
def test_every_declared_fault_is_injected_seen_by_a_subscriber_and_cleared(
    healthy: Cell, case: DeviceCase, fault: str
) -> None:
    cell = healthy
    spec, how = case.module().FAULTS[fault], case.faults[fault]
    if how.bad is not None:
        response = cell.inject(case, fault, **how.bad.request)
        assert not response.ok and all(t in response.error for t in how.bad.named), response.error
        assert list(response.active_faults) == []
    unknown = cell.inject(case, "wobble")
    assert not unknown.ok and "fault" in unknown.error and fault in unknown.error, unknown.error
    response = cell.inject(case, fault, **how.fields)
    assert response.ok, response.error
    assert labelled(fault, response.active_faults), response.active_faults
    seen = cell.status(case, lambda s: labelled(fault, s.active_faults))
    mark = cell.diagnostics.count()
    if isinstance(how.act, Goal):
        assert cell.send_goal(case, how.act.request).accepted
    elif how.act is not None:
        assert cell.call(case, how.act.srv, how.act.name, how.act.request).ok
    if spec.stops_device or how.stops:
        seen = cell.status(case, lambda s: s.state_name == "FAULT" and labelled(fault, s.active_faults))
        assert seen.fault_code == spec.code and not seen.ready and not seen.busy, seen
        if spec.stops_device:  # injected, it stops at once and says which fault
            assert fault in seen.fault_text, seen.fault_text
        refused_naming_the_state(cell, case, "FAULT", remedy=how.restore.name if how.restore else "")
        entry = cell.diagnostic(case, mark, lambda d: d.level == DiagnosticStatus.ERROR)
        assert labelled(fault, values(entry)["active_faults"].split(", "))
    elif spec.code:  # a code that is a warning: the device stays ready
        seen = cell.status(case, lambda s: s.fault_code == spec.code and labelled(fault, s.active_faults))
        assert seen.ready and seen.state_name in READY
    else:
        assert seen.ready and no_fault(seen), seen
    response = cell.inject(case, fault, clear=True)
    assert response.ok and not labelled(fault, response.active_faults), response
    cleared = cell.status(case, lambda s: not labelled(fault, s.active_faults))
    if how.restore is not None:
        assert cleared.state_name == "FAULT", cleared  # cleared, but what it did must be undone too
        assert cell.call(case, how.restore.srv, how.restore.name, how.restore.request).ok
    cell.status(case, healthy_status)


# --- parameters -----------------------------------------------------------------------------------------
@pytest.mark.parametrize("case", DEVICES, ids=IDS)
def test_read_only_parameters_are_refused_and_runtime_ones_applied_or_refused_with_the_reason(
    healthy: Cell, case: DeviceCase
) -> None:
    cell = healthy
    names = list(cell.call(case, ListParameters, "list_parameters", ListParameters.Request()).result.names)
    described = cell.call(
        case, DescribeParameters, "describe_parameters", DescribeParameters.Request(names=names)
    ).descriptors
    read_only = sorted(d.name for d in described if d.read_only)
    declared = {spec.name: spec for spec in case.module().PARAMETERS}
    # The module's declaration is what the node declares: its read-only ones read-only, each described.
    assert set(declared) <= set(names)
    assert {n for n, spec in declared.items() if spec.read_only} <= set(read_only)
    assert not {n for n, spec in declared.items() if not spec.read_only} & set(read_only)
    assert all(d.description for d in described if d.name in declared)
    assert {"inject_faults", "fault_seed", "real_time_factor", "hardware_id", "request_queue_depth"} <= set(
        read_only
    )
    current = cell.get_parameters(case, read_only)
    results = cell.set_parameters(case, current)  # even to the value it has: read-only is read-only
    for name, result in zip(current, results, strict=True):
        assert not result.successful and "read-only" in result.reason, (name, result.reason)
    # a runtime one: applied, and a bad value refused naming it (the applied value stays)
    name, value, bad = case.runtime
    assert name not in read_only
    before = cell.get_parameters(case, [name])
    try:
        result = cell.set_parameters(case, {name: value})[0]
        assert result.successful, result.reason
        assert cell.get_parameters(case, [name]) == {name: value}
        refused = cell.set_parameters(case, {name: bad})[0]
        assert not refused.successful and f"parameter {name}" in refused.reason, refused.reason
        assert cell.get_parameters(case, [name]) == {name: value}
    finally:
        assert cell.set_parameters(case, before)[0].successful
    assert cell.status(case).ready


# --- names ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("case", DEVICES, ids=IDS)
def test_a_device_started_under_a_namespace_keeps_every_private_name_under_it(
    healthy: Cell, case: DeviceCase
) -> None:
    client, node, prefix = healthy.client, case.executable, f"{case.name}/"
    by_node = {
        "publishes": client.get_publisher_names_and_types_by_node(node, NAMESPACE),
        "subscribes": client.get_subscriber_names_and_types_by_node(node, NAMESPACE),
        "serves": client.get_service_names_and_types_by_node(node, NAMESPACE),
    }
    for what, names in by_node.items():
        stray = {n for n, _ in names if not n.startswith(prefix)} - ABSOLUTE
        assert stray == set(), f"{case.name} {what} {stray}"
    published = {n for n, _ in by_node["publishes"]}
    served = {n for n, _ in by_node["serves"]}
    assert {f"{prefix}status", f"{prefix}transition_event", "/diagnostics"} <= published
    for _, service in KIT_SERVICES:
        assert f"{prefix}{service}" in served
    assert {f"{prefix}{s.name}" for s in case.services} | {f"{prefix}change_state"} <= served
    assert f"{prefix}{case.action.name}/_action/send_goal" in served
    assert f"{prefix}{case.action.name}/_action/status" in published
    # nothing of the device is left at the root
    graph = {n for n, _ in client.get_topic_names_and_types()} | {
        n for n, _ in client.get_service_names_and_types()
    }
    assert not {n for n in graph if n.startswith(f"/{node}/")}
    assert healthy.status(case).header.frame_id.strip("/") == case.name.strip("/")  # the kit's frame


# --- hostile requests -----------------------------------------------------------------------------------
@pytest.mark.parametrize("case", DEVICES, ids=IDS)
def test_hostile_requests_and_goals_are_refused_naming_the_field_and_the_device_serves_on(
    healthy: Cell, case: DeviceCase
) -> None:
    cell = healthy
    # Rejected at goal time: nothing starts or is counted; the reason goes to /rosout and /diagnostics.
    action = case.action
    before = counters(cell.status(case, lambda s: s.ready))[action.counter]
    diagnostics_mark = cell.diagnostics.count()
    for bad in action.hostile:
        mark = cell.rosout.count()
        assert not cell.send_goal(case, bad.request, resend=True).accepted, bad.named
        cell.logged(case, mark, f"goal rejected: ~/{action.name}: ", *bad.named)
    assert not cell.status(case).busy  # nothing started
    last = action.hostile[-1].named
    entry = cell.diagnostic(
        case, diagnostics_mark, lambda d: all(t in values(d)["last_goal_rejection"] for t in last)
    )
    assert values(entry)["last_goal_rejection"].startswith(f"~/{action.name}: ")
    # and it serves on: a good goal is accepted, counted once (the rejected ones were not), and ends
    handle = cell.send_goal(case, action.good)
    assert handle.accepted
    counted = cell.status(case, lambda s: counters(s)[action.counter] != before)
    assert counters(counted)[action.counter] == before + 1
    result = wait_future(handle.get_result_async(), 60.0, f"the result of {action.name}")
    assert result.result.outcome_name == action.outcome, result.result
    # every service: hostile requests refused naming the field, then a good one served
    for service in case.services:
        for bad in service.hostile:
            start = time.monotonic()
            response = cell.call(case, service.srv, service.name, bad.request)
            waited = time.monotonic() - start
            assert not response.ok, (service.name, bad.named)
            assert all(text in response.error for text in bad.named), (service.name, response.error[:300])
            assert "internal error" not in response.error and len(response.error) <= 1000
            assert bad.within is None or waited < bad.within, f"{service.name}: refused after {waited:.2f} s"
        response = cell.call(case, service.srv, service.name, service.good)
        assert response.ok, (service.name, response.error)
        assert {key: getattr(response, key) for key in service.answer} == service.answer, response
    cell.status(case, healthy_status)
    assert cell.processes[case.executable].alive()


# --- the kit's guard ------------------------------------------------------------------------------------
class RaisingGoal:
    """A goal whose machine raises at its first tick: the bug the kit's guard turns into an ABORTED goal."""

    def __init__(self) -> None:
        self.halted = False
        self.advanced = 0

    @property
    def done(self) -> bool:
        return False

    def advance(self, now_ns: int) -> None:
        self.advanced += 1
        raise ZeroDivisionError("a bug inside the goal's machine")

    def cancel(self, reason: str) -> None:
        """Nothing to cancel."""

    def interrupt(self, reason: str) -> None:
        """Nothing to interrupt."""

    def feedback(self) -> list[Any]:
        return []

    def result(self) -> tuple[str, Any]:
        # As the devices' adapters do: a result exists only once the goal has ended.
        raise AssertionError("the runner asked for the result of a goal that has not ended")

    def halt(self) -> None:
        self.halted = True


@dataclass
class Guarded:
    """One device running in this process, with two goals of its own action served beside its own."""

    node: Any
    advancing: list[RaisingGoal] = field(default_factory=list)  # machines that raise when advanced
    starts: int = 0  # starts that raised


@pytest.fixture
def in_process(
    caller: Any, tmp_path: Path, request: pytest.FixtureRequest
) -> Iterator[tuple[Guarded, ros_harness.Listener]]:
    """The device's own node class, configured and active in this process (the default rclpy context).

    Besides its own action it serves ``~/raising_goal`` (a machine that raises when advanced) and
    ``~/raising_start`` (a start that raises), through the kit's one goal runner, ``serve_goal``. Returns
    the device and the listener of its status.
    """
    import rclpy
    import yaml
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.lifecycle import TransitionCallbackReturn
    from rclpy.signals import SignalHandlerOptions

    from feeder_device.goals import serve_goal

    case = request.node.callspec.params["case"]
    name = f"{GUARD_NAMESPACE}/{case.executable}"
    assert not rclpy.ok(), "the default rclpy context is in use in this process"
    for server in ("raising_goal", "raising_start", case.action.name):  # the clients first (see Cell)
        caller.prepare_action(case.action.action, f"{name}/{server}")
    status = ros_harness.Listener(caller.node, DeviceStatus, f"{name}/status", history_qos())
    path = tmp_path / "params.yaml"
    path.write_text(yaml.safe_dump({name: {"ros__parameters": dict(case.parameters)}}))
    args = ["--ros-args", "-r", f"__ns:={GUARD_NAMESPACE}", "--params-file", str(path)]
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    executor = SingleThreadedExecutor()
    spinner = threading.Thread(target=executor.spin, daemon=True)
    guarded = None
    try:
        guarded = Guarded(case.device_class()())

        def start_raising(handle: Any) -> Any:
            guarded.starts += 1
            raise KeyError("a bug in the goal's start")

        def start_advancing(handle: Any) -> Any:
            guarded.advancing.append(RaisingGoal())
            return guarded.advancing[-1]

        serve_goal(guarded.node, case.action.action, "~/raising_goal", lambda goal: None, start_advancing)
        serve_goal(guarded.node, case.action.action, "~/raising_start", lambda goal: None, start_raising)
        assert guarded.node.trigger_configure() == TransitionCallbackReturn.SUCCESS
        assert guarded.node.trigger_activate() == TransitionCallbackReturn.SUCCESS
        executor.add_node(guarded.node)
        spinner.start()
        yield guarded, status
    finally:
        executor.shutdown(timeout_sec=10.0)
        if spinner.is_alive():
            spinner.join(timeout=10.0)  # the tick under way ends before the node goes
        if guarded is not None:
            guarded.node.destroy_node()
        rclpy.try_shutdown()


@pytest.mark.parametrize("case", DEVICES, ids=IDS)
def test_a_goal_whose_machine_raises_ends_aborted_and_the_device_serves_on(
    case: DeviceCase, in_process: tuple[Guarded, ros_harness.Listener], caller: Any
) -> None:
    guarded, status = in_process
    name = f"{GUARD_NAMESPACE}/{case.executable}"
    action = case.action.action
    status.wait(lambda s: s.state_name in READY, current=True)
    for server, error in (("raising_goal", "ZeroDivisionError"), ("raising_start", "KeyError")):
        for _ in range(2):  # the first ends the goal; the second shows the server takes goals again
            handle = caller.send_goal(action, f"{name}/{server}", action.Goal())
            assert handle.accepted, server
            result = wait_future(handle.get_result_async(), 60.0, f"the result of {server}")
            assert result.status == GoalStatus.STATUS_ABORTED, (server, result)
            assert result.result.outcome == action.Result.FAULT and result.result.outcome_name == "FAULT"
            message = result.result.message
            assert message.startswith(f"internal error in ~/{server}: {error}: "), message
    assert guarded.starts == 2 and len(guarded.advancing) == 2
    assert all(goal.advanced == 1 and goal.halted for goal in guarded.advancing)  # the guard left it safe
    assert guarded.node.goals == [] and guarded.node.active
    assert status.wait(lambda s: s.state_name in READY, current=True).ready
    # the device's own action serves on
    handle = caller.send_goal(action, f"{name}/{case.action.name}", case.action.good)
    assert handle.accepted
    result = wait_future(handle.get_result_async(), 60.0, f"the result of {case.action.name}")
    assert result.result.outcome_name == case.action.outcome, result.result


# --- shutdown (last: it ends the device's useful life) ---------------------------------------------------
@pytest.mark.parametrize("case", DEVICES, ids=IDS)
def test_shutdown_releases_everything_and_the_node_is_then_ended_by_pid(
    healthy: Cell, case: DeviceCase
) -> None:
    cell = healthy
    statuses, events = cell.statuses[case.name], cell.transitions[case.name]
    process = cell.processes[case.executable]
    lifecycle = cell.lifecycles[case.name]
    mark, event_mark = statuses.count(), events.count()
    sent = time.time_ns()
    assert lifecycle.change("shutdown") == "finalized"
    answered = time.time_ns()
    final = since(statuses, mark, lambda s: s.state_name == "UNCONFIGURED")
    assert sent <= ros_harness.stamp_ns(final) <= answered, (sent, final.header, answered)
    assert not final.ready and list(final.counter_names) == []
    event = since(events, event_mark, lambda e: e.goal_state.label == "finalized")
    assert event.start_state.label == TRANSITION_STATES["shutdown"], event
    assert lifecycle.get_state() == "finalized" and process.alive()
    response = cell.trigger(case, "stop")
    assert not response.success and "UNCONFIGURED" in response.message
    if process.host:
        # Hosted: its neighbours live on in the host; the host is ended once every one is finalized.
        others = [name for name in cell.lifecycles if name != case.name]
        if any(cell.lifecycles[name].get_state() != "finalized" for name in others):
            return
    process.stop()
    assert_ended_by_pid(process)
