"""Boundary conditions, normal modes, static / constraint modes and Craig-Bampton sets.

All mode matrices are full size ``(6N, k)`` in the FE DOF order of
:mod:`flexmbd.fe.assembly` (node ``p``, DOF ``6 p + k``, ``k = [ux, uy, uz, rx, ry, rz]``),
with zeros at constrained DOFs. Frequencies are in Hz, ``f = sqrt(lambda) / (2 pi)`` with
``K phi = lambda M phi``.
"""

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as spla

__all__ = ["FAMILIES", "boundary_dofs", "free_dofs", "normal_modes", "static_modes",
           "constraint_modes", "craig_bampton", "orthonormalize", "rigid_body_fields", "hold_node",
           "mode_labels", "mode_families", "modes_per_family"]

# DOF families of a straight beam (node-local DOF indices); they are uncoupled in K and M. Their
# names are the kinds of modes (a mode's label is its family and its number in it, `mode_labels`)
FAMILIES = {"axial": (0,), "bending xy": (1, 5), "bending xz": (2, 4), "torsion": (3,)}

# eigenvalues below RIGID_TOL * max(diag K / diag M) are rigid-body (zero-frequency) modes
RIGID_TOL = 1e-14


def boundary_dofs(kind, n_nodes):
    """Constrained global DOFs of a standard support.

    Parameters
    ----------
    kind : {"clamped-free", "hinged-hinged", "free-free"}
        - ``"clamped-free"``: all six DOFs of node 0.
        - ``"hinged-hinged"``: node 0: ux, uy, uz, rx; node N-1: uy, uz. Both bending
          rotations are free at both ends (pinned in both planes), the far end slides
          axially, and twist is held at node 0 only (torsion behaves fixed-free).
        - ``"free-free"``: none.
    n_nodes : int
        Number of nodes N (>= 2).

    Returns
    -------
    (n_fixed,) int ndarray
        Sorted global DOF indices.
    """
    if n_nodes < 2:
        raise ValueError(f"a beam needs at least 2 nodes, got {n_nodes}")
    last = 6 * (n_nodes - 1)
    table = {"clamped-free": [0, 1, 2, 3, 4, 5],
             "hinged-hinged": [0, 1, 2, 3, last + 1, last + 2],
             "free-free": []}
    if kind not in table:
        raise ValueError(f"unknown boundary kind {kind!r}; expected one of {sorted(table)}")
    return np.array(sorted(table[kind]), dtype=int)


def free_dofs(n_dof, fixed):
    """Sorted DOFs (int ndarray) of ``range(n_dof)`` not in ``fixed`` (checked to be in range)."""
    fixed = np.asarray(fixed, dtype=int).ravel()
    if fixed.size and (fixed.min() < 0 or fixed.max() >= n_dof):
        raise ValueError(f"fixed DOFs must lie in [0, {n_dof}), got {fixed.min()}..{fixed.max()}")
    mask = np.ones(n_dof, dtype=bool)
    mask[fixed] = False
    return np.flatnonzero(mask)


def _restrict(A, rows, cols=None):
    """Sub-matrix ``A[rows][:, cols]`` of a sparse or dense matrix, as csr."""
    A = sp.csr_matrix(A)
    return A[rows][:, rows if cols is None else cols]


def _expand(X, dofs, n_dof):
    """Full-size (n_dof, k) matrix with the rows ``dofs`` set to ``X`` and zeros elsewhere."""
    out = np.zeros((n_dof, X.shape[1]))
    out[dofs] = X
    return out


def _to_hz(lam):
    """Frequencies in Hz from eigenvalues omega^2 (round-off negatives clipped to 0)."""
    return np.sqrt(np.clip(lam, 0.0, None)) / (2.0 * np.pi)


def _fix_signs(Phi):
    """Flip each column so that its largest-magnitude entry is positive."""
    if Phi.size == 0:
        return Phi
    k = np.argmax(np.abs(Phi), axis=0)
    return Phi * np.where(Phi[k, np.arange(Phi.shape[1])] < 0, -1.0, 1.0)


