"""Rigid bodies fixed to a flexible beam's node (a tip mass): exudyn-beam holds the body's rotation
to the node's, exudyn-ffrf to the node's elastic rotation through a rigid super-element marker on
four massless nodes around it (`exudyn_ffrf.anchor_rows`); mujoco-rod declines. Each is held to
the closed forms of a cantilever with a tip mass and rotary inertia, and the hub beam with a tip
mass (tests/data/hub_beam_tip.toml) to the other solvers."""

from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

pytest.importorskip("exudyn")

from flexmbd import cases  # noqa: E402
from flexmbd.fe import flexbody
from flexmbd.harness import registry
from flexmbd.solvers import exudyn_beam, exudyn_common, exudyn_ffrf  # noqa: E402

pytestmark = pytest.mark.heavy(11)       # seconds, measured with both cores busy (tests/conftest.py)

DATA = Path(__file__).resolve().parents[1] / "data"
CANTILEVER = DATA / "tip_mass_cantilever.toml"
HUB_BEAM_TIP = DATA / "hub_beam_tip.toml"


def tip_mass_frequency(EI: float, rhoA: float, L: float, M: float, J: float) -> float:
    """First bending frequency (Hz) of a clamped Euler-Bernoulli beam with a tip body of mass M and
    rotary inertia J about the tip: W = A (cosh - cos) + B (sinh - sin) of beta x with
    EI W''(L) = w^2 J W'(L) and EI W'''(L) = -w^2 M W(L), the first root of their determinant."""
    def det(b):
        ch, c, sh, s = np.cosh(b * L), np.cos(b * L), np.sinh(b * L), np.sin(b * L)
        w2 = b ** 4 * EI / rhoA
        m = [[EI * b ** 2 * (ch + c) - w2 * J * b * (sh + s), EI * b ** 2 * (sh + s) - w2 * J * b * (ch - c)],
             [EI * b ** 3 * (sh - s) + w2 * M * (ch - c), EI * b ** 3 * (ch + c) + w2 * M * (sh - s)]]
        return (m[0][0] * m[1][1] - m[0][1] * m[1][0]) / (b ** 5 * ch ** 2)
    bs = np.linspace(0.05, 6.0, 4000) / L
    v = np.array([det(b) for b in bs])
    k = int(np.nonzero(np.sign(v[:-1]) != np.sign(v[1:]))[0][0])
    b = brentq(det, bs[k], bs[k + 1], xtol=1e-14)
    return b ** 2 * np.sqrt(EI / rhoA) / (2.0 * np.pi)


def test_closed_form_limits():
    """The classical roots: beta L = 1.8751 without a tip body, 1.2479 with a tip mass equal to the beam's."""
    EI, rhoA, L = 17.5, 1.57, 0.5
    w = lambda beta_L: beta_L ** 2 / L ** 2 * np.sqrt(EI / rhoA) / (2.0 * np.pi)
    assert tip_mass_frequency(EI, rhoA, L, 0.0, 0.0) == pytest.approx(w(1.8751040687), rel=1e-9)
    assert tip_mass_frequency(EI, rhoA, L, rhoA * L, 0.0) == pytest.approx(w(1.2479174096), rel=1e-8)


def crossing_frequency(t: np.ndarray, y: np.ndarray) -> float:
    """Frequency (Hz) of y's oscillation about 0 from its first and last zero crossings (linear
    between samples)."""
    i = np.nonzero(np.sign(y[:-1]) != np.sign(y[1:]))[0]
    tc = t[i] - y[i] * (t[i + 1] - t[i]) / (y[i + 1] - y[i])
    return (len(tc) - 1) / 2.0 / (tc[-1] - tc[0])


