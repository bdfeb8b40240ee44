"""exudyn-beam on closed kinematic loops: the slider-crank (driven rigid crank, prismatic slider,
flexible rod closed at the crank pin) and the four-bars, against closed forms: the mechanism's
initial closure, the slider's travel and the crank-pin force of the rigid limit, the work-energy
balance of the driven crank, the energy and the rocker's moment balance of the free four-bar.
Coarse meshes and short runs: a few seconds in all."""

import dataclasses
from types import MappingProxyType

import numpy as np
import pytest

pytest.importorskip("exudyn")

from flexmbd import cases  # noqa: E402
from flexmbd.harness import registry
from flexmbd.solvers import common, exudyn_beam  # noqa: E402

pytestmark = pytest.mark.kernel_free

A, L, W = 0.15, 0.30, 150.0        # slider-crank: crank and rod length (m), crank rate (rad/s)
# the rigid limit of the slider-crank: a rod 1e4 times stiffer, its axial start transient damped
# within 2 ms by a spectral radius of 0.5, Newton's iteration converged far enough for the
# Lagrange multipliers of so stiff a rod (at the default 1e-5 the drive torque is off by 0.5 N m)
RIGID = ["materials.steel.E=2e15", "solvers.exudyn-beam.elements=4", "solvers.exudyn-beam.dt=1e-4",
         "solvers.exudyn-beam.spectral_radius=0.5", "solvers.exudyn-beam.newton_rtol=1e-8"]


def slider(t):
    """(x, x'') of the rigid slider-crank's slider at times t (n,): x = a cos th + s,
    s = sqrt(L^2 - a^2 sin^2 th), th = W t (m, m/s^2)."""
    th = W * t
    s = np.sqrt(L ** 2 - (A * np.sin(th)) ** 2)
    u = A * A * np.sin(th) * np.cos(th)
    return A * np.cos(th) + s, -A * W ** 2 * np.cos(th) - W ** 2 * A * A * np.cos(2 * th) / s - W ** 2 * u ** 2 / s ** 3


def crank_pin_force(r):
    """(n, 2) global force of the crank on the rod from the channels (components in the rod's
    end-node frame, which in the rigid limit is the chord's, from the slider pin to the crank pin)."""
    th = W * r.t
    x = slider(r.t)[0]
    psi = np.arctan2(A * np.sin(th), A * np.cos(th) - x)
    fx, fy = r.channels["crank_pin_force_x"], r.channels["crank_pin_force_y"]
    return np.column_stack([np.cos(psi) * fx - np.sin(psi) * fy, np.sin(psi) * fx + np.cos(psi) * fy])


def work_energy_gap(r) -> float:
    """Largest |E(t) - E(0) - int_0^t tau W dt| over the run (J), the drive torque tau's work by
    the trapezoidal rule."""
    E, tau = r.channels["energy"], r.channels["drive_torque"]
    work = W * np.concatenate([[0.0], np.cumsum(0.5 * (tau[1:] + tau[:-1]) * np.diff(r.t))])
    return float(np.abs(E - E[0] - work).max())


def test_slider_crank_starts_closed_with_the_rigid_velocities():
    """Crank angle 0: the slider at a + L, the rod pointing back (pi), the slider at rest and the
    rod turning at -a W / L (the crank pin's velocity a W across the rod)."""
    q, qd = exudyn_beam.close_loops(cases.load("slider_crank"), {"rod": 8})
    assert exudyn_beam.dependent(cases.load("slider_crank")) == ["slide", "wrist_pin"]
    assert q["crank_pivot"] == 0.0 and qd["crank_pivot"] == W
    assert q["slide"] == pytest.approx(A + L, abs=1e-12) and q["wrist_pin"] == pytest.approx(np.pi, abs=1e-12)
    assert qd["slide"] == pytest.approx(0.0, abs=1e-12) and qd["wrist_pin"] == pytest.approx(-A * W / L, abs=1e-12)


def test_four_bar_starts_closed():
    """The four-bar's coupler and rocker angles from the crank's by intersecting the coupler's
    circle about the crank pin with the rocker's about its pivot, their rates from the loop's
    velocity equation: what Newton's method on the closure gives, to 1e-10."""
    a, b, c, d, th, w = 0.15, 0.45, 0.40, 0.50, np.pi / 2, 20.0
    B, D = a * np.array([np.cos(th), np.sin(th)]), np.array([d, 0.0])
    e = np.linalg.norm(D - B)
    along = (b * b - c * c + e * e) / (2 * e)                  # from B towards D
    u = (D - B) / e
    C = B + along * u + np.sqrt(b * b - along ** 2) * np.array([-u[1], u[0]])     # the branch above BD
    th2, th3 = np.arctan2(*(C - B)[::-1]), np.arctan2(*(C - D)[::-1])
    w3 = w * a * np.sin(th2 - th) / (c * np.sin(th2 - th3))
    w2 = -w * a * np.sin(th3 - th) / (b * np.sin(th3 - th2))
    for name in ("four_bar_swing", "four_bar_swing_rigid"):
        q, qd = exudyn_beam.close_loops(cases.load(name), {"coupler": 16})
        assert q["crank_pin"] == pytest.approx(th2 - th, abs=1e-10)
        assert q["rocker_pivot"] == pytest.approx(th3, abs=1e-10)
        assert qd["crank_pin"] == pytest.approx(w2 - w, abs=1e-10) and qd["rocker_pivot"] == pytest.approx(w3, abs=1e-10)


