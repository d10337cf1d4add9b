"""Programmable force fields: radial (eq. 3), constant, combined u = |r| + delta*eta, squeeze, quadratic.

Every field is a force per unit area f(r) = -grad u(r). ``wrench`` returns the exact resultant force
(eq. 1) and torque about a reference point (eq. 2) on placed polygon loops, ``lifted`` the lifted
potential (Definition 1); no sampling of the area anywhere. ``wrench_at`` is the same wrench on a rigid
part at a pose (``frame.PartFrame``): the radial and constant fields evaluate it in the part frame, from
the edges and moments the part keeps, without placing the part.
"""

from __future__ import annotations

import dataclasses
import math
from abc import ABC, abstractmethod
from dataclasses import dataclass
from functools import cached_property
from typing import Any, ClassVar, Literal, get_args

import numpy as np

from feeder_planner.errors import InputError
from feeder_planner.fields_io import finite_number, non_negative_number
from feeder_planner.limits import quote
from feeder_planner.mems import lifted
from feeder_planner.mems.frame import PartFrame, Placement
from feeder_planner.mems.regions import area_moments, half_plane_moments, moments

__all__ = [
    "FieldType",
    "FIELD_TYPES",
    "DELTA_MIN",
    "DELTA_MAX",
    "check_delta",
    "check_field_type",
    "Field",
    "RadialField",
    "ConstantField",
    "CombinedField",
    "SqueezeField",
    "QuadraticField",
    "FIELD_CLASSES",
    "field_parameters",
    "field_from_mapping",
    "ProgramStep",
    "program_from_mapping",
]

FieldType = Literal["radial", "constant", "combined", "squeeze", "quadratic"]
FIELD_TYPES: tuple[FieldType, ...] = get_args(FieldType)

# The combined field's delta (section 3.2, contract section 3): 0 <= delta < 1. At delta >= 1 the
# constant field overpowers the unit radial one and U has no minimum (the part is pushed away).
DELTA_MIN = 0.0
DELTA_MAX = 1.0


def check_delta(delta: object, field: str = "delta") -> float:
    """Return ``delta`` as a float if it is a finite number with 0 <= delta < 1, else raise InputError.

    The one check of delta's range, for files, flags, parameters and requests alike; the error names
    ``field``. NaN, inf and non-numbers (bools included) are refused.
    """
    if isinstance(delta, bool) or not isinstance(delta, (int, float)) or not math.isfinite(delta):
        raise InputError(field, f"must be a finite number, got {delta!r}")
    if not DELTA_MIN <= delta < DELTA_MAX:
        raise InputError(field, f"must satisfy 0 <= delta < 1, got {delta!r}")
    return float(delta)


def check_field_type(kind: object, field: str = "type") -> FieldType:
    """Return ``kind`` if it is one of FIELD_TYPES, else raise InputError naming ``field``."""
    for known in FIELD_TYPES:
        if kind == known:
            return known
    raise InputError(field, f"unknown field {kind!r} (expected one of {', '.join(FIELD_TYPES)})")


def _cross(a: np.ndarray, b: np.ndarray) -> float:
    """Return the z component of the cross product of two plane vectors."""
    return float(a[0] * b[1] - a[1] * b[0])


@dataclass(frozen=True)
class Field(ABC):
    """Base class: force per unit area (N/m^2) deriving from a potential u (N/m).

    A subclass's dataclass fields are its parameters, with the names of the field mapping.
    """

    kind: ClassVar[FieldType]

    @abstractmethod
    def force_density(self, points: np.ndarray) -> np.ndarray:
        """Return the force per unit area f(r) (..., 2) at points (..., 2)."""

    @abstractmethod
    def wrench(self, loops: tuple[np.ndarray, ...], about: np.ndarray) -> np.ndarray:
        """Return (Fx, Fy, torque about ``about``) on the placed loops, exactly (eqs. 1-2)."""

    @abstractmethod
    def lifted(self, loops: tuple[np.ndarray, ...]) -> float:
        """Return the lifted potential, the integral of u over the placed loops (Definition 1)."""

    def wrench_at(self, frame: PartFrame, pose: np.ndarray) -> np.ndarray:
        """Return (Fx, Fy, torque about the centroid) on the part at ``pose`` (x, y, theta), eqs. (1-2).

        By default ``wrench`` on the placed loops; fields with a part-frame form override it.
        """
        return self.wrench(frame.placed(pose), pose[:2])


