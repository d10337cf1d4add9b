"""The README leads and the reference pages hold the rest: the node parameter tables cannot drift.

docs/nodes.md's parameter tables are written by ``tools/nodes_doc.py`` from each node's own parameter
declarations; this test fails when the page and the declarations disagree (run the tool to fix it).
"""

from __future__ import annotations

import importlib.util
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _tool() -> object:
    spec = importlib.util.spec_from_file_location("nodes_doc", ROOT / "tools" / "nodes_doc.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_node_pages_parameter_tables_are_the_declarations() -> None:
    result = subprocess.run(
        [sys.executable, str(ROOT / "tools" / "nodes_doc.py"), "--check"], capture_output=True, text=True
    )
    assert result.returncode == 0, result.stderr
    # and the check can fail: a changed default is caught, naming the node
    tool = _tool()
    page = (ROOT / "docs" / "nodes.md").read_text()
    tampered = page.replace("| `quantum` | `0.1` |", "| `quantum` | `0.2` |", 1)
    assert tampered != page
    assert tool.render(tampered) != tampered  # type: ignore[attr-defined]
    assert tool.render(page) == page  # type: ignore[attr-defined]


def test_the_readme_is_short_and_its_tables_narrow() -> None:
    lines = (ROOT / "README.md").read_text().splitlines()
    assert len(lines) <= 250
    wide = [n for n, line in enumerate(lines, 1) if line.startswith("|") and len(line) > 200]
    assert wide == [], f"README table rows over 200 characters at lines {wide}"
    # every page the README's map names exists, and every reference page has a table of contents
    for page in re.findall(r"\]\((docs/[\w.]+\.md)\)", "\n".join(lines)):
        assert (ROOT / page).is_file(), page
    for page in sorted((ROOT / "docs").glob("*.md")):
        text = page.read_text()
        assert "Contents:" in text, page.name
        # every contents link lands on a heading of the page (GitHub's anchors: lower case, spaces to
        # dashes, punctuation other than - and _ dropped)
        anchors = {
            re.sub(r"[^\w\- ]", "", h.strip().lower()).replace(" ", "-")
            for h in re.findall(r"^#{2,4} (.+)$", text, re.MULTILINE)
        }
        toc = text.split("Contents:", 1)[1].split("\n## ", 1)[0]
        missing = [a for a in re.findall(r"\]\(#([^)]+)\)", toc) if a not in anchors]
        assert missing == [], f"{page.name}: contents links without a heading: {missing}"
