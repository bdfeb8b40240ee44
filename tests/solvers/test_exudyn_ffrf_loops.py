"""exudyn-ffrf on closed loops: each cut joint an Exudyn spherical joint between its two points,
the start closed by the adapter's own Newton (`exudyn_ffrf.assembled`).

Checked against models independent of the adapter: the rigid four-bar as one equation in the
crank angle (tests/oracle_four_bar.py) with its cut-joint force from the coupler's and rocker's
moment equations and the coupler's axial force (against the four-bar with a stiff coupler), and
the slider-crank with a stiff rod against its exact rigid kinematics and its crank-pin force and
rod axial force in closed form (inverse dynamics: the crank's motion is prescribed). Each bar
takes the mass properties of its lumped nodes, as the adapter's rigid bodies and FFRF bodies do:
mass sum m_p, centre at half its length, inertia sum m_p (x_p - L/2)^2 + sum J_p about it.
Planar vectors are complex numbers: e^(i a) the unit vector at angle a.
"""

from dataclasses import replace

import numpy as np
import pytest
from scipy.integrate import solve_ivp

pytest.importorskip("exudyn")

from flexmbd import cases  # noqa: E402
from flexmbd.fe import flexbody
from flexmbd.harness import registry
from flexmbd.solvers import exudyn_ffrf  # noqa: E402

from oracle_four_bar import acceleration, angles, rates  # noqa: E402

pytestmark = pytest.mark.kernel_free

FOX_GOODWIN = ['solvers.exudyn-ffrf.solver="fox-goodwin"', "solvers.exudyn-ffrf.dt=1e-4"]
DAMPED = ['solvers.exudyn-ffrf.solver="generalized-alpha"', "solvers.exudyn-ffrf.spectral_radius=0.9",
          "solvers.exudyn-ffrf.dt=2.5e-5"]
STIFF = ["materials.steel.E=2e15"]                 # 10^4 times stiffer: the rod's lowest mode near 13 kHz


def lumped(case, name: str) -> tuple[float, float]:
    """(mass, inertia about the centre normal to the plane) of beam `name`'s lumped nodes."""
    fb = flexbody.undeformed(name, case.bodies[name])
    m = fb.m.sum()
    return m, fb.m @ (fb.x0[:, 0] - fb.x0[:, 0].mean()) ** 2 + fb.J[:, 2, 2].sum()


def lengths(case) -> tuple:
    """(crank, coupler, rocker, ground) lengths of a four-bar case, m."""
    return (*(case.bodies[n].length for n in ("crank", "coupler", "rocker")), case.joints["rocker_pivot"].offset[0])


def cross(a: complex, b: complex) -> float:
    """z component of a x b for planar vectors a, b."""
    return (a.conjugate() * b).imag


# ---------------------------------------------------------------------------------------------
# what the adapter models


def test_loop_cases_apply_and_the_others_say_why():
    assert exudyn_ffrf.LOOPS
    for name in ("four_bar_swing_rigid", "four_bar_swing", "slider_crank"):
        assert exudyn_ffrf.applies(cases.load(name)) == "", name
    spatial = cases.load("four_bar_swing_rigid", ["gravity=[0.0, 0.0, -9.81]"])
    assert exudyn_ffrf.applies(spatial).startswith("loop joint 'rocker_pin': a cut revolute joint is Exudyn's "
                                                   "spherical joint between its two points")
    case = cases.load("four_bar_swing_rigid").resolved                # a fixed cut joint would not close there
    fixed = replace(case, loops={"rocker_pin": replace(case.loops["rocker_pin"], type="fixed")})
    assert exudyn_ffrf.applies(fixed).startswith("loop joint 'rocker_pin': a cut fixed joint is not modelled")


def test_the_trapezoidal_rule_is_refused_on_a_loop():
    """Spectral radius 1 with index-3 constraints lets the loop's alternating constraint force grow
    (four_bar_swing_rigid: Newton fails at 0.90 s): a failed run at t = 0 says what to use."""
    r = registry.run(cases.load("slider_crank", ["solvers.exudyn-ffrf.spectral_radius=1.0"]), "exudyn-ffrf", 0.01)
    assert not r.ok and r.status.t == 0.0
    assert "spectral radius 1" in str(r.status) and "use spectral_radius < 1 (0.9)" in str(r.status)


