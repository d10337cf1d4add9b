"""The PackML commands and service methods of the gateway, ROS-free: the state table and argument checks."""

from __future__ import annotations

from pathlib import Path

import pytest

from feeder_cell.gateway import layout
from feeder_cell.gateway.arguments import Argument, ArgumentError
from feeder_cell.gateway.commands import COMMANDS, LIFECYCLE, TRIGGERS, Plan, plan
from feeder_cell.gateway.config import PACKML_STATES
from feeder_cell.gateway.spec import CallContext
from feeder_msgs.msg import DeviceStatus as S

ROOT = Path(__file__).resolve().parents[2]
STATES = (S.UNCONFIGURED, S.IDLE, S.RUNNING, S.PAUSED, S.FAULT, S.STOPPED)


def test_every_plan_shows_a_packml_state_and_makes_known_device_calls() -> None:
    names = {name for _, name, _ in PACKML_STATES}
    for command in COMMANDS.values():
        for row in command.plans.values():
            assert row.transient in names | {""}
            assert row.calls and all(c in TRIGGERS or c in LIFECYCLE for c in row.calls)


def test_the_standards_way_out_of_aborted_clear_then_reset() -> None:
    refusal = plan(COMMANDS["Reset"], S.FAULT)
    assert isinstance(refusal, str) and "Aborted" in refusal and "Clear it first" in refusal
    assert plan(COMMANDS["Clear"], S.FAULT) == Plan("Clearing", ("clear",))
    assert plan(COMMANDS["Reset"], S.STOPPED) == Plan("Resetting", ("reset",))
    for state in STATES:
        if state != S.FAULT:  # Clear applies in Aborted only
            assert isinstance(plan(COMMANDS["Clear"], state), str)


def test_the_lifecycle_up_and_down() -> None:
    assert plan(COMMANDS["Reset"], S.UNCONFIGURED) == Plan("Resetting", ("configure", "activate"))
    assert plan(COMMANDS["Unconfigure"], S.IDLE) == Plan("", ("deactivate", "cleanup"))
    assert plan(COMMANDS["Unsuspend"], S.PAUSED) == Plan("Unsuspending", ("activate",))
    running = plan(COMMANDS["Unconfigure"], S.RUNNING)
    assert isinstance(running, str) and "Stop it first" in running


def _check(kind: str, method: str, *args: Argument) -> object:
    link = layout.service(kind, method)
    assert link is not None
    return link.check(link.method, list(args), CallContext(str(ROOT / "examples/mems")))


def test_service_methods_check_their_arguments_naming_them() -> None:
    with pytest.raises(ArgumentError, match="Radius") as error:
        _check("throwing_arm", "PlacePart", Argument(2, "Int32"), Argument(0.0, "Double"))
    assert error.value.status == "BadInvalidArgument" and error.value.index == 1
    with pytest.raises(ArgumentError, match="Edge") as error:
        _check("throwing_arm", "PlacePart", Argument(2, "UInt32"), Argument(0.1, "Double"))
    assert error.value.status == "BadTypeMismatch"
    with pytest.raises(ArgumentError, match="State"):
        _check(
            "assembly_fixture",
            "InjectFault",
            Argument("x", "String"),
            Argument(0.0, "Double"),
            Argument(1, "Int32"),
        )
    with pytest.raises(ArgumentError, match="no program 'nope'"):
        _check("mems_field_array", "LoadProgram", Argument("nope", "String"))
    request = _check("mems_field_array", "LoadProgram", Argument("orient_combined", "String")).message()  # type: ignore[attr-defined]
    assert request.program.name == "orient_combined" and request.program.steps[0].type == "combined"
    request = _check("throwing_arm", "ClearFault", Argument(" ", "String")).message()  # type: ignore[attr-defined]
    assert request.clear and request.fault == ""
