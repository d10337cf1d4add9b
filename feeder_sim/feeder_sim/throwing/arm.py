"""A throwing arm holding one part: throw-catch cycles at a chosen fidelity, faults reported, never hidden."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Literal, get_args

import numpy as np

from feeder_planner.errors import FeederError, InputError, SolverError
from feeder_planner.throwing.flight import flight_state, rest_pose
from feeder_planner.throwing.geometry import ArmPart
from feeder_planner.throwing.sensor import reads, reads_pose
from feeder_planner.throwing.throw_map import ThrowParams, ThrowResult, check_start, throw
from feeder_sim.throwing.contact import contact_throw
from feeder_sim.throwing.dynamic import dynamic_throw
from feeder_sim.throwing.outcome import PathPoint, ThrowOutcome
from feeder_sim.throwing.tolerances import DEFAULT_STEP, PATH_SAMPLES

__all__ = [
    "Fidelity",
    "FIDELITIES",
    "FIDELITY_ALIASES",
    "check_fidelity",
    "fidelity_throw",
    "ArmCommandName",
    "ARM_COMMANDS",
    "parse_command",
    "ThrowingArm",
]

# paper: the paper's model (section III); contact: paper plus lift-off and Coulomb impacts (contact.py);
# dynamic: pymunk. "analytic", the paper model's name before the contact fidelity, stays accepted.
Fidelity = Literal["paper", "contact", "dynamic"]
FIDELITIES: tuple[Fidelity, ...] = get_args(Fidelity)
FIDELITY_ALIASES: dict[str, Fidelity] = {"analytic": "paper"}
ArmCommandName = Literal["throw", "start", "stop"]  # the commands of feeder_msgs/ArmCommand
ARM_COMMANDS: tuple[ArmCommandName, ...] = get_args(ArmCommandName)


def check_fidelity(value: object, field: str = "fidelity") -> Fidelity:
    """Return ``value`` as a fidelity (an alias as its name), or raise InputError naming ``field``."""
    for fidelity in FIDELITIES:
        if value == fidelity:
            return fidelity
    if isinstance(value, str) and value in FIDELITY_ALIASES:
        return FIDELITY_ALIASES[value]
    names = ", ".join((*FIDELITIES, *(f"{a} (= {b})" for a, b in FIDELITY_ALIASES.items())))
    raise InputError(field, f"must be one of {names}, got {value!r}")


def fidelity_throw(
    part: ArmPart,
    edge: int,
    radius: float,
    params: ThrowParams,
    fidelity: str,
    dynamic_step: float = DEFAULT_STEP,
) -> ThrowResult:
    """Return one throw at ``fidelity`` as the paper model's result type (`feeder throw`).

    A dynamic throw has no certified flight time or impact count (NaN and -1 here) and makes none of
    the paper's assumptions (its flags are false but ``off_arm``, the part lost); a dynamic throw that
    faults (carry out of the grasp, part lost, rest tilted) raises SolverError with the reason.
    """
    chosen = check_fidelity(fidelity)
    if chosen == "paper":
        return throw(part, edge, radius, params)
    if chosen == "contact":
        return contact_throw(part, edge, radius, params)
    check_start(part, edge, radius, params)
    out = dynamic_throw(part, params, edge, radius, step=dynamic_step, arm_length=params.arm_length)
    if out.kind == "fault":
        raise SolverError(f"dynamic throw: {out.fault}")
    return ThrowResult(
        edge=out.edge_after,
        radius=out.radius_after,
        kind="jog" if out.kind == "jog" else "flip",
        rotation=out.rotation,
        turns=out.turns,
        flight_time=math.nan,
        impacts=-1,
        start_edge=edge,
        start_radius=radius,
        off_arm=out.lost,
        fidelity="dynamic",
    )


def parse_command(text: str, field: str = "command") -> ArmCommandName:
    """Return the arm command named by ``text`` (case and surrounding blanks ignored), or raise InputError."""
    word = text.strip().lower()
    for command in ARM_COMMANDS:
        if word == command:
            return command
    raise InputError(field, f"must be {', '.join(ARM_COMMANDS[:-1])} or {ARM_COMMANDS[-1]}, got {text!r}")


class ThrowingArm:
    """State (edge, R) of the part on the arm and the throw-catch cycle.

    ``faulted`` says why the arm cannot throw until the part is placed again (a throw that faulted, or the
    part lost); ``on_arm`` is False once the part has left the arm (it is then neither seen nor thrown).
    """

    def __init__(
        self,
        part: ArmPart,
        params: ThrowParams,
        edge: int,
        radius: float,
        fidelity: str = "paper",
        arm_length: float = math.inf,
        dynamic_step: float = DEFAULT_STEP,
    ) -> None:
        self.fidelity: Fidelity = check_fidelity(fidelity)
        if not (arm_length > 0):
            raise InputError("arm_length", f"must be > 0, got {arm_length!r}")
        self.part, self.params = part, params
        self.arm_length, self.dynamic_step = arm_length, dynamic_step
        self.place(edge, radius)

    def place(self, edge: int, radius: float) -> None:
        """Put the part at rest; refuses states outside the throw map's domain (naming the field)."""
        check_start(self.part, edge, radius, self.params)
        self.edge, self.radius = int(edge), float(radius)
        self.faulted = ""
        self.on_arm = True

    def replace_part(self, part: ArmPart, edge: int, radius: float) -> None:
        """Hold ``part`` instead, at rest at (edge, R): the grasp, the throws and the sensor follow it.

        Refuses a start outside the new part's throw map domain (naming the field) before anything changes.
        """
        check_start(part, edge, radius, self.params)
        self.part = part
        self.place(edge, radius)

    def ground_truth(self) -> tuple[int, float]:
        """Return (edge, R) of the part at rest, or (-1, NaN) when it is not on the arm (for logging)."""
        return (self.edge, self.radius) if self.on_arm else (-1, math.nan)

    def lose_part(self, reason: str) -> None:
        """Take the part off the arm (it fell off): nothing is sensed or thrown until ``place``."""
        self.on_arm = False
        self.faulted = reason

    def set_release_speed(self, speed: float) -> None:
        """Change W for the next throws (validated as ThrowParams validates it, naming release_speed)."""
        self.params = ThrowParams(self.params.offset, speed, self.params.gravity, self.params.mu)

    def rest_pose(self) -> tuple[float, float, float]:
        """Return (x, y, theta) of the centre of mass at rest."""
        x, y, theta = rest_pose(self.part, self.edge, self.radius, self.params.offset)
        return float(x), float(y), float(theta)

    def throw(self, speed_scale: float = 1.0) -> ThrowOutcome:
        """Throw and catch at W x ``speed_scale``; outside the grasp or off the arm it is a fault.

        After a fault the part stays where it landed (if it came to rest on a stable edge on the arm) and
        every further throw is refused with the reason until ``place``.
        """
        e0, r0 = self.edge, self.radius
        if self.faulted:
            return ThrowOutcome.failure(e0, r0, f"arm faulted earlier: {self.faulted}", lost=not self.on_arm)
        if not (speed_scale > 0 and math.isfinite(speed_scale)):
            raise InputError("speed_scale", f"must be a finite number > 0, got {speed_scale!r}")
        params = (
            self.params if speed_scale == 1.0 else replace(self.params, speed=self.params.speed * speed_scale)
        )
        try:
            check_start(self.part, e0, r0, params)
        except InputError as error:
            self.faulted = f"throw outside the dynamic grasp: {error.problem}"
            return ThrowOutcome.failure(e0, r0, self.faulted)
        try:
            out = self._simulate(e0, r0, params)
        except FeederError as error:
            self.faulted = f"simulation failed: {error}"
            return ThrowOutcome.failure(e0, r0, self.faulted)
        if out.kind != "fault":
            reason, lost = self._landing_fault(out)
            if reason:
                out = out.with_fault(reason, lost)
        if out.kind == "fault":
            self.faulted = out.fault
            if out.lost:
                self.on_arm = False
            if out.edge_after >= 0 and self.part.stable[out.edge_after]:
                self.edge, self.radius = out.edge_after, out.radius_after
        else:
            self.edge, self.radius = out.edge_after, out.radius_after
        return out

    def _simulate(self, edge: int, radius: float, params: ThrowParams) -> ThrowOutcome:
        """Return one throw at the arm's fidelity (paper or contact with the paper's flight path shown)."""
        if self.fidelity == "dynamic":
            return dynamic_throw(self.part, params, edge, radius, step=self.dynamic_step)
        model = contact_throw if self.fidelity == "contact" else throw
        # The arm's end bounds the catch and the rolling too: a contact past it is off_arm (issue 14).
        res = model(self.part, edge, radius, replace(params, arm_length=self.arm_length))
        path = self._flight_path(edge, radius, res.flight_time, params)
        out = ThrowOutcome(
            edge,
            radius,
            res.edge,
            res.radius,
            res.kind,
            res.turns,
            res.rotation,
            "",
            path,
            flags=tuple(res.violations),
        )
        if res.off_arm:
            # The part touched the arm left of the pivot or past its end on the way: it is lost.
            return out.with_fault(
                "part left the arm: a contact lay left of the pivot or past the arm's end", True
            )
        return out

    def _landing_fault(self, out: ThrowOutcome) -> tuple[str, bool]:
        """Return why a landing is a fault (unstable edge, off the arm, next throw out of the grasp) or "".

        The flag says whether the part left the arm.
        """
        if not self.part.stable[out.edge_after]:
            return f"part came to rest on unstable edge {out.edge_after}", False
        xs = [out.radius_after + float(u) for u in self.part.frame_vertices(out.edge_after)[:, 0]]
        lo_x, hi_x = min(xs), max(xs)
        if lo_x < 0 or hi_x > self.arm_length:
            return (
                f"part left the arm: it spans x in [{lo_x:.4g}, {hi_x:.4g}] m, "
                f"the arm [0, {self.arm_length:.4g}] m"
            ), True
        try:
            check_start(self.part, out.edge_after, out.radius_after, self.params)
        except InputError as error:
            return f"the next throw would leave the dynamic grasp: {error.problem}", False
        return "", False

    def _flight_path(
        self, edge: int, radius: float, flight_time: float, params: ThrowParams, samples: int = PATH_SAMPLES
    ) -> tuple[PathPoint, ...]:
        """Return ``samples`` poses (t, x, y, theta) of the analytic flight at ``params``, eq. (5)."""
        t = np.linspace(0.0, flight_time, samples)
        s = flight_state(self.part, edge, radius, params.offset, params.speed, params.gravity, t)
        return tuple(
            (float(tt), float(row[0]), float(row[1]), float(row[2])) for tt, row in zip(t, s, strict=True)
        )

    def sensor(
        self, sensor_radius: float, height: float, pose: tuple[float, float, float] | None = None
    ) -> bool:
        """Return the one-bit proximity sensor's value: at rest, or for a pose in flight (False: no part)."""
        if not self.on_arm:
            return False
        if pose is None:
            return reads(self.part, self.edge, self.radius, sensor_radius, height)
        return reads_pose(self.part, *pose, self.params.offset, sensor_radius, height)