@dataclass(frozen=True)
class RadialField(Field):
    """Unit radial field scaled by ``strength``: f = -strength (r - c)/|r - c|, u = strength |r - c|.

    The unit field (strength 1, centre at the origin) is eq. (3); its lifted potential is V (eq. 4).
    """

    kind: ClassVar[FieldType] = "radial"

    center: tuple[float, float] = (0.0, 0.0)
    strength: float = 1.0

    def force_density(self, points: np.ndarray) -> np.ndarray:
        """Return -strength (r - c)/|r - c| (eq. 3), 0 at the centre."""
        r = points - np.array(self.center)
        norm = np.hypot(r[..., 0], r[..., 1])
        with np.errstate(invalid="ignore", divide="ignore"):
            out = -self.strength * r / norm[..., None]
        return np.where(norm[..., None] > 0, out, 0.0)

    def wrench(self, loops: tuple[np.ndarray, ...], about: np.ndarray) -> np.ndarray:
        """Return the force -strength grad V (eqs. 5-6) and its torque about ``about``."""
        c = np.array(self.center)
        force = -self.strength * lifted.gradient(lifted.loop_edges(loops), -c)
        # (r - c) x f = 0 for a radial field, so the torque about G is (c - G) x F.
        return np.array([force[0], force[1], _cross(c - about, force)])

    def wrench_at(self, frame: PartFrame, pose: np.ndarray) -> np.ndarray:
        """Return ``wrench`` on the part at ``pose``, evaluated in the part frame (``placed_wrench``)."""
        return np.array(self.placed_wrench(frame, Placement.of(pose)))

    def placed_wrench(self, frame: PartFrame, placement: Placement) -> tuple[float, float, float]:
        """Return the wrench in the part frame: the centre carried into it, c' = R^T (c - p).

        There the force is -strength grad V at -c' (eqs. 5-6) on the part's own edges; in the plane it is
        R times that, and the torque about the centroid, (c - p) x F, is c' x F' (a rotation keeps cross
        products).
        """
        # Placement.to_part and .rotate written out: this is every evaluation of the ideal model.
        x, y, cos, sin = placement
        dx, dy = self.center[0] - x, self.center[1] - y
        cx, cy = cos * dx + sin * dy, cos * dy - sin * dx
        gx, gy = lifted.point_gradient(frame.edges, (-cx, -cy))
        fx, fy = -self.strength * gx, -self.strength * gy
        return cos * fx - sin * fy, sin * fx + cos * fy, cx * fy - cy * fx

    def lifted(self, loops: tuple[np.ndarray, ...]) -> float:
        """Return strength V at the translation that puts the centre at the origin (eq. 4)."""
        return float(self.strength * lifted.potential(lifted.loop_edges(loops), -np.array(self.center)))


@dataclass(frozen=True)
class ConstantField(Field):
    """Constant force per unit area f = force, u = -force . r."""

    kind: ClassVar[FieldType] = "constant"

    force: tuple[float, float] = (0.0, -1.0)

    def force_density(self, points: np.ndarray) -> np.ndarray:
        """Return ``force`` at every point."""
        return np.broadcast_to(np.array(self.force), points.shape).copy()

    def wrench(self, loops: tuple[np.ndarray, ...], about: np.ndarray) -> np.ndarray:
        """Return force times area, applied at the centroid."""
        m = area_moments(loops)
        f = np.array(self.force) * m[0]
        centroid = m[1:3] / m[0]
        return np.array([f[0], f[1], _cross(centroid - about, f)])

    def wrench_at(self, frame: PartFrame, pose: np.ndarray) -> np.ndarray:
        """Return ``wrench`` on the part at ``pose`` from the part's own area (``placed_wrench``)."""
        return np.array(self.placed_wrench(frame, Placement.of(pose)))

    def placed_wrench(self, frame: PartFrame, placement: Placement) -> tuple[float, float, float]:
        """Return force times area at the centroid (eqs. 1-2 for f constant): no torque about it."""
        return self.force[0] * frame.area, self.force[1] * frame.area, 0.0

    def lifted(self, loops: tuple[np.ndarray, ...]) -> float:
        """Return -force . (first moment of area)."""
        m = area_moments(loops)
        return float(-(self.force[0] * m[1] + self.force[1] * m[2]))


