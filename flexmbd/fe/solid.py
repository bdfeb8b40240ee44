"""Isoparametric solid elements and the sparse assembly of a solid's stiffness and mass (SI units).

Elements: tet4, tet10, hex8, hex20 (node orders in `fe.mesh`), isotropic linear elasticity, every
element fully integrated (Gauss-Legendre: hex8 2^3, hex20 3^3 points; tetrahedra by the collapsed
Gauss-Legendre rule exact for the polynomial degree of each integrand). The mass is consistent.

DOF order: node p owns global DOFs 3 p + k, k = [ux, uy, uz], m. A solid's mass matrix is
M = Ms (x) I3 with Ms (N, N) the scalar consistent mass (`scalar_mass`); the floating-frame
invariants need only Ms (`flexbody`).

Stress: Voigt order [xx, yy, zz, yz, zx, xy], engineering shear strains, Pa.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from flexmbd.fe.mesh import EDGES, Mesh
from flexmbd.mbd.spatial import skew_rows

HEX_CORNERS = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
                        [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], dtype=float)


# ---------------------------------------------------------------------------------------------
# shape functions N (g, nn) and their natural derivatives dN (g, nn, 3) at points xi (g, 3)

def shape(kind: str, xi: np.ndarray) -> tuple:
    """N (g, nn) and dN/dxi (g, nn, 3) of an element `kind` at natural points xi (g, 3):
    tetrahedra on the unit simplex (xi, eta, zeta >= 0, sum <= 1), hexahedra on [-1, 1]^3."""
    return _SHAPES[kind](np.atleast_2d(np.asarray(xi, dtype=float)))


def _tet4(xi):
    L = np.column_stack([1.0 - xi.sum(axis=1), xi])                       # barycentric (g, 4)
    dL = np.array([[-1.0, -1.0, -1.0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])  # dL_i/dxi (4, 3)
    return L, np.broadcast_to(dL, (xi.shape[0], 4, 3)).copy()


def _tet10(xi):
    L, dL = _tet4(xi)
    N = np.empty((xi.shape[0], 10))
    dN = np.empty((xi.shape[0], 10, 3))
    N[:, :4] = L * (2.0 * L - 1.0)
    dN[:, :4] = (4.0 * L - 1.0)[:, :, None] * dL
    for k, (i, j) in enumerate(EDGES["tet10"]):
        N[:, 4 + k] = 4.0 * L[:, i] * L[:, j]
        dN[:, 4 + k] = 4.0 * (L[:, i, None] * dL[:, j] + L[:, j, None] * dL[:, i])
    return N, dN


def _hex8(xi):
    s = 1.0 + xi[:, None, :] * HEX_CORNERS[None]                          # (g, 8, 3): 1 + xi_a c_a
    N = 0.125 * s.prod(axis=2)
    dN = np.empty(s.shape)
    for a in range(3):
        others = [b for b in range(3) if b != a]
        dN[:, :, a] = 0.125 * HEX_CORNERS[:, a] * s[:, :, others].prod(axis=2)
    return N, dN


def _hex20(xi):
    g = xi.shape[0]
    N = np.empty((g, 20))
    dN = np.empty((g, 20, 3))
    c = HEX_CORNERS
    s = 1.0 + xi[:, None, :] * c[None]                                    # (g, 8, 3)
    t = (xi[:, None, :] * c[None]).sum(axis=2) - 2.0                      # (g, 8): xi.c - 2
    N[:, :8] = 0.125 * s.prod(axis=2) * t
    for a in range(3):
        o = [b for b in range(3) if b != a]
        dN[:, :8, a] = 0.125 * c[:, a] * (s[:, :, o].prod(axis=2) * t + s.prod(axis=2))
    for k, (i, j) in enumerate(EDGES["hex20"]):
        m = 0.5 * (c[i] + c[j])                                            # mid-edge point: one coordinate 0
        a = int(np.flatnonzero(m == 0)[0])                                 # the edge's direction
        o = [b for b in range(3) if b != a]
        q = 1.0 + xi[:, o] * m[o]                                          # (g, 2)
        N[:, 8 + k] = 0.25 * (1.0 - xi[:, a] ** 2) * q.prod(axis=1)
        dN[:, 8 + k, a] = -0.5 * xi[:, a] * q.prod(axis=1)
        dN[:, 8 + k, o[0]] = 0.25 * (1.0 - xi[:, a] ** 2) * m[o[0]] * q[:, 1]
        dN[:, 8 + k, o[1]] = 0.25 * (1.0 - xi[:, a] ** 2) * m[o[1]] * q[:, 0]
    return N, dN


_SHAPES = {"tet4": _tet4, "tet10": _tet10, "hex8": _hex8, "hex20": _hex20}
CENTRE = {"tet4": [0.25, 0.25, 0.25], "tet10": [0.25, 0.25, 0.25], "hex8": [0.0, 0.0, 0.0], "hex20": [0.0, 0.0, 0.0]}


# ---------------------------------------------------------------------------------------------
# quadrature

def gauss(kind: str, degree: int) -> tuple:
    """Points (g, 3) and weights (g,) exact for polynomials of `degree` on the element's natural
    domain: tensor Gauss-Legendre on the cube; on the simplex, Gauss-Legendre on the cube collapsed
    by xi = a (1 - b)(1 - c), eta = b (1 - c), zeta = c (Jacobian (1 - b)(1 - c)^2)."""
    if kind.startswith("hex"):
        x, w = np.polynomial.legendre.leggauss(max(1, -(-(degree + 1) // 2)))
        P = np.stack(np.meshgrid(x, x, x, indexing="ij"), axis=-1).reshape(-1, 3)
        return P, np.einsum("i,j,k->ijk", w, w, w).ravel()
    n = max(1, -(-(degree + 3) // 2))                                      # degree + 2 in c, exact at 2n - 1
    x, w = np.polynomial.legendre.leggauss(n)
    x, w = 0.5 * (x + 1.0), 0.5 * w                                        # on [0, 1]
    a, b, c = (v.ravel() for v in np.meshgrid(x, x, x, indexing="ij"))
    W = np.einsum("i,j,k->ijk", w, w, w).ravel() * (1.0 - b) * (1.0 - c) ** 2
    return np.column_stack([a * (1.0 - b) * (1.0 - c), b * (1.0 - c), c]), W


# the polynomial degree p of N: total on the simplex, per direction on the cube
ORDER = {"tet4": 1, "tet10": 2, "hex8": 1, "hex20": 2}


def stiffness_rule(kind: str) -> tuple:
    """Full integration of dN dN: degree 2p - 2 on an affine tetrahedron; on the cube, 2p per
    direction (hex8 2^3, hex20 3^3 points)."""
    p = ORDER[kind]
    return gauss(kind, 2 * p - 2 if kind.startswith("tet") else 2 * p)


def mass_rule(kind: str) -> tuple:
    """Exact integration of N N on an affine element: degree 2p."""
    return gauss(kind, 2 * ORDER[kind])


# ---------------------------------------------------------------------------------------------
# element quantities, vectorized over the elements of one kind

def jacobians(kind: str, X: np.ndarray, xi: np.ndarray) -> tuple:
    """At natural points xi (g, 3) of elements with node positions X (ne, nn, 3):
    N (g, nn), dN/dx (ne, g, nn, 3) and det J (ne, g)."""
    N, dN = shape(kind, xi)
    J = np.einsum("eni,gnj->egij", X, dN)                                  # dx_i / dxi_j
    det = np.linalg.det(J)
    dNx = np.einsum("gnj,egji->egni", dN, np.linalg.inv(J))
    return N, dNx, det


def elasticity(E: float, nu: float) -> np.ndarray:
    """Isotropic elasticity matrix D (6, 6), Voigt [xx, yy, zz, yz, zx, xy], engineering shear."""
    lam, mu = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)), E / (2.0 * (1.0 + nu))
    D = np.zeros((6, 6))
    D[:3, :3] = lam
    D[[0, 1, 2], [0, 1, 2]] += 2.0 * mu
    D[[3, 4, 5], [3, 4, 5]] = mu
    return D


def strain_matrix(dNx: np.ndarray) -> np.ndarray:
    """B (..., 6, 3 nn) from dN/dx (..., nn, 3): strain = B u_e, u_e = [u_0x u_0y u_0z u_1x ...]."""
    shp = dNx.shape[:-2]
    nn = dNx.shape[-2]
    B = np.zeros(shp + (6, nn, 3))
    x, y, z = dNx[..., 0], dNx[..., 1], dNx[..., 2]
    B[..., 0, :, 0], B[..., 1, :, 1], B[..., 2, :, 2] = x, y, z
    B[..., 3, :, 1], B[..., 3, :, 2] = z, y
    B[..., 4, :, 0], B[..., 4, :, 2] = z, x
    B[..., 5, :, 0], B[..., 5, :, 1] = y, x
    return B.reshape(shp + (6, 3 * nn))


def element_stiffness(kind: str, X: np.ndarray, D: np.ndarray) -> np.ndarray:
    """(ne, 3nn, 3nn) stiffness of each element, integral of B^T D B."""
    xi, w = stiffness_rule(kind)
    _, dNx, det = jacobians(kind, X, xi)
    B = strain_matrix(dNx)                                                  # (ne, g, 6, 3nn)
    DB = np.einsum("ab,egbj->egaj", D, B) * (det * w)[:, :, None, None]
    return np.einsum("egai,egaj->eij", B, DB)


def element_scalar_mass(kind: str, X: np.ndarray, rho: float) -> np.ndarray:
    """(ne, nn, nn) scalar consistent mass of each element, integral of rho N N^T."""
    xi, w = mass_rule(kind)
    N, _, det = jacobians(kind, X, xi)
    return rho * np.einsum("gi,gj,eg->eij", N, N, det * w)


def volumes(kind: str, X: np.ndarray) -> np.ndarray:
    """(ne,) element volumes, m^3."""
    xi, w = stiffness_rule(kind) if kind.startswith("hex") else gauss(kind, 2)
    return jacobians(kind, X, xi)[2] @ w


def min_jacobian(kind: str, X: np.ndarray) -> np.ndarray:
    """(ne,) the smallest det J over the element's corners and integration points: <= 0 where an
    element is inverted or degenerate."""
    corners = HEX_CORNERS if kind.startswith("hex") else np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    pts = np.vstack([corners, stiffness_rule(kind)[0], mass_rule(kind)[0]])
    return jacobians(kind, X, pts)[2].min(axis=1)


# ---------------------------------------------------------------------------------------------
# assembly

def vector_dofs(cells: np.ndarray) -> np.ndarray:
    """(ne, 3nn) global DOFs of each element, node-major: 3 p + k."""
    return (3 * cells[:, :, None] + np.arange(3)).reshape(cells.shape[0], -1)


def _scatter(blocks: np.ndarray, dofs: np.ndarray, n: int) -> sp.csr_matrix:
    rows = np.repeat(dofs, dofs.shape[1], axis=1).ravel()
    cols = np.tile(dofs, (1, dofs.shape[1])).ravel()
    A = sp.coo_matrix((blocks.ravel(), (rows, cols)), shape=(n, n)).tocsr()
    A.sum_duplicates()
    return A


# elements per block of the assembly: bounds the element arrays' memory (hex20: 27 points x 6 x 60
# strain rows, 0.3 GB for 4,000 elements at once) without slowing the vectorized loops
BLOCK = 1000


def stiffness(mesh: Mesh, E: float, nu: float) -> sp.csr_matrix:
    """Global stiffness K (3N, 3N), csr, symmetric."""
    D = elasticity(E, nu)
    n = 3 * mesh.n_nodes
    K = sp.csr_matrix((n, n))
    for kind, cells in mesh.cells.items():
        for c in np.array_split(cells, -(-cells.shape[0] // BLOCK)):
            K = K + _scatter(element_stiffness(kind, mesh.nodes[c], D), vector_dofs(c), n)
    return ((K + K.T) * 0.5).tocsr()


def scalar_mass(mesh: Mesh, rho: float) -> sp.csr_matrix:
    """Scalar consistent mass Ms (N, N), csr: M = Ms (x) I3 (`vector_mass`)."""
    n = mesh.n_nodes
    Ms = sp.csr_matrix((n, n))
    for kind, cells in mesh.cells.items():
        for c in np.array_split(cells, -(-cells.shape[0] // BLOCK)):
            Ms = Ms + _scatter(element_scalar_mass(kind, mesh.nodes[c], rho), c, n)
    return ((Ms + Ms.T) * 0.5).tocsr()


def vector_mass(Ms: sp.spmatrix) -> sp.csr_matrix:
    """M (3N, 3N) = Ms (x) I3 in the node-major DOF order."""
    return sp.kron(Ms, sp.identity(3), format="csr")


# ---------------------------------------------------------------------------------------------
# stress recovery

def centres(mesh: Mesh) -> tuple:
    """Element centres: (kinds (ne_total,) str, rows (ne_total,), x (ne_total, 3)), elements in the
    order of mesh.cells."""
    kinds, rows, xs = [], [], []
    for kind, cells in mesh.cells.items():
        N, _ = shape(kind, np.array([CENTRE[kind]]))
        xs.append(np.einsum("n,enj->ej", N[0], mesh.nodes[cells]))
        kinds += [kind] * cells.shape[0]
        rows.append(np.arange(cells.shape[0]))
    return np.array(kinds), np.concatenate(rows), np.vstack(xs)


def natural(kind: str, X: np.ndarray, x) -> np.ndarray:
    """(3,) the natural coordinates of point x (3,) in the element whose nodes are at X (nn, 3):
    Newton's method on x(xi) = N(xi) X from the element's centre, to 1e-12 of the element's size
    (one step on an undistorted linear element, a few on a quadratic one)."""
    xi, x = np.array(CENTRE[kind], dtype=float), np.asarray(x, dtype=float)
    size = float(np.ptp(X, axis=0).max())
    for _ in range(30):
        N, dN = shape(kind, xi)
        r = N[0] @ X - x
        if np.linalg.norm(r) <= 1e-12 * size:
            return xi
        xi = xi - np.linalg.solve(X.T @ dN[0], r)
    raise ValueError(f"the point {x.tolist()} has no natural coordinates in its {kind} element")


def stress_rows(mesh: Mesh, E: float, nu: float, kind: str, row: int, xi=None) -> tuple:
    """The stress at natural point xi (default: the centre) of element `row` of cells[kind] as
    rows acting on the element's DOFs: (S (6, 3nn), dofs (3nn,)), sigma = S u[dofs]."""
    cells = mesh.cells[kind][row:row + 1]
    _, dNx, _ = jacobians(kind, mesh.nodes[cells], np.array([CENTRE[kind] if xi is None else xi]))
    return elasticity(E, nu) @ strain_matrix(dNx[0, 0]), vector_dofs(cells)[0]


