"""Frames: bodies of straight 3-D beam elements in any orientation (NASTRAN CBAR/CBEAM), SI units.

A mesh whose cells are "bar2" (`fe.mesh`) carries in `mesh.bars` (ne, 9) each element's section
[A, I1, I2, J, K1, K2] and orientation vector v (3,), as NASTRAN defines them:

    element x   from node a to node b
    plane 1     the plane of x and v: element y = (x cross v) cross x / |..|, z = x cross y
    I1          second moment of area for bending in plane 1 (about element z): `Section.Iz`
    I2          for bending in plane 2 (about element y): `Section.Iy`
    J           torsion constant
    K1, K2      shear factors of planes 1 and 2 (shear stiffness K A G): Timoshenko bending in
                that plane; 0 for none (Euler-Bernoulli), as NASTRAN reads 0 or (PBAR) blank

Each element is `fe.element`'s element (Timoshenko, Euler-Bernoulli where K is 0) in its element frame, turned into the
mesh's frame by its triad R (rows: element x, y, z in mesh coordinates): k = T^T k_e T with
T = diag(R, R, R, R). DOF order: node p owns 6 p + [ux, uy, uz, rx, ry, rz], as a beam's
(`fe.assembly`). The mass is lumped (`element.mass_lumped`, turned the same way): half of each
element's mass on each node, and its slice's rotary inertia, which in mesh axes is a full 3 x 3
block.

Stress at a point of the bar's volume (`fibre_rows`): of the element whose axis passes nearest,
the section at the point's station along it and the fibre at its offset (y, z) from the axis:
sigma_xx = E (eps - kappa_z y + kappa_y z) (the curvatures `fe.stress.curvature_rows`') and, from
the twist rate theta', the shear
G theta' r across the fibre's radius r (St Venant's for a circular section; for other sections
a shear of that size at the fibre, an approximation said in docs/fe.md).

A planar frame (`planar_matrices`, `tied`): beams in the x-y plane, three DOFs a node, node p owning
3 p + [ux, uy, rz] in the plane's axes; the same elements, restricted to their in-plane families
(axial, bending x-y), which are uncoupled from the others when the element's z is the plane's
normal. Joints tie DOFs equal or hold them (`tied`: u = T w, T of zeros and ones).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from flexmbd.fe import element, stress
from flexmbd.fe.section import Section


def triads(nodes: np.ndarray, cells: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(ne, 3, 3) each element's triad R, rows its x, y, z axes in mesh coordinates, from its end
    nodes (rows of `nodes` (N, 3), cells (ne, 2)) and orientation vectors v (ne, 3)."""
    d = nodes[cells[:, 1]] - nodes[cells[:, 0]]
    x = d / np.linalg.norm(d, axis=1, keepdims=True)
    z = np.cross(x, v)
    z /= np.linalg.norm(z, axis=1, keepdims=True)
    return np.stack([x, np.cross(z, x), z], axis=1)


