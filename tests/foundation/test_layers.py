"""The layers and their one-way dependencies, checked by walking every import of the three packages.

    feeder_msgs <- feeder_planner (core, node kit, planner nodes) <- feeder_device (device kit)
                <- feeder_sim (core, nodes) <- feeder_cell

The core (mechanics, fidelity models, the device kit's ROS-free declarations) never imports rclpy or a
message package; only the node kit, the device kit's node side, the node modules and feeder_cell do. No
node module imports another node module.
"""

from __future__ import annotations

import ast
import subprocess
import sys
import textwrap
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("feeder_planner", "feeder_device", "feeder_sim", "feeder_cell")
# The device kit's ROS-free modules: what a model package may import of it.
DEVICE_KIT_CORE = (
    "feeder_device",
    "feeder_device.declarations",
    "feeder_device.parameters",
    "feeder_device.rate",
)
# ROS client library and interface packages: what the ROS-free core must never import.
ROS_MODULES = ("rclpy", "rcl_interfaces", "builtin_interfaces", "rosgraph_msgs", "lifecycle_msgs")


@dataclass(frozen=True)
class Import:
    importer: str  # dotted module name of the file
    imported: str  # dotted module name it imports
    line: int


def module_name(path: Path) -> str:
    relative = path.relative_to(ROOT / path.relative_to(ROOT).parts[0])
    parts = list(relative.with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def source_files() -> list[Path]:
    return sorted(p for package in PACKAGES for p in (ROOT / package / package).rglob("*.py"))


def imports_of(path: Path) -> list[Import]:
    name = module_name(path)
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: list[Import] = []

    def visit(node: ast.AST) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.Import):
                found.extend(Import(name, alias.name, child.lineno) for alias in child.names)
            elif isinstance(child, ast.ImportFrom):
                base = child.module or ""
                if child.level:
                    anchor = package.split(".")[: len(package.split(".")) - child.level + 1]
                    base = ".".join([*anchor, base] if base else anchor)
                found.append(Import(name, base, child.lineno))
                # ``from pkg import module`` imports a module too
                found.extend(Import(name, f"{base}.{alias.name}", child.lineno) for alias in child.names)
            visit(child)

    visit(tree)
    return found


ALL_IMPORTS = [imp for path in source_files() for imp in imports_of(path)]
MODULES = {module_name(path) for path in source_files()}


def is_node_module(module: str) -> bool:
    parts = module.split(".")
    return len(parts) >= 3 and parts[1] == "nodes"


def is_core(module: str) -> bool:
    top, _, rest = module.partition(".")
    if top == "feeder_cell":
        return False
    if top == "feeder_device":
        return module in DEVICE_KIT_CORE
    return not (rest.startswith("nodes") or rest.startswith("node_kit"))


def in_device_kit_core(imported: str) -> bool:
    # ``from feeder_device.declarations import CounterSpec`` records the name too: its module counts
    return imported in DEVICE_KIT_CORE or imported.rpartition(".")[0] in DEVICE_KIT_CORE[1:]


def is_ros(module: str) -> bool:
    top = module.split(".")[0]
    return top in ROS_MODULES or top.endswith("_msgs") or top.endswith("_srvs")


def violations(rule) -> list[str]:
    return [f"{i.importer} imports {i.imported} (line {i.line})" for i in ALL_IMPORTS if rule(i)]


def test_the_walk_sees_every_layer() -> None:
    # Guards the walk itself: an empty walk would pass every rule below.
    assert {
        "feeder_planner.parts",
        "feeder_planner.node_kit",
        "feeder_device.device",
        "feeder_device.declarations",
        "feeder_sim.nodes.throwing_arm",
        "feeder_cell.cli.main",
        "feeder_cell.launcher",
    } <= MODULES
    assert any(i.imported == "rclpy" for i in ALL_IMPORTS)


def test_planner_never_imports_sim_or_cell() -> None:
    assert (
        violations(
            lambda i: (
                i.importer.startswith("feeder_planner")
                and i.imported.split(".")[0] in ("feeder_device", "feeder_sim", "feeder_cell")
            )
        )
        == []
    )


