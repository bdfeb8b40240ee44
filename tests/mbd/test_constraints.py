"""Closed loops in the in-house solver (flexmbd/mbd/constraints.py): the cut joint's rows against
finite differences, the assembled start and the rigid four-bar's motion against the one-equation
four-bar of tests/oracle_four_bar.py, the constraints and the energy at every output instant, the
slider-crank against its exact rigid kinematics and its work-energy balance, and the compiled
integrators on a loop (dopri5 against scipy's RK45, fox-goodwin's order, a failed projection)."""

from pathlib import Path

import numpy as np
import pytest

from flexmbd.solvers import build, inhouse
from flexmbd import cases
from flexmbd.fe import flexbody
from flexmbd.mbd import dynamics, integrate
from flexmbd.solvers.common import beam_inertia
from flexmbd.solvers.build import from_case
from flexmbd.mbd.constraints import axis_basis
from flexmbd.mbd.model import make_data
from flexmbd.mbd.compiled import entry

from oracle_four_bar import angles, crank_angle

CASES = Path(__file__).resolve().parents[2] / "cases"


def loops_of(name, overrides=()):
    case = cases.load(str(CASES / f"{name}.toml"), list(overrides))
    model = from_case(case.modelled, flexbody.for_case(case.modelled))
    return case, model, build.loops(model, case.modelled)


@pytest.fixture(scope="module")
def four_bar_swing_rigid():
    """The rigid four-bar over 0.3 s at the case's tolerances: (case, model, loops, Simulation)."""
    case, model, loops = loops_of("four_bar_swing_rigid", ["duration=0.3"])
    ig = case.integrator
    sim = integrate.simulate_loops(loops, 0.3, ig.method, ig.rtol, ig.atol, ig.max_step, ig.output_dt, progress=False)
    assert sim.status.ok, sim.status
    return case, model, loops, sim


def test_axis_basis_is_a_rotation_with_the_axis_third():
    for a in ([0, 0, 1], [1, 0, 0], [0.3, -0.4, 0.5]):
        B = axis_basis(a)
        assert np.allclose(B.T @ B, np.eye(3), atol=1e-15) and np.isclose(np.linalg.det(B), 1.0)
        assert np.allclose(B[:, 2], np.array(a) / np.linalg.norm(a), atol=1e-15)


@pytest.mark.parametrize("name", ["four_bar_swing", "slider_crank"])
def test_rows_jacobian_and_bias_against_finite_differences(name):
    """G is the residual's derivative along v (central differences, h = 1e-6: truncation h^2 |r'''|
    ~ 1e-12 against rows of order 1) and G qdd + gamma the rows' second derivative: d/dt (G v)
    along a state's motion by central differences of G v at q +- h qdot, v +- h qdd (margin 1e-6
    relative to the largest entry: the differences' truncation and round-off ~ 1e-9)."""
    case, model, loops = loops_of(name)
    q, v = loops.close(0.0, model.q0, model.v0)
    rng = np.random.default_rng(1)
    free = np.zeros(v.size)
    free[dynamics.free_velocities(model)] = 1.0
    v = v + 0.3 * rng.standard_normal(v.size) * free                 # off the velocity constraint too
    y, _, _, _ = loops.rates(0.0, q, v)
    qd, qdd = y[:model.nq], y[model.nq:]
    _, r, G, g, _ = loops.state(0.0, q, v)
    h = 1e-6
    dr = (loops.state(h, q + h * qd, v)[1] - loops.state(-h, q - h * qd, v)[1]) / (2 * h)   # profiles move too
    assert np.allclose(dr, G @ loops.prescribed(0.0, q, v)[1], rtol=0, atol=1e-7 * max(1.0, np.abs(dr).max()))

    def Gv(s):
        qs, vs = q + s * qd, v + s * qdd
        return loops.state(s, qs, vs)[2] @ loops.prescribed(s, qs, vs)[1]
    d2 = (Gv(h) - Gv(-h)) / (2 * h)
    assert np.allclose(d2, G @ qdd + g, rtol=0, atol=1e-6 * max(1.0, np.abs(d2).max()))


