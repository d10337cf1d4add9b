"""Count every use of ``typing.Any`` in the four Python packages and say which uses are edges.

    python tools/count_any.py [--json] [--all] [PATH ...]

Every ``Any`` the parser sees counts once: in annotations (parameters, returns, variables, attributes,
dataclass fields, quoted annotations included), in type aliases, in ``cast(Any, ...)`` and anywhere else
an expression names it (``typing.Any`` too). ``from typing import Any`` is not a use; comments and
docstrings are not code. The files are ``feeder_planner/feeder_planner``, ``feeder_device/feeder_device``,
``feeder_sim/feeder_sim`` and ``feeder_cell/feeder_cell`` (or the PATHs given).

Each use is classified by where it stands, from the syntax alone (names and docstrings, not data flow),
as one of:

``message`` edge: an ``Any`` standing for a ROS message, service or action type or instance, or an rclpy
handle. The generated message modules and rclpy are read with ``follow_imports = skip`` (pyproject.toml),
so these types are ``Any`` to mypy whatever the annotation says. A use is a message edge when

- M1 it annotates a parameter, variable, attribute or field whose name has a message word among its parts
  (split at ``_`` and at case changes: ``msg``, ``message``, ``request``/``req``, ``response``/``res``/
  ``resp``, ``goal``, ``feedback``/``fb``, ``result``, ``status``, ``stamp``, ``header``, ``info``/
  ``infos``, ``srv``, ``action``, ``transforms``) or an rclpy handle word (``node``, ``executor``,
  ``client(s)``, ``publisher(s)``, ``subscription(s)``, ``timer``, ``future``, ``handle``, ``service``,
  ``clock``, ``qos``): ``msg: Any``, ``msg_type: Any``, ``self.timer: Any``, ``publishers: dict[int,
  Any]``, ``TFMessage: Any``. Not when a message word names a ``str``-keyed dict: a ROS message is never
  a dict, so ``message: dict[str, Any]`` is a JSON message (J6);
- M2 it is the return of a function that takes a message (a parameter named with a message word: a
  service callback's response, the answer to a request) or whose own name has a message or handle word
  (``_stamp() -> Any`` builds a message, ``_parameter_client() -> Any`` makes a client); or it is an
  argument of a ``Callable`` parameter of such a function, or of one that takes a handle (the callback
  handed the messages, ``work(node, executor, ...)``); a ``Callable``'s own return is an edge only where
  the function takes a message (the service callback returns the response);
- M3 it is in the signature of a method that overrides a method of an rclpy or message-package base
  class (it calls ``super().<its name>``): an override of an untyped base takes what the base takes.

``json`` edge: an ``Any`` for a value parsed from JSON or YAML, or a value about to be serialised:

- J1 in the signature of a function whose name says it reads or writes a document: it contains ``json``,
  ``yaml`` or ``mapping``, or starts with ``parse_``, ``load_`` or ``dump_`` (``to_json() -> dict[str,
  Any]``, ``part_from_mapping(document: dict[str, Any])``, ``parse_yaml(...) -> Any``);
- J2 in the signature of a document reader: a function with a parameter named ``field``, ``field_name``
  or ``where`` (the project's convention for checking one field of an input document and naming it in
  the error: ``finite_number(value: Any, field: str)``) or a parameter named as in J3
  (``optional(document, key, default: Any) -> Any``);
- J3 it annotates a name with a document word among its parts: ``document(s)``, ``doc``, ``raw``,
  ``payload``, ``metadata``, ``json``, ``yaml``;
- J4 it is the value of a JSON object (``Any`` as the value type of a ``str``-keyed ``dict`` or
  ``Mapping``, alone or inside a ``list``/``tuple``/``Sequence``/``Callable``) in the signature of a
  function whose docstring, or whose module's docstring, calls its values JSON, YAML or documents; or
  anywhere in a ``feeder`` subcommand (``feeder_cell/cli/``), where by the command's contract a
  ``dict[str, Any]`` is the one JSON object the command prints;
- J5 it annotates a local variable of a function whose return is a ``json`` edge (the document being
  built: ``out: dict[str, Any] = {}`` inside ``to_json``);
- J6 the value of a JSON object named with a message word (``message: dict[str, Any]``, see M1).

Everything else is ``other`` and counts against the target: an ``Any`` for a numeric array or scalar, a
third-party object (shapely, pymunk, trimesh, solver handles, OPC UA nodes and values), a parameter
value, a callback of our own, a container of our own objects, ``*args: Any`` forwarding of our own code.

Output: totals per package and per file (total, message, json, other) and every ``other`` use as
``path:line  context  annotation``; ``--all`` lists the edges too, with the rule that made them edges;
``--json`` prints one JSON object (totals, per package, per file, and every use).
"""

