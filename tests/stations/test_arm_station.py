"""The throwing arm's station without ROS: the tick's cap, the feed goal's throws and landings, a lost part.

The station is what the throwing_arm node and the ROS-free cell loop both tick (docs/devices.md, "The
station"); these tests drive it as a driver does: a tick every sensor period, the goal decided after it.
"""

from __future__ import annotations

import math
from pathlib import Path

from feeder_device.declarations import ActiveFault
from feeder_sim.throwing.fault_specs import fault_specs
from feeder_sim.throwing.feeding import check_feed_goal
from feeder_sim.throwing.outcome import ThrowOutcome
from feeder_sim.throwing.parameters import ArmParameters
from feeder_sim.throwing.station import ArmStation
from feeder_sim.throwing.tolerances import MAX_TICK_PERIODS

TRIANGLE = Path(__file__).resolve().parents[2] / "examples" / "throwing" / "triangle.yaml"
START = 1_000_000_000  # ns: a driver's first activation
FAULTS = fault_specs({"motor_fault": 101, "part_lost": 102})


class Recorder:
    """The driver's side of ArmEvents: what the station reported, in order."""

    def __init__(self) -> None:
        self.log: list[tuple[str, int]] = []
        self.lost: list[str] = []

    def landed(self, now_ns: int, outcome: ThrowOutcome) -> str:
        self.log.append(("landed", now_ns))
        return f"event at {now_ns}"

    def thrown(self, now_ns: int, outcome: ThrowOutcome) -> None:
        self.log.append(("thrown", now_ns))

    def part_lost(self, now_ns: int, outcome: ThrowOutcome, text: str) -> None:
        self.log.append(("lost", now_ns))
        self.lost.append(text)


def paper_arm(**extra: object) -> ArmParameters:
    """The cell scene's arm: the paper's first example, a part on edge 2 at R = 12 cm."""
    values: dict[str, object] = {
        "part_file": str(TRIANGLE),
        "gravity": -9.66,
        "offset": -0.005,
        "release_speed": math.radians(320),
        "initial_edge": 2,
        "initial_radius": 0.12,
    }
    values.update(extra)
    return ArmParameters(**values)  # type: ignore[arg-type]


def station(events: Recorder, **extra: object) -> ArmStation[str]:
    arm: ArmStation[str] = ArmStation(paper_arm(**extra), events)
    arm.simulated = START
    return arm


def test_a_tick_advances_the_simulated_time_by_at_most_max_tick_periods() -> None:
    arm = station(Recorder())
    period = int(1e9 / arm.p.sensor_rate)
    arm.tick(START + period, period, None, True)
    assert arm.simulated == START + period
    # A driver that stalled for a minute: the model lags, by at most MAX_TICK_PERIODS sensor periods.
    arm.tick(START + 60 * 10**9, 60 * 10**9, None, True)
    assert arm.simulated == START + period + round(MAX_TICK_PERIODS * 1e9 / arm.p.sensor_rate)


def test_a_feed_goal_throws_until_the_bit_reads_true_each_throw_reported_once() -> None:
    events = Recorder()
    arm = station(events)
    period = int(1e9 / arm.p.sensor_rate)
    feed = arm.feed_goal(check_feed_goal(40, 60.0), START)
    assert arm.reading() is False  # edge 2 at R = 12 cm: the sensor on edge 1 from R = 18 cm
    now = START
    while not feed.done and now < START + 60 * 10**9:
        now += period
        arm.tick(now, period, feed, True)
        arm.advance_goal(feed, now, None)
    assert feed.outcome is not None and feed.outcome.name == "PRESENTED", feed.outcome
    throws = [t for kind, t in events.log if kind == "thrown"]
    landings = [t for kind, t in events.log if kind == "landed"]
    assert len(throws) == feed.outcome.throws == arm.throws >= 1
    assert len(landings) == len(throws)  # every throw landed once, after it started
    assert all(land > throw for throw, land in zip(throws, landings, strict=True))
    # The feedback carries what the driver returned for each landing (the node's ThrowEvent).
    assert [r.event for r in feed.reports] == [f"event at {t}" for t in landings]
    # Throws are a period apart at least (0.5 s), as the device's queue spaces them.
    assert min(b - a for a, b in zip(throws, throws[1:], strict=False)) >= int(arm.p.period * 1e9)
    assert arm.reading() is True
    assert arm.reading() == arm.arm.sensor(arm.p.sensor_radius, arm.p.sensing_height)


def test_a_part_lost_fault_clears_the_throw_in_flight_and_asks_for_the_part_again() -> None:
    events = Recorder()
    arm = station(events, autostart=True)
    period = int(1e9 / arm.p.sensor_rate)
    now = START
    while arm.cycle.motion is None:
        now += period
        arm.tick(now, period, None, True)
    assert [kind for kind, _ in events.log] == ["thrown"]
    arm.apply_fault(ActiveFault(FAULTS["part_lost"], 0.0, False, (), 0.0, 0))
    assert arm.cycle.motion is None and not arm.cycle.running  # a stopping fault halts the throws
    # The next throw, the device ready again (a driver that ignores the fault), faults at once.
    arm.cycle.running = True
    for _ in range(int(arm.p.period * arm.p.sensor_rate) + 1):
        now += period
        arm.tick(now, period, None, True)
    assert [kind for kind, _ in events.log][-2:] == ["thrown", "lost"]
    assert events.lost[-1].startswith(f"throw {arm.throws}: ")
    lost = arm.lost_part_text()
    assert lost is not None and lost.endswith("(~/place_part puts it back)")
    arm.cycle.place(1, 0.15, arm.p.arm_length)
    assert arm.lost_part_text() is None


def test_stop_lands_the_throw_in_flight_at_once() -> None:
    events = Recorder()
    arm = station(events)
    period = int(1e9 / arm.p.sensor_rate)
    feed = arm.feed_goal(check_feed_goal(5, 0.0), START)
    now = START
    while arm.cycle.motion is None:
        now += period
        arm.tick(now, period, feed, True)
        arm.advance_goal(feed, now, None)
    arm.stop(now, feed)
    assert arm.cycle.motion is None and not arm.cycle.busy
    assert events.log[-1] == ("landed", now)
    assert not feed.in_flight  # the goal took the landing
