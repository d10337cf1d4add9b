"""Setup is idempotent and stops at once, with a hint, when a build tool is missing."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def test_second_setup_changes_nothing() -> None:
    result = subprocess.run(
        ["bash", str(ROOT / "tools/setup.sh")], capture_output=True, text=True, timeout=300
    )
    assert result.returncode == 0, result.stderr
    # A no-op run neither installs packages nor rebuilds the workspace.
    assert "installing" not in result.stdout
    assert "building" not in result.stdout


def _path_without(tmp_path: Path, missing: set[str]) -> str:
    """A PATH holding links to the tools setup.sh uses, less the ``missing`` ones."""
    tools = [
        "dirname",
        "sha256sum",
        "cut",
        "find",
        "sort",
        "cat",
        "chmod",
        "mv",
        "python3",
        "python3.11",
        "cmake",
        "c++",
        "g++",
        "cc",
        "gcc",
    ]
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    for tool in tools:
        found = shutil.which(tool)
        if found and tool not in missing:
            (bin_dir / tool).symlink_to(found)
    return str(bin_dir)


@pytest.mark.parametrize("missing, named", [({"cmake"}, "cmake"), ({"c++", "g++"}, "C++ compiler")])
def test_missing_build_tool_stops_setup_with_its_name_and_install_hint(
    tmp_path: Path, missing: set[str], named: str
) -> None:
    env = dict(os.environ, PATH=_path_without(tmp_path, missing))
    result = subprocess.run(
        [shutil.which("bash"), str(ROOT / "tools/setup.sh")],
        capture_output=True,
        text=True,
        env=env,
        timeout=60,
    )
    assert result.returncode == 1
    assert named in result.stderr
    assert "apt-get install" in result.stderr
