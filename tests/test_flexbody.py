"""The reduced body: invariants against brute-force node sums, the .npz round trip, stress rows."""

import numpy as np
import pytest

from flexmbd import cases, flexbody
from flexmbd.spatial import skew


def brute_force(fb, eta, v, eta_d):
    """Mass matrix and quadratic forces summed node by node (no invariants).

    Node p: B_p = [[1, 0, Phi_r], [-r~, 1, Phi_t]] maps [w; v; eta_d] to its [angular; linear]
    velocity; M = sum B_p^T diag(J_p, m_p 1) B_p. Quadratic forces: the node's Coriolis and
    centripetal acceleration w x v + w x (w x r) + 2 w x u_d times m_p, projected by B_p^T, and
    the rotary term w x J_p (w + Phi_r eta_d) on the reference rotation only (Lagrange: J_p fixed
    in body axes).
    """
    nm = fb.n_modes
    w, u = v[:3], v[3:]
    M = np.zeros((6 + nm, 6 + nm))
    h = np.zeros(6 + nm)
    for p in range(fb.n_nodes):
        Pr, Pt = fb.Phi[p, :3], fb.Phi[p, 3:]
        r = fb.x0[p] + Pt @ eta
        B = np.zeros((6, 6 + nm))
        B[:3, :3], B[:3, 6:] = np.eye(3), Pr
        B[3:, :3], B[3:, 3:6], B[3:, 6:] = -skew(r), np.eye(3), Pt
        Ip = np.zeros((6, 6))
        Ip[:3, :3], Ip[3:, 3:] = fb.J[p], fb.m[p] * np.eye(3)
        M += B.T @ Ip @ B
        f = fb.m[p] * (np.cross(w, u) + np.cross(w, np.cross(w, r)) + 2 * np.cross(w, Pt @ eta_d))
        tau = np.cross(w, fb.J[p] @ (w + Pr @ eta_d))
        h[:3] += tau + np.cross(r, f)
        h[3:6] += f
        h[6:] += Pt.T @ f
    return M, h


def random_body(rng, boundary):
    raw = {"type": "beam", "material": "m", "length": rng.uniform(0.5, 2.0), "elements": int(rng.integers(5, 30)),
           "section": {"shape": str(rng.choice(["rectangle", "circle"]))}, "modes": {"count": int(rng.integers(1, 9)),
                                                                                    "boundary": boundary}}
    if raw["section"]["shape"] == "rectangle":
        raw["section"].update(b=rng.uniform(0.01, 0.05), h=rng.uniform(0.01, 0.05))
    else:
        raw["section"]["d"] = rng.uniform(0.01, 0.05)
    body = cases._check_body(raw, "test", "body")
    return flexbody.build("b", body, {"E": 2e11, "nu": 0.3, "rho": 7800.0})


@pytest.mark.parametrize("seed,boundary", [(0, "clamped-free"), (1, "free-free"), (2, "hinged-hinged"),
                                           (3, "clamped-free"), (4, "free-free")])
def test_invariants_equal_brute_force_node_sums(seed, boundary):
    rng = np.random.default_rng(seed)
    fb = random_body(rng, boundary)
    inv = flexbody.invariants(fb)
    for _ in range(3):
        eta = rng.normal(size=fb.n_modes) * 0.1
        v, eta_d = rng.normal(size=6), rng.normal(size=fb.n_modes)
        M_ref, h_ref = brute_force(fb, eta, v, eta_d)
        M = flexbody.mass_matrix(inv, 0, eta)
        h = flexbody.quadratic_forces(inv, 0, eta, v, eta_d)
        assert np.abs(M - M_ref).max() <= 1e-10 * np.abs(M_ref).max()
        assert np.abs(h - h_ref).max() <= 1e-10 * np.abs(h_ref).max()


def test_mass_matrix_dot_is_the_derivative_along_eta_d():
    rng = np.random.default_rng(5)
    fb = random_body(rng, "free-free")
    inv = flexbody.invariants(fb)
    eta, eta_d = rng.normal(size=fb.n_modes) * 0.1, rng.normal(size=fb.n_modes)
    h = 1e-6
    fd = (flexbody.mass_matrix(inv, 0, eta + h * eta_d) - flexbody.mass_matrix(inv, 0, eta - h * eta_d)) / (2 * h)
    Md = flexbody.mass_matrix_dot(inv, 0, eta, eta_d)
    assert np.abs(Md - fd).max() <= 1e-7 * np.abs(Md).max()


def test_I7_columns_vanish_on_their_own_mode():
    fb = random_body(np.random.default_rng(6), "clamped-free")
    I7 = flexbody.invariants(fb).I7[0]
    for k in range(fb.n_modes):
        assert np.abs(I7[k, :, k]).max() < 1e-14 * (np.abs(I7).max() + 1e-300)


def test_npz_roundtrip(tmp_path):
    case = cases.load("double_pendulum")
    fb = flexbody.for_case(case)["beam1"]
    flexbody.save(fb, tmp_path / "b.npz")
    back = flexbody.load(tmp_path / "b.npz")
    for f in ("x0", "m", "J", "Phi", "freq_hz", "Km", "Cm", "stress_x", "S_sigma", "S_tau"):
        assert np.array_equal(getattr(back, f), getattr(fb, f))
    assert back.labels.tolist() == fb.labels.tolist() and back.boundary == "hinged-hinged"


def test_stress_rows_follow_channel_order():
    case = cases.load("double_pendulum")
    assert flexbody.stress_points(case, "beam1") == [(0.03, None)]
    fb = flexbody.for_case(case)["beam2"]
    assert fb.stress_x.tolist() == [0.03] and fb.S_sigma.shape == (1, 12)
