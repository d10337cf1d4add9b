"""The MEMS array's station: what one tick does to the scene and what a program goal starts, free of ROS.

One definition of the array's behaviour per tick, run by both drivers (docs/devices.md, "The station"):
the mems_field_array node (an adapter: the device kit owns the loop, the node publishes and counts what the
station reports) and the ROS-free cell loop (``feeder_cell.experiment``).

One tick advances the scene by whole ``time_step`` steps of the elapsed node-clock time (the remainder is
owed to the next tick), at most ``max_steps_per_tick``: the rest is dropped and reported, never simulated
late (docs/mems.md, "Time"). Each step is the field's motion of the parts (Böhringer, Donald and
MacDonald's squeeze and radial fields; ``Scene.step``). A ``~/run_program`` goal installs its program
and follows it until every part settled (``ProgramGoal``), decided after each tick.
"""

from __future__ import annotations

from typing import NamedTuple

from feeder_device.declarations import ActiveFault
from feeder_planner.mems import ProgramStep
from feeder_sim.mems.configure import configure_scene
from feeder_sim.mems.parameters import NANOSECONDS, MemsParameters, max_steps_per_tick
from feeder_sim.mems.placing import place_parts, placement_reach
from feeder_sim.mems.program_goal import ProgramGoal
from feeder_sim.mems.settling import SettlingCriterion, holding_start

__all__ = ["MemsTick", "MemsStation"]


class MemsTick(NamedTuple):
    """What one tick did: the whole steps simulated and those dropped by the cap."""

    steps: int
    dropped: int


class MemsStation:
    """The array's scene and parts, with the tick, the program goal's start, stop, reset and faults.

    Parameters
    ----------
    p
        The device's parameters (a driver that changes one at runtime sets ``p`` again).
    """

    def __init__(self, p: MemsParameters) -> None:
        self.p = p
        configured = configure_scene(p)
        self.scene, self.parts = configured.scene, configured.parts()
        self.step_ns = int(round(p.time_step * NANOSECONDS))
        self.owed_ns = 0  # node-clock time not yet simulated: less than one step

    # --- one tick ----------------------------------------------------------------------------------
    def tick(self, elapsed_ns: int) -> MemsTick:
        """Advance the scene by the whole steps of ``elapsed_ns`` and what was owed, at most the cap."""
        self.owed_ns += elapsed_ns
        steps, self.owed_ns = divmod(self.owed_ns, self.step_ns)
        cap = max_steps_per_tick(self.p, self.step_ns)
        dropped = max(0, steps - cap)
        steps -= dropped
        scene, dt = self.scene, float(self.p.time_step)
        for _ in range(steps):
            scene.step(dt)
        return MemsTick(steps, dropped)

    def moving(self) -> bool:
        """Whether the cells push: a program before its last step, or a part not at rest (on and powered)."""
        scene = self.scene
        if not scene.switched_on or scene.faults.power_loss:
            return False
        return not scene.on_last_step() or not all(scene.settled())

    def stiffness(self) -> str:
        """Return why the present program or drag has had stiff ideal steps ('' when none)."""
        return self.scene.stiffness_warning(float(self.p.time_step))

    # --- the program goal --------------------------------------------------------------------------
    def install(self, program: tuple[ProgramStep, ...]) -> None:
        """Start ``program`` now, from its first step."""
        self.scene.set_program(program)

    def start_program(
        self,
        program: tuple[ProgramStep, ...],
        criterion: SettlingCriterion,
        timeout: float,
        start_ns: int,
    ) -> ProgramGoal:
        """Install a checked goal's program at ``start_ns`` and return the goal that follows it."""
        self.install(program)
        return ProgramGoal(self.scene, self.parts.names, criterion, timeout, start_ns, holding_start(program))

    @staticmethod
    def advance_goal(
        goal: ProgramGoal,
        now_ns: int,
        fault: tuple[int, str] | None,
        stopped: bool,
        warning: tuple[int, str] | None,
    ) -> None:
        """Close the tick for the goal: settled, faulted, timed out, or go on (``ProgramGoal.advance``)."""
        goal.advance(now_ns, fault, stopped, warning)

    def place(self, names: list[str], x: list[float], y: list[float], theta: list[float]) -> None:
        """Put named parts at poses at rest (within the array's reach: InputError names the field)."""
        place_parts(self.scene, self.parts.names, (names, x, y, theta), self.reach())

    def reach(self) -> float:
        """Return how far from the array's centre a part may be placed or spawned (m)."""
        return placement_reach(self.p.array_size, float(self.p.pitch))

    # --- stop, reset, faults -----------------------------------------------------------------------
    def stop(self) -> None:
        """Switch every cell off: parts come to rest where they are."""
        self.scene.switched_on = False

    def reset(self) -> None:
        """Switch the cells back on and restart the present program from its first step."""
        self.scene.switched_on = True
        self.scene.set_program(self.scene.program)

    def apply_fault(self, fault: ActiveFault) -> None:
        """Put an injected fault into the force model (validated there: InputError naming the field)."""
        self.scene.inject_fault(
            fault.spec.name,
            value=fault.value,
            indices=fault.indices,
            angle=fault.angle,
            seed=fault.seed,
            cells=self.p.array_size,
        )

    def clear_fault(self, name: str) -> None:
        """Take an injected fault out of the force model."""
        self.scene.set_faults(self.scene.faults.without(name))