# corner nodes of each face, ordered so that the face's normal (right-hand rule) points outward
FACES = {"tet": ((0, 2, 1), (0, 1, 3), (1, 2, 3), (0, 3, 2)),
         "hex": ((0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7))}


def boundary_faces(mesh: Mesh) -> tuple:
    """The mesh's boundary faces (those of one element only): (faces, owners) with faces a list of
    corner-node index arrays (3 or 4 each, outward normal by the right-hand rule) and owners (nf,)
    the index of each face's element in the order of `centres`."""
    keys, faces, owners, first = {}, [], [], 0
    for kind, cells in mesh.cells.items():
        for local in FACES[kind[:3]]:
            for e, f in enumerate(cells[:, list(local)]):
                key = tuple(sorted(f))
                if key in keys:
                    keys[key] = None                                # shared: interior
                else:
                    keys[key] = len(faces)
                    faces.append(f)
                    owners.append(first + e)
        first += cells.shape[0]
    keep = sorted(i for i in keys.values() if i is not None)
    return [faces[i] for i in keep], np.array([owners[i] for i in keep], dtype=int)


def centre_stress_rows(mesh: Mesh, E: float, nu: float, elements: np.ndarray) -> list:
    """[(S (6, 3nn), dofs (3nn,))] of `stress_rows` at the centres of the elements (indices in the
    order of `centres`)."""
    kinds, rows, _ = centres(mesh)
    return [stress_rows(mesh, E, nu, str(kinds[e]), int(rows[e])) for e in elements]


