"""The suite's own layout: test modules are collected by basename, so basenames must be unique."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

TESTS = Path(__file__).resolve().parents[1]


def test_test_module_basenames_are_unique() -> None:
    counts = Counter(path.name for path in TESTS.rglob("test_*.py"))
    assert [name for name, count in counts.items() if count > 1] == []


def test_every_ros_module_marks_its_tests_ros() -> None:
    """A module named ``*_ros.py`` starts node processes: `-m ros` (docs/setup.md) must select it.

    Two such modules carried no marker (the loop-equivalence test and the controller's policy refusal), so
    `-m "not ros"` ran them with the tests that start no node.
    """
    unmarked = [
        str(path.relative_to(TESTS))
        for path in sorted(TESTS.rglob("test_*_ros.py"))
        if "pytest.mark.ros" not in path.read_text(encoding="utf-8")
    ]
    assert unmarked == []
