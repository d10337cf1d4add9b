"""Package namespaces that import a name's module on first use (PEP 562), declared once.

Every node process used to pay for every package it touched: the node kit reads one tolerance from
``feeder_planner.assembly``, and the package's ``__init__`` imported the whole stability LP, scipy.spatial and
scipy.optimize with it, about 0.5 CPU s of a node's 0.8 s start. A package now lists its public names as
imports under ``if TYPE_CHECKING:`` (what mypy and a reader see), and ``lazy_exports`` reads that block and
imports a name's module the first time the name is asked for. The list is the one definition of the
package's namespace; there is no second table to keep in step with it.
"""

from __future__ import annotations

import ast
import importlib
from collections.abc import Callable
from pathlib import Path
from typing import Any


def _type_checking_imports(source: str, package: str, filename: str) -> dict[str, tuple[str, str]]:
    """Map each exported name to (module, attribute) from the file's ``if TYPE_CHECKING:`` imports."""
    exports: dict[str, tuple[str, str]] = {}
    for node in ast.parse(source, filename).body:
        if (
            not isinstance(node, ast.If)
            or not isinstance(node.test, ast.Name)
            or node.test.id != "TYPE_CHECKING"
        ):
            continue
        for statement in node.body:
            if not isinstance(statement, ast.ImportFrom) or statement.module is None:
                raise ImportError(f"{filename}: the TYPE_CHECKING block holds only 'from M import N' lines")
            module = ("." * statement.level + statement.module) if statement.level else statement.module
            for alias in statement.names:
                exports[alias.asname or alias.name] = (module, alias.name)
    if not exports:
        raise ImportError(f"{filename}: no 'if TYPE_CHECKING:' imports to export for {package}")
    return exports


def lazy_exports(package: str, init_file: str) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """Make the ``__getattr__`` and ``__dir__`` of ``package``, whose ``__init__`` is ``init_file``.

    A name from the TYPE_CHECKING block is imported from its module on first access and cached in the package
    namespace, so later accesses cost nothing; a name shared with a submodule is bound at once. A submodule's
    name imports the submodule, as the eager ``__init__`` made it reachable before. Anything else is the
    usual AttributeError.
    """
    exports = _type_checking_imports(Path(init_file).read_text(encoding="utf-8"), package, init_file)
    namespace = importlib.import_module(package).__dict__
    folder = Path(init_file).parent
    for name, (module, attribute) in exports.items():
        # A name that is also a submodule's (squeeze.squeeze_function) is bound now: importing that submodule
        # later would set the package attribute to the module, and __getattr__ would never be asked.
        if (folder / f"{name}.py").exists() or (folder / name).is_dir():
            namespace[name] = getattr(importlib.import_module(module, package), attribute)

    def get_attribute(name: str) -> Any:
        if name in exports:
            module, attribute = exports[name]
            value = getattr(importlib.import_module(module, package), attribute)
            namespace[name] = value
            return value
        if not name.startswith("__"):
            try:
                return importlib.import_module(f"{package}.{name}")
            except ModuleNotFoundError as missing:
                if missing.name != f"{package}.{name}":
                    raise
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def list_names() -> list[str]:
        return sorted(set(namespace) | set(exports))

    return get_attribute, list_names