def _eig_scale(Kff, Mff):
    """Estimate of the largest eigenvalue, ``max(diag K / diag M)``, used to scale tolerances."""
    dk, dm = Kff.diagonal(), Mff.diagonal()
    return float(np.max(np.abs(dk) / np.where(dm > 0, dm, np.inf)))


def _eig_dense(Kff, Mff, m):
    """Lowest ``m`` eigenpairs of the free-DOF problem by dense ``scipy.linalg.eigh``."""
    return la.eigh(Kff.toarray(), Mff.toarray(), subset_by_index=[0, m - 1])


def _eig_sparse(Kff, Mff, m, lam_ref):
    """Lowest ``m`` eigenpairs by ``eigsh`` shift-invert about a small negative shift."""
    sigma = -1e-9 * lam_ref
    lam, X = spla.eigsh(Kff.tocsc(), k=m, M=Mff.tocsc(), sigma=sigma, which="LM")
    order = np.argsort(lam)
    return lam[order], X[:, order]


def _lowest_elastic(Kff, Mff, n, dense):
    """At least the lowest ``n`` eigenpairs with non-zero eigenvalue (rigid-body modes skipped)."""
    size, lam_ref = Kff.shape[0], _eig_scale(Kff, Mff)
    extra = 6
    while True:
        # solve for a few more than n, to leave room for rigid-body modes
        m = min(n + extra, size)
        use_dense = dense or m >= size - 1
        lam, X = _eig_dense(Kff, Mff, m) if use_dense else _eig_sparse(Kff, Mff, m, lam_ref)
        elastic = np.flatnonzero(lam > RIGID_TOL * lam_ref)
        if elastic.size >= n or m == size:
            break
        extra *= 4
    if elastic.size < n:
        raise ValueError(f"{n} elastic modes requested but the constrained model has only "
                         f"{elastic.size} ({size - elastic.size} rigid-body modes)")
    return lam[elastic], X[:, elastic]


