"""ROS-free: the stated request limits of node_kit.request_limits refuse by name, in bounded time.

The YAML check must refuse a billion-laughs document and deep nesting without expanding them (the test
would hang or run out of memory otherwise), and quote nothing of the text in its message.
"""

from __future__ import annotations

import math
import time

import pytest

from feeder_msgs.msg import Part, Polygon2D
from feeder_planner.errors import InputError
from feeder_planner.node_kit.request_limits import (
    MAX_LOOP_VERTICES,
    MAX_MOVE_SAMPLES,
    MAX_YAML_CHARS,
    MAX_YAML_DEPTH,
    MAX_YAML_NODES,
    bounded_yaml_mapping,
    check_arc_samples,
    check_count,
    check_design,
    check_magnitude,
    check_part_size,
)

BOMB = "a: &a [x, x, x, x, x, x, x, x, x]\n" + "".join(
    f"{c}: &{c} [*{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}]\n"
    for p, c in zip("abcdefgh", "bcdefghi", strict=True)
)


def refused(call, *args) -> InputError:  # type: ignore[no-untyped-def]
    with pytest.raises(InputError) as caught:
        call(*args)
    return caught.value


def test_alias_bomb_refused_without_expanding() -> None:
    start = time.monotonic()
    error = refused(bounded_yaml_mapping, BOMB, "assembly_yaml")
    assert time.monotonic() - start < 2.0
    assert error.field == "assembly_yaml"
    assert str(MAX_YAML_NODES) in error.problem and "x, x" not in str(error)


def test_deep_nesting_and_size_and_bad_text_refused() -> None:
    deep = "a: " + "[" * (MAX_YAML_DEPTH + 5) + "]" * (MAX_YAML_DEPTH + 5)
    assert "levels" in refused(bounded_yaml_mapping, deep, "assembly_yaml").problem
    very_deep = "[" * 1500 + "]" * 1500  # past PyYAML's recursion: still a named refusal
    assert refused(bounded_yaml_mapping, very_deep, "assembly_yaml").field == "assembly_yaml"
    huge = "x" * (MAX_YAML_CHARS + 1)
    assert str(MAX_YAML_CHARS) in refused(bounded_yaml_mapping, huge, "assembly_yaml").problem
    for text in ("\x00", "a: [", "- 1\n- 2\n", ""):
        assert refused(bounded_yaml_mapping, text, "assembly_yaml").field == "assembly_yaml"
    assert bounded_yaml_mapping("a: &x [1, 2]\nb: *x\n", "f") == {"a": [1, 2], "b": [1, 2]}


def test_counts_and_magnitudes_name_the_field() -> None:
    check_count(10, 10, "waypoints", "waypoints")
    error = refused(check_count, 11, 10, "waypoints", "waypoints")
    assert error.field == "waypoints" and error.problem.endswith("the limit per request is 10")
    assert check_magnitude(0.5, 1.0, "radius", "m") == 0.5
    for value in (math.nan, math.inf, 1e308):
        assert refused(check_magnitude, value, 1e4, "radius", "m").field == "radius"
    for name, value in (("offset", 1e308), ("release_speed", 1e308), ("gravity", -1e308), ("mu", 1e9)):
        assert refused(check_design, {name: value}).field == name


def test_part_size_counted_before_reading() -> None:
    big = Part(outer=Polygon2D(x=[0.0] * (MAX_LOOP_VERTICES + 1), y=[0.0] * (MAX_LOOP_VERTICES + 1)))
    assert refused(check_part_size, big).field == "part.outer.x"
    holes = Part(outer=Polygon2D(x=[0.0, 1.0, 0.0], y=[0.0, 0.0, 1.0]), holes=[Polygon2D()] * 101)
    assert refused(check_part_size, holes).field == "part.holes"
    assert refused(check_part_size, Part(name="n" * 1000)).field == "part.name"


def test_path_samples_counted_before_sampling() -> None:
    down, side = (0.0, 0.0, -1.0), (1.0, 0.0, 0.0)
    step = math.radians(0.5)
    # As the samplers count: the start, then ceil(angle / step) per arc; a repeated point adds none.
    assert check_arc_samples(down, [side], step, "waypoints", MAX_MOVE_SAMPLES) == 1 + 180
    assert check_arc_samples(down, [side, side, down], step, "waypoints", MAX_MOVE_SAMPLES) == 1 + 360
    assert check_arc_samples(down, [(0.0, 0.0, -5.0)], step, "waypoints", MAX_MOVE_SAMPLES) == 1
    # A zero direction is the sampler's to refuse by name; it is not counted here.
    assert check_arc_samples(down, [(0.0, 0.0, 0.0)], step, "waypoints", MAX_MOVE_SAMPLES) == 0
    # 100 waypoints swinging a quarter turn each are 18,001 samples at the default step...
    swing = [side, down] * 50
    error = refused(check_arc_samples, down, swing, step, "waypoints", MAX_MOVE_SAMPLES)
    assert error.field == "waypoints" and "18001 path samples" in error.problem
    assert f"limit per request is {MAX_MOVE_SAMPLES}" in error.problem
    # ...and one quarter turn at a tiny step is refused quickly, before 1.6e7 samples are made.
    start = time.monotonic()
    error = refused(check_arc_samples, down, [side], 1e-7, "tilt_waypoints", MAX_MOVE_SAMPLES)
    assert time.monotonic() - start < 0.5 and error.field == "tilt_waypoints"
    # The step the message suggests fits.
    suggested = float(error.problem.rsplit("at least ", 1)[1].split(" rad")[0])
    assert check_arc_samples(down, [side], suggested, "w", MAX_MOVE_SAMPLES) <= MAX_MOVE_SAMPLES