def test_the_start_closes_the_loops():
    """The crank keeps its q0 and rate (prescribed: its profile's), the other loop joints close
    the loop at position (Newton to 1e-13 m) and velocity level on the oracle's branch."""
    case = cases.load("four_bar_swing_rigid")
    fbs = flexbody.for_case(case)
    model = exudyn_ffrf.assembled(case, fbs)
    gap, rate = exudyn_ffrf.gaps_at_start(model, fbs)
    assert np.abs(gap).max() <= 1e-13 and np.abs(rate).max() < 1e-12
    assert exudyn_ffrf.closing_joints(case, fbs) == ["rocker_pivot", "crank_pin"]
    th = case.joints["crank_pivot"].q0[0]
    assert model.joints["crank_pivot"].q0 == (th,) and model.joints["crank_pivot"].qd0 == (20.0,)
    th3, th4 = angles(th, *lengths(case))
    assert model.joints["crank_pin"].q0[0] + th == pytest.approx(th3, abs=1e-12)
    assert model.joints["rocker_pivot"].q0[0] == pytest.approx(th4, abs=1e-12)

    case = cases.load("slider_crank")
    fbs = flexbody.for_case(case)
    model = exudyn_ffrf.assembled(case, fbs)
    j = model.joints
    assert j["crank_pivot"].qd0 == (150.0,) and j["slide"].q0 == pytest.approx((0.45,), abs=1e-15)
    assert j["slide"].qd0 == pytest.approx((0.0,), abs=1e-12)
    assert j["wrist_pin"].q0 == pytest.approx((np.pi,)) and j["wrist_pin"].qd0 == pytest.approx((-75.0,))


# ---------------------------------------------------------------------------------------------
# the rigid four-bar against the one-equation oracle


def four_bar_oracle(case, t: np.ndarray) -> dict:
    """The rigid four-bar of `case` at instants t (n,): crank and rocker angles, energy, the cut
    joint's force on the rocker in the rocker's frame (pin_force_x, _y) and the coupler's axial
    force just past the crank pin (coupler_axial, tension positive), from the oracle's crank
    angle equation and the moment equations of the coupler (about the crank pin A) and the rocker
    (about its pivot D): with F the force on the rocker at the pin C, G_k the centres,
        I_3 a_3 + (G_3 - A) x m_3 a_G3 = (C - A) x (-F) + (G_3 - A) x m_3 g
        I_4 a_4 + (G_4 - D) x m_4 a_G4 = (C - D) x F + (G_4 - D) x m_4 g;
    the axial force takes the coupler's nodes past A off -F, along the coupler e:
    e . (-F - sum m_p (a_p - g)), a_p = a_A + x_p (i a_3 - w_3^2) e."""
    L = lengths(case)
    a, b, c, d = L
    m, I = zip(*(lumped(case, n) for n in ("crank", "coupler", "rocker")))
    g = 9.81
    j = case.joints["crank_pivot"]
    sol = solve_ivp(lambda _, y: [y[1], acceleration(y[0], y[1], L, m, I, g)], (t[0], t[-1]), [j.q0[0], j.qd0[0]],
                    method="DOP853", t_eval=t, rtol=1e-13, atol=1e-13)
    out = {k: [] for k in ("crank_angle", "rocker_angle", "energy", "pin_force_x", "pin_force_y", "coupler_axial")}
    fb = flexbody.undeformed("coupler", case.bodies["coupler"])
    for th, w in sol.y.T:
        th3, th4 = angles(th, *L)
        (u1, _, k1, _), (u3, u3d, k3, k3d), (u4, u4d, k4, k4d) = rates(th, *L)
        wd = acceleration(th, w, L, m, I, g)
        A, C = a * np.exp(1j * th), d + c * np.exp(1j * th4)
        G1, G3, G4 = A / 2, A + b / 2 * np.exp(1j * th3), d + c / 2 * np.exp(1j * th4)
        acc = lambda u, ud: complex(*(ud * w * w + u * wd))              # noqa: E731
        a3, a4 = k3d * w * w + k3 * wd, k4d * w * w + k4 * wd
        grav = -1j * g
        # unknown F = x + i y: coefficients of x and y in each equation, then the right-hand side
        rows = [(cross(C - A, -1), cross(C - A, -1j),
                 I[1] * a3 + m[1] * cross(G3 - A, acc(u3, u3d)) - m[1] * cross(G3 - A, grav)),
                (cross(C - d, 1), cross(C - d, 1j),
                 I[2] * a4 + m[2] * cross(G4 - d, acc(u4, u4d)) - m[2] * cross(G4 - d, grav))]
        (p, q, r), (s, v, z) = rows
        F = complex(*np.linalg.solve([[p, q], [s, v]], [r, z]))
        e3, aA = np.exp(1j * th3), a * (1j * wd - w * w) * np.exp(1j * th)
        inertia = sum(mp * (aA + xp * (1j * a3 - (k3 * w) ** 2) * e3 - grav) for mp, xp in zip(fb.m[1:], fb.x0[1:, 0]))
        T = sum(0.5 * mk * (u @ u) * w * w + 0.5 * Ik * (k * w) ** 2
                for mk, Ik, u, k in zip(m, I, (u1, u3, u4), (k1, k3, k4)))
        V = g * (m[0] * G1.imag + m[1] * G3.imag + m[2] * G4.imag)
        Fr = F * np.exp(-1j * th4)
        for k, x in zip(out, (th, th4, T + V, Fr.real, Fr.imag, (np.conj(e3) * (-F - inertia)).real)):
            out[k].append(x)
    return {k: np.array(x) for k, x in out.items()}