def von_mises(s: np.ndarray) -> np.ndarray:
    """von Mises stress of Voigt stresses (..., 6), Pa."""
    xx, yy, zz, yz, zx, xy = np.moveaxis(s, -1, 0)
    return np.sqrt(0.5 * ((xx - yy) ** 2 + (yy - zz) ** 2 + (zz - xx) ** 2) + 3.0 * (yz ** 2 + zx ** 2 + xy ** 2))


# ---------------------------------------------------------------------------------------------
# modes and interfaces

def node_dofs(nodes: np.ndarray) -> np.ndarray:
    """(3k,) global DOFs of the nodes (k,), node-major."""
    return (3 * np.asarray(nodes, dtype=int)[:, None] + np.arange(3)).ravel()


def clamped_modes(K: sp.spmatrix, Ms: sp.spmatrix, held: np.ndarray, n: int, nodes: np.ndarray) -> tuple:
    """The lowest n normal modes with the nodes `held` fixed (a clamped interface): frequencies
    (n,) Hz and modes Phi (3N, n), M-orthonormal (M = Ms (x) I3), zero on `held`, signed by
    `signed` (nodes (N, 3): their positions); `interface_modes` with no other interface."""
    return interface_modes(K, Ms, nodes, "clamped-interface", n, held=held)


