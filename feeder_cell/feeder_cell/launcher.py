"""Start the node processes of a scene file and end them by pid (launch_ros is not available here)."""

from __future__ import annotations

import ctypes
import ctypes.util
import dataclasses
import json
import os
import re
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, TypeAlias, cast

import yaml

from feeder_cell.experiment.arrivals import Arrivals, scene_arrivals, scene_seed
from feeder_cell.experiment.faults_process import FaultSpec, scene_faults
from feeder_cell.node_modules import declared_parameters, node_class, node_module
from feeder_device.declarations import unknown_fault
from feeder_planner.errors import InputError
from feeder_planner.fields_io import load_yaml_mapping, optional, required, short_string
from feeder_planner.limits import MAX_NAME_CHARS, describe, quote

# A node's clean-up after SIGINT (a bounded executor shutdown; the OPC UA server's stop) may take this long
# before SIGKILL: ROS 2 launch's own default is 10 s too (sigterm_timeout 5 s, then sigkill_timeout 5 s).
# At 5 s, the gateway was killed mid clean-up at load 10 (a CI run's test_every_node_ros: exit -9).
STOP_GRACE_S = 10.0
# prctl(2) option: the signal a child gets when its parent dies (linux/prctl.h).
PR_SET_PDEATHSIG = 1


LifecycleTarget = Literal["active", "inactive", "unconfigured"]
LIFECYCLE_TARGETS: tuple[str, ...] = ("active", "inactive", "unconfigured")
# What a node's own exit does to the scene, as ROS launch's on_exit: "" (a node that ends is reported
# and ends the scene as a failure) or "shutdown" (the scene ends with that node's exit code).
OnExit = Literal["", "shutdown"]
ON_EXIT_ACTIONS: tuple[str, ...] = ("shutdown",)

# A node parameter's value as a scene gives it (``_parameter`` checks it): a bool, integer, double or
# string, or a list of them (of one type).
ParameterScalar: TypeAlias = bool | int | float | str
ParameterValue: TypeAlias = ParameterScalar | list[ParameterScalar]


@dataclass(frozen=True)
class NodeSpec:
    """One node of a scene: which executable, under which name and namespace, with what it starts with."""

    package: str
    executable: str
    parameters: dict[str, ParameterValue] = field(default_factory=dict)
    name: str = ""  # node name remap; empty keeps the executable's own name
    namespace: str = ""  # e.g. /cell/feeder_a; empty: the root namespace
    remappings: tuple[tuple[str, str], ...] = ()  # (from, to) name remappings, as -r from:=to
    lifecycle: LifecycleTarget = "active"  # where `feeder launch` brings a managed node
    on_exit: OnExit = ""  # "shutdown": when this node exits, the scene ends with its exit code
    host: str = (
        ""  # a cell host to run in (its name), "none" for a process of its own, "" the launch's choice
    )

    @property
    def node_name(self) -> str:
        """The node's name in the graph (the executable's name unless remapped)."""
        return self.name or self.executable

    @property
    def fully_qualified_name(self) -> str:
        """Namespace and name, e.g. ``/cell/feeder_a/throwing_arm``."""
        namespace = self.namespace.rstrip("/")
        return f"{namespace}/{self.node_name}" if namespace else f"/{self.node_name}"


@dataclass(frozen=True)
class Scene:
    """A set of nodes run together: a scene runs only the models it names.

    ``seed`` seeds the scene's random inputs, ``arrivals`` says how parts arrive and ``faults`` when the
    devices fail (docs/experiments.md); a scene without those sections has fixed arrivals and no faults.
    """

    name: str
    nodes: tuple[NodeSpec, ...]
    seed: int = 0
    arrivals: Arrivals | None = None
    faults: tuple[FaultSpec, ...] | None = None


