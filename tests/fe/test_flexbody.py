"""The reduced body: the .npz round trip, stress rows against the FE stress recovery, modes orthonormal in the node masses, the
reference node."""

import dataclasses

import numpy as np
import pytest
import scipy.linalg as la

from flexmbd import cases
from flexmbd.harness import channels
from flexmbd.fe import flexbody
from flexmbd.solvers import inhouse
from flexmbd.mbd import integrate
from flexmbd.mbd.invariants import invariants
from flexmbd.fe import assembly, stress
from flexmbd.solvers.build import from_case
from trees import one_beam


def random_body(rng, boundary):
    raw = {"type": "beam", "material": "m", "length": rng.uniform(0.5, 2.0), "elements": int(rng.integers(5, 30)),
           "section": {"shape": str(rng.choice(["rectangle", "circle"]))}, "modes": {"count": int(rng.integers(1, 9)),
                                                                                    "boundary": boundary}}
    if raw["section"]["shape"] == "rectangle":
        raw["section"].update(b=rng.uniform(0.01, 0.05), h=rng.uniform(0.01, 0.05))
    else:
        raw["section"]["d"] = rng.uniform(0.01, 0.05)
    return flexbody.build(one_beam(raw, {"E": 2e11, "nu": 0.3, "rho": 7800.0}))


def scrambled(fb, rng):
    """The body with its nodes off the axis, full rotary inertias and random modes (no beam
    structure to hide an index or a transpose)."""
    N, nm = fb.n_nodes, fb.n_modes
    A = rng.normal(size=(N, 3, 3)) * 1e-3
    return dataclasses.replace(fb, x0=fb.x0 + rng.normal(size=(N, 3)) * 0.1, J=A @ A.transpose(0, 2, 1),
                               Phi=rng.normal(size=(N, 6, nm)) / np.sqrt(fb.m.sum()))


def test_npz_roundtrip(tmp_path):
    case = cases.load("double_pendulum")
    fb = flexbody.for_case(case)["beam1"]
    flexbody.save(fb, tmp_path / "b.npz")
    back = flexbody.load(tmp_path / "b.npz")
    for f in ("x0", "m", "J", "Phi", "freq_hz", "Km", "Cm", "stress_x", "S_strain"):
        assert np.array_equal(getattr(back, f), getattr(fb, f))
    assert back.labels.tolist() == fb.labels.tolist() and back.boundary == "hinged-hinged"


STRESS_CHANNELS = ['channels.s_far={kind="stress_vm", body="beam", at=0.9, fibre=[-0.004, 0.005]}',
                   'channels.s_mid={kind="stress_vm", body="beam", at=0.4}']


def test_stress_sections_and_their_channels():
    """S_strain at each stress section against the FE strain rows there; each stress channel
    against the FE stress recovery at its own section point."""
    case = cases.load("cantilever_step", STRESS_CHANNELS + ["bodies.beam.stress=modes"])     # the modes' strains
    body, mat = case.bodies["beam"], case.materials["steel"]
    assert case.stress_sections("beam") == [0.03, 0.4, 0.9]
    fb = flexbody.for_case(case)["beam"]
    assert fb.stress_x.tolist() == [0.03, 0.4, 0.9] and fb.S_strain.shape == (3, 4, 12)
    nodes, elements = assembly.beam_mesh(body.length, body.elements)
    Phi_fe = fb.Phi[:, [3, 4, 5, 0, 1, 2], :].reshape(-1, fb.n_modes)       # node DOFs [u; theta]
    E, G = mat.E, mat.E / (2 * (1 + mat.nu))
    sec = flexbody.beam_section(body)
    for k, x in enumerate([0.03, 0.4, 0.9]):
        rows = stress.strain_rows(nodes, elements, E, G, sec, x, shear=body.shear) @ Phi_fe
        assert np.abs(fb.S_strain[k] - rows).max() <= 1e-12 * np.abs(rows).max()
    model = from_case(case)
    a = model.body_madr[model.index("beam")]
    eta = np.random.default_rng(8).normal(size=(2, fb.n_modes)) * 1e-3
    Q = np.zeros((2, model.nq))
    Q[:, a:a + fb.n_modes] = eta
    out = channels.channels(case, inhouse.trajectory(case, model, np.zeros(2), Q, np.zeros((2, model.nv))))
    for ch, x, fibre in [("stress_vm", 0.03, None), ("s_far", 0.9, [-0.004, 0.005]), ("s_mid", 0.4, None)]:
        cs, ct = stress.stress_coefficients(nodes, elements, E, G, sec, x, fibre=fibre, shear=body.shear)
        s_sigma, s_tau = cs @ Phi_fe, ct @ Phi_fe
        assert np.allclose(out[ch], np.sqrt((eta @ s_sigma) ** 2 + 3 * (eta @ s_tau) ** 2), rtol=1e-12, atol=0)


# ---------------------------------------------------------------------------------------------
# the modes are orthonormal in the mass the invariants are summed from

def reduced_hz(fb):
    """Natural frequencies (Hz) of the reduced body itself: eig(Km, I9)."""
    lam = la.eigh(fb.Km, invariants(fb).I9[0], eigvals_only=True)
    return np.sqrt(lam) / (2 * np.pi)


