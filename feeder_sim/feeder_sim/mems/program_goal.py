"""The MEMS field array's run-program goal: follow a field program tick by tick until every part settles.

ROS-free: the mems_field_array node's ``~/run_program`` action drives a ``ProgramGoal`` from its ticks
(through the device kit's goal runner), and a test drives it the same way without ROS. The node has
installed the goal's program when the goal was accepted (as ``~/set_program`` does); the goal then only
watches the scene:

- **Settled** (``feeder_sim.mems.settling``): every part has stayed within the tolerance for the dwell
  while the program holds its final field. Parts at rest after steps beyond the ideal model's stability
  margin are not certified (a too-large step can stop a part off its equilibrium): the goal ends FAULT
  with the time-step warning, never SETTLED.
- **Order of the decision** at each tick: a fault of the device, then ``~/stop``, then cancel, then
  settled, then the timeout (node clock from the program's start, ``declarations.deadline_ns``).
- **Feedback** at most every ``FEEDBACK_PERIOD`` s of node clock: 10 Hz, every other tick at the default
  20 Hz, enough to follow a part without doubling the traffic of ``~/part_states``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from feeder_device.declarations import deadline_ns
from feeder_sim.mems.scene import Scene
from feeder_sim.mems.settling import SettlingCriterion, SettlingDetector

__all__ = ["FEEDBACK_PERIOD", "OUTCOME_CODES", "ProgramOutcome", "ProgramGoal"]

FEEDBACK_PERIOD = 0.1
# The result codes of feeder_msgs/action/RunProgram (the node checks its constants agree).
OUTCOME_CODES = {"SETTLED": 1, "TIMEOUT": 2, "FAULT": 3, "CANCELED": 4}
NANOSECONDS = 1_000_000_000


@dataclass(frozen=True)
class ProgramOutcome:
    """How a goal ended: the outcome's name, why, whether every part settled certified, and the fault."""

    name: str
    message: str
    settled: bool
    fault: tuple[int, str] = (0, "")

    @property
    def code(self) -> int:
        """The RunProgram result code of the outcome."""
        return OUTCOME_CODES[self.name]


class ProgramGoal:
    """One ``~/run_program`` goal watching ``scene``; ``advance`` once per tick, ``outcome`` at the end.

    Parameters
    ----------
    scene, names
        The scene the goal started on and its parts' names (a cleanup may release the node's).
    criterion, timeout
        The checked settling criterion and timeout (s of node clock, > 0).
    start_ns
        Node-clock time the program started (ns); 0 when accepted before the clock started (the first
        tick's time is used).
    judging_from
        Program time (s) from which its final field holds: parts are judged from then on.
    """

    def __init__(
        self,
        scene: Scene,
        names: Sequence[str],
        criterion: SettlingCriterion,
        timeout: float,
        start_ns: int,
        judging_from: float,
    ) -> None:
        self.scene = scene
        self.names = list(names)
        self.timeout = timeout
        self.start_ns = start_ns
        self.judging_from = judging_from
        self.detector = SettlingDetector(len(scene.bodies), criterion)
        self.elapsed = 0.0
        self.flags: list[bool] = [False] * len(scene.bodies)
        self.feedback_due = False
        self.cancel_reason = ""
        self.outcome: ProgramOutcome | None = None
        self._last_feedback = -math.inf

    @property
    def done(self) -> bool:
        """Whether the goal has ended (``outcome`` says how)."""
        return self.outcome is not None

    def cancel(self, reason: str) -> None:
        """Ask the goal to end at its next decision: the program stays on, the parts where they are."""
        self.cancel_reason = reason

    def interrupt(self, state: str) -> None:
        """End now: the device left active (``state``), its physics frozen where it was."""
        self._end(
            "FAULT",
            f"the device was deactivated ({state}) {self.elapsed:.3g} s into the goal; "
            "the physics is frozen where it was",
        )

    def advance(
        self,
        now_ns: int,
        fault: tuple[int, str] | None,
        stopped: bool,
        stiff_warning: tuple[int, str] | None,
    ) -> None:
        """Decide after the tick at ``now_ns``: end (in the module's order) or note feedback due."""
        self.feedback_due = False
        if self.done:
            return
        if fault is not None:
            self._end("FAULT", f"the device faulted: {fault[1]}", fault=fault)
            return
        if stopped:
            self._end(
                "FAULT",
                "the device was stopped by ~/stop (cells off, parts where they are; "
                "~/reset returns it to IDLE)",
            )
            return
        if self.cancel_reason:
            self._end(
                "CANCELED",
                f"canceled {self.elapsed:.3g} s into the goal: the program stays on (its last step holds) "
                "and the parts were left where they are",
            )
            return
        if self.start_ns <= 0:  # accepted before the node clock started: count from its first tick
            self.start_ns = now_ns
        self.elapsed = (now_ns - self.start_ns) / NANOSECONDS
        scene = self.scene
        judging = scene.time - scene.program_start >= self.judging_from
        self.flags = list(
            self.detector.update(self.elapsed, np.array([b.pose for b in scene.bodies]), judging)
        )
        settled = judging and self.detector.all_settled
        if settled and stiff_warning is not None:
            # At rest, but possibly where an unstable step stopped them: not certified.
            self._end(
                "FAULT",
                f"every part stopped moving {self.elapsed:.3g} s into the goal, but {stiff_warning[1]}",
                fault=stiff_warning,
            )
        elif settled:
            self._end("SETTLED", f"every part settled {self.elapsed:.3g} s into the goal", settled=True)
        elif now_ns >= (deadline_ns(self.start_ns, self.timeout) or math.inf):
            moving = [n for n, done in zip(self.names, self.flags, strict=True) if not done]
            why = "" if judging else "; the program had not reached its last step"
            self._end(
                "TIMEOUT",
                f"timeout {self.timeout:g} s passed with {len(moving)} of {len(self.flags)} parts "
                f"not settled ({', '.join(moving)}){why}",
            )
        elif self.elapsed - self._last_feedback >= FEEDBACK_PERIOD - 1e-9:
            self._last_feedback = self.elapsed
            self.feedback_due = True

    def _end(
        self, name: str, message: str, *, settled: bool = False, fault: tuple[int, str] = (0, "")
    ) -> None:
        if self.outcome is None:
            self.outcome = ProgramOutcome(name, message, settled, fault)
