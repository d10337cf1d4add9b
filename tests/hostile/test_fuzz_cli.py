"""Fuzz the `feeder` command with a seeded generator of hostile (and some valid) inputs (issue 16 item 9).

Every case is a `feeder` argv plus the files it names, built from the examples by one mutation of a known
category: files that are not UTF-8, FIFOs, devices, directories, oversized files, huge integers, tiny and
huge length scales, alias bombs, deep nesting, wrong types, lists where scalars go, huge counts, silent
accepts of issue 16, flags out of range, scenes rclpy would reject, random byte edits, and valid rewrites
of the examples. Each case runs IN PROCESS (cli.main.main(argv) with stdout and stderr captured) in a pool
of two worker processes, with a per-case timeout (SIGALRM: a FIFO that blocked an open would show as a
timeout) and an address-space limit. Ctrl-C is raised in process too. Per case the test asserts:

- known-bad input: exit 2 and ONE line on stderr naming the expected field (or a documented refusal,
  exit 3); never exit 0 (a silent accept);
- valid input: exit 0 and the same JSON as the example it rewrites;
- random edits (validity unknown): exit 0 with one JSON object, or exit 2/3 with one stderr line;
- never a traceback or an exception out of main(), never past the timeout, and the workers' peak RSS
  below RSS_BOUND_MB.

The seed is FEEDER_FUZZ_SEED (default 16); a failure prints the seed and the failing cases.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import io
import json
import math
import os
import random
import re
import resource
import signal
import time
import traceback
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from multiprocessing import get_context
from pathlib import Path
from typing import Any

import yaml

ROOT = Path(__file__).resolve().parents[2]
SEED = int(os.environ.get("FEEDER_FUZZ_SEED", "16"))
CASES = 520
CASE_TIMEOUT_S = 20.0
# Peak resident memory of a worker over all its cases (ru_maxrss): the interpreter with numpy, scipy and
# the planners is about 150 MB; a case that allocated past the stated limits would show here.
RSS_BOUND_MB = 600
# Address-space cap of a worker: a runaway allocation fails fast with MemoryError (a test failure) rather
# than taking the shared machine's memory.
ADDRESS_SPACE_BYTES = 4 * 1024**3

TRIANGLE = yaml.safe_load((ROOT / "examples/throwing/triangle.yaml").read_text())
SQUARE = yaml.safe_load((ROOT / "examples/mems/square.yaml").read_text())
CORNER = yaml.safe_load((ROOT / "examples/assembly/cube_in_corner.yaml").read_text())
BRACKET = yaml.safe_load((ROOT / "examples/assembly/block_in_l_bracket.yaml").read_text())

THROW_FLAGS = ["--offset=-0.5", "--release-speed=320deg", "--gravity=-966", "--mu=0.5"]


def _commands(path: str) -> dict[str, list[str]]:
    """The subcommands that read a part (keyed by name) with cheap valid flags, reading ``path``."""
    return {
        "equilibria": ["equilibria", path, "--delta=0.1", "--method=asymptotic", "--json"],
        "throw": ["throw", path, "--edge=0", "--radius=5", *THROW_FLAGS, "--json"],
        "limit-set": ["limit-set", path, *THROW_FLAGS, "--starts-per-edge=1", "--throws=100", "--json"],
        "throw-design": [
            "throw-design",
            path,
            "--offsets=-0.5",
            "--release-speeds=320deg",
            "--gravity=-966",
            "--mu=0.5",
            "--goal-edge=1",
            "--json",
        ],
    }


def _assembly_commands(path: str) -> dict[str, list[str]]:
    """The subcommands that read an assembly, reading ``path``."""
    return {
        "stable-region": ["stable-region", path, "--json"],
        "check-stability": ["check-stability", path, "--g", "0", "0", "-1", "--json"],
    }


@dataclass
class Case:
    """One generated input: argv, the files to write first, and what must happen."""

    label: str
    argv: list[str]
    expect: str  # "bad" (exit 2, or 3 if allowed), "valid" (exit 0, same JSON as `reference`), "any"
    field: str = ""  # a substring the one stderr line must contain for "bad" ("a|b": either)
    files: dict[str, bytes] = dataclasses.field(
        default_factory=dict
    )  # name -> content, written into the case folder
    reference: str = ""  # key of the reference result for "valid"
    allow_3: bool = False


# --- the generator ---------------------------------------------------------------------------------------


def _dump(document: Any) -> bytes:
    """The document as YAML text: JSON (a subset of YAML, ten times faster to write than safe_dump)."""
    # YAML 1.1 reads 1e+308 as a string: a float's exponent needs a dot in the mantissa (1.0e+308).
    return re.sub(r"(?<![\w.])(-?\d+)(e[+-]\d+)", r"\1.0\2", json.dumps(document)).encode()


def _block(document: Any) -> bytes:
    """The document in YAML block style."""
    return yaml.safe_dump(document, sort_keys=False).encode()


def _bomb(levels: int = 9, fanout: int = 9) -> str:
    """A billion-laughs document fragment: anchors a0..a{levels}, each a list of `fanout` of the last."""
    lines = ['a0: &a0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    for level in range(1, levels + 1):
        lines.append(f"a{level}: &a{level} [" + ", ".join([f"*a{level - 1}"] * fanout) + "]")
    return "\n".join(lines) + "\n"


@functools.lru_cache(maxsize=None)
def _many_vertices(count: int) -> bytes:
    """A part of ``count`` vertices (JSON is YAML, and dumps fast)."""
    ring = [[math.cos(2 * math.pi * k / count), math.sin(2 * math.pi * k / count)] for k in range(count)]
    return json.dumps({"vertices": ring}).encode()


@functools.lru_cache(maxsize=None)
def _many_boxes(name: str, free: int) -> bytes:
    """The example ``name`` with body ``free`` made of 2001 boxes (one past MAX_ASSEMBLY_PIECES)."""
    base = {"cube_in_corner": CORNER, "block_in_l_bracket": BRACKET}[name]
    bodies = [dict(b) for b in base["bodies"]]
    bodies[free]["boxes"] = [{"min": [k, 0, 5], "max": [k + 1, 1, 6]} for k in range(2001)]
    return json.dumps({**base, "bodies": bodies}).encode()


def _part_mutations(rng: random.Random, base: dict[str, Any]) -> list[tuple[str, bytes, str]]:
    """(label, file bytes, expected field) of known-bad part files derived from ``base``."""
    text = _dump(base)
    verts = base["vertices"]
    k = rng.randrange(len(verts))
    out: list[tuple[str, bytes, str]] = []

    def with_(**changes: Any) -> bytes:
        return _dump({**base, **changes})

    big = rng.choice([10**400, -(10**330), 2**1100])
    bad_vertex = [list(v) for v in verts]
    bad_vertex[k][rng.randrange(2)] = big
    out.append(("huge int vertex", with_(vertices=bad_vertex), f"vertices[{k}]"))
    out.append(("huge int density", with_(density=big), "density"))
    factor = rng.choice([1e-160, 1e-12, 1e150, 1e6, 1e300])
    scaled = [[c * factor for c in v] for v in verts]
    out.append((f"scale x{factor:g}", with_(vertices=scaled, length_unit="m"), "vertices"))
    offset = rng.choice([1e5, 1e300, -1e9])
    shifted = [[v[0] + offset, v[1]] for v in verts]
    out.append((f"far offset {offset:g}", with_(vertices=shifted, length_unit="m"), "vertices"))
    wrong = rng.choice(["abc", 5, True, {"a": 1}, [[0, 0], [1, 0]], [[0, 0, 0], [1, 0, 0], [0, 1, 0]]])
    out.append((f"vertices {type(wrong).__name__}", with_(vertices=wrong), "vertices"))
    out.append(("vertex strings", with_(vertices=[["a", "b"], *verts[1:]]), "vertices[0]"))
    out.append(("vertex list in coordinate", with_(vertices=[[[0], 0], *verts[1:]]), "vertices[0]"))
    out.append(
        ("vertices missing", _dump({key: v for key, v in base.items() if key != "vertices"}), "vertices")
    )
    density = rng.choice(["heavy", -1, 0, [1, 2], True, {"kg": 1}, float("nan"), float("inf"), 1e300])
    out.append((f"density {density!r}", with_(density=density), "density"))
    unit = rng.choice(["furlong", ["m"], 5, {"u": "m"}, "M", ""])
    out.append((f"length_unit {unit!r}", with_(length_unit=unit), "length_unit"))
    name = rng.choice([[[1, 2], [3]], {"a": "b"}, "x" * 5000, 5, "two\nlines", ""])
    out.append((f"name {type(name).__name__}", with_(name=name), "name"))
    holes = rng.choice([5, "none", [[[0, 0]]], [[["a", 0], [1, 0], [0, 1]]]])
    out.append((f"holes {holes!r}"[:40], with_(holes=holes), "holes"))
    bowtie = [[0, 0], [4, 4], [4, 0], [0, 4]]
    out.append(("self-intersecting", with_(vertices=bowtie), "vertices"))
    out.append(("repeated vertex", with_(vertices=[verts[0], *verts]), "vertices"))
    # Alias bombs in the fields the issue names: a string field, a vertex, length_unit, density, vertices.
    target = rng.choice(["name", "length_unit", "density", "vertices", "holes"])
    bomb = (
        _bomb()
        + f"{target}: *a9\n"
        + "".join(f"{key}: {json.dumps(value)}\n" for key, value in base.items() if key != target)
    )
    out.append((f"alias bomb in {target}", bomb.encode(), "<file>"))
    small = _bomb(levels=4) + "vertices: [[0, 0], [1, 0], *a4]\n"
    out.append(("alias bomb as vertex", small.encode(), "vertices[2]"))
    depth = rng.choice([100, 1000, 100000])
    out.append((f"nested {depth}", ("vertices: " + "[" * depth + "]" * depth + "\n").encode(), "<file>"))
    if rng.random() < 0.3:  # reading a big file takes a second: a few such cases, not one in thirty
        count = rng.choice([10_001, 12_000])  # just past MAX_PART_VERTICES
        out.append((f"{count} vertices", _many_vertices(count), "vertices"))
    junk = bytes(rng.randrange(256) for _ in range(rng.randrange(20, 400)))
    out.append(("binary garbage", b"\xff\xfe" + junk, "<file>"))
    out.append(("latin-1", "name: caf\xe9\n".encode("latin-1") + text, "<file>"))
    out.append(("utf-16", text.decode().encode("utf-16"), "<file>"))
    out.append(("empty", b"", "<top level>"))
    out.append(("top-level list", b"- 1\n- 2\n", "<top level>"))
    out.append(("syntax error", b"vertices: [[0, 0], [1, 0]\nname: x\n", "<file>"))
    out.append(("two documents", text + b"---\n" + text, "<file>"))
    out.append(("tab indentation", b"vertices:\n\t- [0, 0]\n", "<file>"))
    out.append(("unknown tag", b"vertices: !!python/object:os.system [ls]\n", "<file>"))
    return out


def _assembly_mutations(rng: random.Random, base: dict[str, Any]) -> list[tuple[str, bytes, str]]:
    """(label, file bytes, expected field) of known-bad assembly files derived from ``base``."""
    out: list[tuple[str, bytes, str]] = []

    def with_body(index: int, **changes: Any) -> bytes:
        bodies = [dict(b) for b in base["bodies"]]
        bodies[index] = {**bodies[index], **changes}
        return _dump({**base, "bodies": bodies})

    def with_(**changes: Any) -> bytes:
        return _dump({**base, **changes})

    free = len(base["bodies"]) - 1
    out.append(("bodies wrong", with_(bodies=rng.choice(["x", [], 5, {"a": 1}])), "bodies"))
    out.append(("body name list", with_body(free, name=rng.choice([[1], "", {"n": 1}, "y" * 4000])), "name"))
    out.append(("grounded string", with_body(0, grounded=rng.choice(["maybe", 5, [True]])), "grounded"))
    out.append(("density negative", with_body(free, density=rng.choice([-1, 0, "x", 10**400])), "density"))
    corner = rng.choice([[0, 0], ["a", 0, 0], [10**400, 0, 0], [1e308, 0, 0], "x"])
    box = {"min": corner, "max": [2, 2, 2]}
    out.append((f"box min {corner!r}"[:40], with_body(free, boxes=[box]), f"bodies[{free}].boxes[0].min"))
    out.append(("box at 1e308", with_body(0, boxes=[{"min": [0, 0, 0], "max": [1e308, 3, 1]}]), "bodies[0]"))
    tiny = [{"min": [0, 0, 0], "max": [1e-12, 1e-12, 1e-12]}]
    out.append(
        (
            "tiny assembly",
            _dump(
                {
                    **base,
                    "length_unit": "m",
                    "bodies": [
                        {"name": "g", "grounded": True, "boxes": tiny},
                        {"name": "f", "boxes": [{"min": [0, 0, 1e-12], "max": [1e-12, 1e-12, 2e-12]}]},
                    ],
                }
            ),
            "bodies",
        )
    )
    out.append(("mu wrong", with_(mu=rng.choice([-1, "a", [0.1], float("nan")])), "mu"))
    out.append(("contacts wrong", with_(contacts=rng.choice([5, "manual", {"a": 1}])), "contacts"))
    names = [b["name"] for b in base["bodies"]]
    contact = {"a": names[free], "b": names[0], "point": [1, 1, 1], "normal": [0, 0, 1]}
    out.append(("contact far", with_(contacts=[{**contact, "point": [1e6, 0, 0]}]), "contacts[0].point"))
    out.append(("contact a list", with_(contacts=[{**contact, "a": [names[free]]}]), "contacts[0].a"))
    out.append(("contact unknown", with_(contacts=[{**contact, "b": "ghost"}]), "contacts[0].b"))
    out.append(("contact normal", with_(contacts=[{**contact, "normal": [0, 0, 2]}]), "contacts[0].normal"))
    out.append(
        ("contact huge point", with_(contacts=[{**contact, "point": [10**400, 0, 0]}]), "contacts[0].point")
    )
    inner = [[0, 0, 1], [1, 0, 1], [0, 1, 1], [0, 0, 2], [0.1, 0.1, 1.1]]
    out.append(("not convex", with_body(free, boxes=[], convex=[inner]), f"bodies[{free}].convex[0][4]"))
    out.append(("no grounded", with_body(0, grounded=False), "bodies"))
    out.append(("2001 boxes", _many_boxes(base["name"], free), "bodies"))
    bomb = _bomb() + "bodies: *a9\n"
    out.append(("alias bomb bodies", bomb.encode(), "<file>"))
    out.append(("nested", ("bodies: " + "[" * 5000 + "]" * 5000 + "\n").encode(), "<file>"))
    out.append(("latin-1", b"name: \xe9\n" + _dump(base), "<file>"))
    return out


def _scene_mutations(rng: random.Random, part: str) -> list[tuple[str, bytes, str]]:
    """(label, file bytes, expected field) of known-bad scene files (none may start a node)."""
    node = {"package": "feeder_sim", "executable": "throwing_arm", "parameters": {"part_file": part}}
    out: list[tuple[str, bytes, str]] = []

    def scene(**changes: Any) -> bytes:
        return _dump({"name": "fuzz", "nodes": [{**node, **changes}]})

    def params(**changes: Any) -> bytes:
        return scene(parameters={**node["parameters"], **changes})

    out.append(
        (
            "node name",
            scene(name=rng.choice(["my arm", "1arm", "a-b", "a/b", [1], "x" * 300])),
            "nodes[0].name",
        )
    )
    out.append(
        ("namespace", scene(namespace=rng.choice(["/a b", "/1x", "/a//b", "/a/-", 5])), "nodes[0].namespace")
    )
    out.append(("package", scene(package=rng.choice([[1], "", "a b", {"p": 1}])), "nodes[0].package"))
    out.append(("executable", scene(executable=rng.choice(["../x", "", [1], "a b"])), "nodes[0].executable"))
    out.append(("parameters", scene(parameters=rng.choice([5, "x", [1]])), "nodes[0].parameters"))
    out.append(("mixed list", params(part_files=[1, "a"]), "nodes[0].parameters.part_files"))
    out.append(("nested dict", params(gravity={"value": -9.66}), "nodes[0].parameters.gravity"))
    out.append(("null value", params(offset=None), "nodes[0].parameters.offset"))
    out.append(("int for double", params(gravity=-9), "nodes[0].parameters.gravity"))
    out.append(("failed check", params(gravity=9.66), "nodes[0].parameters.gravity"))
    out.append(("missing part_file", scene(parameters={}), "nodes[0].parameters.part_file"))
    out.append(("empty list", params(initial=[]), "nodes[0].parameters.initial"))
    out.append(("huge int", params(seed=2**70), "nodes[0].parameters.seed"))
    out.append(("bad param name", params(**{"bad name": 1}), "nodes[0].parameters"))
    out.append(("lifecycle", scene(lifecycle=rng.choice(["running", [1], 5])), "nodes[0].lifecycle"))
    out.append(("nodes", _dump({"name": "fuzz", "nodes": rng.choice([[], 5, "x"])}), "nodes"))
    out.append(("scene name", _dump({"name": [[1]], "nodes": [node]}), "name"))
    out.append(("alias bomb", (_bomb() + "nodes: *a9\n").encode(), "<file>"))
    return out


# Flags of each subcommand and values known to be bad for them (exit 2 naming the flag).
BAD_FLAGS: dict[str, dict[str, list[str]]] = {
    "equilibria": {"--delta": ["1", "5", "-0.1", "nan", "inf", "abc", "", "1e999"]},
    "throw": {
        "--radius": ["1e308", "-1e308", "nan", "inf", "abc", "1e999", "0.1", "1e7"],
        "--release-speed": ["1e308", "1e5", "0", "-5", "nan", "abc", "5degx", "1e308deg"],
        "--gravity": ["0", "5", "nan", "1e308", "-1e308", "abc"],
        "--mu": ["nan", "-1", "abc", "inf"],
        "--offset": ["1e308", "-1e308", "nan", "abc", "1e7"],
        "--edge": ["99", "-1", "1.5", "abc", "99999999999999999999999"],
    },
    "limit-set": {
        "--starts-per-edge": ["1000000", "0", "-3", "abc", "1e6", "99999999999999999999"],
        "--throws": ["100000000", "0", "abc", "-1"],
        "--release-speed": ["1e308", "1e5"],
        "--goal-edge": ["99", "-1", "x"],
        "--sensing-height": ["-1", "nan", "1e308"],
    },
    "throw-design": {"--release-speeds": ["1e308", "nan", "abc"], "--offsets": ["1e308", "nan"]},
    "check-stability": {"--g": ["nan 0 0", "abc 0 0", "0 0 0", "1e999 0 0"], "--mu": ["-1", "nan"]},
    "stable-region": {"--mu": ["-1", "nan", "abc"], "--facets": ["0", "2", "-4", "abc", "1000000000"]},
}


def _set_flag(argv: list[str], flag: str, value: str) -> list[str]:
    """Return argv with ``flag`` given ``value`` (three values for --g), replacing any earlier value."""
    out: list[str] = []
    skip = 0
    for item in argv:
        if skip:
            skip -= 1
            continue
        if item == flag:
            skip = 3 if flag == "--g" else 1
            continue
        if item.startswith(flag + "="):
            continue
        out.append(item)
    if flag == "--g":
        return [*out, "--g", *value.split()]
    return [*out, f"{flag}={value}"]


# Every subcommand: argument errors end before any work (no ROS, no file), in one line naming the argument.
SUBCOMMANDS = (
    "doctor",
    "record",
    "bag-info",
    "bag-reindex",
    "play",
    "bag-plot",
    "launch",
    "lifecycle",
    "equilibria",
    "throw",
    "limit-set",
    "throw-design",
    "stable-region",
    "check-stability",
    "bridge",
)


def _cli_mutations(rng: random.Random) -> list[tuple[str, list[str], str]]:
    """(label, argv, expected text) of argument errors over every subcommand."""
    command = rng.choice(SUBCOMMANDS)
    junk = "".join(rng.choice("abcxyz_") for _ in range(rng.randint(1, 12)))
    return [
        (
            f"{command} unknown flag",
            [command, f"--no-such-flag-{junk}", "x"],
            "unrecognized arguments|arguments are required",
        ),
        ("run unknown package", ["run", f"nopkg_{junk}", "x"], "package"),
        ("run unknown executable", ["run", "feeder_sim", f"no_such_{junk}"], "executable"),
        ("clock bad action", ["clock", f"bogus{junk}"], "action"),
        ("no subcommand", [], "COMMAND"),
        ("unknown subcommand", [f"frob{junk}"], "invalid choice"),
        ("run without arguments", ["run"], "required"),
    ]


def _valid_rewrites(rng: random.Random, base: dict[str, Any]) -> list[tuple[str, bytes]]:
    """Rewrites of a valid document that mean the same: the result must not change."""
    text = _block(base)
    shuffled = dict(rng.sample(list(base.items()), len(base)))
    return [
        ("block style", text),
        (
            "flow style with comments",
            b"# a comment\n" + yaml.safe_dump(base, default_flow_style=True).encode(),
        ),
        ("utf-8 bom", b"\xef\xbb\xbf" + text),
        ("keys shuffled", _block(shuffled)),
        ("json", json.dumps(base).encode()),
        ("crlf", text.replace(b"\n", b"\r\n")),
    ]


def _random_edit(rng: random.Random, text: bytes) -> bytes:
    """One to three random byte edits (replace, insert, delete) of a valid file."""
    data = bytearray(text)
    for _ in range(rng.randint(1, 3)):
        at = rng.randrange(len(data))
        op = rng.randrange(3)
        alphabet = b"0123456789[]{},:-&*!#.e \n'\"\x00\xff"
        if op == 0:
            data[at] = rng.choice(alphabet)
        elif op == 1:
            data.insert(at, rng.choice(alphabet))
        elif len(data) > 1:
            del data[at]
    return bytes(data)


def _issue_cases() -> list[Case]:
    """The inputs issue 16 reports by name, every run (the seeded cases come after them)."""
    triangle = {"f0": _dump(TRIANGLE)}
    commands = _commands("{f0}")
    cases = [
        Case(f"flag/throw {flag}={value}", _set_flag(commands["throw"], flag, value), "bad", flag, triangle)
        for flag, value in (("--radius", "1e308"), ("--release-speed", "1e308"))
    ]
    cases += [
        Case(
            f"cli/{command} unknown flag",
            [command, "--no-such-flag", "x"],
            "bad",
            "unrecognized arguments|arguments are required",
        )
        for command in SUBCOMMANDS
    ]
    cases += [
        Case(
            f"flag/limit-set {flag}={value}",
            _set_flag(commands["limit-set"], flag, value),
            "bad",
            flag,
            triangle,
        )
        for flag, value in (("--starts-per-edge", "1000000"), ("--throws", "100000000"))
    ]
    cases.append(
        Case(
            "part/20000 vertices/equilibria",
            commands["equilibria"],
            "bad",
            "vertices",
            {"f0": _many_vertices(20_000)},
        )
    )
    rng = random.Random(0)
    for label, data, fld in _part_mutations(rng, TRIANGLE):
        cases.append(Case(f"part/{label}/throw", commands["throw"], "bad", fld, {"f0": data}))
    for label, data, fld in _assembly_mutations(rng, BRACKET):
        argv = _assembly_commands("{f0}")["stable-region"]
        cases.append(Case(f"assembly/{label}/stable-region", argv, "bad", fld, {"f0": data}))
    for label, data, fld in _scene_mutations(rng, "{dir}/part.yaml"):
        argv = ["launch", "{f0}", "--duration=0.5", "--log-dir={dir}/logs", "--json"]
        cases.append(Case(f"scene/{label}", argv, "bad", fld, {"f0": data, "part.yaml": _dump(TRIANGLE)}))
    for special in ("fifo", "dev_zero", "dev_null", "directory", "missing", "oversized"):
        cases.append(
            Case(
                f"special/{special}/equilibria",
                commands["equilibria"],
                "bad",
                "<file>",
                {"f0": special.encode()},
            )
        )
    return cases


def generate(seed: int, count: int) -> list[Case]:
    """Return ``count`` cases, reproducible from ``seed``, cycling through every category."""
    rng = random.Random(seed)
    cases: list[Case] = _issue_cases()
    makers = [
        "part_file",
        "part_file",
        "part_file",
        "assembly_file",
        "assembly_file",
        "scene_file",
        "flag",
        "flag",
        "special",
        "valid",
        "random_edit",
        "cli",
    ]
    n = 0
    while len(cases) < count:
        kind = makers[n % len(makers)]
        n += 1
        if kind == "part_file":
            base = rng.choice([TRIANGLE, SQUARE])
            label, data, fld = rng.choice(_part_mutations(rng, base))
            command = rng.choice(list(_commands("{f0}").values()))
            cases.append(Case(f"part/{label}/{command[0]}", command, "bad", fld, {"f0": data}))
        elif kind == "assembly_file":
            base = rng.choice([CORNER, BRACKET])
            label, data, fld = rng.choice(_assembly_mutations(rng, base))
            command = rng.choice(list(_assembly_commands("{f0}").values()))
            cases.append(Case(f"assembly/{label}/{command[0]}", command, "bad", fld, {"f0": data}))
        elif kind == "scene_file":
            label, data, fld = rng.choice(_scene_mutations(rng, "{dir}/part.yaml"))
            argv = ["launch", "{f0}", "--duration=0.5", "--log-dir={dir}/logs", "--json"]
            files = {"f0": data, "part.yaml": _dump(TRIANGLE)}
            cases.append(Case(f"scene/{label}", argv, "bad", fld, files))
        elif kind == "flag":
            command_name = rng.choice(list(BAD_FLAGS))
            flag = rng.choice(list(BAD_FLAGS[command_name]))
            value = rng.choice(BAD_FLAGS[command_name][flag])
            commands = {**_commands("{f0}"), **_assembly_commands("{f0}")}
            base_doc = TRIANGLE if command_name not in ("check-stability", "stable-region") else BRACKET
            argv = _set_flag(commands[command_name], flag, value)
            cases.append(
                Case(f"flag/{command_name} {flag}={value}", argv, "bad", flag, {"f0": _dump(base_doc)})
            )
        elif kind == "special":
            special = rng.choice(["fifo", "dev_zero", "dev_null", "directory", "missing", "oversized"])
            command = rng.choice(list(_commands("{f0}").values()) + list(_assembly_commands("{f0}").values()))
            cases.append(
                Case(f"special/{special}/{command[0]}", command, "bad", "<file>", {"f0": special.encode()})
            )
        elif kind == "valid":
            if rng.random() < 0.6:
                base, key = rng.choice([(TRIANGLE, "triangle"), (SQUARE, "square")])
                commands = _commands("{f0}")
                # limit-set and throw-design cost ten times a throw: one valid case in four runs them
                cheap = ["equilibria", "throw", "equilibria", "throw", "equilibria", "throw"]
                name = rng.choice([*cheap, *commands] if key == "triangle" else ["equilibria"])
            else:
                base, key = rng.choice([(CORNER, "corner"), (BRACKET, "bracket")])
                commands = _assembly_commands("{f0}")
                name = rng.choice(list(commands))
            label, data = rng.choice(_valid_rewrites(rng, base))
            cases.append(
                Case(
                    f"valid/{key}/{label}/{name}", commands[name], "valid", "", {"f0": data}, f"{key}/{name}"
                )
            )
        elif kind == "cli":
            label, argv, fld = rng.choice(_cli_mutations(rng))
            cases.append(Case(f"cli/{label}", argv, "bad", fld))
        else:
            base = rng.choice([TRIANGLE, SQUARE, CORNER, BRACKET])
            is_part = "vertices" in base
            commands = _commands("{f0}") if is_part else _assembly_commands("{f0}")
            name = rng.choice(["equilibria", "throw"] if is_part and base is TRIANGLE else list(commands))
            if is_part and base is SQUARE:
                name = "equilibria"
            data = _random_edit(rng, _block(base))
            cases.append(Case(f"random edit/{name}", commands[name], "any", "", {"f0": data}, allow_3=True))
    return cases


REFERENCES = {
    "triangle": TRIANGLE,
    "square": SQUARE,
    "corner": CORNER,
    "bracket": BRACKET,
}


# --- running a case in a worker ---------------------------------------------------------------------------


class CaseTimeoutError(Exception):
    """Raised in a worker by SIGALRM when a case runs past CASE_TIMEOUT_S."""


def _on_alarm(signum: int, frame: Any) -> None:
    raise CaseTimeoutError()


def _init_worker() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_SPACE_BYTES, ADDRESS_SPACE_BYTES))
    signal.signal(signal.SIGALRM, _on_alarm)
    import feeder_cell.cli.main  # noqa: F401 -- imported once per worker, not per case


def run_in_process(argv: list[str]) -> dict[str, Any]:
    """Run main(argv) with captured output and a timeout; return exit code, output, time and peak RSS."""
    from feeder_cell.cli.main import main

    out, err = io.StringIO(), io.StringIO()
    started = time.monotonic()
    crash = ""
    code: Any = None
    signal.setitimer(signal.ITIMER_REAL, CASE_TIMEOUT_S)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = main(argv)
    except SystemExit as exit_:
        code = exit_.code
    except CaseTimeoutError:
        crash = f"timeout after {CASE_TIMEOUT_S} s"
    except BaseException:  # noqa: BLE001 -- any exception out of main() is the failure being looked for
        crash = traceback.format_exc(limit=8)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
    return {
        "code": code,
        "stdout": out.getvalue(),
        "stderr": err.getvalue(),
        "crash": crash,
        "seconds": time.monotonic() - started,
        "rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    }


def _materialise(case: Case, folder: Path) -> list[str]:
    """Write the case's files into ``folder`` and return its argv with the paths filled in."""
    folder.mkdir(parents=True, exist_ok=True)
    paths = {"dir": str(folder)}
    for name, data in case.files.items():
        path = folder / (f"{name}.yaml" if name.startswith("f") and "." not in name else name)
        special = data.decode(errors="replace") if len(data) < 20 else ""
        if special == "fifo":
            os.mkfifo(path)
        elif special == "dev_zero":
            path = Path("/dev/zero")
        elif special == "dev_null":
            path = Path("/dev/null")
        elif special == "directory":
            path.mkdir()
        elif special == "missing":
            pass
        elif special == "oversized":
            with open(path, "wb") as handle:
                handle.truncate(17 * 1024 * 1024)  # sparse: 17 MiB of size, no disk
        else:
            path.write_bytes(data.replace(b"{dir}", str(folder).encode()))
        paths[name] = str(path)
    return [item.format(**paths) if "{" in item else item for item in argv_of(case)]


