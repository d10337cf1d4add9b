"""Squeeze-grasp orienting (Goldberg 1993; Chen and Ierardi 1995), ROS-free.

The diameter function of a part's hull, the squeeze function and its symmetry, Goldberg's shortest plan
with its completeness certificate, an exhaustive check of the plan length, and the jaw-width sensor.
Angles are radians, lengths metres; the part's orientation is relative to the gripper, whose jaws close
along its x axis.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from feeder_planner.lazy import lazy_exports

if TYPE_CHECKING:  # the package's names; each module is imported on first use (feeder_planner.lazy)
    from feeder_planner.squeeze.diameter import (
        DiameterFunction,
        Extremum,
        Piece,
        convex_hull,
        diameter_function,
    )
    from feeder_planner.squeeze.friction import check_friction, frictional_squeeze, jams
    from feeder_planner.squeeze.plan import (
        Interval,
        Plan,
        PlanCertificate,
        apply_plan,
        check_certificate,
        check_plan_angles,
        plan_squeezes,
        shortest_plan_length,
    )
    from feeder_planner.squeeze.sensor import (
        JawReading,
        distinguishable_groups,
        orientations_for_width,
        read_width,
    )
    from feeder_planner.squeeze.squeeze_function import (
        SqueezeFunction,
        check_angle,
        hull_symmetry_order,
        squeeze_function,
    )

__getattr__, __dir__ = lazy_exports(__name__, __file__)

__all__ = [
    "DiameterFunction",
    "Extremum",
    "Interval",
    "JawReading",
    "Piece",
    "Plan",
    "PlanCertificate",
    "SqueezeFunction",
    "apply_plan",
    "check_angle",
    "check_certificate",
    "check_friction",
    "check_plan_angles",
    "convex_hull",
    "diameter_function",
    "distinguishable_groups",
    "frictional_squeeze",
    "hull_symmetry_order",
    "jams",
    "orientations_for_width",
    "plan_squeezes",
    "read_width",
    "shortest_plan_length",
    "squeeze_function",
]
