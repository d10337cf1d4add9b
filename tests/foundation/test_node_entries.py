"""Every node module is an executable of its own name, with no line of its own anywhere.

Each node package's setup.py makes a console script of every module in its nodes/ folder, and the
package's ``__getattr__`` makes the script's entry on demand (feeder_planner.entry_points.node_main),
holding the stop signals before it imports the module.
"""

from __future__ import annotations

import runpy
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
import setuptools

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("feeder_sim", "feeder_planner", "feeder_cell")


def _scripts(package: str, monkeypatch: pytest.MonkeyPatch) -> list[str]:
    seen: dict[str, Any] = {}
    monkeypatch.setattr(setuptools, "setup", lambda **kwargs: seen.update(kwargs))
    monkeypatch.chdir(ROOT / package)
    runpy.run_path(str(ROOT / package / "setup.py"))
    return list(seen["entry_points"]["console_scripts"])


@pytest.mark.parametrize("package", PACKAGES)
def test_each_node_module_is_a_console_script_of_its_name(
    package: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    modules = sorted(p.stem for p in (ROOT / package / package / "nodes").glob("[a-z]*.py"))
    assert modules, package
    scripts = _scripts(package, monkeypatch)
    for module in modules:
        assert f"{module} = {package}.nodes:{module}_main" in scripts, (module, scripts)


@pytest.mark.parametrize("package", PACKAGES)
def test_an_entry_is_made_without_importing_its_module_and_an_unknown_one_is_refused(package: str) -> None:
    # In a fresh interpreter: whether the node module was imported is the point.
    probe = f"""
import importlib, sys
from pathlib import Path
nodes = importlib.import_module("{package}.nodes")
names = sorted(p.stem for p in Path(nodes.__file__).parent.glob("[a-z]*.py"))
for name in names:
    entry = getattr(nodes, name + "_main")
    assert callable(entry) and "{package}.nodes." + name not in sys.modules, name
for bad in ("nothing_main", "__init___main", "main", "throwing_arm"):
    try:
        getattr(nodes, bad)
    except AttributeError:
        continue
    raise SystemExit("no AttributeError for " + bad)
print(len(names))
"""
    run = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    assert int(run.stdout) >= 4