from __future__ import annotations

import argparse
import ast
import json
import re
import signal
import sys
from collections import Counter
from dataclasses import asdict, dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("feeder_planner", "feeder_device", "feeder_sim", "feeder_cell")

MESSAGE_WORDS = {
    "msg", "msgs", "message", "messages", "request", "requests", "req", "response", "responses", "res",
    "resp", "goal", "feedback", "fb", "result", "status", "stamp", "header", "info", "infos", "srv",
    "action", "transforms",
}  # fmt: skip
HANDLE_WORDS = {
    "node", "executor", "client", "clients", "publisher", "publishers", "subscription", "subscriptions",
    "timer", "future", "handle", "service", "clock", "qos",
}  # fmt: skip
DOCUMENT_WORDS = {"document", "documents", "doc", "raw", "payload", "metadata", "json", "yaml"}
FIELD_PARAMETERS = {"field", "field_name", "where"}
ROS_MODULE = re.compile(r"^(rclpy|rcl_interfaces|builtin_interfaces|rosgraph_msgs|std_srvs|\w+_msgs)(\.|$)")
DOCUMENT_FUNCTION = re.compile(r"json|yaml|mapping|^_?(parse|load|dump)_")
DOCUMENT_DOCSTRING = re.compile(r"\bJSON\b|\bYAML\b|\bdocuments?\b", re.IGNORECASE)


@dataclass(frozen=True)
class Use:
    path: str
    line: int
    site: str  # what the Any annotates: "param NAME of F", "return of F", "variable NAME", "cast", ...
    annotation: str  # the annotation (or expression) it stands in
    kind: str  # "message", "json" or "other"
    rule: str  # the rule that made it an edge ("" for other)


def _words(name: str) -> set[str]:
    """The parts of a name split at ``_`` and case changes, lowercased (``self._status_subscriptions``)."""
    name = name.rsplit(".", 1)[-1]
    name = re.sub(r"([a-z0-9])([A-Z])|([A-Z])([A-Z][a-z])", r"\1\3_\2\4", name)
    return {part for part in name.lower().split("_") if part}


def _target_name(node: ast.expr) -> str:
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        return f"{_target_name(node.value)}.{node.attr}"
    return ast.unparse(node)


class _AnyNames(ast.NodeVisitor):
    """The names that mean typing.Any in one module (``Any``, ``typing.Any``, ``t.Any``)."""

    def __init__(self) -> None:
        self.bare: set[str] = set()
        self.modules: set[str] = set()
        self.ros_names: set[str] = set()

    def visit_ImportFrom(self, node: ast.ImportFrom) -> None:
        for alias in node.names:
            if node.module in ("typing", "typing_extensions") and alias.name == "Any":
                self.bare.add(alias.asname or "Any")
            if node.module and ROS_MODULE.match(node.module):
                self.ros_names.add(alias.asname or alias.name)

    def visit_Import(self, node: ast.Import) -> None:
        for alias in node.names:
            if alias.name in ("typing", "typing_extensions"):
                self.modules.add(alias.asname or alias.name)
            if ROS_MODULE.match(alias.name):
                self.ros_names.add((alias.asname or alias.name).split(".")[0])


def _is_any(node: ast.AST, names: _AnyNames) -> bool:
    if isinstance(node, ast.Name):
        return node.id in names.bare
    if isinstance(node, ast.Attribute) and node.attr == "Any":
        return isinstance(node.value, ast.Name) and node.value.id in names.modules
    return False