def constraint_basis(N: int, nodes: np.ndarray, held=(), rigid=()) -> sp.csr_matrix:
    """T (3N, m): the node DOFs of a mesh of N nodes (positions nodes (N, 3)) from its reduced
    coordinates: first the DOFs of every node neither `held` nor in a rigid set (the identity),
    then six per rigid (RBE2-like) interface of `rigid` [(set (k,), reference point (3,))]: its
    reference point's [rotation; translation], which move its set as one rigid body
    (`rigid_fields`). Held nodes have no coordinate; the sets must not share nodes."""
    fixed = np.concatenate([np.asarray(held, dtype=int)] + [np.asarray(s, dtype=int) for s, _ in rigid])
    keep = np.setdiff1d(np.arange(3 * N), node_dofs(fixed))
    rows, cols, vals = [keep], [np.arange(keep.size)], [np.ones(keep.size)]
    for j, (s, ref) in enumerate(rigid):
        R = rigid_fields(nodes[np.asarray(s, dtype=int)], ref)                      # (3k, 6)
        r, c = np.nonzero(R)
        rows.append(node_dofs(s)[r])
        cols.append(keep.size + 6 * j + c)
        vals.append(R[r, c])
    m = keep.size + 6 * len(rigid)
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(3 * N, m))


def interface_modes(K, Ms, nodes: np.ndarray, boundary: str, n: int, held=(), rigid=(), averaged=(),
                    frame=None) -> tuple:
    """The lowest n modes of a solid's mode set: frequencies (n,) Hz of the reduced body (from
    Phi^T K Phi) and modes Phi (3N, n), M-orthonormal (M = Ms (x) I3), K-diagonal, ascending,
    signed (`signed`). Rigid interfaces `rigid` [(set, ref)] move rigidly in every mode
    (`constraint_basis`); `held` nodes are zero. The mode sets (docs/fe.md, Solids):

    clamped-interface  the normal modes with `held` (the frame interface) fixed
    craig-bampton      `held` fixed; six constraint modes per rigid interface (unit motion of its
                       reference point, the rest static), six attachment modes per averaging
                       interface of `averaged` [(set, ref)] (its reference point's unit forces
                       and moments spread by `averaging`, static), and as many of the lowest
                       normal modes with every rigid interface held too as make n: the whole set,
                       orthonormalized (Rayleigh-Ritz), so that it holds every static response to
                       its interfaces exactly
    free-free          nothing held: the lowest n elastic normal modes, each less the rigid motion
                       that fits the frame interface `frame` = (set, ref) (`averaging`), so that
                       the interface's fitted reference point stays at the body frame; the lowest
                       n of their span (Rayleigh-Ritz)
    """
    N = Ms.shape[0]
    T = constraint_basis(N, nodes, held, rigid)
    M = vector_mass(Ms)
    Kr, Mr = (T.T @ K @ T).tocsc(), (T.T @ M @ T).tocsc()
    if boundary == "clamped-interface":
        # shift-invert Lanczos about 0 (Kr is positive definite with the frame held): only Kr is
        # factored; the frequencies are the eigensolver's own (a Rayleigh quotient would lose
        # digits to the cancellation between K's large entries)
        lam, X = spla.eigsh(Kr, k=n, M=Mr, sigma=0.0, which="LM", v0=start(Kr))
        order = np.argsort(lam)
        return np.sqrt(np.clip(lam[order], 0.0, None)) / (2.0 * np.pi), signed(T @ X[:, order], nodes)
    elif boundary == "craig-bampton":
        m_iface = 6 * len(rigid)
        inner = np.arange(Kr.shape[0] - m_iface)
        lu = spla.splu(Kr[inner][:, inner].tocsc())
        blocks = []
        if m_iface:                                     # constraint modes: [-Kii^-1 Kib; I]
            Kib = Kr[inner][:, inner.size:].toarray()
            blocks.append(np.vstack([-lu.solve(Kib), np.eye(m_iface)]))
        if averaged:                                    # attachment modes: Kr^-1 T^T A^T e_j
            F = np.zeros((3 * N, 6 * len(averaged)))
            for j, (s, ref) in enumerate(averaged):
                F[node_dofs(s), 6 * j:6 * j + 6] = averaging(nodes[np.asarray(s, dtype=int)], ref).T
            blocks.append(spla.splu(Kr).solve(np.asarray(T.T @ F)))
        n_normal = n - sum(b.shape[1] for b in blocks)
        if n_normal < 0:
            raise ValueError(f"{n} Craig-Bampton modes cannot hold the {n - n_normal} interface modes")
        if n_normal:
            Kii = Kr[inner][:, inner].tocsc()
            V = spla.eigsh(Kii, k=n_normal, M=Mr[inner][:, inner].tocsc(), sigma=0.0, which="LM", v0=start(Kii))[1]
            blocks.append(np.vstack([V, np.zeros((m_iface, n_normal))]))
        X = ritz(Kr, Mr, np.hstack(blocks), n)
    elif boundary == "free-free":
        scale = float(np.max(Kr.diagonal() / np.maximum(Mr.diagonal(), 1e-300)))
        lam, X = spla.eigsh(Kr, k=n + 6, M=Mr, sigma=-1e-9 * scale, which="LM", v0=start(Kr))
        X = X[:, np.argsort(lam)[6:]]                   # the six rigid-body modes first
        Phi = T @ X
        s, ref = frame
        fit = averaging(nodes[np.asarray(s, dtype=int)], ref) @ Phi[node_dofs(s)]       # (6, n)
        Phi = Phi - rigid_fields(nodes, ref) @ fit
        return _ritz_hz(K, M, ritz(K.tocsc(), M.tocsc(), Phi, n), nodes)
    else:
        raise ValueError(f"mode set {boundary!r}")
    return _ritz_hz(K, M, T @ X, nodes)