@pytest.mark.parametrize("name", ["four_bar_swing", "slider_crank"])
def test_constrained_rates_keep_the_rows(name):
    """On the constraints (position and velocity), G qdd + gamma = 0: the multipliers' system is
    solved to its round-off (margin 1e-9 of gamma's scale: G M^-1 G^T's condition ~ 1e6)."""
    case, model, loops = loops_of(name)
    q, v = loops.close(0.0, model.q0, model.v0)
    y, _, _, _ = loops.rates(0.0, q, v)
    _, _, G, g, _ = loops.state(0.0, q, v)
    assert np.abs(G @ y[model.nq:] + g).max() < 1e-9 * max(1.0, np.abs(g).max())


def test_four_bar_assembles_on_the_closed_form_branch():
    case, model, loops = loops_of("four_bar_swing_rigid")
    q, v = loops.close(0.0, model.q0, model.v0)
    th = q[0]
    th3, th4 = angles(th, 0.15, 0.45, 0.40, 0.50)
    assert abs(th + q[1] - th3) < 1e-12 and abs(q[2] - th4) < 1e-12    # crank_pin is relative to the crank
    assert list(loops.dep) == [1, 2]
    assert loops.violation(0.0, q, v)[1] < 1e-12


def test_four_bar_rigid_follows_the_one_equation_four_bar(four_bar_swing_rigid):
    """Crank angle within 1e-7 rad of the oracle (DOP853 at 1e-13) over the run; the constraints
    below 1e-10 m and 1e-10 m/s at every output instant; energy closed to 1e-6 of the largest
    kinetic energy."""
    case, model, loops, sim = four_bar_swing_rigid
    bars = [case.bodies[n] for n in ("crank", "coupler", "rocker")]
    inert = [beam_inertia(b, "lumped") for b in bars]
    j = case.joints["crank_pivot"]
    ref = crank_angle(sim.t, j.q0[0], j.qd0[0], (0.15, 0.45, 0.40, 0.50), [m for m, _, _ in inert],
                      [I[2, 2] for _, _, I in inert], 9.81)
    assert np.abs(sim.q[:, 0] - ref).max() < 1e-7
    viol = np.array([loops.violation(t, q, v) for t, q, v in zip(sim.t, sim.q, sim.v)])
    assert viol[:, 0].max() < 1e-10 and viol[:, 1].max() < 1e-10
    data = make_data(model)
    E = np.array([entry.energy(model, data, q, v) for q, v in zip(sim.q, sim.v)])
    assert np.abs(E.sum(1) - E[0].sum()).max() < 1e-6 * E[:, 0].max()


def test_rk4_on_a_loop_converges_at_fourth_order_and_keeps_the_rows():
    """rk4 restarts after each projection like the embedded pairs: on the rigid four-bar over 0.3 s
    (output 1 ms) its crank angle against the one-equation oracle falls 17x from 2e-4 to 1e-4 s
    (measured 3.0e-10 -> 1.7e-11: order 4 is 16x, so at least 8x is asked), and the rows hold
    to the projection's 1e-12 at every output instant."""
    case, model, loops = loops_of("four_bar_swing_rigid", ["duration=0.3"])
    bars = [case.bodies[n] for n in ("crank", "coupler", "rocker")]
    inert = [beam_inertia(b, "lumped") for b in bars]
    j = case.joints["crank_pivot"]
    err = []
    for dt in (2e-4, 1e-4):
        sim = integrate.simulate_loops(loops, 0.3, "rk4", output_dt=case.integrator.output_dt, dt=dt, progress=False)
        assert sim.status.ok and sim.settings["dt"] == dt and sim.steps == round(0.3 / dt)
        ref = crank_angle(sim.t, j.q0[0], j.qd0[0], (0.15, 0.45, 0.40, 0.50), [m for m, _, _ in inert],
                          [I[2, 2] for _, _, I in inert], 9.81)
        err.append(np.abs(sim.q[:, 0] - ref).max())
        viol = np.array([loops.violation(t, q, v) for t, q, v in zip(sim.t, sim.q, sim.v)])
        assert viol[:, 0].max() < 1e-10 and viol[:, 1].max() < 1e-10
    assert err[1] < err[0] / 8 and err[1] < 1e-9, err


