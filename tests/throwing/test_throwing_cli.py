"""`feeder throw` / `feeder limit-set` per the contract: JSON in SI, file units on the command line, bad
input.
"""

import json
import math

import pytest
from throwing_helpers import EXAMPLES, TRIANGLE_PARAMS

from feeder_cell.cli.main import main
from feeder_planner.errors import InputError
from feeder_planner.parts import load_part
from feeder_planner.throwing.geometry import arm_part
from feeder_planner.throwing.grasp import grasp_radius
from feeder_planner.throwing.throw_map import ThrowParams, throw

TRI = str(EXAMPLES / "triangle.yaml")
PAPER = ["--offset", "-0.5", "--release-speed", "320deg", "--gravity", "-966", "--mu", "0.5"]


def _run(capsys, argv):
    code = main(argv)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_throw_json_is_si_and_matches_the_library(capsys):
    code, out, err = _run(capsys, ["throw", TRI, "--edge", "1", "--radius", "12", *PAPER, "--json"])
    assert code == 0 and err == ""
    result = json.loads(out)
    expected = throw(arm_part(load_part(TRI)), 1, 0.12, TRIANGLE_PARAMS)
    assert result["edge"] == expected.edge and result["kind"] == expected.kind
    assert math.isclose(result["radius"], expected.radius, rel_tol=1e-12)
    assert 0.05 < result["radius"] < 0.5  # metres, not centimetres


def test_release_speed_in_radians_equals_degrees(capsys):
    argv = [
        "throw",
        TRI,
        "--edge",
        "1",
        "--radius",
        "12",
        "--offset",
        "-0.5",
        "--gravity",
        "-966",
        "--mu",
        "0.5",
        "--json",
        "--release-speed",
    ]
    _, a, _ = _run(capsys, argv + ["320deg"])
    _, b, _ = _run(capsys, argv + [repr(math.radians(320))])
    assert json.loads(a) == json.loads(b)


def test_limit_set_json_has_contract_keys(capsys):
    code, out, _ = _run(
        capsys,
        ["limit-set", TRI, *PAPER, "--goal-edge", "1", "--starts-per-edge", "6", "--throws", "200", "--json"],
    )
    assert code == 0
    r = json.loads(out)
    for key in ("stable_edges", "grasp_radius", "cycle", "edge_radius_ranges", "trigger"):
        assert key in r
    assert r["cycle"]["edges"] and r["cycle"]["throws_per_cycle"] > 0
    assert r["trigger"]["goal_edge"] == 1
    lo, hi = r["trigger"]["radius_range"]
    assert lo < hi
    assert set(r["grasp_radius"]) == {str(i) for i in r["stable_edges"]}


@pytest.mark.parametrize(
    "change,flag",
    [
        (("--gravity", "966"), "--gravity"),
        (("--gravity", "0"), "--gravity"),
        (("--release-speed", "0"), "--release-speed"),
        (("--release-speed", "-3"), "--release-speed"),
        (("--mu", "0"), "--mu"),
        (("--mu", "-1"), "--mu"),
        (("--radius", "1"), "--radius"),
        (("--radius", "nan"), "--radius"),
        (("--edge", "7"), "--edge"),
    ],
)
def test_bad_flags_exit_2_with_one_line_naming_the_flag(capsys, change, flag):
    argv = ["throw", TRI, "--edge", "1", "--radius", "12", *PAPER]
    i = argv.index(change[0])
    argv[i + 1] = change[1]
    try:
        code = main(argv)
    except SystemExit as stop:
        code = stop.code
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len([line for line in err if not line.startswith("usage")]) == 1
    assert flag in err[-1]


def test_non_simple_polygon_names_file_and_field(tmp_path, capsys):
    bad = tmp_path / "bow.yaml"
    bad.write_text("name: bow\nvertices: [[0, 0], [1, 1], [1, 0], [0, 1]]\n")
    code, out, err = _run(capsys, ["limit-set", str(bad), *PAPER])
    assert code == 2 and out == ""
    assert str(bad) in err and "vertices" in err and len(err.strip().splitlines()) == 1


def test_unstable_goal_edge_is_refused(capsys):
    code, _, err = _run(
        capsys,
        [
            "limit-set",
            str(EXAMPLES / "bracket.yaml"),
            "--offset",
            "-0.25",
            "--release-speed",
            "320deg",
            "--gravity",
            "-220",
            "--mu",
            "0.5",
            "--goal-edge",
            "3",
            "--starts-per-edge",
            "3",
            "--throws",
            "60",
        ],
    )
    assert code == 2 and "--goal-edge" in err


def test_radius_error_is_in_the_file_unit(capsys):
    code, _, err = _run(capsys, ["throw", TRI, "--edge", "1", "--radius", "1", *PAPER])
    assert code == 2 and "R = 1 cm" in err and "R_grasp = 1.97" in err


def test_throw_design_json_table(capsys):
    code, out, _ = _run(
        capsys,
        [
            "throw-design",
            TRI,
            "--offsets",
            "-0.5",
            "-0.2",
            "--release-speeds",
            "320deg",
            "--gravity",
            "-966",
            "--mu",
            "0.5",
            "--goal-edge",
            "1",
            "--json",
        ],
    )
    assert code == 0
    r = json.loads(out)
    assert len(r["designs"]) == 2 and r["goal_edge"] == 1
    assert all(math.isclose(d["release_speed"], math.radians(320)) for d in r["designs"])
    assert {round(d["offset"], 6) for d in r["designs"]} == {-0.005, -0.002}  # metres in JSON
    assert r["best"] is not None  # h = -0.5 cm is the paper's design: unique, with a trigger range
    assert r["best"]["unique"] and r["best"]["width"] == max(d["width"] for d in r["designs"] if d["unique"])


def test_cli_radius_check_is_the_core_domain_check_at_r_grasp(capsys):
    # Bracket edge 1 (file in cm): R_grasp is above the stubbed-toe bound, so R = R_grasp is throwable.
    bracket = str(EXAMPLES / "bracket.yaml")
    part = arm_part(load_part(bracket))
    r_grasp_cm = grasp_radius(part, 1, -0.0025, 0.5) / 0.01
    flags = [
        "--edge",
        "1",
        "--offset",
        "-0.25",
        "--release-speed",
        "320deg",
        "--gravity",
        "-220",
        "--mu",
        "0.5",
    ]
    code, out, _ = _run(capsys, ["throw", bracket, *flags, "--radius", repr(r_grasp_cm), "--json"])
    assert code == 0 and json.loads(out)["kind"] in ("jog", "flip")
    below = repr(r_grasp_cm * (1 - 1e-9))
    code, _, err = _run(capsys, ["throw", bracket, *flags, "--radius", below])
    assert code == 2 and "--radius" in err and f"R_grasp = {r_grasp_cm:.6g} cm" in err
    with pytest.raises(InputError):
        throw(part, 1, float(below) * 0.01, ThrowParams(-0.0025, math.radians(320), -2.2, 0.5))
