"""Start the node processes of a scene file and end them by pid (launch_ros is not available here)."""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import signal
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, cast

import yaml

from feeder_planner.errors import InputError
from feeder_planner.fields_io import load_yaml_mapping, optional, required

STOP_GRACE_S = 5.0
# prctl(2) option: the signal a child gets when its parent dies (linux/prctl.h).
PR_SET_PDEATHSIG = 1


LifecycleTarget = Literal["active", "inactive", "unconfigured"]
LIFECYCLE_TARGETS: tuple[str, ...] = ("active", "inactive", "unconfigured")
# What a node's own exit does to the scene, as ROS launch's on_exit: "" (a node that ends is reported
# and ends the scene as a failure) or "shutdown" (the scene ends with that node's exit code).
OnExit = Literal["", "shutdown"]
ON_EXIT_ACTIONS: tuple[str, ...] = ("shutdown",)


@dataclass(frozen=True)
class NodeSpec:
    """One node of a scene: which executable, under which name and namespace, with what it starts with."""

    package: str
    executable: str
    parameters: dict[str, Any] = field(default_factory=dict)
    name: str = ""  # node name remap; empty keeps the executable's own name
    namespace: str = ""  # e.g. /cell/feeder_a; empty: the root namespace
    remappings: tuple[tuple[str, str], ...] = ()  # (from, to) name remappings, as -r from:=to
    lifecycle: LifecycleTarget = "active"  # where `feeder launch` brings a managed node
    on_exit: OnExit = ""  # "shutdown": when this node exits, the scene ends with its exit code

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
    """A set of nodes run together: a scene runs only the models it names."""

    name: str
    nodes: tuple[NodeSpec, ...]


def scene_from_mapping(document: dict[str, Any], base_dir: Path) -> Scene:
    """Parse a scene; relative ``*_file`` parameter paths are resolved against the scene file's folder."""
    nodes_value = required(document, "nodes")
    if not isinstance(nodes_value, list) or not nodes_value:
        raise InputError("nodes", "expected a non-empty list of nodes")
    nodes = []
    for index, entry in enumerate(nodes_value):
        where = f"nodes[{index}]"
        if not isinstance(entry, dict):
            raise InputError(where, "expected a mapping with package, executable and parameters")
        package, executable = (
            required(entry, "package", f"{where}.package"),
            required(entry, "executable", f"{where}.executable"),
        )
        parameters = optional(entry, "parameters", {})
        if not isinstance(parameters, dict):
            raise InputError(f"{where}.parameters", "expected a mapping of parameter names to values")
        resolved = {key: _resolve_path(key, value, base_dir) for key, value in parameters.items()}
        nodes.append(
            NodeSpec(
                str(package),
                str(executable),
                resolved,
                str(optional(entry, "name", "")),
                _namespace(optional(entry, "namespace", ""), f"{where}.namespace"),
                _remappings(optional(entry, "remappings", {}), f"{where}.remappings"),
                _lifecycle(optional(entry, "lifecycle", "active"), f"{where}.lifecycle"),
                _on_exit(optional(entry, "on_exit", ""), f"{where}.on_exit"),
            )
        )
    return Scene(str(optional(document, "name", "scene")), tuple(nodes))


def _namespace(value: Any, field: str) -> str:
    if not isinstance(value, str):
        raise InputError(field, f"expected a namespace such as /cell/feeder_a, got {value!r}")
    if value and not value.startswith("/"):
        value = "/" + value
    return value.rstrip("/") if value != "/" else ""


def _remappings(value: Any, field: str) -> tuple[tuple[str, str], ...]:
    names_only = isinstance(value, dict) and all(
        isinstance(k, str) and isinstance(v, str) for k, v in value.items()
    )
    if not names_only:
        raise InputError(field, "expected a mapping of names to names, e.g. {sensor: proximity}")
    return tuple(sorted(value.items()))


def _lifecycle(value: Any, field: str) -> LifecycleTarget:
    if value not in LIFECYCLE_TARGETS:
        raise InputError(field, f"must be one of {', '.join(LIFECYCLE_TARGETS)}, got {value!r}")
    return cast(LifecycleTarget, value)


def _on_exit(value: Any, field: str) -> OnExit:
    if value not in ("", *ON_EXIT_ACTIONS):
        raise InputError(field, f"must be one of {', '.join(ON_EXIT_ACTIONS)} (or absent), got {value!r}")
    return cast(OnExit, value)


def _resolve_path(key: str, value: Any, base_dir: Path) -> Any:
    def resolve(item: Any) -> Any:
        return (
            str((base_dir / item).resolve())
            if isinstance(item, str) and item and not os.path.isabs(item)
            else item
        )

    if key.endswith("_file"):
        return resolve(value)
    if key.endswith("_files") and isinstance(value, list):
        return [resolve(item) for item in value]
    return value


def load_scene(path: str | Path) -> Scene:
    """Read and validate a scene file; errors name the file and field."""
    try:
        return scene_from_mapping(load_yaml_mapping(path), Path(path).resolve().parent)
    except InputError as error:
        raise error.with_source(str(path)) from None


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


def start_node(
    spec: NodeSpec,
    log_dir: Path,
    extra_args: tuple[str, ...] = (),
    extra_parameters: dict[str, Any] | None = None,
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
    with open(log_path, "w") as log:
        process = subprocess.Popen(
            command,
            stdout=log,
            stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL,
            env=dict(os.environ, PYTHONUNBUFFERED="1"),
            preexec_fn=_die_with_parent,
        )
    return NodeProcess(spec, process, log_path)