def start(A) -> np.ndarray:
    """A fixed starting vector for the Lanczos iterations on A (ARPACK's own is random): the same
    matrix gives the same modes to the last bit in every process."""
    return np.random.default_rng(0).uniform(0.5, 1.5, A.shape[0])


def ritz(K, M, B: np.ndarray, n: int) -> np.ndarray:
    """The lowest n Rayleigh-Ritz vectors (rows of K, M, n) in the span of B: M-orthonormal,
    K-diagonal, ascending (B's dependent directions dropped; its columns scaled to unit M-norm first,
    so that a constraint mode in m per rad and an attachment mode in m per N weigh alike)."""
    W = B / np.sqrt(np.maximum(np.einsum("ik,ik->k", B, M @ B), 1e-300))
    for tol in (1e-12, 0.0):                            # twice: the second pass restores what round-off
        Mb = W.T @ (M @ W)                              # took from an ill-conditioned first one
        d, U = np.linalg.eigh(0.5 * (Mb + Mb.T))
        keep = d > tol * d.max()
        W = W @ (U[:, keep] / np.sqrt(d[keep]))         # M-orthonormal basis of the span
    Kb = W.T @ (K @ W)
    lam, V = np.linalg.eigh(0.5 * (Kb + Kb.T))
    return W @ V[:, :n]


