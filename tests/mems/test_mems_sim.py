"""Fidelity models: exact cell coverage, array -> ideal as the pitch shrinks, settling at equilibria."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
from shapes import bracket, washer

from feeder_planner.mems import final_equilibrium
from feeder_planner.mems.equilibria import find_equilibria
from feeder_planner.mems.fields import CombinedField, ProgramStep
from feeder_planner.mems.regions import clip_half_plane, moments
from feeder_planner.parts import load_part
from feeder_sim.mems.coverage import Grid
from feeder_sim.mems.models import ArrayForces
from feeder_sim.mems.scene import Body, Scene, random_poses
from feeder_sim.mems.tolerances import STIFF_STEP_RATIO


def test_cell_coverage_is_exact() -> None:
    part = washer()
    loops = part.placed(0.3, -0.4, 0.7)
    grid = Grid(20, 20, 0.5)
    si, sj, cells = grid.cell_moments(loops)
    assert abs(cells[0].sum() / part.area - 1) <= 1e-13
    assert abs(cells[1].sum() - 0.3 * part.area) <= 1e-12 and abs(cells[2].sum() + 0.4 * part.area) <= 1e-12
    # every partly covered cell against clipping the loops by the cell's four half-planes
    for i in range(cells.shape[1]):
        for j in range(cells.shape[2]):
            x0, y0 = grid.x_nodes[si.start + i], grid.y_nodes[sj.start + j]
            clipped = list(loops)
            for normal, offset in (
                ((1, 0), x0),
                ((-1, 0), -(x0 + 0.5)),
                ((0, 1), y0),
                ((0, -1), -(y0 + 0.5)),
            ):
                clipped = [clip_half_plane(loop, np.array(normal, float), offset) for loop in clipped]
            assert np.allclose(moments(tuple(clipped))[:3], cells[:, i, j], atol=1e-13)


def test_array_force_converges_to_ideal_as_pitch_shrinks() -> None:
    part = bracket(scale=1e-3)
    field = CombinedField(0.3)
    pose = (2e-4, -1e-4, 0.4)
    exact = field.wrench(part.placed(*pose), np.array(pose[:2]))
    errors = []
    for pitch in (4e-4, 1e-4, 2.5e-5):
        n = int(round(0.02 / pitch))
        model = ArrayForces(n, n, pitch)
        errors.append(
            np.linalg.norm(model.wrench(field, part.placed(*pose), np.array(pose[:2]))[:2] - exact[:2])
        )
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] <= 0.02 * np.linalg.norm(exact[:2])


def test_edge_integral_wrench_equals_cell_by_cell_sum() -> None:
    """The fast path (prefix sums along the edges) against the sum over every covered cell of its exact
    area and first moments (checked against clipping above), random poses, parts partly off the grid."""
    rng = np.random.default_rng(5)
    worst = 0.0
    for part in (bracket(scale=1e-3), washer()):
        size = 2 * part.radius
        for n, pitch, directions in ((100, 1e-4 * size / 4e-3, 0), (30, 0.21 * size, 8), (7, 0.5 * size, 0)):
            model = ArrayForces(n, n, pitch, directions=directions)
            half = 0.5 * n * pitch
            field = CombinedField(0.3, (0.2 * half, -0.1 * half))
            for _ in range(25):
                pose = (
                    rng.uniform(-1.3, 1.3) * half,
                    rng.uniform(-1.3, 1.3) * half,
                    rng.uniform(0, 2 * math.pi),
                )
                loops = part.placed(*pose)
                about = np.array(pose[:2]) + rng.normal(size=2) * part.radius
                fast = model.wrench(field, loops, about)
                slow = model.wrench_by_cells(field, loops, about)
                # scale: the largest cell force times the part's area (times its reach for the torque)
                reach = part.radius + np.linalg.norm(about - np.array(pose[:2]))
                scale = 1.3 * part.area * np.array([1.0, 1.0, reach])
                worst = max(worst, float((np.abs(fast - slow) / scale).max()))
    assert worst <= 1e-12


def test_quantised_directions() -> None:
    model = ArrayForces(10, 10, 1.0, directions=4)
    forces = model.cell_forces(CombinedField(0.2))
    angles = np.arctan2(forces[..., 1], forces[..., 0])
    assert np.allclose(np.mod(angles + 1e-12, math.pi / 2), 0, atol=1e-9)


def settle(fidelity: str, start: tuple[float, float, float], **kw) -> np.ndarray:
    part = bracket(scale=1e-3)
    scene = Scene(
        [Body(part, np.array(start, float))], (ProgramStep(CombinedField(0.3), math.inf),), fidelity, **kw
    )
    scene.run(1.5, 5e-4)
    return scene.bodies[0].pose


def test_ideal_and_array_settle_at_a_planned_stable_equilibrium() -> None:
    part = bracket(scale=1e-3)
    stable = find_equilibria(part, 0.3, "numeric").stable
    rng = np.random.default_rng(11)
    for fidelity in ("ideal", "array"):
        start = (rng.uniform(-1e-3, 1e-3), rng.uniform(-1e-3, 1e-3), rng.uniform(0, 2 * math.pi))
        pose = settle(fidelity, start, array=(50, 50, 2e-4))
        gaps = [
            abs(math.remainder(pose[2] - e.theta, 2 * math.pi))
            + math.hypot(pose[0] - e.x, pose[1] - e.y) / 1e-3
            for e in stable
        ]
        assert min(gaps) <= (1e-4 if fidelity == "ideal" else 5e-2)


def test_dynamic_single_part_does_not_import_pymunk() -> None:
    code = (
        "import sys, math, numpy as np\n"
        "sys.path[:0] = ['feeder_planner', 'feeder_sim', 'tests/mems']\n"
        "from shapes import bracket\n"
        "from feeder_planner.mems.fields import CombinedField, ProgramStep\n"
        "from feeder_sim.mems.scene import Body, Scene\n"
        "s = Scene([Body(bracket(1e-3), np.zeros(3))], (ProgramStep(CombinedField(0.3), math.inf),),"
        " 'dynamic', damping=1e3)\n"
        "s.run(0.01, 1e-4)\n"
        "print('pymunk' in sys.modules, np.all(np.isfinite(s.bodies[0].pose)))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=60)
    assert out.stdout.split() == ["False", "True"]


def test_dynamic_parts_collide_instead_of_overlapping() -> None:
    part = bracket(scale=1e-3)
    bodies = [Body(part, np.array([-3e-3, 0.0, 0.0])), Body(part, np.array([3e-3, 0.0, 0.0]))]
    scene = Scene(bodies, (ProgramStep(CombinedField(0.0), math.inf),), "dynamic", damping=300.0)
    scene.run(0.2, 1e-4)
    # radial field pulls both to the origin; collisions keep their centroids apart
    distance = math.hypot(*(bodies[0].pose[:2] - bodies[1].pose[:2]))
    assert distance >= 0.5e-3


def test_the_ideal_model_cuts_a_step_beyond_its_margin_and_still_reaches_the_equilibrium() -> None:
    """Heun at lambda dt = 2 froze a part where k2 = -k1, at rest off its equilibrium (fixed steps of 5.5e-3 s
    left the plus 0.75 rad off). The adaptive model cuts such a step (stepping.py), counts it stiff and warns,
    and the part reaches its equilibrium; the cell scene's 2.5e-3 s is inside the margin and never cut.
    """
    part = load_part(Path(__file__).resolve().parents[2] / "examples" / "mems" / "plus.yaml")
    start = random_poses(1, 1e-3, 7)[0]  # the cell scene's part (seed 7)
    field = CombinedField(0.2)
    reached = final_equilibrium(find_equilibria(part, 0.2), start[2])

    def run(dt: float) -> Scene:
        scene = Scene([Body(part, start.copy())], (ProgramStep(field, math.inf),), "ideal", damping=1.0)
        scene.step(dt)  # a placed part has no velocity yet: it reads as settled before its first step
        while scene.time < 25.0 and not scene.settled()[0]:
            scene.step(dt)
        assert scene.settled()[0], f"not at rest after 25 s at dt {dt}"
        return scene

    def off(scene: Scene) -> float:
        return abs(math.remainder(scene.bodies[0].pose[2] - reached.theta, 2 * math.pi))

    fine = run(2.5e-3)
    assert fine.stiff_steps == 0 and 0.5 < fine.peak_step_ratio < STIFF_STEP_RATIO
    assert fine.stiffness_warning(2.5e-3) == ""
    assert off(fine) < 1e-4
    # The step that keeps the margin (ratio 1.8 of the limit's 2): about 4.6e-3 s.
    assert 3e-3 < fine.stable_step_estimate(2.5e-3) < 5e-3
    frozen = run(5.5e-3)
    assert off(frozen) < 1e-4  # formerly 0.75 rad off: the cut steps reach the equilibrium
    assert frozen.stiff_steps > 0 and frozen.stiff_since_mark == frozen.stiff_steps
    assert frozen.peak_step_ratio > STIFF_STEP_RATIO
    assert frozen.stable_step_estimate(5.5e-3) < 5.5e-3
    warning = frozen.stiffness_warning(5.5e-3)
    assert "time_step 0.0055 s" in warning and f"{frozen.stable_step_estimate(5.5e-3):.2g} s" in warning
    stiff = frozen.stiff_steps
    frozen.set_damping(4.0)
    assert frozen.stiff_since_mark == 0 and frozen.peak_step_ratio == 0.0 and frozen.stiff_steps == stiff