def test_slider_crank_rigid_limit_follows_the_closed_form():
    """A rod 1e4 times stiffer: the slider within 1e-6 m of a cos th + sqrt(L^2 - a^2 sin^2 th)
    (measured 3e-9), the loop closed to 1e-12 m; past the rod's start transient (2 ms) the
    crank-pin force within 0.5 N of the rigid mechanism's m_rod (x_s'' - a W^2 cos th) / 2 + m_s x_s''
    (measured 0.11 N of 450 N), and the drive torque the crank pin's moment about the pivot,
    a (cos th F_y - sin th F_x) (the crank turns at a constant rate); the energy gains the drive's
    work within 1e-3 of its range."""
    case = cases.load("slider_crank", RIGID)
    r = registry.run(case, "exudyn-beam", 0.02)
    assert r.ok, r.status
    x, xdd = slider(r.t)
    assert np.abs(r.channels["slider_position"] - x).max() < 1e-6
    assert r.extra["loop_closure_m"] < 1e-12
    m_rod = case.bodies["rod"].material.rho * case.bodies["rod"].geometry.A * L
    F, th, late = crank_pin_force(r), W * r.t, r.t >= 2e-3
    Fx = 0.5 * m_rod * (xdd - A * W ** 2 * np.cos(th)) + case.bodies["slider"].mass * xdd
    assert np.abs(F[late, 0] - Fx[late]).max() < 0.5
    tau = A * (np.cos(th) * F[:, 1] - np.sin(th) * F[:, 0])
    assert np.abs(r.channels["drive_torque"][late] - tau[late]).max() < 0.01
    E = r.channels["energy"]
    assert work_energy_gap(r) < 1e-3 * np.ptp(E)


def test_slider_crank_flexible_rod_over_a_revolution():
    """The steel rod on 16 elements at dt = 1e-4 s over the first revolution: the loop stays closed, the midpoint
    deflection's extremes within 4 % of the converged ones (+3.71 mm, -4.62 mm: 256 elements,
    dt 1.25e-5 s; measured 3 % and 1 % short), and the energy gains the drive's work within 0.5 %
    of its range."""
    case = cases.load("slider_crank", ["solvers.exudyn-beam.elements=16", "solvers.exudyn-beam.dt=1e-4"])
    r = registry.run(case, "exudyn-beam", 2 * np.pi / W)
    assert r.ok, r.status
    assert r.extra["loop_closure_m"] < 1e-12
    d = r.channels["midpoint_deflection"]
    assert d.max() == pytest.approx(3.71e-3, rel=0.04) and d.min() == pytest.approx(-4.62e-3, rel=0.04)
    assert work_energy_gap(r) < 5e-3 * np.ptp(r.channels["energy"])


def test_free_rigid_four_bar_keeps_its_energy_and_balances_the_rocker():
    """four_bar_swing_rigid for 0.5 s: the energy within 5e-5 of the largest kinetic energy (measured
    1.6e-5); the rocker's I_D phi'' (phi'' by central differences) is the moment about its pivot of
    the pin force (at its tip, 0.4 m, in its frame) and of gravity at its centre of mass, within
    1 % of its largest value."""
    case = cases.load("four_bar_swing_rigid")
    r = registry.run(case, "exudyn-beam", 0.5)
    assert r.ok, r.status
    assert r.extra["loop_closure_m"] < 1e-9
    E = r.channels["energy"]
    assert np.abs(E - E[0]).max() < 5e-5 * r.extra["kinetic_max_J"]
    m, com, Ic = common.beam_inertia(case.bodies["rocker"], "lumped")
    phi, h = r.channels["rocker_angle"], case.integrator.output_dt
    lhs = (Ic[2, 2] + m * com[0] ** 2) * (phi[2:] - 2 * phi[1:-1] + phi[:-2]) / h ** 2
    rhs = (0.40 * r.channels["pin_force_y"] - m * 9.81 * com[0] * np.cos(phi))[1:-1]
    assert np.abs(lhs - rhs).max() < 0.01 * np.abs(lhs).max()


def test_loops_it_cannot_model_or_close():
    """A loop joint that is not a pin is not applicable; a loop that cannot close (the rocker's
    pivot beyond the reach of the other three links: a case file refuses it, this adapter's own
    mesh might still not close) is a ValueError saying so."""
    assert exudyn_beam.applies(cases.load("slider_crank")) == ""
    ball = cases.load("four_bar_swing_rigid", ['joints.rocker_pin.type="spherical"'])
    assert exudyn_beam.applies(ball) == "loop joint 'rocker_pin': only revolute (pin) loop joints"
    case = cases.load("four_bar_swing_rigid").resolved
    far = dataclasses.replace(case.joints["rocker_pivot"], offset=(2.0, 0.0, 0.0))
    case = dataclasses.replace(case, joints=MappingProxyType({**case.joints, "rocker_pivot": far}))
    with pytest.raises(ValueError, match="the loops do not close"):
        exudyn_beam.close_loops(case, {})