def scene_from_mapping(document: dict[str, Any], base_dir: Path) -> Scene:
    """Parse a scene; relative ``*_file(s)`` and ``*_dir`` parameter paths are taken from its folder."""
    nodes_value = required(document, "nodes")
    if not isinstance(nodes_value, list) or not nodes_value:
        raise InputError("nodes", "expected a non-empty list of nodes")
    nodes = []
    for index, entry in enumerate(nodes_value):
        where = f"nodes[{index}]"
        if not isinstance(entry, dict):
            raise InputError(where, "expected a mapping with package, executable and parameters")
        package = _ros_name(required(entry, "package", f"{where}.package"), f"{where}.package", "package")
        executable = _executable(required(entry, "executable", f"{where}.executable"), f"{where}.executable")
        parameters = optional(entry, "parameters", {})
        if not isinstance(parameters, dict):
            raise InputError(f"{where}.parameters", "expected a mapping of parameter names to values")
        for key, value in parameters.items():
            _parameter(key, value, f"{where}.parameters")
        resolved = {key: _resolve_path(key, value, base_dir) for key, value in parameters.items()}
        nodes.append(
            NodeSpec(
                package,
                executable,
                resolved,
                _node_name(optional(entry, "name", ""), f"{where}.name"),
                _namespace(optional(entry, "namespace", ""), f"{where}.namespace"),
                _remappings(optional(entry, "remappings", {}), f"{where}.remappings"),
                _lifecycle(optional(entry, "lifecycle", "active"), f"{where}.lifecycle"),
                _on_exit(optional(entry, "on_exit", ""), f"{where}.on_exit"),
                _host(optional(entry, "host", ""), f"{where}.host"),
            )
        )
    return Scene(
        short_string(optional(document, "name", "scene"), "name", "a scene name"),
        tuple(nodes),
        scene_seed(document),
        scene_arrivals(document),
        scene_faults(document, tuple(n.node_name for n in nodes)),
    )


# ROS naming rules (rcl/rmw validate_node_name, validate_namespace): a node name and each namespace token
# are letters, digits and underscores, not starting with a digit; package names likewise (REP 144 asks
# lower case, the ament index does not). Parameter names are such tokens joined by dots.
_TOKEN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_PARAMETER_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*")
_EXECUTABLE = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]*")
# A ROS parameter integer is 64-bit signed.
_INT64 = (-(2**63), 2**63 - 1)


def _ros_name(value: Any, field: str, what: str) -> str:
    """Return a name that follows the ROS naming rules, else an InputError naming ``field``."""
    text = short_string(value, field, f"a {what} name")
    if not _TOKEN.fullmatch(text):
        raise InputError(
            field,
            f"{quote(text)} is not a valid ROS {what} name (letters, digits and underscores, "
            "not starting with a digit)",
        )
    return text


def _node_name(value: Any, field: str) -> str:
    """Return a node name remap ("" keeps the executable's name) that follows the ROS naming rules."""
    return "" if value == "" else _ros_name(value, field, "node")


def _executable(value: Any, field: str) -> str:
    """Return an executable's file name: one path component of safe characters."""
    text = short_string(value, field, "an executable name")
    if not _EXECUTABLE.fullmatch(text):
        raise InputError(field, f"{quote(text)} is not an executable name (letters, digits, '_', '.', '-')")
    return text


def _parameter(key: Any, value: Any, field: str) -> None:
    """Refuse a parameter name or value that rclpy (or rcl's parameter file parser) would reject."""
    if not isinstance(key, str) or not _PARAMETER_NAME.fullmatch(key) or len(key) > MAX_NAME_CHARS:
        raise InputError(f"{field}", f"{quote(key)} is not a valid parameter name")
    where = f"{field}.{key}"
    if isinstance(value, list):
        if not value:
            raise InputError(where, "an empty list has no parameter type for rclpy; leave the parameter out")
        kinds = {_parameter_kind(item, f"{where}[{index}]") for index, item in enumerate(value)}
        if len(kinds) > 1:
            raise InputError(
                where, f"a list parameter needs items of one type, got {', '.join(sorted(kinds))} mixed"
            )
        return
    _parameter_kind(value, where)


def _parameter_kind(value: Any, field: str) -> str:
    """Return the ROS parameter type of a scalar (bool, integer, double, string), else an InputError."""
    if isinstance(value, bool):
        return "bool"
    if isinstance(value, int):
        if not _INT64[0] <= value <= _INT64[1]:
            raise InputError(field, f"{quote(value)} does not fit a 64-bit parameter integer")
        return "integer"
    if isinstance(value, float):
        return "double"
    if isinstance(value, str):
        return "string"
    raise InputError(
        field,
        f"expected a bool, integer, double or string (or a list of one of those), got {describe(value)}",
    )