def argv_of(case: Case) -> list[str]:
    """The case's argv template."""
    return case.argv


def check(case: Case, result: dict[str, Any], references: dict[str, str], folder: Path) -> str:
    """Return what is wrong with a case's result ("" when it behaved)."""
    if result["crash"]:
        return f"exception out of main(): {result['crash']}"
    code, stderr, stdout = result["code"], result["stderr"], result["stdout"]
    if "Traceback" in stderr:
        return f"traceback on stderr: {stderr[-600:]}"
    lines = stderr.splitlines()
    if case.expect == "bad":
        if code == 0:
            return f"silent accept (exit 0), stdout {stdout[:200]!r}"
        if code == 3 and case.allow_3:
            return "" if len(lines) == 1 else f"exit 3 with {len(lines)} stderr lines: {stderr[:400]!r}"
        if code != 2:
            return f"exit {code}, expected 2: {stderr[:400]!r}"
        if len(lines) != 1:
            return f"{len(lines)} stderr lines, expected 1: {stderr[:600]!r}"
        if not any(text in lines[0] for text in case.field.split("|")):
            return f"stderr does not name {case.field!r}: {lines[0][:400]!r}"
        return ""
    if case.expect == "valid":
        if code != 0:
            return f"valid input refused (exit {code}): {stderr[:400]!r}"
        if stdout.replace(str(folder), "<dir>") != references[case.reference]:
            return f"result differs from the example's: {stdout[:300]!r}"
        return ""
    # Random edits: valid or not, the answer has the contract's shape.
    if code == 0:
        try:
            json.loads(stdout)
        except ValueError:
            return f"exit 0 without one JSON object: {stdout[:200]!r}"
        return ""
    if code in (2, 3) and len(lines) == 1 and lines[0].startswith("feeder "):
        return ""
    return f"exit {code} with stderr {stderr[:400]!r}"