@pytest.mark.parametrize("solver", ["exudyn-beam", "exudyn-ffrf", "flexmbd"])
def test_cantilever_with_tip_mass_vibrates_at_the_closed_form(solver):
    """A constant 10 N force on the tip mass (a load on a rigid body) from rest: the tip swings
    about F L^3 / (3 E I) to twice it, at the first frequency of a cantilever with that tip mass and
    rotary inertia (23.378 Hz; 23.428 Hz without the rotary inertia, 33.42 Hz without the body).
    Measured from the zero crossings over these 0.2 s: 3.6e-4 (exudyn-beam), 3.1e-4 (exudyn-ffrf,
    flexmbd) below it (over 1 s: 1.8e-4, -, 1.0e-4); the largest deflection within 8e-4 of twice
    the static one."""
    case = cases.load(str(CANTILEVER))
    b, tip = case.bodies["beam"], case.bodies["tip"]
    EI, rhoA, L = b.material.E * b.geometry.Iz, b.material.rho * b.geometry.A, b.length
    F = -case.loads["push"].force[1]
    f = tip_mass_frequency(EI, rhoA, L, tip.mass, tip.inertia[2])
    assert f == pytest.approx(23.3785, rel=1e-5)
    static = -F * L ** 3 / (3.0 * EI)
    r = registry.run(case, solver)
    assert r.ok, r.status
    y = r.channels["tip_deflection"]
    assert crossing_frequency(r.t, y - static) == pytest.approx(f, rel=5e-4)
    assert y.min() == pytest.approx(2.0 * static, rel=1e-3)


def test_ffrf_anchor_is_the_node_rigidly():
    """The four anchor nodes of a node move with it as one rigid body (their rows are the node's
    translation and theta x d), centred on it: Exudyn's rigid marker on them has the node's
    position and, through W^-1 sum w d x u, exactly its elastic rotation Phi_r eta."""
    case = cases.load(str(CANTILEVER))
    fb = flexbody.for_case(case)["beam"]
    k = case.joints["tip_mount"].node
    x, P = exudyn_ffrf.anchor_rows(fb, k)
    np.testing.assert_allclose(x.mean(axis=0), fb.x0[k], atol=1e-15)
    eta = np.linspace(1.0, -0.5, fb.n_modes)
    u, th = (P @ eta).reshape(4, 3), fb.Phi[k, :3, :] @ eta
    d = x - fb.x0[k]
    np.testing.assert_allclose(u - fb.Phi[k, 3:, :] @ eta, np.cross(th, d), atol=1e-14)
    W = -sum(0.25 * skew(a) @ skew(a) for a in d)
    np.testing.assert_allclose(np.linalg.solve(W, sum(0.25 * np.cross(a, v) for a, v in zip(d, u))), th,
                               rtol=1e-12, atol=1e-14)
    assert exudyn_ffrf.anchor_nodes(fb, False, [k]) == {k: [fb.n_nodes + i for i in range(4)]}
    assert exudyn_ffrf.anchors(case, "beam", {"beam": fb}) == [k]


def skew(a) -> np.ndarray:
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def test_who_models_a_tip_mass():
    """exudyn-beam and exudyn-ffrf model the rigid body fixed to the beam's node; mujoco-rod says
    why it cannot (its vertices carry no bending rotation)."""
    case = cases.load(str(CANTILEVER))
    assert exudyn_beam.applies(case) == "" and exudyn_ffrf.applies(case) == ""
    rod = registry.status_for(case, "mujoco-rod")
    assert rod.startswith("unavailable") or rod.startswith("not applicable: body 'tip': a rigid body joined "
                                                            "to a rod needs the rod's material frame"), rod
    assert exudyn_beam.applies(cases.load(str(HUB_BEAM_TIP))) == ""
    assert exudyn_ffrf.applies(cases.load(str(HUB_BEAM_TIP))) == ""


def tip(r) -> tuple:
    return r.t, r.channels["tip_deflection"]