def checkdeclared_parameters(scene: Scene) -> None:
    """Check each node's parameters against the node's own declarations, before any node starts.

    The declarations are the ``PARAMETERS`` (node_kit ``ParameterSpec``) of the module behind the
    executable's console script: a value of another type than the declared default's (rclpy refuses it:
    an integer where a double is declared), a value the spec's check refuses, and a required parameter
    left out (one whose default fails its own check, such as the throwing arm's ``part_file``) are each
    an InputError naming ``nodes[i].parameters.NAME``. The files the parameters name are read by the
    nodes (through the reading layer) at configure, where a missing one is the device's refusal. A node
    without declarations is left to itself.
    """
    for index, spec in enumerate(scene.nodes):
        where = f"nodes[{index}].parameters"
        declared = declared_parameters(spec.package, spec.executable)
        for name, declaration in declared.items():
            if name not in spec.parameters:
                problem = declaration.check(declaration.default) if declaration.check else None
                if problem:
                    raise InputError(f"{where}.{name}", f"is required: {problem}")
                continue
            value = spec.parameters[name]
            _check_type(value, declaration.default, f"{where}.{name}")
            problem = declaration.check(value) if declaration.check else None
            if problem:
                raise InputError(f"{where}.{name}", problem)


def _check_type(value: Any, default: object, field: str) -> None:
    """Refuse a value whose ROS parameter type differs from the declared default's (rclpy would)."""
    if isinstance(default, list) and default and isinstance(value, list):
        want, got = _parameter_kind(default[0], field), _parameter_kind(value[0], f"{field}[0]")
        if want != got:
            raise InputError(field, f"is declared a list of {want}, got a list of {got}")
        return
    if isinstance(default, list) != isinstance(value, list):
        kind = "a list" if isinstance(default, list) else "a single value"
        raise InputError(field, f"is declared {kind}, got {describe(value)}")
    if isinstance(default, list):
        return
    want, got = _parameter_kind(default, field), _parameter_kind(value, field)
    if want != got:
        hint = f" (write {value!r}.0)" if want == "double" and got == "integer" else ""
        raise InputError(field, f"is declared {want}, got {got} {quote(value)}{hint}")


def scene_copy(scene: Path, folder: Path, overrides: dict[str, dict[str, ParameterValue]]) -> Path:
    """Write ``scene`` into ``folder`` with its file paths made absolute and per-executable parameters set.

    Tests and benchmarks run a scene with, say, the controller's cycle count changed; the copy lives
    elsewhere, so the paths relative to the scene file are resolved first.
    """
    document = yaml.safe_load(scene.read_text())
    for node in document["nodes"]:
        parameters = node.setdefault("parameters", {})
        for key, value in list(parameters.items()):
            parameters[key] = _resolve_path(key, value, scene.parent)
        parameters.update(overrides.get(node["executable"], {}))
    path = folder / scene.name
    path.write_text(yaml.safe_dump(document))
    return path


def with_overrides(scene: Scene, assignments: list[str]) -> Scene:
    """Return ``scene`` with parameters set from ``NODE.PARAM=VALUE`` texts (``feeder launch --set``).

    NODE is a node's name in the scene (``cell_controller``) or its fully qualified name; VALUE is YAML (a
    number, a string, a list); a path parameter (``*_file``) is taken relative to the working directory.
    The result is checked against the nodes' declarations as the scene file is; errors name ``--set``.
    """
    nodes = list(scene.nodes)
    for text in assignments:
        target, equals, value_text = text.partition("=")
        node_name, dot, name = target.strip().rpartition(".")
        if not (equals and dot and node_name and name):
            raise InputError("--set", f"expected NODE.PARAM=VALUE, got {text!r}")
        matches = [i for i, n in enumerate(nodes) if node_name in (n.node_name, n.fully_qualified_name)]
        if len(matches) != 1:
            known = ", ".join(n.node_name for n in nodes)
            raise InputError(
                "--set", f"{node_name!r} names {len(matches)} nodes of the scene (its nodes: {known})"
            )
        try:
            value = yaml.safe_load(value_text)
        except yaml.YAMLError as error:
            raise InputError("--set", f"{text!r}: the value is not YAML ({type(error).__name__})") from None
        _parameter(name, value, "--set")
        spec = nodes[matches[0]]
        resolved = _resolve_path(name, value, Path.cwd())
        nodes[matches[0]] = dataclasses.replace(spec, parameters={**spec.parameters, name: resolved})
    changed = dataclasses.replace(scene, nodes=tuple(nodes))
    try:
        checkdeclared_parameters(changed)
    except InputError as error:
        raise InputError("--set", str(error)) from None
    return changed


