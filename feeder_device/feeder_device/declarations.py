"""What a device declares about itself, ROS-free: its counters and its faults.

One declaration per physical fact: a device's counter names feed its ``~/status``, its ``/diagnostics``,
the OPC UA gateway's variables and the timeline plots, so they are declared once, in the device's model
package (``feeder_sim.<model>.counters``), and every reader takes them from there. Faults are data too:
a ``FaultSpec`` per fault the device can have injected, with the status code it reports.

Nothing here imports rclpy, so the model packages, the gateway's profiles and the tests read it alone.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, Iterator, Mapping, Sequence

from feeder_planner.errors import FeederError, InputError

__all__ = [
    "CounterSpec",
    "Counters",
    "FaultSpec",
    "ActiveFault",
    "FaultEntry",
    "DeviceError",
    "parse_fault_parameter",
    "deadline_ns",
]


@dataclass(frozen=True)
class CounterSpec:
    """One counter a device reports: its name (the status, diagnostics and gateway key) and meaning."""

    name: str
    description: str


class Counters(Mapping[str, int]):
    """The running counts of one device, keyed by its declaration: an undeclared name is a bug, not a key.

    ``add`` counts events; ``set`` holds a count derived from the model (parts at rest now). Iteration
    follows the declaration's order, which is the order every reader shows them in.
    """

    def __init__(self, specs: Sequence[CounterSpec]) -> None:
        self.specs = tuple(specs)
        self._values = {spec.name: 0 for spec in self.specs}

    def add(self, name: str, amount: int = 1) -> None:
        """Count ``amount`` more of ``name`` (KeyError for an undeclared counter)."""
        self._values[self._known(name)] += amount

    def set(self, name: str, value: int) -> None:
        """Hold ``value`` for a counter the model derives (KeyError for an undeclared counter)."""
        self._values[self._known(name)] = int(value)

    def reset(self) -> None:
        """Every counter back to zero (a cleanup forgets the run)."""
        for name in self._values:
            self._values[name] = 0

    def _known(self, name: str) -> str:
        if name not in self._values:
            raise KeyError(f"counter {name!r} is not declared (declared: {', '.join(self._values)})")
        return name

    def __getitem__(self, name: str) -> int:
        return self._values[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._values)

    def __len__(self) -> int:
        return len(self._values)


@dataclass(frozen=True)
class FaultSpec:
    """A fault a device can have injected: what it does, what its value means, and whether it stops it."""

    name: str
    description: str
    value_meaning: str = ""  # e.g. "probability in [0, 1]"; empty when the fault takes no value
    stops_device: bool = False  # the device goes to FAULT and refuses commands until ~/reset
    code: int = 0  # DeviceStatus fault code reported while it is active (0: FAULT_NONE)
    indices_label: str = ""  # what indices name in the label: "cells" (counted), "axes" (listed); "" hides
    shows_state: bool = False  # the request's state matters (a stuck reading, a fixed error): show it


@dataclass(frozen=True)
class ActiveFault:
    """A fault in force: its spec and the request's magnitudes."""

    spec: FaultSpec
    value: float = 0.0
    state: bool = False
    indices: tuple[int, ...] = ()
    angle: float = 0.0
    seed: int = 0

    @property
    def label(self) -> str:
        """Name with the magnitude that matters, as status and diagnostics list it."""
        parts = []
        if self.spec.value_meaning and not (self.indices and self.value == 0.0):
            parts.append(f"{self.value:g}")
        if self.indices and self.spec.indices_label:
            label = self.spec.indices_label
            listed = ";".join(str(i) for i in self.indices)
            parts.append(f"{len(self.indices)} {label}" if label == "cells" else f"{label}={listed}")
        if self.spec.shows_state:
            parts.append(f"state={str(self.state).lower()}")
        return f"{self.spec.name}({', '.join(parts)})" if parts else self.spec.name


def stopping_fault(
    model_fault: tuple[int, str] | None, faults: Iterable[ActiveFault]
) -> tuple[int, str] | None:
    """Return (code, text) of the fault that stops a device: its model's, else the first stopping injection.

    One rule for the node's kit (``status.StatusReporting``) and the ROS-free cell loop (``experiment.kit``).
    """
    if model_fault is not None:
        return model_fault
    for fault in faults:
        if fault.spec.stops_device:
            return fault.spec.code, f"injected fault {fault.label}: {fault.spec.description}"
    return None


class DeviceError(FeederError):
    """A command the device refuses in its present state (not active, stopped, in fault)."""


@dataclass(frozen=True)
class FaultEntry:
    """One parsed ``inject_faults`` entry: the fault and the InjectFault fields it sets."""

    name: str
    value: float = 0.0
    state: bool = False
    indices: tuple[int, ...] = ()
    angle: float = 0.0


def _number(text: str, field: str) -> float:
    lowered = text.strip().lower()
    if lowered in ("true", "false"):
        return 1.0 if lowered == "true" else 0.0
    try:
        return float(lowered)
    except ValueError:
        raise InputError(field, f"must be a number, got {text!r}") from None


def parse_fault_parameter(entry: str, index: int) -> FaultEntry:
    """Parse one ``inject_faults`` entry: ``NAME``, ``NAME=VALUE``, then ``,KEY=VALUE`` for the other fields.

    ``NAME=VALUE`` alone sets value, state (VALUE nonzero or ``true``) and angle, as one magnitude;
    ``,state=``, ``,angle=`` and ``,indices=3;7;9`` set the fields one by one, e.g.
    ``axis_stall,indices=1,angle=0.3``.
    """
    field = f"parameter inject_faults[{index}]"
    head, *options = [part.strip() for part in entry.split(",")]
    name, _, value_text = head.partition("=")
    name = name.strip()
    if not name:
        raise InputError(field, f"needs a fault name, got {entry!r}")
    value = _number(value_text, field) if value_text.strip() else 0.0
    state, angle = value != 0.0, value
    indices: tuple[int, ...] = ()
    for option in options:
        key, _, text = option.partition("=")
        key = key.strip()
        if key == "indices":
            try:
                indices = tuple(int(i) for i in text.replace(";", " ").split())
            except ValueError:
                raise InputError(
                    f"{field} (indices)", f"must be integers separated by ';', got {text!r}"
                ) from None
        elif key == "value":
            value = _number(text, f"{field} (value)")
        elif key == "angle":
            angle = _number(text, f"{field} (angle)")
        elif key == "state":
            state = _number(text, f"{field} (state)") != 0.0
        else:
            raise InputError(field, f"unknown key {key!r} (expected value, state, angle or indices)")
    return FaultEntry(name, value, state, indices, angle)


def unknown_fault(name: str, faults: Mapping[str, FaultSpec]) -> str:
    """Say that ``name`` is no fault of this device, listing the ones it knows."""
    return f"unknown fault {name!r} (this device knows: {', '.join(faults) or 'none'})"


def deadline_ns(start_ns: int, timeout_s: float) -> int | None:
    """Return the node-clock instant (ns) a goal started at ``start_ns`` times out (None: no timeout).

    The one timeout rule of every device's goals: node-clock time from acceptance, 0 s meaning none, so a
    goal's outcome is the same at any speed of the cell clock.
    """
    return start_ns + round(timeout_s * 1e9) if timeout_s > 0 else None
