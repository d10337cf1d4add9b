"""The feeder command's shell contract: help, usage errors, doctor's real checks, run's resolution."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

FEEDER = [sys.executable, "-m", "feeder_cell.cli.main"]


def feeder(
    *args: str, env: dict[str, str] | None = None, timeout: float = 60.0
) -> subprocess.CompletedProcess:
    return subprocess.run(
        [*FEEDER, *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        env=env if env is not None else dict(os.environ),
    )


def test_help_lists_subcommands_and_units() -> None:
    result = feeder("--help")
    assert result.returncode == 0
    for word in ("doctor", "run", "radians", "SI"):
        assert word in result.stdout


def test_the_command_table_names_what_each_module_registers() -> None:
    """`feeder COMMAND` imports only the module the table gives; a command missing from it would be lost."""
    import argparse
    import importlib

    from feeder_cell.cli import SUBCOMMANDS, modules_for

    for module, commands in SUBCOMMANDS.items():
        subparsers = argparse.ArgumentParser().add_subparsers()
        importlib.import_module(module).register(subparsers)
        assert tuple(subparsers.choices) == commands, module
        for command in commands:
            assert modules_for(command) == (module,)
    assert modules_for("frobnicate") == tuple(SUBCOMMANDS)


def test_a_command_imports_only_its_own_module() -> None:
    """`feeder bag-info` must not pay for the other commands' modules or the experiment's scipy."""
    probe = (
        "import sys\n"
        "from feeder_cell.cli import main\n"
        "try:\n"
        "    main.main(['bag-info', '--help'])\n"
        "except SystemExit:\n"
        "    pass\n"
        "print(sorted(m for m in sys.modules if m.startswith(('feeder_cell.', 'scipy.optimize'))))\n"
    )
    result = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=60)
    assert "usage: feeder bag-info" in result.stdout, result.stderr
    loaded = result.stdout.strip().splitlines()[-1]
    assert "'feeder_cell.cli.bag'" in loaded, loaded
    for other in ("'feeder_cell.cli.launch'", "'feeder_cell.experiment", "'scipy.optimize"):
        assert other not in loaded, loaded


@pytest.mark.parametrize("args", [("frobnicate",), ("doctor", "--no-such-flag"), ()])
def test_unknown_subcommand_or_flag_exits_2_with_usage(args: tuple[str, ...]) -> None:
    result = feeder(*args)
    assert result.returncode == 2
    assert "usage: feeder" in result.stderr
    assert "Traceback" not in result.stderr


@pytest.mark.ros
def test_doctor_passes_every_check_with_a_real_dds_round_trip(ros_domain: int) -> None:
    result = feeder("doctor")
    lines = result.stdout.strip().splitlines()
    assert result.returncode == 0, result.stdout + result.stderr
    assert len(lines) == 4
    assert all(line.startswith("OK") for line in lines)
    assert "rmw_fastrtps_cpp" in lines[1]
    assert "echo after" in lines[3]


@pytest.mark.ros
def test_doctor_reports_a_missing_rmw_with_a_fix_and_exit_1(ros_domain: int) -> None:
    env = dict(os.environ, RMW_IMPLEMENTATION="rmw_no_such_dds_cpp")
    result = feeder("doctor", env=env)
    assert result.returncode == 1
    failing = [line for line in result.stdout.splitlines() if line.startswith("FAIL")]
    assert failing and all("fix:" in line for line in failing)
    assert any("RMW" in line for line in failing)


def test_run_names_a_missing_executable_and_lists_the_available_ones() -> None:
    result = feeder("run", "feeder_sim", "no_such_node")
    assert result.returncode == 2
    assert "no_such_node" in result.stderr and "mems_field_array" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1


def test_run_names_a_missing_package() -> None:
    result = feeder("run", "no_such_package", "node")
    assert result.returncode == 2
    assert "no_such_package" in result.stderr


def test_a_swallowed_ctrl_c_is_seen_by_subcommands_when_the_cli_runs_as_python_m():
    """``python -m feeder_cell.cli.main`` makes a second copy of cli.main; the request must not live in it.

    The script takes Ctrl-C through a copy of cli.main as ``-m`` makes it, swallows the KeyboardInterrupt
    as an import lock's callback does, and asks a subcommand's module whether Ctrl-C came.
    """
    script = (
        "import os, runpy, signal\n"
        "copy = runpy.run_module('feeder_cell.cli.main', run_name='as_python_m')\n"
        "copy['take_ctrl_c']()\n"
        "try:\n"
        "    os.kill(os.getpid(), signal.SIGINT)\n"
        "except KeyboardInterrupt:\n"
        "    pass\n"
        "from feeder_cell.cli.throwing_studies import check_ctrl_c\n"
        "try:\n"
        "    check_ctrl_c()\n"
        "except KeyboardInterrupt:\n"
        "    print('seen')\n"
        "else:\n"
        "    print('lost')\n"
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "seen", done.stdout + done.stderr


def _run_with_site(tmp_path: Path, site: str, module: str, argv: list[str]) -> subprocess.CompletedProcess:
    """Run ``argv`` from the repository with ``site`` as its sitecustomize, aimed at ``module``."""
    (tmp_path / "sitecustomize.py").write_text(site)
    path = os.pathsep.join(p for p in (str(tmp_path), os.environ.get("PYTHONPATH", "")) if p)
    env = dict(os.environ, PYTHONPATH=path, FEEDER_TEST_SIGINT_AT=module)
    return subprocess.run(argv, capture_output=True, text=True, timeout=120, env=env, cwd=ROOT)


# A sitecustomize that sends this process SIGINT as the module named first on its command line is
# looked up: deterministically inside the imports of cli.main (or program), before main() runs.
SIGINT_AT_IMPORT = """
import os, signal, sys
class _InterruptAt:
    def find_spec(self, name, path=None, target=None):
        if name == os.environ["FEEDER_TEST_SIGINT_AT"]:
            sys.meta_path.remove(self)
            os.kill(os.getpid(), signal.SIGINT)
        return None