def joins_lockstep(package: str, executable: str) -> bool:
    """Whether an executable's node joins the cell clock's lockstep (it declares ``lockstep``)."""
    return "lockstep" in declared_parameters(package, executable)


def _namespace(value: Any, field: str) -> str:
    if not isinstance(value, str) or len(value) > MAX_NAME_CHARS:
        raise InputError(field, f"expected a namespace such as /cell/feeder_a, got {describe(value)}")
    if value and not value.startswith("/"):
        value = "/" + value
    value = value.rstrip("/") if value != "/" else ""
    for token in value.split("/")[1:]:
        if not _TOKEN.fullmatch(token):
            raise InputError(
                field,
                f"{quote(value)} is not a valid ROS namespace: each part between slashes is letters, digits "
                "and underscores, not starting with a digit",
            )
    return value


def _remappings(value: Any, field: str) -> tuple[tuple[str, str], ...]:
    names_only = isinstance(value, dict) and all(
        isinstance(k, str) and isinstance(v, str) for k, v in value.items()
    )
    if not names_only:
        raise InputError(field, "expected a mapping of names to names, e.g. {sensor: proximity}")
    for source, target in value.items():
        for name in (source, target):
            if not name or len(name) > MAX_NAME_CHARS or any(c.isspace() for c in name) or ":=" in name:
                raise InputError(field, f"{quote(name)} is not a ROS name to remap")
    return tuple(sorted(value.items()))


def _lifecycle(value: Any, field: str) -> LifecycleTarget:
    if not isinstance(value, str) or value not in LIFECYCLE_TARGETS:
        raise InputError(field, f"must be one of {', '.join(LIFECYCLE_TARGETS)}, got {quote(value)}")
    return cast(LifecycleTarget, value)


def _on_exit(value: Any, field: str) -> OnExit:
    if not isinstance(value, str) or value not in ("", *ON_EXIT_ACTIONS):
        raise InputError(
            field, f"must be one of {', '.join(ON_EXIT_ACTIONS)} (or absent), got {quote(value)}"
        )
    return cast(OnExit, value)


NO_HOST = "none"  # a scene node's host: a process of its own


def _host(value: Any, field: str) -> str:
    """Return a host name (a ROS name token) or ``none``, else an InputError naming ``field``."""
    if value in ("", NO_HOST):
        return str(value)
    return _ros_name(value, field, "host")


def _resolve_path(key: str, value: ParameterValue, base_dir: Path) -> ParameterValue:
    def resolve(item: ParameterScalar) -> ParameterScalar:
        return (
            str((base_dir / item).resolve())
            if isinstance(item, str) and item and not os.path.isabs(item)
            else item
        )

    if key.endswith(("_file", "_dir")):
        return value if isinstance(value, list) else resolve(value)
    if key.endswith("_files") and isinstance(value, list):
        return [resolve(item) for item in value]
    return value


def load_scene(path: str | Path) -> Scene:
    """Read and validate a scene file, each node's parameters against its declarations; errors name the file.

    Everything is checked before any node starts (``check_declared_parameters``): a bad scene starts nothing.
    """
    try:
        scene = scene_from_mapping(load_yaml_mapping(path), Path(path).resolve().parent)
        checkdeclared_parameters(scene)
        check_fault_names(scene)
        return with_section_files(scene, Path(path))
    except InputError as error:
        raise error.with_source(str(path)) from None


def check_fault_names(scene: Scene) -> None:
    """Refuse a ``faults:`` entry whose node is no device, or whose fault that device does not know.

    The faults a device knows are its node module's ``FAULTS`` (what its ``~/inject_fault`` accepts).
    """
    for spec in scene.faults or ():
        node = next(n for n in scene.nodes if n.node_name == spec.device)
        module = node_module(node.package, node.executable)
        faults = getattr(module, "FAULTS", None)
        if not isinstance(faults, dict):
            raise InputError(
                f"faults.{spec.device}",
                f"{node.package}/{node.executable} is not a device with injectable faults",
            )
        if spec.fault not in faults:
            raise InputError(f"faults.{spec.device}.fault", unknown_fault(spec.fault, faults))


# The parameters by which a node reads a scene's random inputs (the reference controller's): the scene file.
ARRIVALS_PARAMETER, FAULTS_PARAMETER = "arrivals_file", "faults_file"