def _reference_results(folder: Path) -> dict[str, str]:
    """The JSON output of each valid example and command, computed in this process."""
    results: dict[str, str] = {}
    for key, document in REFERENCES.items():
        path = folder / f"{key}.yaml"
        path.write_bytes(_dump(document))
        commands = _commands(str(path)) if "vertices" in document else _assembly_commands(str(path))
        for name, argv in commands.items():
            if key == "square" and name != "equilibria":
                continue  # the square is an equilibria example only
            outcome = run_in_process(argv)
            assert outcome["code"] == 0, (key, name, outcome)
            results[f"{key}/{name}"] = outcome["stdout"].replace(str(path), "<dir>/f0.yaml")
    return results


def _run_pool(cases: list[Case], root: Path) -> list[tuple[Case, dict[str, Any], Path]]:
    jobs = []
    for index, case in enumerate(cases):
        folder = root / f"case{index:04d}"
        jobs.append((case, _materialise(case, folder), folder))
    with ProcessPoolExecutor(max_workers=2, mp_context=get_context("fork"), initializer=_init_worker) as pool:
        futures = [pool.submit(run_in_process, argv) for _, argv, _ in jobs]
        return [
            (case, future.result(timeout=CASE_TIMEOUT_S * 3), folder)
            for (case, _, folder), future in zip(jobs, futures, strict=True)
        ]