def test_consistent_mass_modes_are_the_reduced_bodys_modes():
    case = cases.load("cantilever_step", ['bodies.beam.mass="consistent"', "bodies.beam.damping_ratio=0.01"])
    body = case.bodies["beam"]
    fb = flexbody.for_case(case)["beam"]
    I9 = invariants(fb).I9[0]
    assert fb.n_modes == 12
    assert np.abs(I9 - np.eye(12)).max() <= 1e-12
    assert np.abs(fb.Km - np.diag(np.diag(fb.Km))).max() <= 1e-10 * np.abs(fb.Km).max()
    assert np.abs(fb.freq_hz / reduced_hz(fb) - 1).max() <= 1e-10
    assert np.allclose(np.diag(fb.Cm), 2 * 0.01 * 2 * np.pi * fb.freq_hz, rtol=1e-14, atol=0)
    # Euler-Bernoulli: first bending mode in the weak (x-z) plane
    sec, mat = flexbody.beam_section(body), case.materials["steel"]
    closed = 1.8751040687**2 / body.length**2 * np.sqrt(mat.E * sec.Iy / (mat.rho * sec.A)) / (2 * np.pi)
    assert fb.labels[0] == "bending xz 1"
    assert abs(fb.freq_hz[0] / closed - 1) < 1e-3


def test_lumped_mass_modes_are_the_reduced_bodys_modes():
    fb = flexbody.for_case(cases.load("pendulum"))["beam"]
    assert np.abs(invariants(fb).I9[0] - np.eye(fb.n_modes)).max() <= 1e-12
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
    assert fb.n_modes == case.bodies["beam"].modes.count
    assert np.abs(fb.Phi[0]).max() <= 1e-12 and np.abs(fb.Phi[1:]).max() > 1.0
    assert np.abs(invariants(fb).I9[0] - np.eye(fb.n_modes)).max() <= 1e-12
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
    fb = flexbody.build(one_beam(raw, {"E": 2e11, "nu": 0.3, "rho": 7800.0}))
    assert fb.n_modes == raw["modes"]["count"]
    assert np.abs(fb.Phi[0]).max() <= 1e-12
    assert np.abs(invariants(fb).I9[0] - np.eye(fb.n_modes)).max() <= 1e-12


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


# ---------------------------------------------------------------------------------------------
# one reduction per content, one snapping rule


def test_a_beam_is_reduced_once_per_content():
    a = flexbody.for_case(cases.load("pendulum"))["beam"]
    assert flexbody.for_case(cases.load("pendulum"))["beam"] is a
    assert not a.Phi.flags.writeable and not a.Km.flags.writeable
    b = flexbody.for_case(cases.load("pendulum", ["materials.steel.E=2.0e11"]))["beam"]
    assert b is not a and b.freq_hz[0] < a.freq_hz[0]


def test_snapping_is_the_nearest_node():
    rng = np.random.default_rng(8)
    length, n = 1.5, 37
    x0 = np.linspace(0.0, length, n + 1)
    for x in rng.uniform(-0.1, length + 0.1, 200):
        assert flexbody.node_index(length, n, x) == int(np.argmin(np.abs(x0 - x)))
    h = length / n
    assert flexbody.node_index(length, n, 2.5 * h) == 2                 # half-way: the root side
    assert flexbody.snapped(length, n, 0.03) == pytest.approx(x0[1])


# ---------------------------------------------------------------------------------------------
# foreshortening (geometric stiffening)


def test_foreshortening_gives_the_euler_buckling_load():
    """D_tip is the modal geometric stiffness of a unit axial tip force: K_m - P D_tip turns
    singular at the Euler load of the clamped-free beam, pi^2 E I / (4 L^2)."""
    case = cases.load("cantilever_step")
    fb = flexbody.for_case(case)["beam"]
    sec, E = flexbody.beam_section(case.bodies["beam"]), case.materials["steel"].E
    lam = la.eigh(fb.Km, fb.D[-1], eigvals_only=True)
    P_cr = np.pi ** 2 * E * min(sec.Iy, sec.Iz) / (4 * 1.5 ** 2)
    assert lam[lam > 0].min() == pytest.approx(P_cr, rel=1e-3)           # 2e-4 with 100 elements


def test_foreshortening_gives_southwell_coefficients():
    """sum_p m_p x_p D_p projected on a mass-normalised bending mode is its Southwell coefficient
    (omega^2 = omega_0^2 + K Omega^2, flapwise, hub radius 0): 1.1933, 6.4782, 17.8595 from the
    continuous beam's Rayleigh quotients (benchmarks of docs/formulation.md §4b)."""
    fb = flexbody.for_case(cases.load("cantilever_step"))["beam"]
    Dh = np.einsum("p,p,pkl->kl", fb.m, fb.x0[:, 0], fb.D)
    flap = [k for k, label in enumerate(fb.labels) if label.startswith("bending xz")][:3]
    assert np.allclose(np.diag(Dh)[flap], [1.1933, 6.4782, 17.8595], rtol=2e-3)


def test_modal_field_is_the_shapes_at_each_samples_coordinates():
    """`modal_field` against the same sum written as an einsum, on a non-contiguous slice of
    shapes and of states (as inhouse.node_forces passes them), and with no mode at all."""
    rng = np.random.default_rng(5)
    Phi, Q = rng.standard_normal((11, 6, 4)), rng.standard_normal((7, 9))
    P, eta = Phi[:, 3:, :], Q[:, 2:6]
    assert np.allclose(flexbody.modal_field(P, eta), np.einsum("pim,nm->npi", P, eta), rtol=0, atol=1e-14)
    assert flexbody.modal_field(np.zeros((11, 3, 0)), np.zeros((7, 0))).shape == (7, 11, 3)
