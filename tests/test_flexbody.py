"""The reduced body: invariants against brute-force node sums, the .npz round trip, stress rows,
modes orthonormal in the node masses, the reference node."""

import numpy as np
import pytest
import scipy.linalg as la

from flexmbd import cases, flexbody, integrate
from flexmbd.model import from_case
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


# ---------------------------------------------------------------------------------------------
# the modes are orthonormal in the mass the invariants are summed from

def reduced_hz(fb):
    """Natural frequencies (Hz) of the reduced body itself: eig(Km, I9)."""
    lam = la.eigh(fb.Km, flexbody.invariants(fb).I9[0], eigvals_only=True)
    return np.sqrt(lam) / (2 * np.pi)


def test_consistent_mass_modes_are_the_reduced_bodys_modes():
    case = cases.load("cantilever_step", ['bodies.beam.mass="consistent"', "bodies.beam.damping_ratio=0.01"])
    body = case["bodies"]["beam"]
    fb = flexbody.for_case(case)["beam"]
    I9 = flexbody.invariants(fb).I9[0]
    assert fb.n_modes == 12
    assert np.abs(I9 - np.eye(12)).max() <= 1e-12
    assert np.abs(fb.Km - np.diag(np.diag(fb.Km))).max() <= 1e-10 * np.abs(fb.Km).max()
    assert np.abs(fb.freq_hz / reduced_hz(fb) - 1).max() <= 1e-10
    assert np.allclose(np.diag(fb.Cm), 2 * 0.01 * 2 * np.pi * fb.freq_hz, rtol=1e-14, atol=0)
    # Euler-Bernoulli: first bending mode in the weak (x-z) plane
    sec, mat = flexbody.beam_section(body), case["materials"]["steel"]
    closed = 1.8751040687**2 / body["length"]**2 * np.sqrt(mat["E"] * sec.Iy / (mat["rho"] * sec.A)) / (2 * np.pi)
    assert fb.labels[0] == "bending xz 1"
    assert abs(fb.freq_hz[0] / closed - 1) < 1e-3


def test_lumped_mass_modes_are_the_reduced_bodys_modes():
    fb = flexbody.for_case(cases.load("pendulum"))["beam"]
    assert np.abs(flexbody.invariants(fb).I9[0] - np.eye(fb.n_modes)).max() <= 1e-12
    # the eigensolver's frequencies; Km = Phi^T K Phi carries the round-off of K (cond ~ 3e9)
    assert np.abs(fb.freq_hz / reduced_hz(fb) - 1).max() <= 1e-8


# ---------------------------------------------------------------------------------------------
# the reference node: the parent joint acts on node 0, which the modes leave in place

CB_PENDULUM = ['bodies.beam.modes.boundary="craig-bampton"', "bodies.beam.modes.interfaces=[0.0, 1.5]"]


@pytest.mark.parametrize("overrides", [CB_PENDULUM, ['bodies.beam.modes.boundary="free-free"'],
                                       CB_PENDULUM + ['bodies.beam.mass="consistent"', "bodies.beam.modes.count=5"]])
def test_floating_modes_hold_the_reference_node(overrides):
    case = cases.load("pendulum", overrides)
    fb = flexbody.for_case(case)["beam"]
    assert fb.n_modes == case["bodies"]["beam"]["modes"]["count"]
    assert np.abs(fb.Phi[0]).max() <= 1e-12 and np.abs(fb.Phi[1:]).max() > 1.0
    assert np.abs(flexbody.invariants(fb).I9[0] - np.eye(fb.n_modes)).max() <= 1e-12
    assert np.abs(fb.freq_hz / reduced_hz(fb) - 1).max() <= 1e-10
    assert "rigid" not in fb.labels.tolist() and np.all(np.diff(fb.freq_hz) >= 0)


def test_craig_bampton_held_at_the_root_is_the_clamped_free_body():
    # interfaces at both ends with node 0 held: fixed-fixed modes plus the tip's constraint modes,
    # a Ritz basis of the cantilever: its frequencies bound the clamped-free ones from above
    free = flexbody.for_case(cases.load("pendulum"))["beam"]
    cb = flexbody.for_case(cases.load("pendulum", CB_PENDULUM))["beam"]
    assert cb.labels[:4].tolist() == free.labels[:4].tolist()
    assert np.all(cb.freq_hz[:4] >= free.freq_hz[:4] * (1 - 1e-10))
    assert np.abs(cb.freq_hz[:4] / free.freq_hz[:4] - 1).max() < 1e-3


@pytest.mark.parametrize("seed,boundary", [(7, "free-free"), (8, "craig-bampton"), (9, "free-free")])
def test_random_floating_bodies_hold_the_reference_node(seed, boundary):
    rng = np.random.default_rng(seed)
    raw = {"type": "beam", "material": "m", "length": 1.0, "elements": int(rng.integers(5, 30)),
           "section": {"shape": "circle", "d": rng.uniform(0.01, 0.05)},
           "modes": {"count": int(rng.integers(1, 9)), "boundary": boundary}}
    if boundary == "craig-bampton":
        raw["modes"]["interfaces"] = [0.0, float(rng.uniform(0.2, 1.0))]
    fb = flexbody.build("b", cases._check_body(raw, "test", "body"), {"E": 2e11, "nu": 0.3, "rho": 7800.0})
    assert fb.n_modes == raw["modes"]["count"]
    assert np.abs(fb.Phi[0]).max() <= 1e-12
    assert np.abs(flexbody.invariants(fb).I9[0] - np.eye(fb.n_modes)).max() <= 1e-12


def test_pendulum_on_craig_bampton_modes_swings_about_its_root_node():
    tip = {}
    for name, overrides in (("cb", CB_PENDULUM), ("clamped", [])):
        model = from_case(cases.load("pendulum", overrides))
        fb, i = model.bodies["beam"], model.index("beam")
        a, n = model.body_madr[i], model.body_nm[i]
        sim = integrate.simulate(model, 0.05, progress=False)
        eta = sim.q[:, a:a + n]
        assert np.abs(fb.x0[0] + eta @ fb.Phi[0, 3:].T).max() <= 1e-12       # the pivot stays on the axis
        tip[name] = eta @ fb.Phi[-1, 4].T                                      # tip deflection, y
    # the beam bends about its held root as the clamped-root pendulum does (0.9 % apart: other
    # 12-mode bases of the same beam)
    assert np.abs(tip["clamped"]).max() > 1e-4
    assert np.abs(tip["cb"] - tip["clamped"]).max() <= 2e-2 * np.abs(tip["clamped"]).max()
