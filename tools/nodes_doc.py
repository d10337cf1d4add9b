"""Write the parameter tables of docs/nodes.md from the nodes' own parameter declarations.

Each node section of docs/nodes.md holds a block between ``<!-- parameters EXECUTABLE -->`` and
``<!-- end parameters -->``; this script rewrites every block from the declarations the node declares at
start-up (its module's ``PARAMETERS``: name, default, read-only, description), so the page cannot drift
from the code. ``--check`` changes nothing and exits 1 naming the first block that differs (the test
``tests/foundation/test_nodes_doc.py`` runs it).

    python tools/nodes_doc.py           # rewrite the tables
    python tools/nodes_doc.py --check   # exit 1 if the page and the declarations disagree
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "nodes.md"
# Each node of the page, by the package that installs it: every node module of the three node packages
# (an executable of its own name, docs/devices.md), so a new node needs its section here, not a line.
PACKAGES = ("feeder_sim", "feeder_planner", "feeder_cell")
NODES = {
    path.stem: package
    for package in PACKAGES
    for path in sorted((ROOT / package / package / "nodes").glob("[a-z]*.py"))
}
BLOCK = re.compile(r"(<!-- parameters (\w+) -->\n)(.*?)(<!-- end parameters -->)", re.S)


def _default(value: object) -> str:
    text = json.dumps(value) if isinstance(value, (list, str, bool)) else repr(value)
    return f"`{text}`"


def table(executable: str) -> str:
    """Return the markdown table of one node's declared parameters, in declaration order."""
    from feeder_cell.node_modules import declared_parameters

    specs = declared_parameters(NODES[executable], executable)
    if not specs:
        raise SystemExit(f"nodes_doc: {executable} declares no parameters (or its module did not import)")
    rows = ["| parameter | default | when | description |", "| --- | --- | --- | --- |"]
    for spec in specs.values():
        when = "read-only" if spec.read_only else "runtime"
        description = spec.description.replace("|", "\\|").replace("\n", " ")
        rows.append(f"| `{spec.name}` | {_default(spec.default)} | {when} | {description} |")
    return "\n".join(rows) + "\n"


def render(text: str) -> str:
    """Return the page with every parameter block rewritten."""
    seen: set[str] = set()

    def block(match: re.Match[str]) -> str:
        executable = match.group(2)
        if executable not in NODES:
            raise SystemExit(f"nodes_doc: docs/nodes.md has a block for unknown node {executable!r}")
        seen.add(executable)
        return match.group(1) + table(executable) + match.group(4)

    rendered = BLOCK.sub(block, text)
    missing = sorted(set(NODES) - seen)
    if missing:
        raise SystemExit(f"nodes_doc: docs/nodes.md has no parameter block for {', '.join(missing)}")
    return rendered


def main() -> int:
    """Rewrite (or check) docs/nodes.md's parameter tables."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="change nothing; exit 1 if the page differs")
    args = parser.parse_args()
    text = PAGE.read_text()
    rendered = render(text)
    if args.check:
        if rendered != text:
            for old, new in zip(BLOCK.finditer(text), BLOCK.finditer(rendered), strict=True):
                if old.group(0) != new.group(0):
                    print(
                        f"docs/nodes.md: the parameters of {old.group(2)} differ from its declarations; "
                        "run python tools/nodes_doc.py",
                        file=sys.stderr,
                    )
                    return 1
        return 0
    PAGE.write_text(rendered)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