def test_cut_reaction_balances_the_rocker(four_bar_swing_rigid):
    """The rocker hangs on its pivot and the cut pin only: the pin force (child frame) and the
    pivot's reaction (corrected for the cut's force in its subtree) with gravity give the rocker's
    momentum rate, m a_c = f_pin + f_pivot + m g, checked from the run's states."""
    case, model, loops, sim = four_bar_swing_rigid
    k = np.arange(0, sim.t.size, 50)
    t, Q, V = sim.t[k], sim.q[k], sim.v[k]
    cuts = inhouse.cut_forces(loops, t, Q, V)
    ev = inhouse.evaluate(model, t, Q, V, loops, cuts)
    i = model.index("rocker")
    m = beam_inertia(case.bodies["rocker"], "lumped")[0]
    for n in range(len(t)):
        E = ev.X0[n, i, :3, :3]                       # world -> rocker
        f_pin = cuts[n].reactions["rocker_pin"][3:]
        f_piv = ev.f[n, i, 3:]                        # pivot onto rocker, rocker frame
        w, a_lin = ev.v[n, i, :3], ev.a[n, i, 3:]     # (gravity enters a as a base acceleration)
        al = ev.a[n, i, :3]
        c = np.array([0.2, 0.0, 0.0])
        a_c = a_lin + np.cross(w, ev.v[n, i, 3:]) + np.cross(al, c) + np.cross(w, np.cross(w, c))
        assert np.allclose(m * a_c, f_pin + f_piv, rtol=0, atol=1e-9 * max(1.0, np.abs(f_pin).max())), (n, E)


def test_slider_crank_rigid_rod_follows_the_exact_kinematics():
    """With the rod rigid, the slider at x = a cos th + sqrt(L^2 - a^2 sin^2 th), th = 150 t,
    within 1e-9 m (the constraints' projection holds 1e-12)."""
    case, model, loops = loops_of("slider_crank", ["bodies.rod.rigid=true", "duration=0.02", "durability.discard=0"])
    ig = case.integrator
    sim = integrate.simulate_loops(loops, 0.02, ig.method, ig.rtol, ig.atol, ig.max_step, ig.output_dt, progress=False)
    assert sim.status.ok
    th = 150.0 * sim.t
    x = 0.15 * np.cos(th) + np.sqrt(0.30 ** 2 - (0.15 * np.sin(th)) ** 2)
    assert np.abs(sim.q[:, model.jnt_qadr[model.index("slider")]] - x).max() < 1e-9


def test_fox_goodwin_on_a_loop_converges_at_second_order_and_keeps_the_rows():
    """fox-goodwin restarts after each projection with the projected state's accelerations: on the
    rigid four-bar over 0.3 s (output 1 ms, Newton to 1e-12) its crank angle against the
    one-equation oracle falls with the step as h^2 (Newmark's order: measured 4.3e-6 -> 1.1e-6,
    4.0x a halving; at least 3x asked), and the rows hold to the projection's 1e-12 at every
    output instant."""
    case, model, loops = loops_of("four_bar_swing_rigid", ["duration=0.3"])
    bars = [case.bodies[n] for n in ("crank", "coupler", "rocker")]
    inert = [beam_inertia(b, "lumped") for b in bars]
    j = case.joints["crank_pivot"]
    err = []
    for dt in (2e-4, 1e-4):
        sim = integrate.simulate_loops(loops, 0.3, "fox-goodwin", rtol=1e-12, atol=1e-12,
                                       output_dt=case.integrator.output_dt, dt=dt, progress=False)
        assert sim.status.ok and sim.settings["dt"] == dt and sim.steps == round(0.3 / dt)
        ref = crank_angle(sim.t, j.q0[0], j.qd0[0], (0.15, 0.45, 0.40, 0.50), [m for m, _, _ in inert],
                          [I[2, 2] for _, _, I in inert], 9.81)
        err.append(np.abs(sim.q[:, 0] - ref).max())
        viol = np.array([loops.violation(t, q, v) for t, q, v in zip(sim.t, sim.q, sim.v)])
        assert viol[:, 0].max() < 1e-10 and viol[:, 1].max() < 1e-10
    assert err[1] < err[0] / 3, err