def with_section_files(scene: Scene, path: Path) -> Scene:
    """Return ``scene`` with each node that takes ``arrivals_file`` / ``faults_file`` pointed at the scene.

    Only when the scene has that section (``arrivals:``, ``faults:``) and the node's own parameters leave
    the parameter unset: a node so told draws each cycle's parts from the scene's arrivals, or injects the
    scene's fault processes, from the scene's seed (docs/experiments.md).
    """
    wanted = [
        name
        for name, section in ((ARRIVALS_PARAMETER, scene.arrivals), (FAULTS_PARAMETER, scene.faults))
        if section is not None
    ]
    if not wanted:
        return scene
    nodes = []
    for spec in scene.nodes:
        declared = declared_parameters(spec.package, spec.executable)
        added = {n: str(path.resolve()) for n in wanted if n in declared and n not in spec.parameters}
        nodes.append(dataclasses.replace(spec, parameters={**spec.parameters, **added}) if added else spec)
    return dataclasses.replace(scene, nodes=tuple(nodes))


def resolve_executable(package: str, executable: str) -> Path:
    """``<prefix of package>/lib/<package>/<executable>``, the layout ``ros2 run`` looks up."""
    from ament_index_python.packages import PackageNotFoundError, get_package_prefix

    try:
        prefix = Path(get_package_prefix(package))
    except (PackageNotFoundError, ValueError):
        raise InputError(
            "package",
            f"package {package!r} not found in the ament index "
            "(did you run 'make setup' and 'source env.sh'?)",
        ) from None
    lib_dir = prefix / "lib" / package
    candidate = lib_dir / executable
    if not (candidate.is_file() and os.access(candidate, os.X_OK)):
        available = (
            sorted(p.name for p in lib_dir.iterdir() if p.is_file() and os.access(p, os.X_OK))
            if lib_dir.is_dir()
            else []
        )
        raise InputError(
            "executable",
            f"no executable {executable!r} in package {package!r} "
            f"(available: {', '.join(available) or 'none'})",
        )
    return candidate


@dataclass
class NodeProcess:
    """A node running as its own process; its output goes to a log file so a full pipe never blocks it."""

    spec: NodeSpec
    process: subprocess.Popen
    log_path: Path
    stopped: bool = False
    host: str = ""  # the cell host it runs in (shared with the host's other nodes), or "" alone
    end_file: Path | None = None  # a host's: which of its nodes' work ended it (feeder_cell.host)

    @property
    def pid(self) -> int:
        """Process id of the node."""
        return self.process.pid

    @property
    def package(self) -> str:
        """Package of the node's executable."""
        return self.spec.package

    @property
    def executable(self) -> str:
        """Name of the node's executable."""
        return self.spec.executable

    def alive(self) -> bool:
        """Return whether the process is still running."""
        return self.process.poll() is None

    def output(self) -> str:
        """Return what the node has written to its log so far."""
        return self.log_path.read_text(errors="replace") if self.log_path.exists() else ""

    def ended_by(self) -> list[str]:
        """Return the hosted nodes whose own work (the controller's cycles) ended the host, once it ended."""
        if self.end_file is None or self.alive() or not self.end_file.exists():
            return []
        try:
            return list(json.loads(self.end_file.read_text()).get("ended_by", []))
        except (OSError, ValueError):
            return []

    def cpu_seconds(self) -> float | None:
        """CPU seconds (user + system) the process has used so far, from /proc; None once it has ended."""
        try:
            fields = Path(f"/proc/{self.pid}/stat").read_text().rpartition(")")[2].split()
        except OSError:
            return None
        # utime and stime are fields 14 and 15 of proc(5); after the command's ")" they are 12th and 13th.
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")

    def stop(self) -> int | None:
        """End the process by pid: SIGINT (a clean ROS shutdown), then SIGKILL after a grace period."""
        if not self.stopped:
            self.stopped = True
            if self.alive():
                os.kill(self.pid, signal.SIGINT)
                try:
                    self.process.wait(timeout=STOP_GRACE_S)
                except subprocess.TimeoutExpired:
                    os.kill(self.pid, signal.SIGKILL)
                    self.process.wait(timeout=STOP_GRACE_S)
        return self.process.returncode