@dataclass(frozen=True)
class CombinedField(Field):
    """Section 3.2: u = strength (|r - c| + delta eta), the radial field plus the constant -delta (0, 1)."""

    kind: ClassVar[FieldType] = "combined"

    delta: float = 0.0
    center: tuple[float, float] = (0.0, 0.0)
    strength: float = 1.0

    def _parts(self) -> tuple[RadialField, ConstantField]:
        """Return the radial and the constant field this field is the sum of."""
        return RadialField(self.center, self.strength), ConstantField((0.0, -self.delta * self.strength))

    def force_density(self, points: np.ndarray) -> np.ndarray:
        """Return the sum of the radial and the constant force densities."""
        a, b = self._parts()
        return a.force_density(points) + b.force_density(points)

    def wrench(self, loops: tuple[np.ndarray, ...], about: np.ndarray) -> np.ndarray:
        """Return the sum of the radial and the constant wrenches."""
        a, b = self._parts()
        return a.wrench(loops, about) + b.wrench(loops, about)

    @cached_property
    def _components(self) -> tuple[RadialField, ConstantField]:
        """Return ``_parts()`` once: the field is immutable, and the simulator asks at every evaluation."""
        return self._parts()

    def wrench_at(self, frame: PartFrame, pose: np.ndarray) -> np.ndarray:
        """Return the sum of the radial and the constant wrenches (section 3.2), one placement for both."""
        a, b = self._components
        placement = Placement.of(pose)
        ra, rb = a.placed_wrench(frame, placement), b.placed_wrench(frame, placement)
        return np.array([ra[0] + rb[0], ra[1] + rb[1], ra[2] + rb[2]])

    def lifted(self, loops: tuple[np.ndarray, ...]) -> float:
        """Return the lifted potential of eq. (12) in the plane frame (placed loops)."""
        a, _ = self._parts()
        # the constant part is measured from eta = 0 through the centre, as in eq. (12)
        m = moments(loops)
        return a.lifted(loops) + self.strength * self.delta * float(m[2] - self.center[1] * m[0])


@dataclass(frozen=True)
class SqueezeField(Field):
    """Squeeze field towards the line through ``center`` with normal angle ``angle``.

    u = strength |n.(r - c)|: a force of magnitude strength towards the line on either side.
    """

    kind: ClassVar[FieldType] = "squeeze"

    center: tuple[float, float] = (0.0, 0.0)
    angle: float = 0.0
    strength: float = 1.0

    def _normal(self) -> np.ndarray:
        """Return the unit normal of the line."""
        return np.array([math.cos(self.angle), math.sin(self.angle)])

    def force_density(self, points: np.ndarray) -> np.ndarray:
        """Return -strength sign(n.(r - c)) n (0 on the line)."""
        n = self._normal()
        side = np.sign((points - np.array(self.center)) @ n)
        return -self.strength * side[..., None] * n

    def _sides(self, loops: tuple[np.ndarray, ...]) -> tuple[np.ndarray, np.ndarray]:
        """Return the moments of the loops' region on the + and the - side of the line."""
        n = self._normal()
        whole = moments(loops)
        plus = half_plane_moments(loops, n, float(n @ np.array(self.center)))
        return plus, whole - plus

    def wrench(self, loops: tuple[np.ndarray, ...], about: np.ndarray) -> np.ndarray:
        """Return the sum over both sides of the side's constant force applied at its centroid."""
        n = self._normal()
        out = np.zeros(3)
        for m, sign in zip(self._sides(loops), (1.0, -1.0), strict=True):
            if abs(m[0]) <= 0.0:
                continue
            f = -self.strength * sign * n * m[0]
            out += [f[0], f[1], _cross(m[1:3] / m[0] - about, f)]
        return out

    def lifted(self, loops: tuple[np.ndarray, ...]) -> float:
        """Return strength times the integral of |n.(r - c)|, side by side."""
        n, c = self._normal(), np.array(self.center)
        plus, minus = self._sides(loops)
        return float(
            self.strength * ((n @ plus[1:3] - n @ c * plus[0]) - (n @ minus[1:3] - n @ c * minus[0]))
        )