sys.meta_path.insert(0, _InterruptAt())
"""


@pytest.mark.parametrize(
    "entry", [["-m", "feeder_cell.cli.main"], ["-c", "from feeder_cell.cli.program import run; run()"]]
)
def test_ctrl_c_during_the_commands_own_imports_ends_it_with_the_interrupted_line_and_130(
    entry: list[str], tmp_path: Path
) -> None:
    argv = [sys.executable, *entry, "part-info", "examples/throwing/triangle.yaml"]
    done = _run_with_site(tmp_path, SIGINT_AT_IMPORT, "feeder_planner.errors", argv)
    assert done.returncode == 130, done.stderr[-1500:]
    assert done.stdout == "" and "Traceback" not in done.stderr
    assert done.stderr.strip() == "feeder: interrupted"


# A sitecustomize whose hook, as the module named in FEEDER_TEST_SIGINT_AT is first looked up, makes a
# class whose __set_name__ gets SIGINT: Python raises the handler's KeyboardInterrupt out of the class
# body as a RuntimeError ("Error calling __set_name__"), as a dataclass field did in a real import.
SIGINT_IN_SET_NAME = """
import os, signal, sys
class _SignalOnSetName:
    def __set_name__(self, owner, name):
        os.kill(os.getpid(), signal.SIGINT)
        for _ in range(10**7):  # the handler runs here, inside __set_name__
            pass
class _InterruptAt:
    def find_spec(self, name, path=None, target=None):
        if name == os.environ["FEEDER_TEST_SIGINT_AT"]:
            sys.meta_path.remove(self)
            type("Wrapped", (), {"field": _SignalOnSetName()})
        return None
sys.meta_path.insert(0, _InterruptAt())
"""


@pytest.mark.parametrize(
    ("module", "line"),
    [
        ("feeder_planner.parts", "feeder: interrupted"),  # while the subcommand's module is imported
        ("dask", "feeder throw-design: interrupted"),  # while the subcommand runs (its Dask import)
    ],
)
def test_ctrl_c_that_python_wraps_in_another_exception_still_ends_the_command_as_interrupted(
    module: str, line: str, tmp_path: Path
) -> None:
    """Before: the RuntimeError's traceback and exit 1. After: the interrupted line and 130."""
    argv = [*FEEDER, "throw-design", "examples/throwing/triangle.yaml", "--offsets", "-0.5"]
    argv += ["--release-speeds", "300deg", "--gravity", "-966", "--mu", "0.5", "--goal-edge", "1"]
    argv += ["--robust", "4", "--speed-sigma", "0.03", "--workers", "2"]
    done = _run_with_site(tmp_path, SIGINT_IN_SET_NAME, module, argv)
    assert done.returncode == 130, done.stderr[-1500:]
    assert done.stdout == "" and "Traceback" not in done.stderr, done.stderr[-1500:]
    assert done.stderr.strip() == line
