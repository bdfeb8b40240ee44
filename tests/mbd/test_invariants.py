"""The inertia shape invariants against their node-loop definitions, and the mass matrix and
quadratic velocity forces rebuilt from them against node sums."""

import numpy as np
import pytest

from flexmbd.mbd import invariants
from oracles import node_mass_matrix, quadratic_forces, skew
from tests.fe.test_flexbody import random_body, scrambled

pytestmark = pytest.mark.kernel_free


@pytest.mark.parametrize("seed,boundary,scramble", [(0, "clamped-free", False), (1, "free-free", False),
                                                    (2, "hinged-hinged", False), (3, "clamped-free", True),
                                                    (4, "free-free", True)])
def test_mass_matrix_and_quadratic_forces_equal_node_sums(seed, boundary, scramble):
    """M, h of `inertia_and_forces_into` and `mass_matrix` against node sums (oracles: h by Lagrange from T)."""
    rng = np.random.default_rng(seed)
    fb = random_body(rng, boundary)
    fb = scrambled(fb, rng) if scramble else fb
    inv, nm = invariants.invariants(fb), fb.n_modes
    for _ in range(3):
        eta = rng.normal(size=nm) * 0.1
        v, eta_d = rng.normal(size=6), rng.normal(size=nm)
        M_ref, h_ref = node_mass_matrix(fb, eta), quadratic_forces(fb, eta, v, eta_d)
        M, h = np.empty((6 + nm, 6 + nm)), np.empty(6 + nm)
        invariants.inertia_and_forces_into(inv, 0, eta, v, eta_d, M, h)
        assert np.abs(M - M_ref).max() <= 1e-10 * np.abs(M_ref).max()
        assert np.abs(invariants.mass_matrix(inv, 0, eta) - M_ref).max() <= 1e-10 * np.abs(M_ref).max()
        assert np.abs(h - h_ref).max() <= 1e-10 * np.abs(h_ref).max()


def node_loop_invariants(fb):
    """I1..I10 by their definitions (docs/formulation.md §3), one node and one mode at a time."""
    N, nm = fb.n_nodes, fb.n_modes
    I = {k: np.zeros(s) for k, s in [("I1", (3, 3)), ("I2", (nm, 3, 3)), ("I3", (nm, nm, 3, 3)), ("I4", 3),
                                      ("I5", (3, nm)), ("I6", (3, nm)), ("I7", (nm, 3, nm)), ("I8", ()),
                                      ("I9", (nm, nm)), ("I10", (3, nm))]}
    for p in range(N):
        m, x, J = fb.m[p], fb.x0[p], fb.J[p]
        Pr, Pt = fb.Phi[p, :3], fb.Phi[p, 3:]
        X = skew(x)
        I["I1"] += J - m * X @ X
        I["I4"] += m * x
        I["I8"] += m
        for k in range(nm):
            Pk = skew(Pt[:, k])
            I["I2"][k] -= m * (X @ Pk + Pk @ X)
            I["I5"][:, k] += m * Pt[:, k]
            I["I6"][:, k] += m * X @ Pt[:, k]
            I["I10"][:, k] += J @ Pr[:, k]
            for l in range(nm):
                I["I3"][k, l] -= m * Pk @ skew(Pt[:, l])
                I["I7"][k, :, l] += m * Pk @ Pt[:, l]
                I["I9"][k, l] += Pr[:, k] @ J @ Pr[:, l] + m * Pt[:, k] @ Pt[:, l]
    return I


@pytest.mark.parametrize("seed", [6, 7])
def test_invariants_equal_their_node_loop_definitions(seed):
    """Every invariant I1..I10 of a scrambled body against plain loops over nodes and modes."""
    rng = np.random.default_rng(seed)
    fb = scrambled(random_body(rng, "clamped-free"), rng)
    inv, ref = invariants.invariants(fb), node_loop_invariants(fb)
    for name, r in ref.items():
        x = getattr(inv, name)[0]
        assert x.shape == r.shape and np.abs(x - r).max() <= 1e-12 * np.abs(r).max(), name


def test_mass_sums_of_a_solid_are_its_continuum_integrals():
    """`mass_sums` with a solid's consistent scalar mass: the rigid invariants are the box's own
    integrals (I1 its inertia about the origin, I4 its first moment, I8 its mass; exact, since the
    elements interpolate x exactly), I9 = Phi^T M Phi = 1 for M-orthonormal modes, I5 the modes'
    momentum sum_pq Ms_pq Phi_q; and with a diagonal Ms they are the lumped node sums."""
    import scipy.sparse as sp

    from flexmbd.fe import mesh, solid
    L, h, b, rho = 0.4, 0.05, 0.03, 2700.0
    m = mesh.box(L, h, b, (8, 2, 2), "hex20")
    x = m.nodes - np.array([0.1, 0.0, 0.0])                                # the body frame 0.1 m in
    K, Ms = solid.stiffness(m, 7e10, 0.33), solid.scalar_mass(m, rho)
    _, Phi = solid.clamped_modes(K, Ms, m.node_sets["x0"], 4, m.nodes)
    Pt = Phi.reshape(-1, 3, 4)
    I = invariants.mass_sums(x, Pt, np.asarray(Ms.sum(axis=1)).ravel(), Ms @ x,
                             (Ms @ Pt.reshape(len(x), -1)).reshape(Pt.shape))
    mass, c = rho * L * h * b, np.array([L / 2 - 0.1, 0.0, 0.0])
    Ic = mass / 12 * np.diag([h ** 2 + b ** 2, L ** 2 + b ** 2, L ** 2 + h ** 2])
    I1 = Ic + mass * (c @ c * np.eye(3) - np.outer(c, c))
    assert np.allclose(I[0], I1, rtol=1e-12, atol=1e-12 * I1.max())
    assert np.allclose(I[3], mass * c, atol=1e-12 * mass * L) and I[7] == pytest.approx(mass, rel=1e-13)
    assert np.allclose(I[8], np.eye(4), atol=1e-10)
    assert np.allclose(I[4], (Ms @ Pt.reshape(len(x), -1)).reshape(Pt.shape).sum(axis=0), atol=1e-12)
    # a diagonal Ms reduces every sum to the lumped body's node sums (invariants.invariants)
    d = np.random.default_rng(0).uniform(0.5, 1.5, len(x))
    lumped = invariants.mass_sums(x, Pt, d, d[:, None] * x, d[:, None, None] * Pt)
    via = invariants.mass_sums(x, Pt, d, sp.diags(d) @ x, (sp.diags(d) @ Pt.reshape(len(x), -1)).reshape(Pt.shape))
    for a, b_ in zip(lumped, via):
        assert np.allclose(a, b_, rtol=1e-14, atol=1e-14 * np.abs(a).max())
    I2 = [-sum(d[p] * (skew(x[p]) @ skew(Pt[p, :, k]) + skew(Pt[p, :, k]) @ skew(x[p])) for p in range(len(x)))
          for k in range(4)]                                               # the node-loop definition
    assert np.allclose(lumped[1], I2, atol=1e-12 * np.abs(I2).max())