@pytest.fixture(scope="module")
def four_bar_swing_rigid():
    case = cases.load("four_bar_swing_rigid", FOX_GOODWIN)
    r = registry.run(case, "exudyn-ffrf", 0.3)
    assert r.ok, r.status
    return r, four_bar_oracle(case, r.t)


def test_rigid_four_bar_follows_the_oracle(four_bar_swing_rigid):
    """0.3 s (1.4 crank turns), Fox-Goodwin at 1e-4 s: the angles within 1e-5 rad, the energy
    within 5e-5 J of 3.87 J (measured 8.5e-6, 2.2e-6 rad, 3.9e-5 J), the cut joint's force
    within 0.01 N of the oracle's (up to 64 N; measured 6e-3 N), the loop closed to 1e-6 m (an
    index-2 scheme holds the gap's rate: measured 1.1e-7 m)."""
    r, want = four_bar_swing_rigid
    for k, tol in (("crank_angle", 1e-5), ("rocker_angle", 1e-5), ("energy", 5e-5), ("pin_force_x", 0.01),
                   ("pin_force_y", 0.01)):
        assert np.abs(r.channels[k] - want[k]).max() < tol, k
    assert np.abs(want["pin_force_y"]).max() > 60.0
    assert r.extra["loop_gap_m"]["rocker_pin"] < 1e-6


def test_stiff_four_bar_follows_the_oracle():
    """The coupler 10^4 times stiffer, 0.1 s: the crank angle as the rigid four-bar's (measured
    1.7e-6 rad), and the coupler's largest axial load (from the node forces, the cut joint's on
    the coupler's far node among them: tension 91 N) as the oracle's (measured 1e-4). Its
    cut-joint force is not: the coupler starts undeformed, and the bending vibration that start
    sets off, however stiff the coupler, moves the pin force by up to 2.5 N about the rigid one."""
    case = cases.load("four_bar_swing", STIFF + DAMPED)
    r = registry.run(case, "exudyn-ffrf", 0.1)
    want = four_bar_oracle(case, r.t)
    assert np.abs(r.channels["crank_angle"] - want["crank_angle"]).max() < 1e-5
    sec = case.bodies["coupler"].geometry
    buckling = np.pi ** 2 * case.materials["steel"].E * min(sec.Iy, sec.Iz) / case.bodies["coupler"].length ** 2
    # (the Euler load of a beam pinned at both ends: the coupler's hinged-hinged modes)
    largest = r.extra["validity"]["largest"]["coupler"]["axial_load"] * buckling
    assert largest == pytest.approx(np.abs(want["coupler_axial"]).max(), rel=1e-3)