def _die_with_parent() -> None:
    """In the child before exec: ask the kernel for SIGTERM when the launcher dies, even by SIGKILL."""
    libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
    libc.prctl(PR_SET_PDEATHSIG, signal.SIGTERM)
    if os.getppid() == 1:  # the launcher died between fork and prctl: nothing will send the signal
        os._exit(1)


def _spawn(command: list[str], log_path: Path) -> subprocess.Popen:
    """Start a node's (or a host's) process with its output to ``log_path``; it dies with the launcher."""
    with open(log_path, "w") as log:
        return subprocess.Popen(
            command,
            stdout=log,
            stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL,
            env=dict(os.environ, PYTHONUNBUFFERED="1"),
            preexec_fn=_die_with_parent,
            # Its own session: Ctrl-C in a terminal signals the launch's process group, and the launch ends
            # each process by pid in order; a node that got the SIGINT too would end first and be reported
            # as having died early (exit 1). The nodes still die with the launch (_die_with_parent).
            start_new_session=True,
        )


def start_node(
    spec: NodeSpec,
    log_dir: Path,
    extra_args: tuple[str, ...] = (),
    extra_parameters: dict[str, ParameterValue] | None = None,
) -> NodeProcess:
    """Start one node with its parameters passed through a params file (types survive, unlike -p)."""
    path = resolve_executable(spec.package, spec.executable)
    log_dir.mkdir(parents=True, exist_ok=True)
    stem = f"{spec.fully_qualified_name.strip('/').replace('/', '.')}-{time.monotonic_ns()}"
    command = [str(path), "--ros-args"]
    if spec.name:
        command += ["-r", f"__node:={spec.name}"]
    if spec.namespace:
        command += ["-r", f"__ns:={spec.namespace}"]
    for source, target in spec.remappings:
        command += ["-r", f"{source}:={target}"]
    parameters = {**spec.parameters, **(extra_parameters or {})}
    if parameters:
        params_path = log_dir / f"{stem}-params.yaml"
        params_path.write_text(yaml.safe_dump({"/**": {"ros__parameters": parameters}}))
        command += ["--params-file", str(params_path)]
    command += list(extra_args)
    log_path = log_dir / f"{stem}.log"
    return NodeProcess(spec, _spawn(command, log_path), log_path)


def hostable(specs: list[NodeSpec]) -> list[NodeSpec]:
    """Return the nodes of ``specs`` one cell host can take: those whose module offers ``NODE``, one per name.

    The host's ROS arguments are node-targeted by the node's own name (``throwing_arm:__ns:=...``), so two
    nodes of one executable cannot share a host: the second runs in a process of its own.
    """
    taken: set[str] = set()
    chosen = []
    for spec in specs:
        if node_class(spec.package, spec.executable) is not None and spec.executable not in taken:
            taken.add(spec.executable)
            chosen.append(spec)
    return chosen


def start_host(
    name: str, specs: list[tuple[NodeSpec, dict[str, ParameterValue]]], log_dir: Path
) -> list[NodeProcess]:
    """Start one cell host process for ``specs`` (each with its extra parameters); one NodeProcess each.

    Every entry shares the host's process (its pid, log, exit code and CPU time); ending one ends all.
    """
    log_dir.mkdir(parents=True, exist_ok=True)
    stem = f"{name}-{time.monotonic_ns()}"
    end_file = log_dir / f"{stem}-end.json"
    command = [sys.executable, "-m", "feeder_cell.host", f"--end-file={end_file}"]
    command += [f"{spec.package}/{spec.executable}" for spec, _ in specs]
    command.append("--ros-args")
    documents: dict[str, Any] = {}
    for spec, extra in specs:
        own = spec.executable  # a node-targeted rule matches the name the node was built with
        if spec.name:
            command += ["-r", f"{own}:__node:={spec.name}"]
        if spec.namespace:
            command += ["-r", f"{own}:__ns:={spec.namespace}"]
        for source, target in spec.remappings:
            command += ["-r", f"{own}:{source}:={target}"]
        parameters = {**spec.parameters, **extra}
        if parameters:
            documents[spec.fully_qualified_name] = {"ros__parameters": parameters}
    if documents:
        params_path = log_dir / f"{stem}-params.yaml"
        params_path.write_text(yaml.safe_dump(documents))
        command += ["--params-file", str(params_path)]
    log_path = log_dir / f"{stem}.log"
    process = _spawn(command, log_path)
    return [NodeProcess(spec, process, log_path, host=name, end_file=end_file) for spec, _ in specs]
