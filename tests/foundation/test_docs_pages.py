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


def _blocks(text: str) -> list[str]:
    """Return a page's paragraphs and lists (code blocks left out), whitespace normalised."""
    text = re.sub(r"```.*?```", "", text, flags=re.S)
    # Generated tables (docs/nodes.md's per-node parameter tables) and the line that heads each repeat
    # by design, and a picture's alt text says what its caption says.
    text = re.sub(r"<!--.*?-->", "", text, flags=re.S)
    raw = [b for b in re.split(r"\n\s*\n", text) if b.strip()]
    table = [bool(re.search(r"^\s*[|!]", b, flags=re.M)) for b in raw]
    return [
        " ".join(b.split())
        for k, b in enumerate(raw)
        if not table[k] and not (k + 1 < len(raw) and raw[k + 1].lstrip().startswith("|"))
    ]


def repeated_blocks(text: str) -> list[str]:
    """Return the paragraphs or lists a page holds more than once (a pasted contents list, issue 35)."""
    seen: set[str] = set()
    out = []
    for block in _blocks(text):
        if block in seen and len(block) > 40:
            out.append(block[:80])
        seen.add(block)
    return out


def repeated_phrases(text: str, words: int = 9) -> list[str]:
    """Return runs of ``words`` words that two different paragraphs of a page share (a said-twice)."""
    where: dict[tuple[str, ...], int] = {}
    out = []
    for k, block in enumerate(_blocks(text)):
        tokens = re.findall(r"[\w`'/.-]+", block.lower())
        for i in range(len(tokens) - words + 1):
            key = tuple(tokens[i : i + words])
            if where.setdefault(key, k) != k:
                out.append(" ".join(key))
    return out


def test_no_page_repeats_a_paragraph_or_its_contents_list() -> None:
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    for page in pages:
        assert not repeated_blocks(page.read_text()), (page.name, repeated_blocks(page.read_text()))
    # and the check can fail: a contents list pasted twice, a paragraph said twice in other words
    listed = "- [Conventions](#conventions)\n- [Names](#names)\n- [Worked example](#worked-example)\n"
    assert repeated_blocks(f"Contents:\n\n{listed}\n{listed}")
    said = "It draws every planner step's result and the recorded run's timeline into the folder."
    assert repeated_phrases(f"{said}\n\nThen {said.lower()}")


def test_the_readme_says_what_make_demo_produced_once() -> None:
    readme = (ROOT / "README.md").read_text()
    section = readme.split("## What `make demo` produced", 1)[1].split("\n## ", 1)[0]
    assert not repeated_phrases(section, words=6), repeated_phrases(section, words=6)
    assert section.count("draws") == 1
