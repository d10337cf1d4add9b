"""``ReceiptTicks``: which cell time held when a message reached the recorder (ROS-free)."""

from __future__ import annotations

import pytest

from feeder_cell.bag.receipt_clock import ReceiptTicks


def test_a_message_gets_the_cell_time_of_the_last_tick_that_arrived_before_it() -> None:
    ticks = ReceiptTicks()
    for arrival, cell in ((100, 1_000), (200, 1_500), (300, 2_000)):
        ticks.add(arrival, cell)
    assert ticks.at(99) == 0, "before the first tick there is no cell time"
    assert [ticks.at(a) for a in (100, 150, 200, 299, 300, 10_000)] == [
        1_000,
        1_000,
        1_500,
        1_500,
        2_000,
        2_000,
    ]


def test_no_arrival_time_reads_the_newest_tick_and_no_tick_reads_0() -> None:
    ticks = ReceiptTicks()
    assert ticks.at(0) == 0 and ticks.at(5) == 0
    ticks.add(10, 7)
    ticks.add(20, 9)
    assert ticks.at(0) == 9


def test_a_clock_set_back_is_followed_by_arrival() -> None:
    """A rewind (/clock back to its start) stamps later arrivals with the earlier cell times."""
    ticks = ReceiptTicks()
    ticks.add(100, 5_000)
    ticks.add(200, 1_000)
    assert (ticks.at(150), ticks.at(250)) == (5_000, 1_000)


def test_ticks_from_two_writers_interleave_by_arrival() -> None:
    ticks = ReceiptTicks()
    ticks.add(300, 3)
    ticks.add(100, 1)
    ticks.add(200, 2)
    assert [ticks.at(a) for a in (100, 200, 300)] == [1, 2, 3]


def test_the_history_is_bounded_and_an_arrival_older_than_it_gets_the_oldest_tick_not_0() -> None:
    ticks = ReceiptTicks(history_ns=1_000)
    for arrival in range(0, 100_001, 10):
        ticks.add(arrival + 1, arrival)
    assert len(ticks) <= 2 * (1_000 // 10 + 1), len(ticks)
    oldest = ticks.at(50)
    assert oldest > 0, "pruned: not 'before the first tick'"
    assert oldest <= ticks.at(100_001 - 1_000) == 99_000, "the last history_ns of arrivals are kept"
    assert ticks.at(100_001) == 100_000


@pytest.mark.parametrize("history_ns", [0, -1])
def test_a_history_that_is_not_positive_is_refused_by_name(history_ns: int) -> None:
    with pytest.raises(ValueError, match="history_ns"):
        ReceiptTicks(history_ns)
