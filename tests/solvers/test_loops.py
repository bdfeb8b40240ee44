"""The closed-loop cases across solvers (cases/four_bar_rigid.toml, cases/slider_crank.toml): the
in-house solver against the independent peers that share the case, and the slider-crank's
work-energy balance. Runs are cut short (a fraction of a revolution) to keep the suite fast;
the report runs them whole."""

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import cumulative_simpson

from flexmbd import cases
from flexmbd.harness import registry

pytestmark = pytest.mark.heavy(13)       # seconds, measured with both cores busy (tests/conftest.py)

W = 150.0                          # rad/s: the slider-crank's crank rate
REV = 2 * np.pi / W                # s: one revolution


def run(name, solver, t_end, overrides=()):
    r = registry.run(cases.load(name, list(overrides)), solver, t_end)
    assert r.ok, (solver, r.status)
    return r


def test_rigid_four_bar_flexmbd_pinocchio_and_mujoco_agree():
    """four_bar_rigid (the Kitis-Lindenberg crank-rocker, rigid, coasting): the follower and crank
    angles within 1e-7 rad over 0.35 s (1.8 crank turns) between flexmbd, pinocchio (constraint
    dynamics, DOP853 1e-12) and mujoco (equality constraints, RK4 at 1e-4 s; its softness is what
    bounds it: measured 7.7e-10 rad on the follower, 3.1e-9 on the crank); the cut joint's reaction
    within 1e-6 of its largest value between flexmbd and pinocchio (measured 8e-12)."""
    pytest.importorskip("pinocchio")
    pytest.importorskip("mujoco")
    runs = {s: run("four_bar_rigid", s, 0.35) for s in ("flexmbd", "pinocchio", "mujoco")}
    ref = runs["pinocchio"].channels
    for s in ("flexmbd", "mujoco"):
        for ch in ("follower_angle", "crank_angle"):
            assert np.abs(runs[s].channels[ch] - ref[ch]).max() < 1e-7, (s, ch)
    f = runs["flexmbd"].channels
    for ch in ("pin_force_x", "pin_force_y"):     # the cut joint's reaction, child frame
        assert np.abs(f[ch] - ref[ch]).max() < 1e-6 * np.abs(ref[ch]).max(), ch


def test_slider_crank_rigid_limit_reactions_match_pinocchio():
    """The rod rigid: flexmbd's crank-pin force (the cut joint's multipliers) and drive torque (the
    driven pivot's reaction, corrected for the cut force in its subtree) against pinocchio's to
    1e-6 of their largest values over a quarter revolution; both pose the rod's lumped inertia."""
    pytest.importorskip("pinocchio")
    rigid = ["bodies.rod.rigid=true", 'solvers.pinocchio.beam_mass="lumped"']
    f = run("slider_crank", "flexmbd", REV / 4, rigid).channels
    p = run("slider_crank", "pinocchio", REV / 4, rigid).channels
    for ch in ("crank_pin_force_x", "crank_pin_force_y", "drive_torque", "slider_position"):
        assert np.abs(f[ch] - p[ch]).max() < 1e-6 * max(np.abs(p[ch]).max(), 1e-3), ch


def test_slider_crank_stiff_rod_slider_follows_the_rigid_kinematics():
    """A rod 100 times stiffer (bending modes at 1.3 and 5.2 kHz): the slider within 1e-6 m of
    a cos th + sqrt(L^2 - a^2 sin^2 th) over a quarter revolution."""
    r = run("slider_crank", "flexmbd", REV / 4, ["materials.steel.E=2e13"])
    th = W * r.t
    x = 0.15 * np.cos(th) + np.sqrt(0.30 ** 2 - (0.15 * np.sin(th)) ** 2)
    assert np.abs(r.channels["slider_position"] - x).max() < 1e-6


def test_slider_crank_work_energy_balance():
    """The energy's change equals the drive torque's work (Simpson's rule on 1e-5 s samples: its
    error on the 131-525 Hz bending content is ~ (2 pi f h)^4 / 180 ~ 1e-7 of the power) to 1e-6
    of the largest kinetic energy, over 5 ms."""
    r = run("slider_crank", "flexmbd", 0.005, ["integrator.output_dt=1e-5"])
    E, tau = r.channels["energy"], r.channels["drive_torque"]
    work = cumulative_simpson(tau * W, x=r.t, initial=0.0)
    assert np.abs(E - E[0] - work).max() < 1e-6 * r.extra["kinetic_max_J"]


def test_slider_crank_flexmbd_against_converged_exudyn_beam():
    """Over the first revolution the midpoint deflection's RMS difference below 3 % of its largest
    magnitude and its two extremes within 3 % (measured 0.17 %, 0.03 % and 0.26 %)."""
    pytest.importorskip("exudyn")
    f = run("slider_crank", "flexmbd", REV).channels["midpoint_deflection"]
    b = run("slider_crank", "exudyn-beam", REV).channels["midpoint_deflection"]
    assert np.sqrt(np.mean((f - b) ** 2)) < 0.03 * np.abs(b).max()
    assert f.max() == pytest.approx(b.max(), rel=0.03) and f.min() == pytest.approx(b.min(), rel=0.03)


def test_slider_crank_exudyn_ffrf_matches_flexmbd_without_stiffening():
    """The same linear floating-frame model in two codes: midpoint deflection within 0.5 % RMS of
    its largest magnitude over half a revolution (measured 0.025 % over two)."""
    pytest.importorskip("exudyn")
    linear = ["bodies.rod.stiffening=false"]
    f = run("slider_crank", "flexmbd", REV / 2, linear).channels["midpoint_deflection"]
    e = run("slider_crank", "exudyn-ffrf", REV / 2, linear).channels["midpoint_deflection"]
    assert np.sqrt(np.mean((f - e) ** 2)) < 0.005 * np.abs(f).max()