def _expand_strings(node: ast.expr) -> ast.expr:
    """Parse a quoted annotation (``"dict[str, Any]"``) so that its names are seen."""
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        try:
            return ast.parse(node.value, mode="eval").body
        except SyntaxError:
            return node
    return node


@dataclass(frozen=True)
class _Found:
    node: ast.expr
    object_value: bool  # the value type of a str-keyed dict or Mapping (a JSON object's value)
    callable_part: str  # "" outside a Callable, else "args" or "return" of the outermost Callable


def _any_nodes(annotation: ast.expr | None, names: _AnyNames) -> list[_Found]:
    """Each Any inside ``annotation``."""
    found: list[_Found] = []

    def walk(node: ast.expr, object_value: bool, callable_part: str) -> None:
        node = _expand_strings(node)
        if _is_any(node, names):
            found.append(_Found(node, object_value, callable_part))
            return
        if isinstance(node, ast.Subscript):
            head = _target_name(node.value).rsplit(".", 1)[-1]
            items = list(node.slice.elts) if isinstance(node.slice, ast.Tuple) else [node.slice]
            if head in ("dict", "Dict", "Mapping", "MutableMapping") and len(items) == 2:
                key = _expand_strings(items[0])
                str_keys = isinstance(key, ast.Name) and key.id == "str"
                walk(items[0], False, callable_part)
                walk(items[1], str_keys or object_value, callable_part)
                return
            carries = head in ("list", "List", "tuple", "Tuple", "Sequence", "Iterable", "Iterator")
            if head == "Callable" and not callable_part and len(items) == 2:
                walk(items[0], object_value, "args")
                walk(items[1], object_value, "return")
                return
            for item in items:
                walk(item, object_value and carries, callable_part)
            return
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.expr):
                walk(child, False, callable_part)

    if annotation is not None:
        walk(annotation, False, "")
    return found


def _message_name(name: str) -> bool:
    return bool(_words(name) & (MESSAGE_WORDS | HANDLE_WORDS))


def _message_word_only(name: str) -> bool:
    words = _words(name)
    return bool(words & MESSAGE_WORDS) and not words & HANDLE_WORDS


def _name_rule(name: str, found: _Found) -> tuple[str, str]:
    """M1, J3 or J6 from the annotated name alone, else ("", "")."""
    if _document_name(name):
        return "json", "J3"
    if _message_name(name):
        if found.object_value and _message_word_only(name):
            return "json", "J6"
        return "message", "M1"
    return "", ""


def _document_name(name: str) -> bool:
    return bool(_words(name) & DOCUMENT_WORDS)