def test_the_generator_covers_every_category_and_is_reproducible() -> None:
    cases = generate(SEED, CASES)
    assert len(cases) >= 500
    assert [c.label for c in cases] == [c.label for c in generate(SEED, CASES)]
    prefixes = {c.label.split("/")[0] for c in cases}
    assert prefixes == {"part", "assembly", "scene", "flag", "special", "valid", "random edit", "cli"}
    labels = " ".join(c.label for c in cases)
    for category in (
        "alias bomb",
        "nested",
        "huge int",
        "latin-1",
        "utf-16",
        "binary",
        "fifo",
        "dev_zero",
        "directory",
        "oversized",
        "scale",
        "20000 vertices",
        "2001 boxes",
        "contact far",
        "not convex",
        "mixed list",
        "missing part_file",
        "--radius=1e308",
        "--release-speed=1e308",
        "--starts-per-edge=1000000",
        "--throws=100000000",
    ):
        assert category in labels, f"seed {SEED}: no case of {category}"


def test_fuzz_every_case_is_refused_in_one_line_or_answered(tmp_path: Path) -> None:
    cases = generate(SEED, CASES)
    references = _reference_results(tmp_path)
    started = time.monotonic()
    results = _run_pool(cases, tmp_path / "cases")
    elapsed = time.monotonic() - started
    failures = []
    peak = 0.0
    for case, result, folder in results:
        problem = check(case, result, references, folder)
        peak = max(peak, result["rss_mb"])
        if problem:
            failures.append(f"{case.label} {result['seconds']:.2f}s: {problem}")
    print(f"fuzz seed {SEED}: {len(cases)} cases in {elapsed:.1f} s, worker peak RSS {peak:.0f} MB")
    by_kind: dict[str, float] = {}
    for case, result, _ in results:
        kind = case.label.split("/")[0]
        by_kind[kind] = by_kind.get(kind, 0.0) + result["seconds"]
    slowest = sorted(results, key=lambda r: -r[1]["seconds"])[:8]
    print("seconds by kind:", {k: round(v, 1) for k, v in by_kind.items()})
    print("slowest:", [(c.label, round(r["seconds"], 2)) for c, r, _ in slowest])
    assert not failures, f"seed {SEED} (FEEDER_FUZZ_SEED): {len(failures)} failing case(s):\n" + "\n".join(
        failures
    )
    assert peak < RSS_BOUND_MB, f"seed {SEED}: a worker's RSS peaked at {peak:.0f} MB"


def test_ctrl_c_during_a_long_limit_set_is_one_line_not_a_traceback(tmp_path: Path, capsys) -> None:
    from feeder_cell.cli.main import main

    part = tmp_path / "triangle.yaml"
    part.write_bytes(_dump(TRIANGLE))

    def interrupt(signum: int, frame: Any) -> None:
        raise KeyboardInterrupt  # what Python's own SIGINT handler raises

    previous = signal.signal(signal.SIGALRM, interrupt)
    signal.setitimer(signal.ITIMER_REAL, 0.5)  # well into the grid's 400 x 2000 throws (about a minute)
    try:
        code = main(["limit-set", str(part), *THROW_FLAGS, "--starts-per-edge=400", "--throws=2000"])
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    captured = capsys.readouterr()
    assert code == 130
    # One line, saying how far it got ("interrupted after N of M; no result"), and nothing on stdout.
    (line,) = captured.err.splitlines()
    assert line.startswith("feeder limit-set: interrupted") and captured.out == ""