def test_flexible_four_bar_keeps_its_energy_and_its_loop():
    """The flexible coupler, 0.1 s: the energy within 3e-5 J of its start (measured 2.1e-5 J),
    which is the rigid four-bar's (the coupler starts undeformed); the loop closed to 1e-6 m."""
    r = registry.run(cases.load("four_bar_swing", FOX_GOODWIN), "exudyn-ffrf", 0.1)
    e = r.channels["energy"]
    assert e[0] == pytest.approx(four_bar_oracle(cases.load("four_bar_swing_rigid"), r.t[:2])["energy"][0], abs=1e-12)
    assert np.abs(e - e[0]).max() < 3e-5
    assert r.extra["loop_gap_m"]["rocker_pin"] < 1e-6
    assert np.abs(r.channels["midspan_deflection"]).max() > 2e-3


# ---------------------------------------------------------------------------------------------
# the slider-crank with a stiff rod against its closed form


def slider_crank(case, t: np.ndarray) -> tuple:
    """The rigid slider-crank of `case` at instants t (n,), crank at the constant rate w from angle
    0: (slider position x, m; the crank pin's force on the rod in the rod's frame, complex, N;
    the rod's axial force N just past the slider pin, tension positive). The rod makes the angle
    pi - b with x, sin b = (a / L) sin(w t); then x = a cos(w t) + L cos b and, with the slider
    force along x, the rod's force balance along x and its moment balance about the slider pin S
    give the pin force F: F_x = m_r a_Gx + m_s x'', (P - S) x F = I_r psi'' + (G - S) x m_r a_G.
    N takes the inertia of the rod's nodes past S off F, along the rod: e . (F - sum m_p a_p),
    a_p = x'' + x_p (i psi'' - psi'^2) e."""
    a, L, w = case.bodies["crank"].length, case.bodies["rod"].length, 150.0
    mr, Ir = lumped(case, "rod")
    ms = case.bodies["slider"].mass
    fb = flexbody.undeformed("rod", case.bodies["rod"])
    th = w * t
    b = np.arcsin(a / L * np.sin(th))
    bd = a / L * np.cos(th) * w / np.cos(b)
    bdd = (-a / L * np.sin(th) * w * w + bd * bd * np.sin(b)) / np.cos(b)
    x = a * np.cos(th) + L * np.cos(b)
    xdd = -a * np.cos(th) * w * w - L * (np.sin(b) * bdd + np.cos(b) * bd * bd)
    psi, psid, psidd = np.pi - b, -bd, -bdd
    e, P = np.exp(1j * psi), a * np.exp(1j * th)
    aG = (xdd - a * w * w * np.exp(1j * th)) / 2
    Fx = mr * aG.real + ms * xdd
    M = Ir * psidd + mr * cross(L / 2 * e, aG)
    Fy = (M + (P - x).imag * Fx) / (P - x).real
    F = Fx + 1j * Fy
    N = (np.conj(e) * F).real - sum(m * ((np.conj(e) * xdd).real - xp * psid ** 2)
                                    for m, xp in zip(fb.m[1:], fb.x0[1:, 0]))
    return x, F * np.exp(-1j * psi), N


def test_stiff_slider_crank_follows_the_closed_form():
    """A rod 10^4 times stiffer, 0.02 s: the slider on the exact kinematics (measured 5e-13 m), the
    crank-pin force (the cut joint's reaction, rod frame) within 1e-3 of its largest, 451 N
    (measured 0.1 N, 0.33 N at the last sample, whose step mean lags by half a step), and the
    rod's largest axial load (from the node forces, the cut joint's among them) as the rigid
    mechanism's (measured 175 N, to 1e-14)."""
    case = cases.load("slider_crank", STIFF + DAMPED)
    r = registry.run(case, "exudyn-ffrf", 0.02)
    assert r.ok, r.status
    x, F, N = slider_crank(case, r.t)
    assert np.abs(r.channels["slider_position"] - x).max() < 1e-10
    assert r.extra["loop_gap_m"]["crank_pin"] < 1e-10
    for got, want in ((r.channels["crank_pin_force_x"], F.real), (r.channels["crank_pin_force_y"], F.imag)):
        assert np.abs(got - want).max() < 1e-3 * np.abs(F).max()
    sec = case.bodies["rod"].geometry
    buckling = np.pi ** 2 * case.materials["steel"].E * min(sec.Iy, sec.Iz) / case.bodies["rod"].length ** 2
    # (the Euler load of a beam pinned at both ends: the rod's hinged-hinged modes)
    assert r.extra["validity"]["largest"]["rod"]["axial_load"] * buckling == pytest.approx(np.abs(N).max(), rel=1e-6)
