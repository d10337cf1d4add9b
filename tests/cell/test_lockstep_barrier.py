"""The cell clock's lockstep rules, ROS-free: phases in order, admission, start-up, timeouts."""

from __future__ import annotations

from feeder_cell.lockstep_barrier import Barrier

Q = 100_000_000  # a quantum of 0.1 s
T0 = 1_000_000_000_000


def _started(expect: tuple[str, ...] = ("/arm", "/controller")) -> Barrier:
    """A barrier past start-up: the arm answered T0 (tick), the controller joined (react)."""
    barrier = Barrier(T0, Q, expect, timeout_s=5.0, join_timeout_s=10.0)
    barrier.answer("tick", "/arm", T0)
    barrier.answer("react", "/controller", 0)
    assert barrier.complete()
    return barrier


def test_start_up_holds_until_every_expected_name_joined_and_every_tick_participant_answered_t0() -> None:
    barrier = Barrier(T0, Q, ("/arm", "/controller"))
    assert not barrier.complete()
    barrier.answer("tick", "/arm", 0)  # a join message: its clock is not at T0 yet
    barrier.answer("react", "/controller", 0)
    assert not barrier.complete(), "a device whose clock is not at T0 must not be configured yet"
    barrier.answer("tick", "/arm", T0)
    assert barrier.complete()
    # T0's react phase comes next (its ticks were the join answers), waiting for the controller.
    assert barrier.next_phase(0.0) == "react" and barrier.now_ns == T0
    assert [m.name for m in barrier.waiting_for()] == ["/controller"]


def test_phases_run_tick_react_observe_and_each_waits_only_for_its_role() -> None:
    barrier = _started()
    barrier.next_phase(0.0)
    barrier.answer("react", "/controller", T0)
    assert barrier.complete()
    assert barrier.next_phase(0.0) == "observe" and barrier.complete()  # no recorder
    assert barrier.next_phase(0.0) == "done"
    assert barrier.next_phase(0.0) == "tick" and barrier.now_ns == T0 + Q
    assert [m.name for m in barrier.waiting_for()] == ["/arm"]
    barrier.answer("tick", "/arm", T0)  # an old answer does not count
    assert not barrier.complete()
    barrier.answer("tick", "/arm", T0 + Q)
    assert barrier.complete()


def test_a_late_joiner_is_waited_for_from_the_next_quantum() -> None:
    barrier = _started(("/arm",))
    for phase in ("react", "observe", "done", "tick"):
        assert barrier.next_phase(0.0) == phase
    barrier.answer("tick", "/viewer", 0)
    barrier.answer("tick", "/arm", T0 + Q)
    assert barrier.complete(), "joined during this quantum: not waited for in it"
    for _ in range(4):
        barrier.next_phase(0.0)
    assert sorted(m.name for m in barrier.waiting_for()) == ["/arm", "/viewer"]


def test_a_participant_that_does_not_answer_is_dropped_after_the_timeout_and_not_readmitted() -> None:
    barrier = _started()
    barrier.next_phase(10.0)  # react T0 starts at wall 10 s
    assert barrier.overdue(14.9) == []
    dropped = barrier.overdue(15.1)
    assert [d.name for d in dropped] == ["/controller"]
    assert "/controller (react) did not answer react" in dropped[0].describe()
    assert barrier.complete()
    barrier.answer("react", "/controller", T0)  # too late: it stays out
    assert "/controller" not in barrier.joined()


def test_an_expected_name_that_never_joins_is_dropped_after_the_join_timeout() -> None:
    barrier = Barrier(T0, Q, ("/arm", "/ghost"), join_timeout_s=10.0)
    barrier.answer("tick", "/arm", T0)
    assert not barrier.complete()
    assert barrier.overdue(9.0) == []
    assert [d.describe() for d in barrier.overdue(10.5)] == [
        "/ghost (expected) did not join within 10.5 s: dropped"
    ]
    assert barrier.complete()


def test_leaving_ends_the_wait_for_that_participant() -> None:
    barrier = _started()
    barrier.next_phase(0.0)
    assert not barrier.complete()
    barrier.answer("react", "/controller", -1, leave=True)
    assert barrier.complete()


def test_the_cell_clock_node_has_every_method_its_service_handlers_call() -> None:
    # ClockServices declares them abstract: a rename in the node would leave one unimplemented.
    from feeder_cell.clock_services import ClockServices
    from feeder_cell.nodes.cell_clock import CellClock

    assert ClockServices.__abstractmethods__ == {"tick", "publish", "_pump", "_announce"}
    assert not CellClock.__abstractmethods__
