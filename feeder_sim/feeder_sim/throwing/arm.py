"""A throwing arm holding one part: throw-catch cycles at a chosen fidelity, with faults reported, never hidden."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from feeder_planner.errors import FeederError, InputError
from feeder_planner.throwing.flight import flight_state
from feeder_planner.throwing.geometry import ArmPart
from feeder_planner.throwing.sensor import reads, reads_pose
from feeder_planner.throwing.throw_map import ThrowParams, check_start, throw

FIDELITIES = ("analytic", "dynamic")


@dataclass
class ThrowOutcome:
    """One throw: before/after states, jog or flip, and the part's path (poses in the arm frame)."""

    edge_before: int
    radius_before: float
    edge_after: int
    radius_after: float
    kind: str  # jog | flip | fault
    turns: int
    rotation: float
    fault: str = ""
    path: list[tuple[float, float, float, float]] = field(default_factory=list)  # (t, x, y, theta)


class ThrowingArm:
    """State (edge, R) of the part on the arm and the throw-catch cycle."""

    def __init__(
        self,
        part: ArmPart,
        params: ThrowParams,
        edge: int,
        radius: float,
        fidelity: str = "analytic",
        arm_length: float = math.inf,
        dynamic_step: float = 1e-4,
    ) -> None:
        if fidelity not in FIDELITIES:
            raise InputError("fidelity", f"must be one of {', '.join(FIDELITIES)}, got {fidelity!r}")
        if not (arm_length > 0):
            raise InputError("arm_length", f"must be > 0, got {arm_length!r}")
        self.part, self.params, self.fidelity = part, params, fidelity
        self.arm_length, self.dynamic_step = arm_length, dynamic_step
        self.place(edge, radius)
        self.faulted = ""

    def place(self, edge: int, radius: float) -> None:
        """Put the part at rest; refuses states outside the throw map's domain (naming the field)."""
        check_start(self.part, edge, radius, self.params)
        self.edge, self.radius = int(edge), float(radius)
        self.faulted = ""

    def rest_pose(self) -> tuple[float, float, float]:
        """(x, y, theta) of the centre of mass at rest."""
        return (
            self.radius,
            self.params.offset + float(self.part.d[self.edge]),
            -float(self.part.edge_angle[self.edge]),
        )

    def throw(self) -> ThrowOutcome:
        """One throw and catch; outside the dynamic grasp, or off the arm, it is a fault and the part stays put."""
        e0, r0 = self.edge, self.radius
        if self.faulted:
            return ThrowOutcome(e0, r0, -1, math.nan, "fault", 0, 0.0, f"arm faulted earlier: {self.faulted}")
        try:
            check_start(self.part, e0, r0, self.params)
        except InputError as error:
            self.faulted = f"throw outside the dynamic grasp: {error.problem}"
            return ThrowOutcome(e0, r0, -1, math.nan, "fault", 0, 0.0, self.faulted)
        try:
            if self.fidelity == "analytic":
                res = throw(self.part, e0, r0, self.params)
                out = ThrowOutcome(e0, r0, res.edge, res.radius, res.kind, res.turns, res.rotation)
                out.path = self._flight_path(e0, r0, res.flight_time)
            else:
                from feeder_sim.throwing.dynamic import dynamic_throw

                out = dynamic_throw(self.part, self.params, e0, r0, step=self.dynamic_step)
        except FeederError as error:
            self.faulted = f"simulation failed: {error}"
            return ThrowOutcome(e0, r0, -1, math.nan, "fault", 0, 0.0, self.faulted)
        if out.kind != "fault":
            lo_x = min(out.radius_after + float(u) for u in self.part.frame_vertices(out.edge_after)[:, 0])
            hi_x = max(out.radius_after + float(u) for u in self.part.frame_vertices(out.edge_after)[:, 0])
            if not self.part.stable[out.edge_after]:
                out.kind, out.fault = "fault", f"part came to rest on unstable edge {out.edge_after}"
            elif lo_x < 0 or hi_x > self.arm_length:
                out.kind, out.fault = (
                    "fault",
                    (
                        f"part left the arm: it spans x in [{lo_x:.4g}, {hi_x:.4g}] m, "
                        f"the arm [0, {self.arm_length:.4g}] m"
                    ),
                )
            else:
                try:
                    check_start(self.part, out.edge_after, out.radius_after, self.params)
                except InputError as error:
                    out.kind, out.fault = (
                        "fault",
                        f"the next throw would leave the dynamic grasp: {error.problem}",
                    )
        if out.kind == "fault":
            self.faulted = out.fault
            if out.edge_after >= 0 and self.part.stable[out.edge_after]:
                self.edge, self.radius = out.edge_after, out.radius_after
        else:
            self.edge, self.radius = out.edge_after, out.radius_after
        return out

    def _flight_path(
        self, edge: int, radius: float, flight_time: float, samples: int = 20
    ) -> list[tuple[float, float, float, float]]:
        t = np.linspace(0.0, flight_time, samples)
        s = flight_state(
            self.part, edge, radius, self.params.offset, self.params.speed, self.params.gravity, t
        )
        return [(float(tt), float(row[0]), float(row[1]), float(row[2])) for tt, row in zip(t, s)]

    def sensor(
        self, sensor_radius: float, height: float, pose: tuple[float, float, float] | None = None
    ) -> bool:
        """The one-bit proximity sensor: at rest, or for a pose in flight."""
        if pose is None:
            return reads(self.part, self.edge, self.radius, sensor_radius, height)
        return reads_pose(self.part, *pose, self.params.offset, sensor_radius, height)
