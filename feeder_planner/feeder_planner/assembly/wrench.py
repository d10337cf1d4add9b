"""The equilibrium system of eqs. (5)-(9): contact wrenches with a K-facet friction pyramid, and gravity."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import sparse
from scipy.sparse.csgraph import connected_components

from feeder_planner.assembly.contacts import Contact
from feeder_planner.assembly.geometry import tangent_basis
from feeder_planner.assembly.model import Assembly
from feeder_planner.assembly.tolerances import DEFAULT_FACETS, MIN_FACETS, STANDARD_GRAVITY
from feeder_planner.errors import InputError
from feeder_planner.limits import MAX_FACETS, quote

__all__ = [
    "EquilibriumSystem",
    "build_system",
    "contact_forces",
    "pyramid_edges",
    "split_components",
    "validate_facets",
    "wrench_system",
]


@dataclass(frozen=True)
class EquilibriumSystem:
    """Scaled system  A lam + B g = 0,  lam >= 0  (eq. 9 with generator form of the friction pyramid).

    Column k of A is the wrench of one pyramid edge (generator) of one contact, scaled by ``column_scale``
    (kg) so that lam is O(1) for any mass ratio; rows of body j are divided by M_j (forces) and M_j L_j
    (torques). ``generators[k]`` is the force direction of column k; ``contact_of[k]`` its contact.
    """

    A: sparse.csc_matrix
    B: np.ndarray
    generators: np.ndarray
    contact_of: np.ndarray
    column_scale: np.ndarray
    body_of_row: np.ndarray
    contacts: tuple[Contact, ...]
    facets: int

    @property
    def columns(self) -> int:
        """Number of LP columns (pyramid edges of all contacts)."""
        return self.A.shape[1]


def validate_facets(facets: object, field: str = "facets") -> int:
    """Return ``facets`` as an int K >= MIN_FACETS; InputError naming ``field`` otherwise (bools refused)."""
    if isinstance(facets, bool) or not isinstance(facets, (int, np.integer)) or facets < MIN_FACETS:
        raise InputError(field, f"must be an integer >= {MIN_FACETS}, got {quote(facets)}")
    if facets > MAX_FACETS:  # the pyramids' edges are allocated per contact and facet
        raise InputError(field, f"{int(facets)} exceeds the limit of {MAX_FACETS}")
    return int(facets)


def pyramid_edges(
    normals: np.ndarray, mus: np.ndarray, facets: int, circumscribed: bool = False
) -> np.ndarray:
    """Return the edges (contacts, K, 3) of the K-facet pyramid inscribed in each Coulomb cone (eq. 9, K = 4).

    Edge k is n + mu (cos t_k u + sin t_k v) with t_k = (2k + 1) pi / K, which for K = 4 is exactly |f_x|,
    |f_y| <= mu f_n / sqrt(2) in the paper's (u, v) axes. ``circumscribed`` scales the tangential part by 1 /
    cos(pi / K), giving the smallest pyramid that contains the cone (used to bound the exact cone, eq. 2).
    """
    u = np.array([tangent_basis(n)[0] for n in normals]).reshape(-1, 3)
    v = np.cross(normals, u)
    angles = (2 * np.arange(facets) + 1) * np.pi / facets
    radius = mus / np.cos(np.pi / facets) if circumscribed else mus
    return normals[:, None, :] + radius[:, None, None] * (
        np.cos(angles)[None, :, None] * u[:, None, :] + np.sin(angles)[None, :, None] * v[:, None, :]
    )


def build_system(
    assembly: Assembly, contacts: list[Contact], facets: int = DEFAULT_FACETS, circumscribed: bool = False
) -> EquilibriumSystem:
    """Assemble eq. (6)'s J^T f + G in scaled generator form for the free bodies."""
    facets = validate_facets(facets)
    generators_array, contact_array = _generators(contacts, facets, circumscribed)
    return wrench_system(assembly, contacts, generators_array, contact_array, facets)