# ---------------------------------------------------------------------------------------------
# a driven crank-rocker with flexible links (tests/data/fourbar_al.toml)

ALU = str(Path(__file__).parents[1] / "data" / "fourbar_al.toml")
RIGID_CRANK = ["bodies.crank.rigid=true", "bodies.crank.modes.count=0"]


def test_a_driven_loop_takes_no_mode_as_a_dependent_coordinate():
    """With the crank driven, the loop's two in-plane rows are met by the two free joints; the
    links' in-plane modes move the pins by round-off out of the plane only (1e-12 of their
    slopes), which must not make a mode dependent: its start and its velocity would be set by the
    projection instead of by the dynamics."""
    from flexmbd.solvers import build
    from flexmbd.fe import flexbody
    from flexmbd.mbd import constraints
    case = cases.load(ALU, RIGID_CRANK).modelled
    model = build.from_case(case, flexbody.for_case(case))
    loops = build.loops(model, case)
    dep = loops.partition(model.q0, model.v0)
    joints = {model.jnt_vadr[model.index(b)] for b in ("coupler", "follower")}
    assert set(dep.tolist()) == joints, dep
    q, v = loops.close(0.0, model.q0, model.v0)
    modal = [k for b in ("coupler", "follower")
             for k in range(model.body_madr[model.index(b)], model.body_madr[model.index(b)] + 2)]
    assert np.all(q[modal] == 0.0) and np.all(v[modal] == 0.0)


def test_the_driven_four_bar_keeps_its_links_vibration_as_exudyn_beam_does():
    """The rigid crank driven at 150 rpm: the follower's and the coupler's midspan deflections over
    0.1-0.3 s within 5 % RMS of exudyn-beam's (measured 0.4 % and 0.7 %: the modal truncation and
    exudyn-beam's mesh; a mode taken as dependent made the coupler's 2.7 x)."""
    runs = {s: run(ALU, s, 0.3, RIGID_CRANK) for s in ("flexmbd", "exudyn-beam")}
    t = runs["flexmbd"].t
    m = t >= 0.1
    for ch in ("follower_midspan", "coupler_midspan"):
        x, y = runs["flexmbd"].channels[ch][m], runs["exudyn-beam"].channels[ch][m]
        assert np.sqrt(np.mean((x - y) ** 2)) < 0.05 * np.sqrt(np.mean(y ** 2)), ch


@pytest.mark.parametrize("crank", ["1.5707963", "1.57", "1.6"])
def test_every_solver_starts_in_the_assembly_the_case_states(crank):
    """The crank at about 90 degrees and the dependent joints' guesses at 0, equidistant-looking
    from both branches: the case closes its loops once, nearest the guesses (the follower at
    about 1.67 rad, not the other branch's 3.81), and every solver starts there, its joint values
    equal to 1e-9 (each closes the loop with its own model from the case's values)."""
    case = cases.load(ALU, [f"joints.crank_pivot.q0={crank}", "joints.crank_pin.q0=0", "joints.follower_pivot.q0=0"])
    x = {n: v for n, _, v in case.assembly}
    assert 1.6 < x["follower_pivot"] < 1.7 and -1.0 < x["crank_pin"] < -0.9, x
    assert case.joints["follower_pivot"].q0 == (x["follower_pivot"],)
    for s in ("flexmbd", "exudyn-beam", "exudyn-ffrf", "pinocchio"):
        r = registry.run(case, s, 2e-3)
        assert r.ok and r.extra["assembly"] == x, (s, r.status)
        assert abs(r.channels["follower_angle"][0] - x["follower_pivot"]) < 1e-9, s


def test_a_run_that_starts_in_another_assembly_is_failed_naming_the_joint():
    from flexmbd.harness import channels
    case = cases.load(ALU)
    x = dict((n, v) for n, _, v in case.assembly)
    ok = channels.Trajectory(t=np.zeros(1), joints={"follower_pivot": np.array([x["follower_pivot"] + 1e-8])})
    assert registry.started(case, ok) is None
    turned = channels.Trajectory(t=np.zeros(1), joints={"follower_pivot": np.array([x["follower_pivot"] - 2 * np.pi])})
    assert registry.started(case, turned) is None                  # a whole turn apart: the same start
    other = channels.Trajectory(t=np.zeros(1), joints={"follower_pivot": np.array([3.8128])})
    why = registry.started(case, other)
    assert why is not None and why.kind == "failed" and "follower_pivot at 3.8128" in str(why), why


def test_the_branch_is_named_by_the_guesses():
    """The guesses near the other branch give the other branch, for every solver alike."""
    other = cases.load(ALU, ["joints.crank_pin.q0=-3", "joints.follower_pivot.q0=-2.4"])
    x = {n: v for n, _, v in other.assembly}
    assert abs(x["follower_pivot"] - (3.81284 - 2 * np.pi)) < 1e-4 and abs(x["crank_pin"] + 2.99005) < 1e-4, x


def test_the_crank_rocker_linearizes_with_more_modes_and_its_columns_are_explained(capsys):
    """Five coupler modes (the report's finer set): the loop closes at every perturbed state (a
    mode taken as dependent for its round-off made Newton fail there); the driven, moving state's
    negative damping ratios and the shares above 100 % each get their note."""
    from flexmbd.cli import main
    assert main(["modes", ALU, "--system", "--set", "bodies.coupler.modes.count=5"]) == 0
    out = capsys.readouterr().out
    assert "coupler: bending xy 1" in out and "note: a negative damping ratio" in out, out
    assert "note: an energy share above 100 %" in out