def lengths(nodes: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """(ne,) element lengths, m."""
    return np.linalg.norm(nodes[cells[:, 1]] - nodes[cells[:, 0]], axis=1)


def section(bar: np.ndarray) -> Section:
    """The `fe.section.Section` of one element's row of `mesh.bars`: A, Iz = I1, Iy = I2, J; the
    polar moment Ip = I1 + I2 (the slice's rotary inertia about the axis); shear factors ky = K1,
    kz = K2, infinite where 0 (no shear flexibility: the Timoshenko element is then exactly the
    Euler-Bernoulli one). Fibre distances are not on the card (stress by `fibre_rows`)."""
    A, I1, I2, J, K1, K2 = (float(c) for c in bar[:6])
    return Section(A=A, Iy=I2, Iz=I1, J=J, Ip=I1 + I2, ky=K1 or np.inf, kz=K2 or np.inf, cy=0.0, cz=0.0,
                   tau_factor=0.0, shape="general")


def turned(k: np.ndarray, R: np.ndarray) -> np.ndarray:
    """(12, 12) an element matrix k in element axes turned into mesh axes: T^T k T, T = diag(R x 4)."""
    T = np.kron(np.eye(4), R)
    return T.T @ k @ T


def element_matrices(nodes: np.ndarray, cells: np.ndarray, bars: np.ndarray, E: float, G: float,
                     rho: float) -> tuple:
    """(k (ne, 12, 12), m (ne, 12, 12)): each element's stiffness and lumped mass in mesh axes."""
    R, ls = triads(nodes, cells, bars[:, 6:9]), lengths(nodes, cells)
    k = np.array([turned(element.stiffness(E, G, section(b), l, shear=True), r) for b, l, r in zip(bars, ls, R)])
    m = np.array([turned(element.mass_lumped(rho, section(b), l), r) for b, l, r in zip(bars, ls, R)])
    return k, m


def assemble(blocks: np.ndarray, cells: np.ndarray, n_nodes: int) -> sp.csr_matrix:
    """(dN, dN) the sum of element blocks (ne, 2d, 2d) over their nodes' DOFs (cells (ne, 2)), d DOFs
    a node: 6 in space, 3 in a plane (`planar_matrices`)."""
    d = blocks.shape[1] // 2
    dofs = (d * cells[:, :, None] + np.arange(d)).reshape(-1, 2 * d)
    rows = np.repeat(dofs, 2 * d, axis=1).ravel()
    cols = np.tile(dofs, (1, 2 * d)).ravel()
    n = d * n_nodes
    return sp.coo_matrix((blocks.ravel(), (rows, cols)), shape=(n, n)).tocsr()


def matrices(mesh, E: float, nu: float, rho: float) -> tuple:
    """(K, M) (6N, 6N) of a frame mesh: stiffness and lumped mass (with its point masses) in mesh axes."""
    cells = mesh.cells["bar2"]
    k, m = element_matrices(mesh.nodes, cells, mesh.bars, E, E / (2.0 * (1.0 + nu)), rho)
    return assemble(k, cells, mesh.n_nodes), assemble(m, cells, mesh.n_nodes) + point_masses(mesh)


def point_masses(mesh) -> sp.csr_matrix:
    """(6N, 6N) the frame's point masses (`mesh.masses`, CONM2) on their nodes' DOFs: m on the
    translations, Ixx, Iyy, Izz on the rotations."""
    n = 6 * mesh.n_nodes
    d = np.zeros(n)
    for row, m, *inertia in mesh.masses:
        d[6 * int(row):6 * int(row) + 6] += [m, m, m, *inertia]
    return sp.diags(d, format="csr") if d.any() else sp.csr_matrix((n, n))


def nearest(mesh, x: np.ndarray) -> tuple:
    """(row, s, offset): the element whose axis passes nearest to point x (3,) (mesh coordinates),
    the station s in [0, 1] along it and the point's offset (3,) from the axis there, mesh axes."""
    cells = mesh.cells["bar2"]
    a, b = mesh.nodes[cells[:, 0]], mesh.nodes[cells[:, 1]]
    d = b - a
    s = np.clip(np.einsum("ni,ni->n", x - a, d) / np.einsum("ni,ni->n", d, d), 0.0, 1.0)
    off = x - (a + s[:, None] * d)
    row = int(np.argmin(np.linalg.norm(off, axis=1)))
    return row, float(s[row]), off[row]


def fibre_rows(mesh, E: float, nu: float, x: np.ndarray) -> tuple:
    """(rows (6, 12), dofs (12,)): the stress at point x (3,) of the frame's volume (`nearest`
    element, its station and fibre) per unit nodal displacement of that element's 12 DOFs, as a
    Voigt vector in mesh axes [xx, yy, zz, yz, zx, xy], Pa: the fibre's axial stress
    sigma = E (eps - kappa_z y + kappa_y z) along the element's x and the torsion shear
    tau = G theta' r along the fibre's circumferential direction c = (-z, y) / r."""
    row, xi, off = nearest(mesh, np.asarray(x, dtype=float))
    cells = mesh.cells["bar2"]
    R = triads(mesh.nodes, cells[row:row + 1], mesh.bars[row:row + 1, 6:9])[0]
    l = float(lengths(mesh.nodes, cells[row:row + 1])[0])
    y, z = R[1] @ off, R[2] @ off
    r, G = np.hypot(y, z), E / (2.0 * (1.0 + nu))
    # per local DOF: eps = (u2 - u1) / l, theta' = (rx2 - rx1) / l, and the curvatures
    # kappa_z = v'' (x-y plane) and kappa_y = -w'' (x-z plane, ry = -w')
    eps, twist = np.zeros(12), np.zeros(12)
    eps[[0, 6]] = twist[[3, 9]] = [-1.0 / l, 1.0 / l]
    kz, ky = stress.curvature_rows(E, G, section(mesh.bars[row]), xi, l, shear=True)
    sigma = E * (eps - kz * y + ky * z)
    tau = G * twist * r
    # the element-axes tensor sigma e_x e_x^T + tau (e_x c^T + c e_x^T), turned into mesh axes:
    # s[i, j] = sum_ab R[a, i] R[b, j] s_local[a, b]; rows per mesh DOF through T
    c = np.array([0.0, -z / r, y / r]) @ R if r > 0 else np.zeros(3)
    ex = R[0]
    out = np.empty((6, 12))
    for k, (i, j) in enumerate(((0, 0), (1, 1), (2, 2), (1, 2), (2, 0), (0, 1))):
        out[k] = ex[i] * ex[j] * sigma + (ex[i] * c[j] + c[i] * ex[j]) * tau
    return out @ np.kron(np.eye(4), R), (6 * cells[row][:, None] + np.arange(6)).ravel()


# ---------------------------------------------------------------------------------------------
# a planar frame: beams in the x-y plane, three DOFs a node

PLANAR = np.array([0, 1, 5, 6, 7, 11])     # an element's in-plane DOFs: ux, uy, rz of node a, then of node b


def planar_triads(nodes: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """(ne, 3, 3) each element's triad, rows its x (node a to b, projected on the x-y plane), y = z
    cross x and z = the plane's normal (0, 0, 1), from nodes (N, 3) and cells (ne, 2)."""
    d = nodes[cells[:, 1], :2] - nodes[cells[:, 0], :2]
    x = d / np.linalg.norm(d, axis=1, keepdims=True)
    zero, one = np.zeros(len(x)), np.ones(len(x))
    return np.stack([np.column_stack([x, zero]), np.column_stack([-x[:, 1], x[:, 0], zero]),
                     np.column_stack([zero, zero, one])], axis=1)


def planar_matrices(nodes: np.ndarray, cells: np.ndarray, E: float, G: float, rho: float, sec: Section,
                    shear: bool = False) -> tuple:
    """(k (ne, 6, 6), m (ne, 6, 6)): each element's stiffness and consistent mass in the plane's
    axes, DOFs [ux, uy, rz] of node a then node b (N/m, N, N m/rad; kg, kg m, kg m^2). The 12-DOF
    element (`element.stiffness`, Euler-Bernoulli or with `shear` Timoshenko; `element.mass_consistent`)
    turned by its `planar_triads` (`turned`) and restricted to PLANAR. Exact: with the element's z
    along the plane's normal the turn mixes ux with uy and keeps rz, and the in-plane families (axial
    EA, bending E Iz) are uncoupled from torsion and x-z bending. The section's Iz is the one bending
    in the plane: a beam whose body z is the plane's normal (either way: the in-plane matrices do
    not change when y and z both turn over). Nodes (N, 3), m; cells (ne, 2)."""
    R, ls = planar_triads(nodes, cells), lengths(nodes, cells)
    keep = np.ix_(PLANAR, PLANAR)
    k = np.array([turned(element.stiffness(E, G, sec, l, shear=shear), r)[keep] for l, r in zip(ls, R)])
    m = np.array([turned(element.mass_consistent(rho, sec, l), r)[keep] for l, r in zip(ls, R)])
    return k, m


def tied(n: int, pairs: np.ndarray, held: np.ndarray) -> sp.csr_matrix:
    """(n, r) T, u = T w: n DOFs of which `pairs` (k, 2) are tied equal (a joint's shared DOFs) and
    `held` (h,) are zero (a joint to ground). Each class of DOFs tied together (through any chain of
    pairs) is one column of ones, a class holding a held DOF none: the constraints eliminated, so
    that T^T K T and T^T M T are the model's on its free coordinates w. Columns in the order of
    their classes' first DOFs."""
    pairs = np.asarray(pairs, dtype=int).reshape(-1, 2)
    graph = sp.coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    free = np.ones(label.max() + 1, dtype=bool)
    free[label[np.asarray(held, dtype=int)]] = False
    first = np.unique(label, return_index=True)[1]                 # each class's first DOF
    order = np.argsort(first[free])
    column = np.full(free.size, -1)
    column[np.flatnonzero(free)[order]] = np.arange(order.size)
    rows = np.flatnonzero(free[label])
    return sp.csr_matrix((np.ones(rows.size), (rows, column[label[rows]])), shape=(n, order.size))
