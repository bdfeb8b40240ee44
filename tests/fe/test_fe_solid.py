"""The solid elements and their assembly (flexmbd/fe/solid.py, flexmbd/fe/mesh.py), each checked
against what they do not compute themselves: interpolation and quadrature identities, rigid-body
fields, the continuum's mass moments, scikit-fem's independent assembly, and Euler-Bernoulli."""

from math import factorial

import meshio
import numpy as np
import pytest
import scipy.sparse.linalg as spla

from flexmbd.fe import mesh, solid

pytestmark = pytest.mark.kernel_free

KINDS = ("tet4", "tet10", "hex8", "hex20")
E, NU, RHO = 2.1e11, 0.3, 7850.0


def natural_nodes(kind):
    """The element's nodes in natural coordinates, in the node order of fe.mesh."""
    corners = solid.HEX_CORNERS if kind.startswith("hex") else np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    if kind in mesh.EDGES:
        corners = np.vstack([corners, [0.5 * (corners[i] + corners[j]) for i, j in mesh.EDGES[kind]]])
    return corners


@pytest.mark.parametrize("kind", KINDS)
def test_shape_functions_interpolate(kind):
    X = natural_nodes(kind)
    N, dN = solid.shape(kind, X)
    assert np.allclose(N, np.eye(len(X)), atol=1e-14)                  # N_i(x_j) = delta_ij
    xi = np.random.default_rng(1).uniform(0.0, 0.3, (7, 3))
    N, dN = solid.shape(kind, xi)
    assert np.allclose(N.sum(axis=1), 1.0, atol=1e-14)
    h = 1e-6                                                            # central differences: error ~ h^2 ~ 1e-12
    fd = np.stack([(solid.shape(kind, xi + h * e)[0] - solid.shape(kind, xi - h * e)[0]) / (2 * h)
                   for e in np.eye(3)], axis=-1)
    assert np.allclose(dN, fd, atol=1e-8)


@pytest.mark.parametrize("degree", range(0, 7))
def test_simplex_rule_integrates_monomials(degree):
    xi, w = solid.gauss("tet4", degree)
    for a in range(degree + 1):
        for b in range(degree + 1 - a):
            c = degree - a - b                                          # integral over the unit simplex
            exact = factorial(a) * factorial(b) * factorial(c) / factorial(a + b + c + 3)
            assert w @ (xi[:, 0] ** a * xi[:, 1] ** b * xi[:, 2] ** c) == pytest.approx(exact, rel=1e-13)


@pytest.mark.parametrize("kind", KINDS)
def test_assembly_rigid_motions_mass_and_moments(kind):
    m = mesh.box(0.3, 0.04, 0.02, (3, 2, 2), kind)
    K, Ms = solid.stiffness(m, E, NU), solid.scalar_mass(m, RHO)
    R = solid.rigid_fields(m.nodes, np.array([0.1, -0.2, 0.3]))         # six rigid fields (3N, 6)
    assert np.abs(K @ R).max() < 1e-12 * abs(K).max()
    V, x = 0.3 * 0.04 * 0.02, m.nodes
    assert Ms.sum() == pytest.approx(RHO * V, rel=1e-13)
    # isoparametric fields reproduce x exactly, so x^T Ms x is the continuum's second moment
    Q = x.T @ (Ms @ x)
    exact = RHO * V * np.diag([0.3 ** 2 / 3, 0.04 ** 2 / 12, 0.02 ** 2 / 12])
    exact[0, 0] = RHO * V * 0.3 ** 2 / 3
    assert np.allclose(Q, exact, rtol=1e-12, atol=1e-12 * exact.max())
    assert solid.min_jacobian(kind, x[m.cells[kind]]).min() > 0


