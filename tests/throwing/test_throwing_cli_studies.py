"""`feeder limit-set` attractors and `feeder throw-design` progress, Ctrl-C and --robust (issues 14, 16)."""

import json
import os
import re
import signal
import subprocess
import sys
import time

import numpy as np
from throwing_helpers import EXAMPLES

from feeder_cell.cli.main import main

TRI = str(EXAMPLES / "triangle.yaml")
CONVEX12 = str(EXAMPLES / "convex12.yaml")
PAPER = ["--offset", "-0.5", "--release-speed", "320deg", "--gravity", "-966", "--mu", "0.5"]
CONVEX12_FLAGS = ["--offset", "-0.3", "--release-speed", "320deg", "--gravity", "-9660", "--mu", "0.5"]


def _run(capsys, argv):
    code = main(argv)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_limit_set_json_lists_the_attractors(capsys):
    code, out, err = _run(
        capsys, ["limit-set", TRI, *PAPER, "--goal-edge", "1", "--starts-per-edge", "4", "--json"]
    )
    # Nothing on stderr but the progress lines the command writes once it has run PROGRESS_AFTER s (a
    # loaded machine gets there): no warning, no error.
    progress = re.compile(r"feeder limit-set: \d+ of \d+ done \(\d+ s; about \d+ s left\)")
    assert code == 0 and all(progress.fullmatch(line) for line in err.splitlines()), err
    result = json.loads(out)
    assert result["unique"] and result["converged"] and result["cycle"]["edges"] == [1, 0, 2]
    (a,) = result["attractors"]
    assert a["periodic"] and a["cycle"] == [1, 0, 2] and a["basin"] == 1.0
    assert len(a["throws_per_round"]) == 3 and a["pattern"] == [[1, 1, 1], [0, 1, 1], [2, 1, 1]]
    assert set(a["assumption_violations"]) == {"lift_off", "slip", "off_arm"}


def test_limit_set_with_too_few_throws_says_the_search_did_not_converge(capsys):
    code, out, err = _run(capsys, ["limit-set", CONVEX12, *CONVEX12_FLAGS, "--throws", "12"])
    assert code == 3 and out == ""
    assert err.count("\n") == 1 and "did not converge" in err and "--throws" in err


def test_throw_design_robust_flags_are_checked(capsys):
    flags = ["--offsets", "-0.5", "--release-speeds", "320deg", "--gravity", "-966", "--mu", "0.5"]
    code, _, err = _run(capsys, ["throw-design", TRI, *flags, "--goal-edge", "1", "--robust", "0"])
    assert code == 2 and "--robust" in err
    code, _, err = _run(
        capsys, ["throw-design", TRI, *flags, "--goal-edge", "1", "--robust", "2", "--speed-sigma", "2"]
    )
    assert code == 2 and "--speed-sigma" in err and err.count("\n") == 1
    code, out, err = _run(
        capsys,
        ["throw-design", TRI, *flags, "--goal-edge", "1", "--robust", "2", "--mu-sigma", "0.05", "--json"],
    )
    assert code == 0
    result = json.loads(out)
    assert result["samples"] == 2 and result["points"][0]["p_unique"] in (0.0, 0.5, 1.0)


def test_throw_design_shows_progress_and_stops_cleanly_on_ctrl_c():
    offsets = [f"{v:.3f}" for v in np.linspace(-0.8, -0.1, 40)]
    speeds = [f"{v:.1f}deg" for v in np.linspace(250, 400, 40)]
    argv = [sys.executable, "-m", "feeder_cell.cli.main", "throw-design", TRI, "--offsets", *offsets]
    argv += ["--release-speeds", *speeds, "--gravity", "-966", "--mu", "0.5", "--goal-edge", "1"]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=os.environ)
    try:
        assert proc.stderr is not None
        line = proc.stderr.readline()  # the first progress line (1,600 designs take far longer than 2 s)
        assert "throw-design:" in line and "of 1600 done" in line, line
        proc.send_signal(signal.SIGINT)
        deadline = time.monotonic() + 60
        while proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        out, err = proc.communicate(timeout=5)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 130 and out == ""
    assert "interrupted after" in err and "Traceback" not in err


def test_limit_set_reports_progress_on_a_long_run(capsys, monkeypatch):
    # A long run (a part with many hull vertices takes minutes) says how far it is; here every
    # window reports, since the threshold is set to zero, and the result is still one JSON object.
    import feeder_cell.cli.throwing_studies as studies

    monkeypatch.setattr(studies, "PROGRESS_AFTER", 0.0)
    code, out, err = _run(
        capsys, ["limit-set", CONVEX12, *CONVEX12_FLAGS, "--starts-per-edge", "2", "--json"]
    )
    assert code == 0, err
    lines = err.splitlines()
    assert lines and all(line.startswith("feeder limit-set: ") and " done (" in line for line in lines), lines
    assert json.loads(out)["converged"]