@dataclass(frozen=True)
class QuadraticField(Field):
    """Elliptic potential u = (k1 a^2 + k2 b^2)/2 in axes rotated by ``angle`` about ``center``.

    f = -K (r - c) with K the stiffness matrix (``matrix``).
    """

    kind: ClassVar[FieldType] = "quadratic"

    center: tuple[float, float] = (0.0, 0.0)
    k: tuple[float, float] = (1.0, 1.0)
    angle: float = 0.0

    def matrix(self) -> np.ndarray:
        """Return the stiffness matrix K = R diag(k) R^T."""
        c, s = math.cos(self.angle), math.sin(self.angle)
        r = np.array([[c, -s], [s, c]])
        return r @ np.diag(self.k) @ r.T

    def force_density(self, points: np.ndarray) -> np.ndarray:
        """Return -K (r - c)."""
        return -(points - np.array(self.center)) @ self.matrix().T

    def wrench(self, loops: tuple[np.ndarray, ...], about: np.ndarray) -> np.ndarray:
        """Return the force and torque from the area's first and second moments."""
        m = moments(loops)
        area, s, c, g, k = m[0], m[1:3], np.array(self.center), about, self.matrix()
        force = -k @ (s - c * area)
        # int (r - g) (r - c)^T dA from the second moments about the origin
        second = np.array([[m[3], m[5]], [m[5], m[4]]])
        outer = second - np.outer(s, c) - np.outer(g, s) + area * np.outer(g, c)
        t = -(k @ outer.T)  # t[i, j] = int f_i (r - g)_j dA
        return np.array([force[0], force[1], float(t[1, 0] - t[0, 1])])

    def lifted(self, loops: tuple[np.ndarray, ...]) -> float:
        """Return tr(K J_c)/2 with J_c the second moment of area about the centre."""
        m = moments(loops)
        area, s, c = m[0], m[1:3], np.array(self.center)
        second = np.array([[m[3], m[5]], [m[5], m[4]]])
        about_c = second - np.outer(s, c) - np.outer(c, s) + area * np.outer(c, c)
        return float(0.5 * np.trace(self.matrix() @ about_c))


FIELD_CLASSES: dict[FieldType, type[Field]] = {
    cls.kind: cls for cls in (RadialField, ConstantField, CombinedField, SqueezeField, QuadraticField)
}


def field_parameters(kind: FieldType) -> tuple[str, ...]:
    """Return the parameter names of a field type, as its mapping and messages name them."""
    return tuple(parameter.name for parameter in dataclasses.fields(FIELD_CLASSES[kind]))


def _point(value: Any, field: str) -> tuple[float, float]:
    """Return [x, y] as two finite floats; errors name ``field`` and the coordinate."""
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise InputError(field, f"expected [x, y], got {value!r}")
    return (finite_number(value[0], f"{field}[0]"), finite_number(value[1], f"{field}[1]"))


def field_from_mapping(spec: Any, field: str = "field", length_scale: float = 1.0) -> Field:
    """Build a field from {'type': ..., parameters}; errors name ``field`` and the offending key.

    Lengths (the centre) are multiplied by ``length_scale`` (metres per unit of the mapping).
    """
    if not isinstance(spec, dict):
        raise InputError(field, f"expected a mapping with a 'type', got {type(spec).__name__}")
    kind = check_field_type(spec.get("type"), f"{field}.type")
    extra = set(spec) - {"type", *field_parameters(kind)}
    if extra:
        raise InputError(f"{field}.{sorted(extra)[0]}", f"not a parameter of a {kind} field")
    cx, cy = _point(spec.get("center", [0.0, 0.0]), f"{field}.center")
    center = (cx * length_scale, cy * length_scale)
    strength = non_negative_number(spec.get("strength", 1.0), f"{field}.strength")
    if kind == "radial":
        return RadialField(center, strength)
    if kind == "constant":
        return ConstantField(_point(spec.get("force", [0.0, -1.0]), f"{field}.force"))
    if kind == "combined":
        where = f"{field}.delta"
        return CombinedField(
            check_delta(finite_number(spec.get("delta", 0.0), where), where), center, strength
        )
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
    """Return a field program read from {'steps': [{'field': {...}, 'duration': s}, ...]}.

    A step without a duration lasts forever (as does .inf); errors name the step and key.
    """
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
            raise InputError(f"{where}.duration", f"must be a number > 0 (or .inf), got {quote(duration)}")
        out.append(
            ProgramStep(field_from_mapping(step["field"], f"{where}.field", length_scale), float(duration))
        )
    return tuple(out)