def scikit_fem_frequencies(m, kind, n):
    """The clamped (x = 0) frequencies of the same mesh assembled by scikit-fem, Hz."""
    from skfem import Basis, BilinearForm, ElementHex1, ElementHexS2, ElementTetP1, ElementTetP2, ElementVector, asm
    from skfem.helpers import dot
    from skfem.io.meshio import from_meshio
    from skfem.models.elasticity import lame_parameters, linear_elasticity
    element, cell, corners = {"tet4": (ElementTetP1, "tetra", 4), "tet10": (ElementTetP2, "tetra", 4),
                              "hex8": (ElementHex1, "hexahedron", 8), "hex20": (ElementHexS2, "hexahedron", 8)}[kind]
    sk = from_meshio(meshio.Mesh(m.nodes, [(cell, m.cells[kind][:, :corners])]))
    basis = Basis(sk, ElementVector(element()), intorder=6)
    K = asm(linear_elasticity(*lame_parameters(E, NU)), basis)
    M = asm(BilinearForm(lambda u, v, w: RHO * dot(u, v)), basis)
    free = basis.complement_dofs(basis.get_dofs(lambda x: np.isclose(x[0], 0.0)).all())
    lam = spla.eigsh(K[free][:, free].tocsc(), k=n, M=M[free][:, free].tocsc(), sigma=0.0, which="LM")[0]
    return np.sqrt(np.sort(lam)) / (2 * np.pi)


@pytest.mark.parametrize("kind", KINDS)
def test_clamped_frequencies_match_scikit_fem(kind):
    m = mesh.box(0.2, 0.02, 0.03, (6, 2, 2), kind)
    f, Phi = solid.clamped_modes(solid.stiffness(m, E, NU), Ms := solid.scalar_mass(m, RHO), m.node_sets["x0"], 6, m.nodes)
    # two assemblies of the same discrete problem: agreement to round-off through a sparse
    # shift-invert eigensolve of a matrix of condition ~1e8 (seen: 4e-11); 1e-6 is the criterion
    assert np.abs(f / scikit_fem_frequencies(m, kind, 6) - 1).max() < 1e-6
    assert np.allclose(Phi.T @ (solid.vector_mass(Ms) @ Phi), np.eye(6), atol=1e-10)
    assert not Phi.reshape(-1, 3, 6)[m.node_sets["x0"]].any()


def test_cantilever_against_euler_bernoulli():
    """The paper's beam (1.5 x 0.015 x 0.01 m) as 30 x 1 x 1 hex20: the first bending frequency in
    each plane and the static tip deflection under a tip force spread by an averaging interface
    within 1 % of Euler-Bernoulli (seen: +0.33 %, +0.40 %, -0.50 %; the mesh's own error falls
    with refinement, docs/fe.md; shear and rotary inertia enter at (h/L)^2 = 1e-4)."""
    L, h, b, E_, nu, rho, P = 1.5, 0.015, 0.01, 2.06e11, 0.29, 7820.0, 12.0
    m = mesh.box(L, h, b, (30, 1, 1), "hex20")
    K, Ms = solid.stiffness(m, E_, nu), solid.scalar_mass(m, rho)
    f, Phi = solid.clamped_modes(K, Ms, m.node_sets["x0"], 2, m.nodes)
    A, Iz, Iy = b * h, b * h ** 3 / 12, h * b ** 3 / 12
    eb = lambda I: 1.875104068711961 ** 2 / (2 * np.pi * L ** 2) * np.sqrt(E_ * I / (rho * A))
    assert f[0] == pytest.approx(eb(Iy), rel=0.01)                      # thin direction (z) first
    assert f[1] == pytest.approx(eb(Iz), rel=0.01)
    tip = m.node_sets["xL"]
    A_tip = solid.averaging(m.nodes[tip], np.array([L, 0.0, 0.0]))
    F = np.zeros(K.shape[0])
    F[solid.node_dofs(tip)] = A_tip.T @ np.array([0, 0, 0, 0, -P, 0.0])
    free = np.setdiff1d(np.arange(K.shape[0]), solid.node_dofs(m.node_sets["x0"]))
    u = np.zeros(K.shape[0])
    u[free] = spla.spsolve(K[free][:, free].tocsc(), F[free])
    assert (A_tip @ u[solid.node_dofs(tip)])[4] == pytest.approx(-P * L ** 3 / (3 * E_ * Iz), rel=0.01)


def test_averaging_interface():
    x = np.random.default_rng(2).normal(size=(9, 3))
    ref, w = np.array([0.3, 0.1, -0.2]), np.linspace(1.0, 2.0, 9)
    A = solid.averaging(x, ref, w)
    R = solid.rigid_fields(x, ref)
    assert np.allclose(A @ R, np.eye(6), atol=1e-12)                    # a rigid motion is recovered
    mf = np.array([0.5, -1.0, 2.0, 3.0, 0.0, -4.0])                      # [moment; force] at ref
    f = (A.T @ mf).reshape(-1, 3)
    assert np.allclose(f.sum(axis=0), mf[3:], atol=1e-12)
    assert np.allclose(np.cross(x - ref, f).sum(axis=0), mf[:3], atol=1e-12)


