"""Mutated DXF, SVG and STEP files: a part or one InputError, never another exception, never a hang.

Each case mutates an example twin with a seeded generator (so a failure names a reproducible case):
numbers replaced by extreme or broken values, lines deleted, duplicated or swapped, bytes flipped, the
file cut short. Each read must end within CASE_SECONDS (SIGALRM, the test's main thread).
"""

from __future__ import annotations

import random
import re
import signal
from collections.abc import Iterator
from pathlib import Path
from types import FrameType

import pytest

from feeder_planner.cad import read_outline
from feeder_planner.errors import InputError

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
# File -> cases. A STEP read starts OpenCASCADE in a child process (about 1 s): fewer cases.
SOURCES = {
    EXAMPLES / "mems/bracket_filleted.dxf": 300,
    EXAMPLES / "mems/washer.dxf": 300,
    EXAMPLES / "mems/washer.svg": 300,
    EXAMPLES / "throwing/triangle.svg": 300,
    EXAMPLES / "mems/bracket.step": 6,
    EXAMPLES / "assembly/meshes/block_in_l_bracket.step": 3,
}
CASE_SECONDS = 60
_NUMBER = re.compile(rb"-?\d+(\.\d+)?(e-?\d+)?")
_ODD_NUMBERS = [
    b"nan",
    b"inf",
    b"-1e308",
    b"1e308",
    b"0",
    b"-0",
    b"1e-300",
    b"",
    b"x",
    b"99999999999999999999",
]


def mutate(data: bytes, rng: random.Random) -> bytes:
    """Return ``data`` after one to four random mutations."""
    for _ in range(rng.randint(1, 4)):
        kind = rng.randrange(6)
        lines = data.split(b"\n")
        if kind == 0:  # a number replaced by an odd value
            numbers = list(_NUMBER.finditer(data))
            if numbers:
                m = rng.choice(numbers)
                data = data[: m.start()] + rng.choice(_ODD_NUMBERS) + data[m.end() :]
        elif kind == 1 and len(lines) > 2:  # a line deleted
            del lines[rng.randrange(len(lines))]
            data = b"\n".join(lines)
        elif kind == 2 and len(lines) > 2:  # a line duplicated
            k = rng.randrange(len(lines))
            lines.insert(k, lines[k])
            data = b"\n".join(lines)
        elif kind == 3 and len(lines) > 2:  # two lines swapped
            a, b = rng.randrange(len(lines)), rng.randrange(len(lines))
            lines[a], lines[b] = lines[b], lines[a]
            data = b"\n".join(lines)
        elif kind == 4 and data:  # a byte flipped
            k = rng.randrange(len(data))
            data = data[:k] + bytes([data[k] ^ (1 << rng.randrange(8))]) + data[k + 1 :]
        elif data:  # cut short
            data = data[: rng.randrange(len(data))]
    return data


def _timeout(_signum: int, _frame: FrameType | None) -> None:
    raise TimeoutError(f"a read took more than {CASE_SECONDS} s")


@pytest.fixture
def alarm() -> Iterator[None]:
    previous = signal.signal(signal.SIGALRM, _timeout)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, previous)


@pytest.mark.parametrize("source", list(SOURCES), ids=lambda p: p.name)
def test_mutated_files_give_a_part_or_one_input_error(source: Path, tmp_path: Path, alarm: None) -> None:
    rng = random.Random(f"issue-39:{source.name}")
    original = source.read_bytes()
    outcomes = {"read": 0, "refused": 0}
    for case in range(SOURCES[source]):
        path = tmp_path / f"case{case}{source.suffix}"
        path.write_bytes(mutate(original, rng))
        signal.alarm(CASE_SECONDS)
        try:
            read_outline(path)
            outcomes["read"] += 1
        except InputError as error:
            message = str(error)
            assert "\n" not in message and str(path) in message, (case, message)
            assert len(message) < 2000, (case, message[:200])
            outcomes["refused"] += 1
        except Exception as exc:  # the failure this test exists to find: name the reproducible case
            pytest.fail(f"{source.name} case {case}: {type(exc).__name__}: {exc}")
        finally:
            signal.alarm(0)
    assert outcomes["refused"] > 0  # the mutations do break files: the test exercises the error paths
