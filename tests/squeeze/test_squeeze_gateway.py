"""The squeeze gripper's gateway profile, without a server: RunPlan and PlacePart arguments checked."""

from __future__ import annotations

import math

import pytest

from feeder_cell.gateway.arguments import ArgumentError
from feeder_cell.gateway.kinds import KINDS
from feeder_cell.gateway.kinds.squeeze_gripper import PROFILE, check_place_part, check_run_plan
from feeder_cell.gateway.spec import Argument
from feeder_sim.squeeze.counters import COUNTERS

RUN = PROFILE.action.method if PROFILE.action is not None else None
PLACE = PROFILE.services[0].method


def angles(*values: float) -> Argument:
    return Argument(list(values), "Double", True)


def test_the_profile_is_registered_with_the_devices_own_counters() -> None:
    assert KINDS["squeeze_gripper"] is PROFILE
    assert PROFILE.counters == COUNTERS
    assert RUN is not None and RUN.name == "RunPlan"


def test_run_plan_goal_carries_the_angles_and_timeout() -> None:
    assert RUN is not None
    goal = check_run_plan(RUN, [angles(0.0, math.pi / 4), Argument(5.0, "Double")])
    message = goal.message()
    assert list(message.angles) == [0.0, math.pi / 4] and message.timeout == 5.0
    assert check_place_part(PLACE, [Argument(0.3, "Double")]).message().orientation == 0.3


@pytest.mark.parametrize(
    ("args", "named"),
    [
        ([Argument(None, "Null"), Argument(0.0, "Double")], "Angles: a plan needs at least one squeeze"),
        ([angles(0.0, math.nan), Argument(0.0, "Double")], "Angles[1]: must be finite"),
        ([angles(*[0.0] * 1001), Argument(0.0, "Double")], "Angles: 1001 squeezes"),
        ([angles(0.0), Argument(-1.0, "Double")], "Timeout: must be >= 0 s"),
    ],
)
def test_bad_run_plan_arguments_are_refused_naming_the_argument(args: list[Argument], named: str) -> None:
    assert RUN is not None
    with pytest.raises(ArgumentError, match=named.replace("[", r"\[").replace("]", r"\]")):
        check_run_plan(RUN, args)