def test_stress_of_uniform_tension():
    m = mesh.box(0.2, 0.02, 0.03, (2, 2, 2), "hex20")
    eps = 1e-4
    u = np.zeros_like(m.nodes)
    u[:, 0] = eps * m.nodes[:, 0]
    u[:, 1] = -NU * eps * m.nodes[:, 1]
    u[:, 2] = -NU * eps * m.nodes[:, 2]
    S, dofs = solid.stress_rows(m, E, NU, "hex20", 3)
    s = S @ u.ravel()[dofs]
    assert np.allclose(s, [E * eps, 0, 0, 0, 0, 0], atol=1e-9 * E * eps)
    assert solid.von_mises(s) == pytest.approx(E * eps, rel=1e-12)


def test_box_tetrahedra_conform():
    """Kuhn's split: every interior triangle is shared by exactly two tetrahedra, so the six per
    cell and their neighbours conform."""
    m = mesh.box(1.0, 1.0, 1.0, (2, 2, 2), "tet4")
    t = m.cells["tet4"]
    faces = np.sort(np.concatenate([t[:, [0, 1, 2]], t[:, [0, 1, 3]], t[:, [0, 2, 3]], t[:, [1, 2, 3]]]), axis=1)
    _, counts = np.unique(faces, axis=0, return_counts=True)
    boundary = 6 * 2 * 2 * 2                                            # 6 faces x 4 squares x 2 triangles
    assert (counts <= 2).all() and (counts == 1).sum() == boundary


def test_mode_signs_do_not_depend_on_the_node_order():
    """A symmetric mesh's torsion and bending modes have entries of equal size and opposite sign:
    the sign rule (`solid.signed`) gives the same modes when the nodes are renumbered."""
    m = mesh.box(0.1, 0.02, 0.02, (4, 2, 2), "hex8")
    perm = np.random.default_rng(3).permutation(m.n_nodes)
    inv = np.argsort(perm)
    p = m._replace(nodes=m.nodes[perm], cells={k: inv[c] for k, c in m.cells.items()},
                   node_sets={k: np.sort(inv[v]) for k, v in m.node_sets.items()})
    modes = []
    for q in (m, p):
        _, Phi = solid.clamped_modes(solid.stiffness(q, E, NU), solid.scalar_mass(q, RHO), q.node_sets["x0"], 5, q.nodes)
        modes.append(Phi.reshape(q.n_nodes, 3, 5))
    f = solid.clamped_modes(solid.stiffness(m, E, NU), solid.scalar_mass(m, RHO), m.node_sets["x0"], 5, m.nodes)[0]
    distinct = np.flatnonzero(np.diff(f) > 1e-6 * f[1:])                # the square section's pairs aside
    single = [k for k in range(5) if (k == 0 or k - 1 in distinct) and (k == 4 or k in distinct)]
    assert single == [2]                                                # the torsion mode
    for k in single:
        assert np.allclose(modes[1][inv][:, :, k], modes[0][:, :, k], atol=1e-9 * np.abs(modes[0][:, :, k]).max()), k


def small_bar():
    m = mesh.box(0.3, 0.02, 0.03, (6, 1, 2), "hex20")
    return m, solid.stiffness(m, E, NU), solid.scalar_mass(m, RHO)


