"""Parts and parameters the throwing tests share (the paper's section V values)."""

from __future__ import annotations

import math
from pathlib import Path

from feeder_planner.parts import load_part, make_part
from feeder_planner.throwing.geometry import ArmPart, arm_part
from feeder_planner.throwing.throw_map import ThrowParams

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "throwing"
TRIANGLE_PARAMS = ThrowParams(offset=-0.005, speed=math.radians(320), gravity=-9.66, mu=0.5)
BRACKET_PARAMS = ThrowParams(offset=-0.0025, speed=math.radians(320), gravity=-2.20, mu=0.5)


def triangle() -> ArmPart:
    return arm_part(load_part(EXAMPLES / "triangle.yaml"))


def bracket() -> ArmPart:
    return arm_part(load_part(EXAMPLES / "bracket.yaml"))


def regular(n: int, radius: float = 0.02) -> ArmPart:
    return arm_part(
        make_part(
            [
                [radius * math.cos(2 * math.pi * k / n), radius * math.sin(2 * math.pi * k / n)]
                for k in range(n)
            ]
        )
    )


def rectangle(width: float, height: float) -> ArmPart:
    return arm_part(make_part([[0, 0], [width, 0], [width, height], [0, height]]))
