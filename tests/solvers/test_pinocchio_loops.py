"""The `pinocchio` peer on closed loops: cut joints closed by Pinocchio's rigid constraints.

Checked against models independent of the adapter: the rigid four-bar as one equation in the
crank angle (tests/oracle_four_bar.py), with its energy and its cut joint's force from the
coupler's and rocker's moment equations, and the rigid slider-crank's exact kinematics, crank-pin
force and drive torque in closed form (a uniform rod, a slider, no gravity). Each bar or rod takes
the inertia the peer's setting `beam_mass` gives it: across it m L^2 / 12 for the prism,
m L^2 / 12 (1 + 2 / n^2) for the lumped mesh of n elements, plus its section's rotary inertia.
Planar vectors are complex numbers: e^(i a) the unit vector at angle a.
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from flexmbd import cases
from flexmbd.harness import registry
from flexmbd.cases import closure

pin = pytest.importorskip("pinocchio")

from flexmbd.solvers import common, pinocchio_rigid  # noqa: E402

from oracle_four_bar import acceleration, angles, rates  # noqa: E402

pytestmark = pytest.mark.kernel_free

BARS = ("crank", "coupler", "rocker")


def across(case, name: str, m: float) -> float:
    """Inertia of beam `name` (mass m) about a normal to it through its centre, without the
    section's rotary part, as the peer's `beam_mass` has it."""
    beam = case.bodies[name]
    lumped = registry.settings(case, "pinocchio")["beam_mass"] == "lumped"
    return m * beam.length ** 2 / 12 * (1 + 2 / beam.elements ** 2 if lumped else 1)


def cross(a: complex, b: complex) -> float:
    """z component of a x b for planar vectors a, b."""
    return (a.conjugate() * b).imag


def four_bar_oracle(case, t: np.ndarray) -> dict:
    """The rigid four-bar of `case` (bars of mass rho b h L, inertia `across` + m h^2 / 12 about
    their centres, h in the plane) at instants t (n,): crank and rocker angles, kinetic and total
    energy, and the cut joint's force on the rocker at the pin C, rocker axes (n, 2), from the
    moment equations of the coupler (about the crank pin A) and the rocker (about its pivot D):
        I_3 a_3 + (G_3 - A) x m_3 a_G3 = (C - A) x (-F) + (G_3 - A) x m_3 g
        I_4 a_4 + (G_4 - D) x m_4 a_G4 = (C - D) x F + (G_4 - D) x m_4 g."""
    L = tuple(case.bodies[n].length for n in BARS) + (case.joints["rocker_pivot"].offset[0],)
    a, b, c, d = L
    beams = [case.bodies[n] for n in BARS]
    m = [s.material.rho * s.section.b * s.section.h * s.length for s in beams]
    I = [across(case, n, mk) + mk * s.section.h ** 2 / 12 for n, s, mk in zip(BARS, beams, m)]
    g = -case.gravity[1]
    j = case.joints["crank_pivot"]
    sol = solve_ivp(lambda _, y: [y[1], acceleration(y[0], y[1], L, m, I, g)], (t[0], t[-1]), [j.q0[0], j.qd0[0]],
                    method="DOP853", t_eval=t, rtol=1e-12, atol=1e-12)
    out = {k: [] for k in ("crank_angle", "rocker_angle", "kinetic", "energy", "pin_force")}
    for th, w in sol.y.T:
        th3, th4 = angles(th, *L)
        parts = rates(th, *L)
        wd = acceleration(th, w, L, m, I, g)
        A, C = a * np.exp(1j * th), d + c * np.exp(1j * th4)
        G = [A / 2, A + b / 2 * np.exp(1j * th3), d + c / 2 * np.exp(1j * th4)]
        T = sum(mk * w * w * (u @ u) / 2 + Ik * (k * w) ** 2 / 2 for (u, _, k, _), mk, Ik in zip(parts, m, I))
        _, (u3, u3d, k3, k3d), (u4, u4d, k4, k4d) = parts
        acc3, acc4 = complex(*(u3d * w * w + u3 * wd)), complex(*(u4d * w * w + u4 * wd))
        b3 = I[1] * (k3d * w * w + k3 * wd) + m[1] * cross(G[1] - A, acc3 + 1j * g)
        b4 = I[2] * (k4d * w * w + k4 * wd) + m[2] * cross(G[2] - d, acc4 + 1j * g)
        # F = x + i y: the coupler's and the rocker's equations, linear in x and y
        M = np.array([[cross(C - A, -1), cross(C - A, -1j)], [cross(C - d, 1), cross(C - d, 1j)]])
        F = complex(*np.linalg.solve(M, [b3, b4])) * np.exp(-1j * th4)
        out["crank_angle"].append(th)
        out["rocker_angle"].append(th4)
        out["kinetic"].append(T)
        out["energy"].append(T + g * sum(mk * Gk.imag for mk, Gk in zip(m, G)))
        out["pin_force"].append((F.real, F.imag))
    return {k: np.array(v) for k, v in out.items()}


def slider_crank(case, t):
    """Exact rigid slider-crank at t (n,): slider position x (n,), the crank pin's force on the
    rod in its axes (n, 2) and the torque driving the crank (n,). Crank a at th = w t, rod L from
    the slider's pin B = x to the crank pin P, at angle phi (cos phi < 0); forces on the rod F_P
    at P, F_B at B: slider m_s x'' = -F_Bx, rod m_r a_G = F_P + F_B, I_G phi'' = r x (F_P - F_B),
    r = (P - B) / 2; the crank turns steadily about its fixed pivot, so its torque is P x F_P."""
    a, L = case.bodies["crank"].length, case.bodies["rod"].length
    w = case.joints["crank_pivot"].motion["rate"]
    rod = case.bodies["rod"]
    m_r = rod.material.rho * np.pi * rod.section.d ** 2 / 4 * L
    I_r = across(case, "rod", m_r) + m_r * rod.section.d ** 2 / 16
    m_s = case.bodies["slider"].mass
    th = w * t
    x = a * np.cos(th) + np.sqrt(L * L - (a * np.sin(th)) ** 2)
    phi = np.pi - np.arcsin(a * np.sin(th) / L)
    phid = a * w * np.cos(th) / (L * np.cos(phi))
    phidd = (-a * w * w * np.sin(th) + L * phid ** 2 * np.sin(phi)) / (L * np.cos(phi))
    xdd = -a * w * w * np.cos(th) + L * phidd * np.sin(phi) + L * phid ** 2 * np.cos(phi)
    P, Pdd = a * np.exp(1j * th), -a * w * w * np.exp(1j * th)
    aG, r = (Pdd + xdd) / 2, (P - x) / 2
    fx = m_r * aG.real + m_s * xdd
    fy = ((I_r * phidd + m_r * cross(r, aG)) / 2 + r.imag * fx) / r.real
    F = (fx + 1j * fy) * np.exp(-1j * phi)
    return x, np.column_stack([F.real, F.imag]), cross(P, fx + 1j * fy)


@pytest.fixture(scope="module")
def four_bar_swing():
    """four_bar_swing_rigid by the peer (1 s), and the oracle at its outputs."""
    case = cases.load("four_bar_swing_rigid")
    r = registry.run(case, "pinocchio")
    return r, four_bar_oracle(case, r.t)


def test_loops_close_from_the_start_and_stay_closed():
    """The closed start keeps the independent coordinates (the crank's angle and rate) and
    moves the guessed ones to the closure; integrated, the closure holds at every output to
    1e-10 m (position) and 1e-9 m/s (velocity)."""
    for name, t_end, crank in (("four_bar_swing_rigid", 0.5, (np.pi / 2, 20.0)), ("slider_crank", 0.0837758, (0.0, 150.0))):
        case = cases.load(name)
        eng = pinocchio_rigid.Rigid(case)
        q0, v0 = eng.start()
        j = eng.joint["crank_pivot"]
        assert (q0[j.idx_q], v0[j.idx_v]) == crank
        e, J = eng.closure(q0)
        assert np.abs(e).max() < 1e-15 and np.abs(J @ v0).max() < 1e-13
        t = common.sample_times(case, t_end)
        Y, _, status = pinocchio_rigid.integrate(eng, np.concatenate([q0, v0]), t, "DOP853", 1e-12, 1e-12)
        assert status.ok
        closure = [eng.closure(y[:eng.nq]) for y in Y]
        assert max(np.abs(e).max() for e, _ in closure) < 1e-10
        assert max(np.abs(J @ y[eng.nq:]).max() for (_, J), y in zip(closure, Y)) < 1e-9


def test_four_bar_follows_the_oracle_and_keeps_its_energy(four_bar_swing):
    """Crank and rocker angles within 1e-7 rad of the oracle's over 1 s; the energy the oracle's,
    constant to 1e-6 of the largest kinetic energy."""
    r, ref = four_bar_swing
    assert r.ok
    assert np.abs(r.channels["crank_angle"] - ref["crank_angle"]).max() < 1e-7
    assert np.abs(r.channels["rocker_angle"] - ref["rocker_angle"]).max() < 1e-7
    E = r.channels["energy"]
    assert np.abs(E - E[0]).max() < 1e-6 * ref["kinetic"].max()
    assert np.abs(E - ref["energy"]).max() < 1e-6 * ref["kinetic"].max()


def test_four_bar_pin_force_balances_the_rocker_and_the_coupler(four_bar_swing):
    """The cut joint's reaction (coupler onto rocker, rocker axes) is the force the oracle's
    moment equations of the two bars need, to 1e-6 of its largest value."""
    r, ref = four_bar_swing
    f = np.column_stack([r.channels["pin_force_x"], r.channels["pin_force_y"]])
    assert np.abs(f - ref["pin_force"]).max() < 1e-6 * np.abs(ref["pin_force"]).max()


def test_slider_crank_rigid_kinematics_crank_pin_force_and_drive():
    """Driven crank, loop closed through the slider: the slider at the exact rigid kinematics to
    1e-6 m, the crank pin's force on the rod (cut joint) and the crank's drive torque (tree joint)
    the closed-form rigid ones to 1e-6 of their largest."""
    case = cases.load("slider_crank")
    r = registry.run(case, "pinocchio")
    assert r.ok
    x, F, torque = slider_crank(case, r.t)
    assert np.abs(r.channels["slider_position"] - x).max() < 1e-6
    f = np.column_stack([r.channels["crank_pin_force_x"], r.channels["crank_pin_force_y"]])
    assert np.abs(f - F).max() < 1e-6 * np.abs(F).max()
    assert np.abs(r.channels["drive_torque"] - torque).max() < 1e-6 * np.abs(torque).max()


def test_tree_joints_carry_no_moment_or_force_along_their_free_axes():
    """The cut joints' forces, put on both their sides, leave the free tree joints nothing to
    carry along their axes (a revolute joint's moment, a prismatic one's force)."""
    for name in ("four_bar_swing_rigid", "slider_crank"):
        case = cases.load(name)
        eng = pinocchio_rigid.Rigid(case)
        q, v = eng.start()
        R = eng.reactions(0.013, q, v)
        for jn, j in case.joints.items():
            if j.motion is None:
                along = (R[jn][:3] if j.type == "revolute" else R[jn][3:]) @ np.array(j.axis)
                assert abs(along) < 1e-10 * np.abs(R[jn]).max()


def test_applies_to_planar_hinges_only(monkeypatch):
    """A revolute cut joint on a planar loop applies; one whose loop turns about another axis,
    or a prismatic cut joint, does not, and says why (the tilted loop cannot close at its start,
    which loading refuses: the assembly is off for it here)."""
    assert pinocchio_rigid.applies(cases.load("four_bar_swing_rigid")) == ""
    monkeypatch.setattr(closure, "assemble", lambda case, where: {})
    tilted = cases.load("four_bar_swing_rigid", ["joints.rocker_pivot.axis=[0.0, 1.0, 0.0]"])
    assert "not all turn about its axis" in registry.status_for(tilted, "pinocchio")
    sliding = cases.load("slider_crank", ['joints.crank_pin.type="prismatic"'])
    assert "is prismatic" in registry.status_for(sliding, "pinocchio")
