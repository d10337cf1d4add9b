"""feeder bag-compare's rules, ROS-free: field paths, NaN, heartbeat copies, and bags it cannot read."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from feeder_cell.bag.compare import _differences, _without, compare_bags
from feeder_planner.errors import InputError


def test_the_first_difference_names_its_field_path_and_nan_equals_nan() -> None:
    left = {"header": {"stamp": {"sec": 1}}, "values": [1.0, math.nan, 3.0], "name": "a"}
    assert next(_differences(left, {**left, "values": [1.0, math.nan, 3.0]}, ""), None) is None
    right = {**left, "values": [1.0, math.nan, 3.5]}
    assert next(_differences(left, right, "")) == ("values[2]", 3.0, 3.5)
    assert next(_differences(left, {**left, "values": [1.0]}, "")) == ("values (length)", 3, 1)
    assert next(_differences({"x": 1}, {"x": 1.0}, "")) == ("x", 1, 1.0), "an int is not a float"


def test_a_status_heartbeat_copy_differs_only_in_its_stamp_and_wall_clock_figures() -> None:
    status = {
        "header": {"stamp": {"sec": 5, "nanosec": 0}, "frame_id": "cell/arm"},
        "state": 2,
        "achieved_rate": 99.0,
        "configured_real_time_factor": 0.0,
    }
    copy = {
        **status,
        "header": {**status["header"], "stamp": {"sec": 9, "nanosec": 0}},
        "achieved_rate": 101.0,
    }
    kind = "feeder_msgs/msg/DeviceStatus"
    assert _without(status, kind, True) == _without(copy, kind, True)
    assert _without(status, kind, False) != _without(copy, kind, False), "the stamp counts outside heartbeats"


def test_a_folder_that_is_no_bag_or_holds_a_damaged_file_is_refused_naming_the_bag(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"bag: .* is not a bag directory"):
        compare_bags(tmp_path / "none", tmp_path / "none")
    with pytest.raises(InputError, match=r"bag: .* holds no \.mcap file"):
        compare_bags(tmp_path, tmp_path)
    (tmp_path / "run_0.mcap").write_bytes(b"not an mcap file")
    with pytest.raises(InputError, match=r"bag: .*run_0\.mcap cannot be read \(not a valid MCAP file"):
        compare_bags(tmp_path, tmp_path)
