"""The throw cycle a device shows: the command queue, the period, the joint swing and the landing."""

import math

import pytest
from throwing_helpers import TRIANGLE_PARAMS, triangle

from feeder_planner.errors import InputError
from feeder_sim.throwing.arm import ThrowingArm
from feeder_sim.throwing.cycle import RELEASE_SHOWN, ThrowCycle, joint_swing, ns
from feeder_sim.throwing.faults import ArmFaults

WINDOW = ns(0.5 * 0.3)  # the node's default period x motion_fraction


def cycle() -> ThrowCycle:
    arm = ThrowingArm(triangle(), TRIANGLE_PARAMS, 1, 0.12)
    return ThrowCycle(arm, ArmFaults(arm))


def test_the_joint_angle_is_the_integral_of_the_joint_velocity_and_ends_level():
    speed, release = 5.585, 0.0075
    step = release / 1000
    angle = 0.0
    for k in range(1200):  # past the release too
        t = k * step
        shown, velocity = joint_swing(speed, t, release)
        assert shown == pytest.approx(angle, abs=speed * step * 1e-6)
        angle += velocity * step
    assert joint_swing(speed, release / 2, release)[0] == pytest.approx(speed * release / 2)
    assert joint_swing(speed, release, release) == (0.0, 0.0)  # level again to catch the part


def test_a_throw_shown_swings_the_joint_up_and_back_then_lands_once():
    c = cycle()
    c.queue(1)
    assert c.throw_due(0, ns(0.5), False, True)
    outcome = c.throw(0)
    assert outcome.kind != "fault" and c.motion is not None and c.pending == 0
    release = RELEASE_SHOWN * WINDOW
    rising = c.show(int(release * 0.25), WINDOW)
    falling = c.show(int(release * 0.75), WINDOW)
    after = c.show(int(release * 2), WINDOW)
    speed = TRIANGLE_PARAMS.speed
    assert rising.velocity == speed and rising.joint > 0 and rising.landed is None
    assert falling.velocity == -speed and falling.joint > 0
    assert after.joint == after.velocity == 0.0 and after.landed is None
    landed = c.show(WINDOW, WINDOW)
    assert landed.landed is outcome and c.motion is None and landed.joint == 0.0
    assert c.show(WINDOW + 1, WINDOW).landed is None  # reported once


def test_commands_queue_start_and_stop_and_bad_counts_name_the_field():
    c = cycle()
    c.command("throw", 3)
    assert c.pending == 3 and c.busy
    c.command("stop", 0)
    assert c.pending == 0 and not c.busy
    c.command("start", 0)
    assert c.running and c.doing() == "throwing every period"
    with pytest.raises(InputError, match="count"):
        c.queue(0)
    with pytest.raises(InputError, match="count"):
        c.queue(10**9)


def test_placing_checks_the_radius_against_the_arm_and_clears_a_lost_part():
    c = cycle()
    with pytest.raises(InputError, match="radius"):
        c.place(1, math.nan, 0.4)
    with pytest.raises(InputError, match="radius"):
        c.place(1, 0.5, 0.4)
    c.arm.lose_part("fell off")
    c.place(1, 0.12, 0.4)
    assert c.arm.on_arm and c.arm.radius == 0.12 and c.motion is None