class _Counter(ast.NodeVisitor):
    def __init__(self, path: str, names: _AnyNames, module_docstring: str) -> None:
        self.path = path
        self.module_docstring = module_docstring
        self.names = names
        self.in_cli = "/cli/" in path
        self.uses: list[Use] = []
        self.seen: set[int] = set()
        # (function, the kind of its return's Any) of the functions being visited, innermost last
        self.functions: list[tuple[ast.FunctionDef | ast.AsyncFunctionDef, str]] = []
        self.classes: list[ast.ClassDef] = []

    # -- recording -----------------------------------------------------------------------------------

    def _record(self, node: ast.expr, site: str, annotation: ast.expr, kind: str, rule: str) -> None:
        self.seen.add(id(node))
        self.uses.append(Use(self.path, node.lineno, site, ast.unparse(annotation), kind, rule))

    # -- function signatures ---------------------------------------------------------------------------

    def _ros_override(self, function: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
        """Whether ``function`` overrides a method of an rclpy or message-package base class."""
        if not self.classes:
            return False
        roots = {_target_name(base).split(".")[0] for base in self.classes[-1].bases}
        if not roots & self.names.ros_names:
            return False
        for node in ast.walk(function):
            if (
                isinstance(node, ast.Call)
                and isinstance(node.func, ast.Attribute)
                and node.func.attr == function.name
                and isinstance(node.func.value, ast.Call)
                and _target_name(node.func.value.func) == "super"
            ):
                return True
        return False

    def _visit_function(self, node: ast.FunctionDef | ast.AsyncFunctionDef) -> None:
        args = node.args
        params = [*args.posonlyargs, *args.args, *args.kwonlyargs]
        if args.vararg:
            params.append(args.vararg)
        if args.kwarg:
            params.append(args.kwarg)
        param_names = {p.arg for p in params}
        module_docstring = self.module_docstring
        docstring = (ast.get_docstring(node) or "") + "\n" + module_docstring
        document_function = bool(DOCUMENT_FUNCTION.search(node.name.lower()))
        reader = bool(param_names & FIELD_PARAMETERS) or any(_document_name(p) for p in param_names)
        documented = bool(DOCUMENT_DOCSTRING.search(docstring)) or self.in_cli
        override = self._ros_override(node)
        # the parameters that may hold a message or a handle: not self, not a callable
        named = [
            p.arg
            for p in params
            if p.arg not in ("self", "cls")
            and not (p.annotation is not None and "Callable" in ast.unparse(p.annotation))
        ]
        takes_message = any(_words(p) & MESSAGE_WORDS for p in named)
        takes_handle = any(_message_name(p) for p in named)
        builds_message = _message_name(node.name)

        def classify(name: str | None, found: _Found) -> tuple[str, str]:
            if name is not None and not found.callable_part:
                kind, rule = _name_rule(name, found)
                if kind:
                    return kind, rule
            if document_function:
                return "json", "J1"
            if reader:
                return "json", "J2"
            if override:
                return "message", "M3"
            if found.object_value and documented:
                return "json", "J4"
            if name is None and not found.callable_part and (takes_message or builds_message):
                return "message", "M2"
            if found.callable_part == "args" and (takes_handle or builds_message):
                return "message", "M2"
            if found.callable_part == "return" and takes_message:
                return "message", "M2"
            return "other", ""

        for param in params:
            for found in _any_nodes(param.annotation, self.names):
                kind, rule = classify(param.arg, found)
                assert param.annotation is not None
                self._record(found.node, f"param {param.arg} of {node.name}", param.annotation, kind, rule)
        return_kind = "other"
        for found in _any_nodes(node.returns, self.names):
            kind, rule = classify(None, found)
            assert node.returns is not None
            self._record(found.node, f"return of {node.name}", node.returns, kind, rule)
            if kind == "json":
                return_kind = "json"
        for decorator in node.decorator_list:
            self.visit(decorator)
        for default in [*args.defaults, *(d for d in args.kw_defaults if d is not None)]:
            self.visit(default)
        self.functions.append((node, return_kind))
        saved_classes = self.classes
        self.classes = []
        for statement in node.body:
            self.visit(statement)
        self.classes = saved_classes
        self.functions.pop()

    def visit_FunctionDef(self, node: ast.FunctionDef) -> None:
        self._visit_function(node)

    def visit_AsyncFunctionDef(self, node: ast.AsyncFunctionDef) -> None:
        self._visit_function(node)

    def visit_ClassDef(self, node: ast.ClassDef) -> None:
        for expr in [*node.bases, *node.decorator_list]:
            self.visit(expr)
        self.classes.append(node)
        for statement in node.body:
            self.visit(statement)
        self.classes.pop()

    # -- variables, attributes, fields -------------------------------------------------------------------

    def visit_AnnAssign(self, node: ast.AnnAssign) -> None:
        name = _target_name(node.target)
        local_of_json = bool(self.functions) and self.functions[-1][1] == "json" and not self.classes
        for found in _any_nodes(node.annotation, self.names):
            kind, rule = _name_rule(name, found) if not found.callable_part else ("", "")
            if not kind and local_of_json:
                kind, rule = "json", "J5"
            if not kind and found.object_value and self.in_cli:
                kind, rule = "json", "J4"
            if not kind:
                kind, rule = "other", ""
            where = "field" if self.classes and not self.functions else "variable"
            self._record(found.node, f"{where} {name}", node.annotation, kind, rule)
        if node.value is not None:
            self.visit(node.value)

    # -- everything else: casts, aliases, subscripts in expressions ----------------------------------

    def visit_Call(self, node: ast.Call) -> None:
        if _target_name(node.func).rsplit(".", 1)[-1] == "cast" and node.args:
            subject = ast.unparse(node.args[1]) if len(node.args) > 1 else ""
            for found in _any_nodes(node.args[0], self.names):
                name = subject if subject.replace(".", "_").isidentifier() else ""
                kind, rule = _name_rule(name, found) if name else ("", "")
                self._record(found.node, f"cast of {subject}", node.args[0], kind or "other", rule)
        self.generic_visit(node)

    def visit_Assign(self, node: ast.Assign) -> None:
        names = [_target_name(t) for t in node.targets]
        for found in _any_nodes(node.value, self.names):
            if id(found.node) in self.seen:
                continue
            self._record(found.node, f"alias {', '.join(names)}", node.value, "other", "")
        self.generic_visit(node)

    def generic_visit(self, node: ast.AST) -> None:
        for child in ast.iter_child_nodes(node):
            if _is_any(child, self.names) and id(child) not in self.seen:
                assert isinstance(child, ast.expr)
                self._record(child, "expression", child, "other", "")
            self.visit(child)

    def visit_Name(self, node: ast.Name) -> None:  # a bare Any as a statement-level expression
        return

    def visit_Attribute(self, node: ast.Attribute) -> None:
        self.visit(node.value)


def count_file(path: Path) -> list[Use]:
    """Every Any in one Python file."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    names = _AnyNames()
    names.visit(tree)
    if not names.bare and not names.modules:
        return []
    where = path.relative_to(ROOT).as_posix() if path.is_relative_to(ROOT) else str(path)
    counter = _Counter(where, names, ast.get_docstring(tree) or "")
    counter.visit(tree)
    return sorted(counter.uses, key=lambda use: use.line)


def python_files(roots: list[Path]) -> list[Path]:
    files: list[Path] = []
    for root in roots:
        files.extend([root] if root.is_file() else sorted(root.rglob("*.py")))
    return files


def _package(path: str) -> str:
    return path.split("/", 1)[0]


def _totals(uses: list[Use]) -> dict[str, int]:
    kinds = Counter(use.kind for use in uses)
    return {"total": len(uses), "message": kinds["message"], "json": kinds["json"], "other": kinds["other"]}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("paths", nargs="*", type=Path, help="files or folders (default: the four packages)")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--all", action="store_true", help="list the edges too, with their rule")
    args = parser.parse_args(argv)
    signal.signal(signal.SIGPIPE, signal.SIG_DFL)  # `| head` ends the listing quietly
    roots = [p.resolve() for p in args.paths] or [ROOT / package / package for package in PACKAGES]
    uses = [use for path in python_files(roots) for use in count_file(path)]
    files = sorted({use.path for use in uses})
    packages = sorted({_package(use.path) for use in uses})
    if args.json:
        document = {
            "totals": _totals(uses),
            "packages": {p: _totals([u for u in uses if _package(u.path) == p]) for p in packages},
            "files": {f: _totals([u for u in uses if u.path == f]) for f in files},
            "uses": [asdict(use) for use in uses],
        }
        sys.stdout.write(json.dumps(document, indent=1) + "\n")
        return 0
    row = "{:<64} {:>6} {:>8} {:>5} {:>6}"
    print(row.format("", "total", "message", "json", "other"))
    for package in packages:
        totals = _totals([u for u in uses if _package(u.path) == package])
        print(row.format(package, *totals.values()))
    print(row.format("all", *_totals(uses).values()))
    print()
    print(row.format("file", "total", "message", "json", "other"))
    for file in files:
        print(row.format(file, *_totals([u for u in uses if u.path == file]).values()))
    print()
    listed = [u for u in uses if args.all or u.kind == "other"]
    print("uses listed:" if args.all else "other (not an edge) uses:")
    for use in listed:
        tag = f"[{use.kind} {use.rule}] " if args.all else ""
        print(f"{use.path}:{use.line}  {tag}{use.site}: {use.annotation}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