def test_compiled_dopri5_on_a_loop_agrees_with_scipys_rk45():
    """The compiled dopri5 (rates and projection inside) and scipy's RK45 from Python on
    `Loops.rates`, both at rtol 1e-10, on the flexible slider-crank over 10 ms: the same states to
    1e-7 of each coordinate's largest value (each within 1.3e-8 of DOP853 at rtol 1e-13, each
    other within 4.5e-9 measured: a margin of 20)."""
    case, model, loops = loops_of("slider_crank", ["duration=0.01", "durability.discard=0"])
    runs = [integrate.simulate_loops(loops, 0.01, m, 1e-10, 1e-12, 1e-3, case.integrator.output_dt, progress=False)
            for m in ("dopri5", "rk45")]
    assert all(r.status.ok for r in runs) and runs[0].t.size == runs[1].t.size == 101
    Y = [np.hstack([r.q, r.v]) for r in runs]
    scale = np.maximum(np.abs(Y[1]).max(axis=0), 1e-300)
    assert (np.abs(Y[0] - Y[1]) / scale).max() < 1e-7, (np.abs(Y[0] - Y[1]) / scale).max()


def test_fox_goodwin_on_the_flexible_slider_crank_converges_to_dopri5():
    """The rod's largest modal coordinate over 10 ms (output 0.1 ms, Newton to 1e-10) against
    dopri5 at rtol 1e-11: fox-goodwin's error falls as h^2 (measured 1.5e-4 -> 3.7e-5 of its
    largest value from 1e-4 to 5e-5 s, 4.0x; at least 3x asked), the joints' within 1e-6 rad (m)
    (measured 6.4e-8 at 1e-4 s), and the rows hold to the projection's 1e-12 at every output
    instant."""
    case, model, loops = loops_of("slider_crank", ["duration=0.01", "durability.discard=0"])
    ref = integrate.simulate_loops(loops, 0.01, "dopri5", 1e-11, 1e-13, 1e-3, 1e-4, progress=False)
    a, nm = model.body_madr[model.index("rod")], model.body_nm[model.index("rod")]
    k = a + int(np.argmax(np.abs(ref.q[:, a:a + nm]).max(axis=0)))
    err = []
    for dt in (1e-4, 5e-5):
        sim = integrate.simulate_loops(loops, 0.01, "fox-goodwin", 1e-10, 1e-12, output_dt=1e-4, dt=dt, progress=False)
        assert sim.status.ok and sim.t.size == ref.t.size
        err.append(np.abs(sim.q[:, k] - ref.q[:, k]).max() / np.abs(ref.q[:, k]).max())
        assert np.abs(sim.q[:, :a] - ref.q[:, :a]).max() < 1e-6
        viol = np.array([loops.violation(t, q, v) for t, q, v in zip(sim.t, sim.q, sim.v)])
        assert viol[:, 0].max() < 1e-10 and viol[:, 1].max() < 1e-10
    assert err[1] < err[0] / 3 and err[0] < 1e-3, err


def test_a_loop_that_does_not_close_names_its_joint():
    """The projection's Newton given no iteration from a state off the loop (a dependent joint
    turned by 0.01 rad) fails, and says which cut joint and by how much; a run whose projection
    fails inside the compiled integrator ends failed with the same words and the instant."""
    case, model, loops = loops_of("four_bar_swing_rigid", ["duration=0.3"])
    q, v = loops.close(0.0, model.q0, model.v0)
    q[loops.dep[0]] += 0.01
    with pytest.raises(loops.NotClosed) as e:
        loops.close(0.0, q, v, iterations=0)
    assert e.value.args[0] == "rocker_pin" and e.value.args[1] > 1e-3
    from flexmbd.mbd.integrate import loops as driver
    from flexmbd.mbd.integrate.base import NOT_CLOSED, WHY, failed

    def fails(model, y0, t_out, Y, *args, cuts=None, **kw):   # the integrator's report of a failed projection
        cuts.fail[:] = 2e-6, 1.0
        return 3, 12, 80, failed(WHY[NOT_CLOSED], t_out[4])
    real, driver._dopri5 = driver._dopri5, fails
    try:
        sim = integrate.simulate_loops(loops, 0.3, "dopri5", output_dt=1e-3, progress=False)
    finally:
        driver._dopri5 = real
    assert not sim.status.ok and sim.status.t == 4e-3 and sim.t.size == 4
    assert sim.status.why == "the loop of joint 'rocker_pin' no longer closes (residual 2e-06)"