@pytest.mark.slow
def test_hub_beam_with_tip_mass_three_solvers():
    """The hub beam with a 0.5 kg tip mass (its centre 2 cm beyond the tip: the offset's coupling),
    no [report] table, no solver settings: flexmbd, exudyn-ffrf and exudyn-beam agree on the tip
    deflection within 1 % RMS of its largest value, and flexmbd without geometric stiffening (the
    linear floating frame's model) matches exudyn-ffrf within 0.5 %. Measured: flexmbd 1.5e-4 and
    exudyn-ffrf 6.6e-3 off exudyn-beam (the missing stiffening), flexmbd without it 1.4e-8 off
    exudyn-ffrf (the same model: the anchor's rigid marker is exact)."""
    case = cases.load(str(HUB_BEAM_TIP))
    runs = {s: registry.run(case, s) for s in ("exudyn-beam", "flexmbd", "exudyn-ffrf")}
    assert all(r.ok for r in runs.values()), {s: str(r.status) for s, r in runs.items()}
    t, ref = tip(runs["exudyn-beam"])
    scale = np.abs(ref).max()
    for s in ("flexmbd", "exudyn-ffrf"):
        ts, y = tip(runs[s])
        d = np.interp(t, ts, y) - ref
        assert np.sqrt(np.mean(d ** 2)) / scale < 0.01, s
    linear = registry.run(cases.load(str(HUB_BEAM_TIP), ["bodies.beam.stiffening=false"]), "flexmbd")
    ts, y = tip(linear)
    t, ref = tip(runs["exudyn-ffrf"])
    assert np.sqrt(np.mean((np.interp(t, ts, y) - ref) ** 2)) / np.abs(ref).max() < 0.005


@pytest.mark.parametrize("profile", ['{type="step", t0=0.02}', '{type="constant"}'])
@pytest.mark.parametrize("solver", ["exudyn-beam", "exudyn-ffrf"])
def test_body_frame_load_on_the_tip_mass_follows_flexmbd(solver, profile):
    """A body-frame force on the tip mass, constant or switched on at 0.02 s (a load user function
    turning with the rigid body, which turns with the tip node): the tip deflection within 0.5 %
    RMS of flexmbd's."""
    case = cases.load(str(CANTILEVER), ['loads.push.frame="body"', f'loads.push.profile={profile}'])
    ref, r = registry.run(case, "flexmbd"), registry.run(case, solver)
    assert r.ok, r.status
    y = np.interp(ref.t, r.t, r.channels["tip_deflection"])
    assert np.sqrt(np.mean((y - ref.channels["tip_deflection"]) ** 2)) / np.abs(y).max() < 0.005


@pytest.mark.parametrize("solver", ["exudyn-beam", "exudyn-ffrf"])
def test_rigid_hub_beam_and_tip_mass_follow_flexmbd(solver):
    """A beam fixed to a driven rigid hub off its axis (a fixed joint from a rigid body), a tip mass
    whose centre is off the tip node in x and y, a body-frame force at a point of the tip mass:
    tip deflection within 0.5 % RMS of flexmbd's largest (measured: exudyn-beam 0.14 %,
    exudyn-ffrf 0.22 %), energy within 0.1 % (0.067 %, 0.040 %), the hub angle its profile."""
    case = cases.load(str(DATA / "hub_rigid_tip.toml"))
    ref, r = registry.run(case, "flexmbd"), registry.run(case, solver)
    assert r.ok, r.status
    for ch, tol in (("tip_deflection", 0.005), ("energy", 0.001), ("drive_angle", 1e-9)):
        x, y = ref.channels[ch], np.interp(ref.t, r.t, r.channels[ch])
        assert np.sqrt(np.mean((y - x) ** 2)) / np.abs(x).max() < tol, ch


def test_a_tip_mass_is_not_fixed_to_ground():
    """A body fixed to a flexible node turns with it: its body-frame loads follow it (a load user
    function), unlike a body tied to ground by fixed joints on frames."""
    case = cases.load(str(CANTILEVER))
    assert exudyn_common.fixed_to_ground(case, "beam")
    assert not exudyn_common.fixed_to_ground(case, "tip")
