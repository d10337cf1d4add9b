"""The fixture's per-tick stability verdict is solved again only when gravity changed (stability.py)."""

from __future__ import annotations

import numpy as np
import pytest

from feeder_planner.assembly import check_result, prepare
from feeder_planner.assembly.parameters import load_assembly_parameter
from feeder_planner.errors import FeederError
from feeder_sim.fixture.parameters import FixtureParameters, table_limits
from feeder_sim.fixture.stability import StabilityCache
from feeder_sim.fixture.table import Table

TILT = np.array([-0.5, 0.0, -0.8660254037844386])  # the cell scene's fixture_route


def test_a_still_table_solves_once_and_a_moving_one_at_every_tick() -> None:
    prepared = prepare(load_assembly_parameter(""))
    table = Table(np.zeros(2), table_limits(FixtureParameters()))
    cache = StabilityCache()
    first = cache.check(prepared, table.gravity())
    for _ in range(100):  # a still table: the same bits of gravity
        table.advance(0.05)
        assert cache.check(prepared, table.gravity()) is first
    assert (cache.solves, cache.reuses) == (1, 100)
    table.start(table.plan(np.array([table.gravity(), TILT])))
    ticks = 0
    while table.moving:
        table.advance(0.05)
        g = table.gravity()
        result = cache.check(prepared, g)
        ticks += 1
        # the reused or new answer is the LP's answer for exactly this gravity
        fresh = check_result(prepared, g)
        assert (result.stable, result.margin_rad, result.unbalanced_bodies) == (
            fresh.stable,
            fresh.margin_rad,
            fresh.unbalanced_bodies,
        )
    assert cache.solves == 1 + ticks  # every tick of the move changed gravity
    for _ in range(20):  # still again at the tilt
        table.advance(0.05)
        cache.check(prepared, table.gravity())
    assert cache.solves == 1 + ticks and cache.reuses == 120


def test_a_new_prepared_assembly_or_a_one_ulp_change_solves_again() -> None:
    assembly = load_assembly_parameter("")
    g = np.array([0.0, 0.0, -1.0])
    cache = StabilityCache()
    a, b = prepare(assembly), prepare(assembly, mu=0.05)  # configure with another friction: a new object
    cache.check(a, g)
    cache.check(b, g)
    cache.check(a, g)
    assert (cache.solves, cache.reuses) == (2, 1)
    cache.check(a, np.array([np.nextafter(0.0, 1.0), 0.0, -1.0]))
    assert cache.solves == 3


def test_an_uncertified_answer_is_raised_again_without_solving() -> None:
    class Failing:
        calls = 0

    cache = StabilityCache()
    prepared = prepare(load_assembly_parameter(""))

    def boom(*_: object) -> None:
        Failing.calls += 1
        raise FeederError("LP not certified")

    g = np.array([0.0, 0.0, -1.0])
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr("feeder_sim.fixture.stability.check_result", boom)
        for _ in range(3):
            with pytest.raises(FeederError, match="not certified"):
                cache.check(prepared, g)
    assert Failing.calls == 1 and cache.solves == 1 and cache.reuses == 2