def test_a_rigid_interface_against_its_constraint_as_a_null_space():
    """`constraint_basis` (the tip face moving with its reference point's six coordinates) against
    the same constraint written on the node DOFs, (1 - R R^+) u_set = 0, whose null space a dense
    SVD gives: the clamped-interface frequencies agree to 1e-8 (seen 1e-12)."""
    import scipy.linalg as sla
    m, K, Ms = small_bar()
    tip, ref = m.node_sets["xL"], np.array([0.3, 0.0, 0.0])
    f, Phi = solid.interface_modes(K, Ms, m.nodes, "clamped-interface", 6, held=m.node_sets["x0"], rigid=[(tip, ref)])
    R = solid.rigid_fields(m.nodes[tip], ref)
    P = np.eye(R.shape[0]) - R @ np.linalg.pinv(R)                       # rows: the set's non-rigid part
    G = np.zeros((P.shape[0] + 3 * len(m.node_sets["x0"]), K.shape[0]))
    G[:P.shape[0], solid.node_dofs(tip)] = P
    G[P.shape[0] + np.arange(3 * len(m.node_sets["x0"])), solid.node_dofs(m.node_sets["x0"])] = 1.0
    Z = sla.null_space(G)
    Kz, Mz = Z.T @ K.toarray() @ Z, Z.T @ solid.vector_mass(Ms).toarray() @ Z
    theirs = np.sqrt(sla.eigh(Kz, Mz, eigvals_only=True, subset_by_index=[0, 5])) / (2 * np.pi)
    assert np.abs(f / theirs - 1).max() < 1e-8
    moved = Phi[solid.node_dofs(tip)]                                    # the face moves rigidly
    assert np.abs(P @ moved).max() < 1e-10 * np.abs(moved).max()


def test_craig_bampton_spans_the_static_responses_at_its_interfaces():
    """The static response to a force and moment at an averaging interface, and to a unit motion of
    a rigid interface, lie in the Craig-Bampton set (attachment and constraint modes), to 1e-8."""
    m, K, Ms = small_bar()
    M = solid.vector_mass(Ms)
    held, mid = m.node_sets["x0"], np.flatnonzero(np.isclose(m.nodes[:, 0], 0.15))
    tip, ref = m.node_sets["xL"], np.array([0.3, 0.0, 0.0])
    f, Phi = solid.interface_modes(K, Ms, m.nodes, "craig-bampton", 14, held=held,
                                   rigid=[(mid, np.array([0.15, 0.0, 0.0]))], averaged=[(tip, ref)])
    T = solid.constraint_basis(m.n_nodes, m.nodes, held, [(mid, np.array([0.15, 0.0, 0.0]))])
    Kr = (T.T @ K @ T).tocsc()
    F = np.zeros(K.shape[0])
    F[solid.node_dofs(tip)] = solid.averaging(m.nodes[tip], ref).T @ np.array([0.3, -0.2, 0.5, 10.0, -40.0, 25.0])
    u = T @ spla.spsolve(Kr, T.T @ F)                                    # the interface's ref free too
    c = Phi.T @ (M @ u)                                                   # M-orthonormal: the projection
    assert np.linalg.norm(u - Phi @ c) < 1e-8 * np.linalg.norm(u)
    inner = np.arange(Kr.shape[0] - 6)
    e = np.zeros(Kr.shape[0])
    e[-5] = 1e-3                                                          # the rigid interface's y translation
    x = e.copy()
    x[inner] = -spla.spsolve(Kr[inner][:, inner].tocsc(), Kr[inner] @ e)
    u = T @ x
    assert np.linalg.norm(u - Phi @ (Phi.T @ (M @ u))) < 1e-8 * np.linalg.norm(u)
    assert np.allclose(Phi.T @ (M @ Phi), np.eye(14), atol=1e-10)


def test_free_free_modes_less_the_frame_fit_span_the_free_free_modes():
    """Free-free modes with the rigid motion fitting the frame interface removed span, with the six
    rigid fields, what the free-free modes span (those of a dense eigensolution, to 1e-8), and the
    frame interface's fit is zero in each."""
    import scipy.linalg as sla
    m, K, Ms = small_bar()
    M = solid.vector_mass(Ms)
    frame = (m.node_sets["x0"], np.zeros(3))
    f, Phi = solid.interface_modes(K, Ms, m.nodes, "free-free", 5, frame=frame)
    fit = solid.averaging(m.nodes[frame[0]], frame[1]) @ Phi[solid.node_dofs(frame[0])]
    assert np.abs(fit).max() < 1e-10 * np.abs(Phi).max()
    lam, X = sla.eigh(K.toarray(), M.toarray(), subset_by_index=[0, 10])
    X = X[:, 6:]                                                          # the five lowest elastic ones
    B = np.hstack([Phi, solid.rigid_fields(m.nodes, frame[1])])
    Q, _ = np.linalg.qr(B)
    assert np.linalg.norm(X - Q @ (Q.T @ X)) < 1e-8 * np.linalg.norm(X)


