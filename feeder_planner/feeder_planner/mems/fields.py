"""Programmable force fields: radial (eq. 3), constant, combined u = |r| + delta*eta, squeeze, quadratic."""

from __future__ import annotations

# Every field is a force per unit area f(r) = -grad u(r). ``wrench`` returns the exact resultant force
# (eq. 1) and torque about a reference point (eq. 2) on placed polygon loops, ``lifted`` the lifted
# potential (Definition 1); no sampling of the area anywhere.
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from feeder_planner.errors import InputError
from feeder_planner.fields_io import finite_number, non_negative_number
from feeder_planner.mems import lifted
from feeder_planner.mems.regions import half_plane_moments, moments


def _cross(a: np.ndarray, b: np.ndarray) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def loop_edges(loops: tuple[np.ndarray, ...]) -> lifted.Edges:
    """lifted.Edges of already placed loops (outer counter-clockwise, holes clockwise)."""
    a = np.vstack(loops)
    b = np.vstack([np.roll(loop, -1, axis=0) for loop in loops])
    d = b - a
    length = np.hypot(d[:, 0], d[:, 1])
    u = d / length[:, None]
    return lifted.Edges(a, u, np.column_stack([u[:, 1], -u[:, 0]]), length, float(np.abs(a).max()))


@dataclass(frozen=True)
class Field:
    """Base class: force per unit area (N/m^2) deriving from a potential u (N/m)."""

    def force_density(self, points: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def wrench(self, loops: tuple[np.ndarray, ...], about: np.ndarray) -> np.ndarray:  # pragma: no cover
        raise NotImplementedError

    def lifted(self, loops: tuple[np.ndarray, ...]) -> float:  # pragma: no cover
        raise NotImplementedError

    def to_dict(self) -> dict[str, Any]:  # pragma: no cover
        raise NotImplementedError


@dataclass(frozen=True)
class RadialField(Field):
    """Unit radial field scaled by ``strength``: f = -strength (r - c)/|r - c|, u = strength |r - c| (eq. 3)."""

    center: tuple[float, float] = (0.0, 0.0)
    strength: float = 1.0

    def force_density(self, points: np.ndarray) -> np.ndarray:
        r = points - np.array(self.center)
        norm = np.hypot(r[..., 0], r[..., 1])
        with np.errstate(invalid="ignore", divide="ignore"):
            out = -self.strength * r / norm[..., None]
        return np.where(norm[..., None] > 0, out, 0.0)

    def wrench(self, loops: tuple[np.ndarray, ...], about: np.ndarray) -> np.ndarray:
        c = np.array(self.center)
        force = -self.strength * lifted.gradient(loop_edges(loops), -c)
        # (r - c) x f = 0 for a radial field, so the torque about G is (c - G) x F.
        return np.array([force[0], force[1], _cross(c - about, force)])

    def lifted(self, loops: tuple[np.ndarray, ...]) -> float:
        return float(self.strength * lifted.potential(loop_edges(loops), -np.array(self.center)))

    def to_dict(self) -> dict[str, Any]:
        return {"type": "radial", "center": list(self.center), "strength": self.strength}


@dataclass(frozen=True)
class ConstantField(Field):
    """Constant force per unit area f = force, u = -force . r."""

    force: tuple[float, float] = (0.0, -1.0)

    def force_density(self, points: np.ndarray) -> np.ndarray:
        return np.broadcast_to(np.array(self.force), points.shape).copy()

    def wrench(self, loops: tuple[np.ndarray, ...], about: np.ndarray) -> np.ndarray:
        m = moments(loops)
        f = np.array(self.force) * m[0]
        centroid = m[1:3] / m[0]
        return np.array([f[0], f[1], _cross(centroid - about, f)])

    def lifted(self, loops: tuple[np.ndarray, ...]) -> float:
        m = moments(loops)
        return float(-(self.force[0] * m[1] + self.force[1] * m[2]))

    def to_dict(self) -> dict[str, Any]:
        return {"type": "constant", "force": list(self.force)}


@dataclass(frozen=True)
class CombinedField(Field):
    """Section 3.2: u = strength (|r - c| + delta eta), the radial field plus the constant field -delta (0, 1)."""

    delta: float = 0.0
    center: tuple[float, float] = (0.0, 0.0)
    strength: float = 1.0

    def _parts(self) -> tuple[RadialField, ConstantField]:
        return RadialField(self.center, self.strength), ConstantField((0.0, -self.delta * self.strength))

    def force_density(self, points: np.ndarray) -> np.ndarray:
        a, b = self._parts()
        return a.force_density(points) + b.force_density(points)

    def wrench(self, loops: tuple[np.ndarray, ...], about: np.ndarray) -> np.ndarray:
        a, b = self._parts()
        return a.wrench(loops, about) + b.wrench(loops, about)

    def lifted(self, loops: tuple[np.ndarray, ...]) -> float:
        a, b = self._parts()
        # the constant part is measured from eta = 0 through the centre, as in eq. (12)
        m = moments(loops)
        return a.lifted(loops) + self.strength * self.delta * float(m[2] - self.center[1] * m[0])

    def to_dict(self) -> dict[str, Any]:
        return {
            "type": "combined",
            "delta": self.delta,
            "center": list(self.center),
            "strength": self.strength,
        }


@dataclass(frozen=True)
class SqueezeField(Field):
    """Squeeze field towards the line through ``center`` with normal angle ``angle``: u = strength |n.(r - c)|."""

    center: tuple[float, float] = (0.0, 0.0)
    angle: float = 0.0
    strength: float = 1.0

    def _normal(self) -> np.ndarray:
        return np.array([math.cos(self.angle), math.sin(self.angle)])

    def force_density(self, points: np.ndarray) -> np.ndarray:
        n = self._normal()
        side = np.sign((points - np.array(self.center)) @ n)
        return -self.strength * side[..., None] * n

    def _sides(self, loops: tuple[np.ndarray, ...]) -> tuple[np.ndarray, np.ndarray]:
        n = self._normal()
        whole = moments(loops)
        plus = half_plane_moments(loops, n, float(n @ np.array(self.center)))
        return plus, whole - plus

    def wrench(self, loops: tuple[np.ndarray, ...], about: np.ndarray) -> np.ndarray:
        n = self._normal()
        out = np.zeros(3)
        for m, sign in zip(self._sides(loops), (1.0, -1.0)):
            if abs(m[0]) <= 0.0:
                continue
            f = -self.strength * sign * n * m[0]
            out += [f[0], f[1], _cross(m[1:3] / m[0] - about, f)]
        return out

    def lifted(self, loops: tuple[np.ndarray, ...]) -> float:
        n, c = self._normal(), np.array(self.center)
        plus, minus = self._sides(loops)
        return float(
            self.strength * ((n @ plus[1:3] - n @ c * plus[0]) - (n @ minus[1:3] - n @ c * minus[0]))
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "type": "squeeze",
            "center": list(self.center),
            "angle": self.angle,
            "strength": self.strength,
        }


@dataclass(frozen=True)
class QuadraticField(Field):
    """Elliptic potential u = (k1 a^2 + k2 b^2)/2 in axes rotated by ``angle`` about ``center``: f = -K (r - c)."""

    center: tuple[float, float] = (0.0, 0.0)
    k: tuple[float, float] = (1.0, 1.0)
    angle: float = 0.0

    def matrix(self) -> np.ndarray:
        c, s = math.cos(self.angle), math.sin(self.angle)
        r = np.array([[c, -s], [s, c]])
        return r @ np.diag(self.k) @ r.T

    def force_density(self, points: np.ndarray) -> np.ndarray:
        return -(points - np.array(self.center)) @ self.matrix().T

    def wrench(self, loops: tuple[np.ndarray, ...], about: np.ndarray) -> np.ndarray:
        m = moments(loops)
        area, s, c, g, k = m[0], m[1:3], np.array(self.center), about, self.matrix()
        force = -k @ (s - c * area)
        # int (r - g) (r - c)^T dA from the second moments about the origin
        second = np.array([[m[3], m[5]], [m[5], m[4]]])
        outer = second - np.outer(s, c) - np.outer(g, s) + area * np.outer(g, c)
        t = -(k @ outer.T)  # t[i, j] = int f_i (r - g)_j dA
        return np.array([force[0], force[1], float(t[1, 0] - t[0, 1])])

    def lifted(self, loops: tuple[np.ndarray, ...]) -> float:
        m = moments(loops)
        area, s, c = m[0], m[1:3], np.array(self.center)
        second = np.array([[m[3], m[5]], [m[5], m[4]]])
        about_c = second - np.outer(s, c) - np.outer(c, s) + area * np.outer(c, c)
        return float(0.5 * np.trace(self.matrix() @ about_c))

    def to_dict(self) -> dict[str, Any]:
        return {"type": "quadratic", "center": list(self.center), "k": list(self.k), "angle": self.angle}


FIELD_TYPES = ("radial", "constant", "combined", "squeeze", "quadratic")


def _point(value: Any, field: str) -> tuple[float, float]:
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise InputError(field, f"expected [x, y], got {value!r}")
    return (finite_number(value[0], f"{field}[0]"), finite_number(value[1], f"{field}[1]"))


def field_from_mapping(spec: Any, field: str = "field", length_scale: float = 1.0) -> Field:
    """Build a field from {'type': ..., parameters}; errors name ``field`` and the offending key."""
    if not isinstance(spec, dict):
        raise InputError(field, f"expected a mapping with a 'type', got {type(spec).__name__}")
    kind = spec.get("type")
    known = {
        "radial": {"type", "center", "strength"},
        "constant": {"type", "force"},
        "combined": {"type", "delta", "center", "strength"},
        "squeeze": {"type", "center", "angle", "strength"},
        "quadratic": {"type", "center", "k", "angle"},
    }
    if kind not in known:
        raise InputError(
            f"{field}.type", f"unknown field {kind!r} (expected one of {', '.join(FIELD_TYPES)})"
        )
    extra = set(spec) - known[kind]
    if extra:
        raise InputError(f"{field}.{sorted(extra)[0]}", f"not a parameter of a {kind} field")
    center = tuple(v * length_scale for v in _point(spec.get("center", [0.0, 0.0]), f"{field}.center"))
    strength = non_negative_number(spec.get("strength", 1.0), f"{field}.strength")
    if kind == "radial":
        return RadialField(center, strength)
    if kind == "constant":
        return ConstantField(_point(spec.get("force", [0.0, -1.0]), f"{field}.force"))
    if kind == "combined":
        delta = finite_number(spec.get("delta", 0.0), f"{field}.delta")
        if not 0.0 <= delta < 1.0:
            raise InputError(f"{field}.delta", f"must satisfy 0 <= delta < 1, got {delta!r}")
        return CombinedField(delta, center, strength)
    if kind == "squeeze":
        return SqueezeField(center, finite_number(spec.get("angle", 0.0), f"{field}.angle"), strength)
    k = _point(spec.get("k", [1.0, 1.0]), f"{field}.k")
    if min(k) < 0:
        raise InputError(f"{field}.k", f"stiffnesses must be >= 0, got {list(k)}")
    return QuadraticField(center, k, finite_number(spec.get("angle", 0.0), f"{field}.angle"))


@dataclass(frozen=True)
class ProgramStep:
    """One field applied for ``duration`` seconds (inf: until the next program)."""

    field: Field
    duration: float


def program_from_mapping(
    document: Any, field: str = "program", length_scale: float = 1.0
) -> tuple[ProgramStep, ...]:
    """A field program {'steps': [{'field': {...}, 'duration': s}, ...]}; the last step may last forever."""
    steps = document.get("steps") if isinstance(document, dict) else document
    if not isinstance(steps, list) or not steps:
        raise InputError(f"{field}.steps", "expected a non-empty list of {field, duration}")
    out = []
    for i, step in enumerate(steps):
        where = f"{field}.steps[{i}]"
        if not isinstance(step, dict) or "field" not in step:
            raise InputError(where, "expected a mapping with 'field' and 'duration'")
        duration = step.get("duration", math.inf)
        if (
            isinstance(duration, bool)
            or not isinstance(duration, (int, float))
            or math.isnan(duration)
            or duration <= 0
        ):
            raise InputError(f"{where}.duration", f"must be a number > 0 (or .inf), got {duration!r}")
        out.append(
            ProgramStep(field_from_mapping(step["field"], f"{where}.field", length_scale), float(duration))
        )
    return tuple(out)