def wrench_system(
    assembly: Assembly,
    contacts: list[Contact],
    generators_array: np.ndarray,
    contact_array: np.ndarray,
    facets: int,
) -> EquilibriumSystem:
    """Assemble the scaled system of eq. (6) for arbitrary force directions.

    Each column is one force direction at one contact with its torques about the bodies' centres, eqs.
    (3)-(4), on body a and, opposite, on body b; B is eq. (7)'s G per unit g. Column k is a unit multiple of
    force ``generators_array[k]`` at contact ``contact_array[k]`` (pyramid edges, or the exact cone's n, u, v
    axes).
    """
    free = assembly.free_bodies
    slot = np.full(len(assembly.bodies), -1)
    slot[free] = np.arange(len(free))
    masses = np.array([assembly.bodies[b].mass for b in free])
    lengths = np.array([assembly.bodies[b].size for b in free])
    centers = np.array([assembly.bodies[b].center for b in free]).reshape(-1, 3)
    all_mass = np.array([b.mass for b in assembly.bodies])
    grounded = np.array([b.grounded for b in assembly.bodies])
    a = np.array([c.a for c in contacts], dtype=int)[contact_array]
    b = np.array([c.b for c in contacts], dtype=int)[contact_array]
    points = np.array([c.point for c in contacts]).reshape(-1, 3)[contact_array]
    # Column scale: the lightest free body the contact touches, so lam is O(1) at any mass ratio.
    mass_a = np.where(grounded[a], np.inf, all_mass[a])
    mass_b = np.where(grounded[b], np.inf, all_mass[b])
    column_scale = np.minimum(mass_a, mass_b)
    rows, cols, vals = [], [], []
    columns = np.arange(len(generators_array))
    for body, sign in ((a, 1.0), (b, -1.0)):
        k = slot[body]
        on = k >= 0
        kk = k[on]
        arm = points[on] - centers[kk]
        factor = sign * column_scale[on] / masses[kk]
        force = generators_array[on] * factor[:, None]
        torque = np.cross(arm, generators_array[on]) * (factor / lengths[kk])[:, None]
        block = np.hstack([force, torque])
        rows.append((6 * kk[:, None] + np.arange(6)[None, :]).ravel())
        cols.append(np.repeat(columns[on], 6))
        vals.append(block.ravel())
    A = sparse.csc_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
        shape=(6 * len(free), len(generators_array)),
    )
    A.eliminate_zeros()
    B = np.zeros((6 * len(free), 3))
    for k in range(len(free)):
        B[6 * k : 6 * k + 3] = np.eye(3)
    return EquilibriumSystem(
        A,
        B,
        generators_array,
        contact_array.astype(int),
        column_scale,
        np.repeat(np.asarray(free, dtype=int), 6),
        tuple(contacts),
        facets,
    )


def _generators(contacts: list[Contact], facets: int, circumscribed: bool) -> tuple[np.ndarray, np.ndarray]:
    """Return the pyramid edges of all contacts, ordered by contact, and each edge's contact index."""
    if not contacts:
        return np.zeros((0, 3)), np.zeros(0, dtype=int)
    normals = np.array([c.normal for c in contacts])
    mus = np.array([c.mu for c in contacts])
    edges = pyramid_edges(normals, mus, facets, circumscribed)
    frictional = mus > 0
    generators: list[np.ndarray] = []
    owners: list[np.ndarray] = []
    # mu = 0 contacts have the single generator n (the pyramid collapses onto its axis).
    for index in range(len(contacts)):
        if frictional[index]:
            generators.append(edges[index])
            owners.append(np.full(facets, index))
        else:
            generators.append(normals[index][None, :])
            owners.append(np.array([index]))
    return np.vstack(generators), np.concatenate(owners)


def contact_forces(
    system: EquilibriumSystem, lam: np.ndarray, gravity: float = STANDARD_GRAVITY
) -> np.ndarray:
    """Return the force on body a at each contact (N, eq. 1) from scaled multipliers, |g| = ``gravity``."""
    forces = np.zeros((len(system.contacts), 3))
    weighted = system.generators * (lam * system.column_scale * gravity)[:, None]
    np.add.at(forces, system.contact_of, weighted)
    return forces


def split_components(system: EquilibriumSystem) -> list[EquilibriumSystem]:
    """Split into independent sub-assemblies: free bodies linked only through grounded ones.

    Eq. (9) is then a product of smaller LPs and V is the intersection of their cones, so each part's region
    can be found on its own (smaller, faster LPs) and the parts' constraints intersected.
    """
    rows = system.A.shape[0]
    bodies = rows // 6
    if bodies <= 1:
        return [system]
    pattern = (system.A != 0).astype(np.int8).tocsr()
    # Body-by-column incidence (sum of each body's six rows), then body adjacency through shared columns.
    collapse = sparse.csr_matrix(
        (np.ones(rows, dtype=np.int8), (np.arange(rows) // 6, np.arange(rows))), shape=(bodies, rows)
    )
    incidence = (collapse @ pattern) != 0
    count, labels = connected_components(incidence @ incidence.T, directed=False)
    if count == 1:
        return [system]
    parts = []
    incidence_csc = incidence.tocsc()
    for label in range(count):
        members = np.nonzero(labels == label)[0]
        row_index = (6 * members[:, None] + np.arange(6)[None, :]).ravel()
        columns = np.unique(incidence_csc[members].nonzero()[1])
        parts.append(
            EquilibriumSystem(
                system.A[row_index][:, columns].tocsc(),
                system.B[row_index],
                system.generators[columns],
                system.contact_of[columns],
                system.column_scale[columns],
                system.body_of_row[row_index],
                system.contacts,
                system.facets,
            )
        )
    return parts