def test_the_stress_at_a_surface_point_against_scikit_fem_and_beam_theory():
    """cantilever_solid's mesh (1.5 x 0.015 x 0.01 m, 75 x 2 x 2 hex20), clamped, 12 N across its
    tip face: the normal stress at the top surface 0.03 m from the clamp, (0.03, h/2, 0), from the
    element's displacement gradient there (`flexbody.point_stress_rows`).

    - against scikit-fem's assembly and solve of the same mesh and load, its displacement gradient
      at the point by three-point differences along each axis inside one element (exact: a 20-node
      serendipity field is at most quadratic along any one axis; one-sided along y at the surface and
      along z, where z = 0 is a face between two elements, mirror images). Two solves of one
      discrete problem of condition ~1e10: bound 1e-6 (the criterion is 0.5 %);
    - against Euler-Bernoulli, M c / I = 47.04 MPa: within 3 % (seen -1.9 %: the mesh's own error
      and the clamp's Poisson restraint 2h from it);
    - the element's centre, y = h/4, reads about half of it, as the channel read before."""
    from skfem import Basis, ElementHexS2, ElementVector, asm, solve, condense
    from skfem.io.meshio import from_meshio
    from skfem.models.elasticity import lame_parameters, linear_elasticity
    from flexmbd.fe import flexbody
    L, h, b, E_, nu, P = 1.5, 0.015, 0.01, 2.06e11, 0.29, 12.0
    m = mesh.box(L, h, b, (75, 2, 2), "hex20")
    K = solid.stiffness(m, E_, nu)
    tip, root = m.node_sets["xL"], m.node_sets["x0"]
    F = np.zeros(K.shape[0])
    F[solid.node_dofs(tip)] = solid.averaging(m.nodes[tip], np.array([L, 0.0, 0.0])).T @ np.array([0, 0, 0, 0, -P, 0.0])
    free = np.setdiff1d(np.arange(K.shape[0]), solid.node_dofs(root))
    u = np.zeros(K.shape[0])
    u[free] = spla.spsolve(K[free][:, free].tocsc(), F[free])
    x = np.array([0.03, h / 2, 0.0])
    S, dofs = flexbody.point_stress_rows(m, E_, nu, x)
    ours = S @ u[dofs]

    sk = from_meshio(meshio.Mesh(m.nodes, [("hexahedron", m.cells["hex20"][:, :8])]))
    basis = Basis(sk, ElementVector(ElementHexS2()), intorder=6)
    Ksk = asm(linear_elasticity(*lame_parameters(E_, nu)), basis)
    locs = basis.doflocs.T                                         # (ndof, 3): each DOF's node
    at = {tuple(np.round(p, 12)): k for k, p in enumerate(m.nodes)}
    node = np.array([at[tuple(np.round(p, 12))] for p in locs])
    comp = np.empty(len(locs), int)
    for c in range(3):
        comp[basis.nodal_dofs[c]] = c
        comp[basis.edge_dofs[c]] = c
    fsk = F[3 * node + comp]
    usk = solve(*condense(Ksk, fsk, D=basis.get_dofs(lambda p: np.isclose(p[0], 0.0)).all()))
    probe = lambda pts: (basis.probes(np.array(pts).T) @ usk).reshape(3, -1)   # (3 components, points)
    d = 1e-3
    grad = np.zeros((3, 3))
    e = np.array([d, 0.0, 0.0])
    grad[:, 0] = (probe([x + e])[:, 0] - probe([x - e])[:, 0]) / (2 * d)          # x = 0.03: an element's middle
    for a, step in ((1, -d), (2, d)):                  # y = h/2 the surface, z = 0 an element face: one-sided
        e = np.eye(3)[a] * step
        u0, u1, u2 = (probe([x + k * e])[:, 0] for k in (0, 1, 2))
        grad[:, a] = (-3 * u0 + 4 * u1 - u2) / (2 * step)
    eps = 0.5 * (grad + grad.T)
    lam, mu = lame_parameters(E_, nu)
    sigma = lam * np.trace(eps) * np.eye(3) + 2 * mu * eps
    assert ours[0] == pytest.approx(sigma[0, 0], rel=1e-6)
    assert ours[0] == pytest.approx(P * (L - 0.03) * (h / 2) / (b * h ** 3 / 12), rel=0.03)
    Sc, dc = flexbody.point_stress_rows(m, E_, nu, np.array([0.03, h / 4, 0.0]))
    assert (Sc @ u[dc])[0] == pytest.approx(0.5 * ours[0], rel=0.05)