def _family_codes(n_dof):
    """Family weight (1 axial, 2 bending xy, 3 bending xz, 4 torsion) of each global DOF."""
    code = np.zeros(6)
    for w, dofs in enumerate(FAMILIES.values(), start=1):
        code[list(dofs)] = w
    return np.tile(code, n_dof // 6)


def _split_degenerate(lam, Phi, M, rtol=1e-10):
    """Rotate modes of (numerically) equal eigenvalue so each lies in one DOF family.

    Equal-frequency pairs (e.g. the two bending planes of a circular section) come out of
    the eigensolver as arbitrary mixtures; an orthogonal rotation within each cluster keeps
    them M-orthonormal and K-diagonal and makes them pure (order: axial, xy, xz, torsion).
    """
    code = _family_codes(Phi.shape[0])
    atol = 1e-13 * np.max(np.abs(lam), initial=0.0)
    breaks = np.flatnonzero(np.diff(lam) > rtol * np.abs(lam[1:]) + atol) + 1
    for c in np.split(np.arange(lam.size), breaks):
        if c.size < 2:
            continue
        # family-weighted mass matrix of the cluster; its eigenvectors separate the families
        parts = [Phi[:, c] * (code == w)[:, None] for w in (1, 2, 3, 4)]
        C = sum(w * P.T @ (M @ P) for w, P in enumerate(parts, start=1))
        _, Q = la.eigh(0.5 * (C + C.T))
        Phi[:, c] = Phi[:, c] @ Q
    return Phi


def _ritz(K, M, Phi, tol):
    """One Rayleigh-Ritz pass: (lam, Phi_out) M-orthonormal, K-diagonal, dependent dirs dropped."""
    # reduced matrices, Jacobi-scaled
    Kr, Mr = Phi.T @ (K @ Phi), Phi.T @ (M @ Phi)
    d = np.sqrt(np.clip(np.diag(Mr), 0.0, None))
    d = np.where(d > 0, d, 1.0)
    s, V = la.eigh(0.5 * (Mr + Mr.T) / np.outer(d, d))

    # basis of the independent directions with T^T Mr T = I
    keep = s > tol * np.max(s, initial=0.0)
    T = V[:, keep] / np.sqrt(s[keep]) / d[:, None]

    # reduced eigenproblem in that basis
    lam, Y = la.eigh(0.5 * (T.T @ Kr @ T + (T.T @ Kr @ T).T))
    return lam, Phi @ (T @ Y)


def normal_modes(K, M, fixed, n, dense_limit=3000):
    """Lowest ``n`` elastic normal modes of ``K phi = omega^2 M phi`` with DOFs ``fixed`` held.

    Parameters
    ----------
    K, M : (6N, 6N) sparse or dense
        Stiffness and (positive definite) mass matrices.
    fixed : array_like of int
        Constrained global DOFs.
    n : int
        Number of modes.
    dense_limit : int
        Dense ``scipy.linalg.eigh`` when 6N is at most this, else sparse ``eigsh``
        (shift-invert about a small negative shift, so free-free K is fine).

    Returns
    -------
    freq_hz : (n,) ndarray
        Ascending natural frequencies, Hz.
    Phi : (6N, n) ndarray
        Modes, zero at ``fixed``, with ``Phi.T @ M @ Phi = I``. Modes of equal frequency are
        rotated to be pure in one DOF family; each column's largest entry is positive.

    Notes
    -----
    Rigid-body (zero-frequency) modes, e.g. the six of a free-free beam, are excluded:
    the first ``n`` elastic modes are returned. A mode is rigid when its eigenvalue is
    below ``RIGID_TOL * max(diag K / diag M)`` (a frequency below about 1e-7 of the highest
    one of the mesh, i.e. numerically zero in double precision).
    """
    n_dof = K.shape[0]
    free = free_dofs(n_dof, fixed)
    if n < 0 or n > free.size:
        raise ValueError(f"{n} modes requested but the model has only {free.size} free DOFs")
    if n == 0:
        return np.zeros(0), np.zeros((n_dof, 0))

    # eigenpairs on the free DOFs
    Kff, Mff = _restrict(K, free), _restrict(M, free)
    lam, X = _lowest_elastic(Kff, Mff, n, dense=n_dof <= dense_limit)

    # Ritz clean-up for orthonormality, pure families (before cutting through a pair), signs
    lam, X = _ritz(Kff, Mff, X, tol=0.0)
    Phi = _split_degenerate(lam, _expand(X, free, n_dof), sp.csr_matrix(M))
    return _to_hz(lam[:n]), _fix_signs(Phi[:, :n])


def _factor(A):
    """Sparse LU of a square matrix; ValueError if it is singular."""
    try:
        return spla.splu(sp.csc_matrix(A))
    except RuntimeError as exc:
        raise ValueError("stiffness is singular on the retained DOFs: the supports must "
                         "suppress every rigid-body motion") from exc


def _check_subset(dofs, allowed, what):
    """Validated int array of ``dofs`` (no duplicates, all in ``allowed``)."""
    dofs = np.asarray(dofs, dtype=int).ravel()
    if np.unique(dofs).size != dofs.size:
        raise ValueError(f"{what} contain duplicates")
    if not np.all(np.isin(dofs, allowed)):
        raise ValueError(f"{what} must be free (not fixed) DOFs")
    return dofs


def static_modes(K, fixed, load_dofs):
    """Static deflections under unit loads.

    Parameters
    ----------
    K : (6N, 6N) sparse or dense
        Stiffness.
    fixed : array_like of int
        Constrained DOFs (must make K non-singular).
    load_dofs : array_like of int, (k,)
        Loaded DOFs; column j is the response to a unit force (N) or moment (N m) at load_dofs[j].

    Returns
    -------
    (6N, k) ndarray
        Deflections, m and rad per unit load; zero at ``fixed``.
    """
    n_dof = K.shape[0]
    free = free_dofs(n_dof, fixed)
    load_dofs = _check_subset(load_dofs, free, "load DOFs")

    # unit loads on the free DOFs
    F = np.zeros((free.size, load_dofs.size))
    F[np.searchsorted(free, load_dofs), np.arange(load_dofs.size)] = 1.0
    return _expand(_factor(_restrict(K, free)).solve(F), free, n_dof)


def constraint_modes(K, fixed, interface_dofs):
    """Craig-Bampton constraint modes.

    Column j is the static shape with a unit displacement (m or rad) at ``interface_dofs[j]``,
    the other interface DOFs and ``fixed`` held at zero, and the interior DOFs statically
    condensed: ``u_i = -K_ii^{-1} K_ib``.

    Returns
    -------
    (6N, k) ndarray
    """
    n_dof = K.shape[0]
    free = free_dofs(n_dof, fixed)
    iface = _check_subset(interface_dofs, free, "interface DOFs")
    interior = np.setdiff1d(free, iface)

    # unit interface displacements, interior from static condensation
    Psi = np.zeros((n_dof, iface.size))
    Psi[iface, np.arange(iface.size)] = 1.0
    if interior.size:
        Kib = _restrict(K, interior, iface).toarray()
        Psi[interior] = -_factor(_restrict(K, interior)).solve(Kib)
    return Psi


def craig_bampton(K, M, fixed, interface_dofs, n_normal):
    """Craig-Bampton basis: ``n_normal`` fixed-interface normal modes, then the constraint modes.

    Returns
    -------
    (6N, n_normal + k) ndarray
        Not orthonormal; pass it to :func:`orthonormalize` for an M-orthonormal set.
    """
    held = np.union1d(np.asarray(fixed, dtype=int), np.asarray(interface_dofs, dtype=int))
    _, Phi_n = normal_modes(K, M, held, n_normal)
    return np.hstack([Phi_n, constraint_modes(K, fixed, interface_dofs)])


def orthonormalize(K, M, Phi, tol=1e-10):
    """M-orthonormal, K-diagonal modes spanning the columns of ``Phi``.

    Solves ``(Phi^T K Phi) x = omega^2 (Phi^T M Phi) x``. Directions with an eigenvalue of the
    (Jacobi-scaled) ``Phi^T M Phi`` below ``tol`` times its largest are linearly dependent and
    dropped. Two Ritz passes are made so orthonormality holds to round-off.

    Returns
    -------
    freq_hz : (m,) ndarray
        Ascending, Hz; rigid-body directions appear at ~0 Hz and are kept.
    Phi_out : (6N, m) ndarray
        ``Phi_out.T @ M @ Phi_out = I`` and ``Phi_out.T @ K @ Phi_out = diag((2 pi f)^2)``.
    """
    K, M = sp.csr_matrix(K), sp.csr_matrix(M)
    lam, X = _ritz(K, M, np.asarray(Phi, dtype=float), tol)
    lam, X = _ritz(K, M, X, tol=0.0)
    return _to_hz(lam), _fix_signs(_split_degenerate(lam, X, M))


def rigid_body_fields(nodes, p):
    """The six rigid-body displacement fields of the mesh about node ``p``.

    Column ``k`` of ``[t; theta]`` (translation of node p, then rotation) moves node ``q`` by
    ``u_q = t + theta x (x_q - x_p)`` and turns it by ``theta``.

    Parameters
    ----------
    nodes : (N, 3) ndarray
        Node positions, m.
    p : int
        The node the fields are referred to.

    Returns
    -------
    (6N, 6) ndarray
        Rows in the FE DOF order ``[ux, uy, uz, rx, ry, rz]`` per node.
    """
    d = np.asarray(nodes, dtype=float) - nodes[p]
    R = np.zeros((d.shape[0], 6, 6))
    R[:, np.arange(6), np.arange(6)] = 1.0
    R[:, :3, 3:] = np.cross(np.eye(3)[None, :, :], d[:, None, :]).transpose(0, 2, 1)   # e_k x d
    return R.reshape(-1, 6)


def hold_node(Phi, nodes, p):
    """``Phi`` with the rigid-body motion of node ``p`` taken out of every column.

    Each mode loses the rigid displacement field that has node p's translation and rotation in
    that mode (:func:`rigid_body_fields`), so node p's six DOFs are exactly zero. K annihilates
    rigid motion, so ``Phi^T K Phi`` is unchanged; the mass products are not, and the result is
    not orthonormal (pass it to :func:`orthonormalize`).

    Returns
    -------
    (6N, k) ndarray
    """
    Phi = np.asarray(Phi, dtype=float)
    return Phi - rigid_body_fields(nodes, p) @ Phi[6 * p:6 * p + 6]


def modes_per_family(elements):
    """Elastic modes of each family (`FAMILIES`) of a straight beam of ``elements`` elements:
    the family's free DOFs less its rigid-body motions, ``elements`` axial and torsion modes and
    ``2 elements`` bending modes in each plane, the same for every boundary of
    :func:`boundary_dofs` and for a Craig-Bampton set (clamped-free: node 0 holds one DOF of the
    axial and torsion families and two of each bending one; hinged-hinged: the same six over both
    ends; free-free: none, and its six rigid-body modes, as many in a family as it has DOFs at a
    node, are not elastic)."""
    n = int(elements)
    return {"axial": n, "bending xy": 2 * n, "bending xz": 2 * n, "torsion": n}


def _is_rigid(Phi, tol):
    """Columns whose rotations and axial displacement are the same at every node."""
    B = Phi.reshape(-1, 6, Phi.shape[1])[:, [0, 3, 4, 5]]
    spread = np.max(np.abs(B - B[:1]), axis=(0, 1))
    return spread <= tol * np.max(np.abs(Phi), axis=0)


def mode_labels(Phi, M=None, rigid_tol=1e-6):
    """Family label of each mode: "bending xy 1", "bending xz 2", "torsion 1", "axial 1", "rigid":
    its family (:func:`mode_families`) and its number within the family, in column order.

    Parameters
    ----------
    Phi : (6N, k) ndarray
        Modes in frequency order (columns); families are numbered in that order.
    M, rigid_tol
        As :func:`mode_families`.

    Returns
    -------
    list of str
    """
    count, labels = dict.fromkeys(FAMILIES, 0), []
    for name in mode_families(Phi, M, rigid_tol):
        if name == "rigid":
            labels.append(name)
            continue
        count[name] += 1
        labels.append(f"{name} {count[name]}")
    return labels


def mode_families(Phi, M=None, rigid_tol=1e-6):
    """The family (a key of `FAMILIES`, the mode's kind) of each mode, or "rigid".

    Parameters
    ----------
    Phi : (6N, k) ndarray
        Modes (columns).
    M : (6N, 6N) sparse or dense, optional
        Mass matrix. The family of a mode is the one with the largest M-weighted share
        ``sum_{i in family} phi_i (M phi)_i``; without M the plain shares ``phi_i^2`` are used
        (same answer for the pure-family modes of a straight beam).
    rigid_tol : float
        A mode is "rigid" when its rotations and axial displacement are uniform along the
        beam to ``rigid_tol`` times its largest entry (rigid-body motion of a straight beam).

    Returns
    -------
    list of str
    """
    Phi = np.asarray(Phi, dtype=float)
    weighted = Phi * (Phi if M is None else np.asarray(M @ Phi))
    per_dof = weighted.reshape(-1, 6, Phi.shape[1]).sum(axis=0)
    shares = np.array([per_dof[list(d)].sum(axis=0) for d in FAMILIES.values()])
    names = list(FAMILIES)
    return ["rigid" if rigid else names[int(np.argmax(shares[:, j]))]
            for j, rigid in enumerate(_is_rigid(Phi, rigid_tol))]