def test_device_kit_never_imports_sim_or_cell() -> None:
    assert (
        violations(
            lambda i: (
                i.importer.startswith("feeder_device")
                and i.imported.split(".")[0] in ("feeder_sim", "feeder_cell")
            )
        )
        == []
    )


def test_sim_never_imports_cell() -> None:
    assert (
        violations(lambda i: i.importer.startswith("feeder_sim") and i.imported.startswith("feeder_cell"))
        == []
    )


def test_no_node_imports_another_node() -> None:
    assert (
        violations(
            lambda i: (
                is_node_module(i.imported) and i.importer != i.imported and not i.imported.endswith(".nodes")
            )
        )
        == []
    )


def test_core_imports_neither_ros_nor_the_node_kit() -> None:
    assert (
        violations(
            lambda i: (
                is_core(i.importer)
                and (
                    is_ros(i.imported)
                    or ".node_kit" in i.imported
                    or ".nodes" in i.imported
                    or (i.imported.startswith("feeder_device") and not in_device_kit_core(i.imported))
                )
            )
        )
        == []
    )


def test_only_nodes_kit_and_cell_import_rclpy() -> None:
    assert violations(lambda i: i.imported.split(".")[0] == "rclpy" and is_core(i.importer)) == []


def test_no_import_cycles() -> None:
    # Every import counts, also those inside functions or under TYPE_CHECKING: deferring one side of a
    # cycle hides it from the interpreter, not from a reader.
    graph: dict[str, set[str]] = {m: set() for m in MODULES}
    for i in ALL_IMPORTS:
        if i.imported in MODULES and i.imported != i.importer:
            # a package's __init__ is imported with any of its modules, but is not a cycle by that alone
            if not i.importer.startswith(i.imported + "."):
                graph[i.importer].add(i.imported)
    cycles = strongly_connected(graph)
    assert [sorted(c) for c in cycles if len(c) > 1] == []


def strongly_connected(graph: dict[str, set[str]]) -> list[set[str]]:
    """Tarjan's algorithm, iterative over the recursion stack of the walk."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    on_stack: set[str] = set()
    stack: list[str] = []
    components: list[set[str]] = []
    counter = 0
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, successors = work[-1]
            advanced = False
            for succ in successors:
                if succ not in index:
                    index[succ] = low[succ] = counter
                    counter += 1
                    stack.append(succ)
                    on_stack.add(succ)
                    work.append((succ, iter(sorted(graph[succ]))))
                    advanced = True
                    break
                if succ in on_stack:
                    low[node] = min(low[node], index[succ])
            if advanced:
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = set()
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.add(member)
                    if member == node:
                        break
                components.append(component)
    return components


def test_cycle_finder_finds_a_cycle() -> None:
    assert [sorted(c) for c in strongly_connected({"a": {"b"}, "b": {"a"}, "c": {"a"}}) if len(c) > 1] == [
        ["a", "b"]
    ]


CORE_MODULES = sorted(m for m in MODULES if is_core(m))


@pytest.mark.parametrize("blocked", [ROS_MODULES])
def test_every_core_module_imports_with_ros_blocked(blocked: tuple[str, ...]) -> None:
    script = textwrap.dedent(f"""
        import importlib, importlib.abc, sys
        BLOCKED = {blocked!r}

        class Block(importlib.abc.MetaPathFinder):
            def find_spec(self, name, path=None, target=None):
                top = name.split('.')[0]
                if top in BLOCKED or top.endswith('_msgs') or top.endswith('_srvs'):
                    raise ImportError(f'blocked for the core: {{name}}')
                return None

        sys.meta_path.insert(0, Block())
        for name in {CORE_MODULES!r}:
            importlib.import_module(name)
        leaked = sorted(m for m in sys.modules if m.split('.')[0] in BLOCKED)
        assert not leaked, leaked
        print(len({CORE_MODULES!r}))
    """)
    paths = [str(ROOT / package) for package in PACKAGES]
    result = subprocess.run(
        [sys.executable, "-c", script],
        capture_output=True,
        text=True,
        timeout=300,
        env={"PYTHONPATH": ":".join(paths), "PATH": "/usr/bin:/bin"},
    )
    assert result.returncode == 0, result.stderr
    assert int(result.stdout.strip()) == len(CORE_MODULES) > 40
