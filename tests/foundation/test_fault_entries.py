"""The ``inject_faults`` parameter's entries, as every device reads them."""

from __future__ import annotations

import pytest

from feeder_device.declarations import FaultEntry, parse_fault_parameter
from feeder_planner.errors import InputError


@pytest.mark.parametrize(
    ("entry", "expected"),
    [
        ("power_loss", FaultEntry("power_loss")),
        ("sensor_stuck=true", FaultEntry("sensor_stuck", 1.0, True, (), 1.0)),
        ("sensor_dropout=0.25", FaultEntry("sensor_dropout", 0.25, True, (), 0.25)),
        ("axis_stall,indices=1,angle=0.3", FaultEntry("axis_stall", 0.0, False, (1,), 0.3)),
        ("stuck_cells,indices=3;7;9,angle=-1.5", FaultEntry("stuck_cells", 0.0, False, (3, 7, 9), -1.5)),
        ("release_speed_error=0.02,state=true", FaultEntry("release_speed_error", 0.02, True, (), 0.02)),
    ],
)
def test_entries_set_the_fields_they_name(entry: str, expected: FaultEntry) -> None:
    assert parse_fault_parameter(entry, 0) == expected


@pytest.mark.parametrize(
    ("entry", "field"),
    [
        ("=0.1", "parameter inject_faults[2]"),
        ("dead_cells=lots", "parameter inject_faults[2]"),
        ("dead_cells,indices=1;x", "parameter inject_faults[2] (indices)"),
        ("dead_cells,colour=red", "parameter inject_faults[2]"),
    ],
)
def test_bad_entries_name_the_entry(entry: str, field: str) -> None:
    with pytest.raises(InputError) as error:
        parse_fault_parameter(entry, 2)
    assert error.value.field == field