def _ritz_hz(K, M, Phi: np.ndarray, nodes: np.ndarray) -> tuple:
    """(frequencies (n,) Hz from Phi^T K Phi, Phi signed) of M-orthonormal, K-diagonal modes."""
    lam = np.einsum("ik,ik->k", Phi, K @ Phi)
    return np.sqrt(np.clip(lam, 0.0, None)) / (2.0 * np.pi), signed(Phi, nodes)


# a fixed field with no symmetry (a constant and a generic linear part) against which mode signs
# are set: unlike the sign of a column's largest entry, it does not depend on the node order of a
# symmetric mesh, whose modes have entries of equal size and opposite sign
SIGN_FIELD = (np.array([1.0, 1.3, 1.7]), np.array([[0.31, 0.73, 0.19], [0.53, 0.11, 0.97], [0.67, 0.43, 0.23]]))


def signed(Phi: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """Modes (3N, n), each column's sign set so that its projection on SIGN_FIELD (evaluated at
    the nodes (N, 3), centred and scaled to the mesh's extent) is positive: the same signs for the
    same mesh whatever the order of its nodes."""
    x = (nodes - nodes.mean(axis=0)) / max(float(np.ptp(nodes, axis=0).max()), 1e-300)
    w = (SIGN_FIELD[0] + x @ SIGN_FIELD[1].T).ravel()
    return Phi * np.where(w @ Phi < 0, -1.0, 1.0)


def rigid_fields(x: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """(3k, 6) displacements of the points x (k, 3) under a rigid motion of the reference point
    ref (3,): columns [rotation x, y, z; translation x, y, z] (spatial order), u = theta x (x - ref) + t."""
    d = np.asarray(x, dtype=float) - np.asarray(ref, dtype=float)
    R = np.zeros((d.shape[0], 3, 6))
    R[:, :, :3] = -skew_rows(d)                                      # theta x d = -d~ theta
    R[:, :, 3:] = np.eye(3)
    return R.reshape(-1, 6)


def fits_rigid(x: np.ndarray) -> bool:
    """True when the points x (k, 3) fix a rigid motion: at least three, not on one line (to 1e-6
    of their spread). Fewer, or points on a line, leave a rotation about that line that moves none
    of them: a rigid interface on them does not hold it, and their least-squares fit (`averaging`)
    is singular."""
    d = np.asarray(x, dtype=float).reshape(-1, 3)
    s = np.linalg.svd(d - d.mean(axis=0), compute_uv=False)
    return s.size > 1 and bool(s[1] > 1e-6 * s[0])


def averaging(x: np.ndarray, ref: np.ndarray, w=None) -> np.ndarray:
    """The averaging (RBE3-like) interface of points x (k, 3) about ref (3,): A (6, 3k) giving the
    reference point's [theta; t] as the weighted least-squares rigid fit of their displacements,
    A = (R^T W R)^-1 R^T W (R = `rigid_fields`, W = diag of the weights w (k,), default 1). A force
    and moment [m; f] at the reference point spread over the points as A^T [m; f]: the same
    resultant and moment about ref, each point's share proportional to its weight. The points must
    fix a rigid motion (`fits_rigid`)."""
    R = rigid_fields(x, ref)
    W = np.repeat(np.ones(len(x)) if w is None else np.asarray(w, dtype=float), 3)
    RtW = R.T * W
    return np.linalg.solve(RtW @ R, RtW)
