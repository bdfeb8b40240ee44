"""The peer adapters: `pinocchio` and `mujoco` (rigid limit) and `mujoco-rod` (elastic rod).

The rigid peers build their models from the case, not from flexmbd's Model: their mass
matrices, body poses, energies and accelerations are checked against flexmbd's Model at the
same state (a cross-check of two independent constructions, the peers with the lumped-mesh beam
inertia that flexmbd integrates for a beam declared rigid), their closed-form beam inertia
against flexmbd's lumped beam, and their runs against each other and against `flexmbd` on beams
declared rigid (`agreement`; tests/solvers/test_peers_independent.py shows that this check fails when an
error is planted in `build.from_case`). The rod against Euler–Bernoulli statics and, in the slow
suite, against `flexmbd` on cantilever_step.
"""

import numpy as np
import pytest

from flexmbd.solvers import build
from flexmbd import cases
from flexmbd.harness import channels, registry
from flexmbd.fe import flexbody
from flexmbd.mbd import dynamics, spatial
from flexmbd.solvers.build import from_case
from flexmbd.mbd.compiled.entry import forward_dynamics
from flexmbd.mbd.model import make_data

pin = pytest.importorskip("pinocchio")
mujoco = pytest.importorskip("mujoco")

from flexmbd.solvers import common, mujoco_common, mujoco_rigid, mujoco_rod, pinocchio_model, pinocchio_rigid  # noqa: E402
from flexmbd.mbd.compiled import entry

LUMPED = ['solvers.pinocchio.beam_mass="lumped"', 'solvers.mujoco.beam_mass="lumped"']

TREE = """
title = "rigid tree with every joint type"
duration = 0.2
gravity = [0.0, -9.81, 0.0]
[materials.steel]
E = 2.06e11
nu = 0.29
rho = 7820.0
[bodies.base]
type = "rigid"
mass = 2.0
com = [0.1, 0.02, -0.03]
inertia = [0.03, 0.05, 0.04, 0.001, -0.002, 0.003]
[bodies.arm]
type = "beam"
material = "steel"
length = 0.8
elements = 8
section = { shape = "rectangle", b = 0.02, h = 0.03 }
modes = { count = 0 }
[bodies.ball]
type = "rigid"
mass = 0.7
com = [0.05, 0.0, 0.01]
inertia = [0.002, 0.003, 0.004, 0.0, 0.0001, 0.0]
[bodies.slider]
type = "rigid"
mass = 0.4
inertia = [0.001, 0.001, 0.001, 0.0, 0.0, 0.0]
[joints.float]
type = "free"
parent = "ground"
child = "base"
at = [0.1, 0.2, 0.3]
rpy = [0.1, -0.2, 0.3]
q0 = [0.3, -0.5, 0.8, 0.1, 0.2, -0.1]
qd0 = [0.5, -1.0, 0.7, 0.2, -0.3, 0.4]
[joints.hinge]
type = "revolute"
parent = "base"
child = "arm"
at = [0.2, 0.0, 0.1]
axis = [0.0, 1.0, 1.0]
q0 = 0.4
qd0 = -1.5
[joints.shoulder]
type = "spherical"
parent = "arm"
child = "ball"
at = 0.8
q0 = [0.2, 0.4, -0.3]
qd0 = [1.0, 0.5, -0.5]
[joints.rail]
type = "prismatic"
parent = "ball"
child = "slider"
axis = [1.0, 0.0, 0.0]
rpy = [0.0, 0.0, 0.7]
q0 = 0.05
qd0 = 0.3
[bodies.tool]
type = "rigid"
mass = 0.3
com = [0.02, 0.01, 0.0]
inertia = [0.001, 0.002, 0.0015, 0.0001, 0.0, 0.0002]
[joints.weld]
type = "fixed"
parent = "arm"
child = "tool"
at = 0.43
rpy = [0.3, 0.2, -0.4]
[bodies.tip]
type = "rigid"
mass = 0.2
inertia = [0.001, 0.001, 0.001, 0.0, 0.0, 0.0]
[joints.wrist]
type = "revolute"
parent = "tool"
child = "tip"
at = [0.1, 0.0, 0.05]
axis = [1.0, 1.0, 0.0]
rpy = [0.1, 0.0, 0.2]
q0 = 0.3
qd0 = 2.0
[loads.push]
type = "point_force"
body = "arm"
at = 0.6
force = [0.0, 3.0, -2.0]
frame = "body"
[loads.wind]
type = "point_force"
body = "slider"
at = [0.0, 0.1, 0.0]
force = [1.0, 0.0, 0.5]
frame = "global"
[loads.grip]
type = "point_force"
body = "tool"
at = [0.05, 0.0, 0.02]
force = [1.0, -2.0, 0.5]
frame = "global"
[channels.hinge]
kind = "joint_angle"
joint = "hinge"
[channels.energy]
kind = "energy"
"""


@pytest.fixture
def tree(tmp_path):
    path = tmp_path / "tree.toml"
    path.write_text(TREE)
    return cases.load(str(path))


def rigid(name, extra=()):
    return cases.load(name, [f"bodies.{b}.rigid=true" for b in cases.load(name).bodies] + list(extra))


def velocity_permutation(model):
    """P (nv, nv) with v_pin = P v_flexmbd (the free joint's [w; v] becomes [v; w])."""
    return np.array([pinocchio_model.to_pin_v(model, e) for e in np.eye(model.nv)]).T


def spatial_to_pin_matrix(I6):
    """flexmbd [angular; linear] spatial inertia -> Pinocchio's [linear; angular] ordering."""
    P = np.block([[np.zeros((3, 3)), np.eye(3)], [np.eye(3), np.zeros((3, 3))]])
    return P @ I6 @ P


# ---------------------------------------------------------------------------------------------
# pinocchio


def test_beam_inertia_in_closed_form_against_flexmbds_lumped_beam():
    """`common.beam_inertia` ("lumped") equals flexmbd's rigid beam (its node sums) to round-off,
    for rectangles with h along y and along z and a circle; the prism differs from it by exactly
    m L^2 / (6 n^2) about the two axes across the beam and nowhere else."""
    mat = cases.Material(name="steel", E=2.06e11, nu=0.29, rho=7820.0)
    for section, n in [(cases.Section("rectangle", b=0.01, h=0.015, d=None, h_axis="y"), 8),
                       (cases.Section("rectangle", b=0.01, h=0.015, d=None, h_axis="z"), 10),
                       (cases.Section("circle", b=None, h=None, d=0.02, h_axis="y"), 7)]:
        body = cases.Beam(name="b", material=mat, length=0.8, elements=n, section=section,
                          modes=cases.Modes(count=0, boundary="clamped-free", interfaces=None), damping_ratio=0.0,
                          mass="lumped", shear=False, rigid=True, stiffening=True, segments=1)
        ref = build.rigid_inertia_of_beam(flexbody.undeformed("b", body))       # flexmbd, at the root
        m, c, Ic = common.beam_inertia(body, "lumped")
        assert np.allclose(spatial.inertia(m, c, Ic), ref, rtol=1e-13, atol=1e-13 * np.abs(ref).max())
        mp, cp, Ip = common.beam_inertia(body, "prism")
        assert mp == m and np.array_equal(cp, c)
        lumping = np.diag([0.0, 1.0, 1.0]) * m * 0.8 ** 2 / (6 * n * n)
        assert np.allclose(Ic - Ip, lumping, rtol=0, atol=1e-15 * Ic.max())


def test_pinocchio_model_from_the_case_against_flexmbds_model(tree):
    """The peer's Pinocchio model, built from the case, against flexmbd's Model of the same case
    at its initial state: the case's initial values converted by each (q, v), the mass matrix
    (crba against the polarized kinetic energy) and the energies. The Model-conversion helpers
    the algorithm tests use (tests/mbd/test_dynamics.py) round-trip inertias and placements."""
    model = from_case(pinocchio_rigid.rigid_case(tree))
    for i in range(1, model.nb + 1):
        I6 = model.body_inertia[i]
        assert np.allclose(pinocchio_model.inertia(I6).matrix(), spatial_to_pin_matrix(I6), atol=1e-14)
        X = model.jnt_Xtriad[i]
        M = pinocchio_model.se3(X)                               # [linear; angular] action matrix
        P = np.block([[np.zeros((3, 3)), np.eye(3)], [np.eye(3), np.zeros((3, 3))]])
        assert np.allclose(P @ M.inverse().toActionMatrix() @ P, X, atol=1e-14)
    eng = pinocchio_rigid.Rigid(tree, "lumped")
    assert eng.nq == model.nq and eng.nv == model.nv
    assert np.allclose(eng.q0, pinocchio_model.to_pin_q(model, model.q0), rtol=0, atol=1e-15)
    assert np.array_equal(eng.v0, pinocchio_model.to_pin_v(model, model.v0))
    data = make_data(model)
    P = velocity_permutation(model)
    M_ref = P @ entry.mass_matrix_system(model, data, model.q0) @ P.T
    M = pin.crba(eng.pm, eng.pd, eng.q0)
    M = np.triu(M) + np.triu(M, 1).T
    assert np.allclose(M, M_ref, rtol=1e-12, atol=1e-12 * np.abs(M_ref).max())
    T, V = entry.energy(model, data, model.q0, model.v0)
    assert eng.energy(eng.q0, eng.v0) == pytest.approx(T + V, rel=1e-12, abs=1e-12)


def test_pinocchio_accelerations_with_loads_match_flexmbd(tree):
    """The peer's accelerations (its own model, loads converted to Pinocchio's joint frames) are
    flexmbd's at the case's initial state."""
    model = from_case(pinocchio_rigid.rigid_case(tree))
    eng = pinocchio_rigid.Rigid(tree, "lumped")
    a, _, _ = eng.qdd(0.0, eng.q0, eng.v0)
    ref = forward_dynamics(model, make_data(model), model.q0, model.v0)
    assert np.allclose(pinocchio_model.from_pin_v(model, a), ref, rtol=1e-10, atol=1e-10)


def test_pinocchio_prescribed_spin_up_follows_its_profile():
    case = cases.load("pendulum", ['joints.pivot.motion={type="spin_up", W=2.0, T=0.2}'])
    r = registry.run(case, "pinocchio", 0.3)
    assert r.ok
    W, T, t = 2.0, 0.2, r.t
    ref = np.where(t < T, W / T * (t ** 2 / 2 + (T / (2 * np.pi)) ** 2 * (np.cos(2 * np.pi * t / T) - 1)),
                   W * (t - T / 2))
    assert np.abs(r.channels["joint_angle"] - ref).max() < 1e-12
    assert np.all(r.channels["tip_deflection"] == 0.0)           # the rigid limit does not deform


def test_pinocchio_hybrid_dynamics_leaves_free_joints_unforced():
    """With pivot1 prescribed, the accelerations make the free joint's inverse-dynamics torque zero."""
    case = cases.load("double_pendulum", ["bodies.beam1.rigid=true", "bodies.beam2.rigid=true",
                                          'joints.pivot1.motion={type="harmonic", amplitude=0.3, frequency=1.5}'])
    eng = pinocchio_rigid.Rigid(case)
    q, v = np.array([0.2, -0.7]), np.array([0.4, 1.1])
    a, q, v = eng.qdd(0.13, q, v)
    tau = pin.rnea(eng.pm, eng.pd, q, v, a)
    assert abs(tau[1]) < 1e-12 and abs(tau[0]) > 1e-3
    assert a[0] == pytest.approx(-0.3 * (3 * np.pi) ** 2 * np.sin(3 * np.pi * 0.13), rel=1e-12)


# ---------------------------------------------------------------------------------------------
# mujoco (rigid)


def mujoco_of(case, beam_mass="lumped"):
    """MuJoCo model and data of the peer's MJCF, at the case's initial state."""
    bodies = common.rigid_bodies(case, beam_mass)
    m = mujoco.MjModel.from_xml_string(mujoco_rigid.mjcf(bodies, case.gravity, 1e-4))
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = mujoco_rigid.initial_state(bodies, m)
    return m, d


def test_mujoco_body_poses_velocities_and_energy_from_the_case_match_flexmbd(tree):
    """The MJCF written from the case, at the case's initial state: MuJoCo's body poses (w-first
    quaternions), body velocities and energies equal flexmbd's forward kinematics of its own
    Model at its own initial state; so do the mass matrices."""
    model = from_case(pinocchio_rigid.rigid_case(tree))
    m, d = mujoco_of(tree)
    assert (m.nq, m.nv) == (model.nq, model.nv)
    mujoco.mj_forward(m, d)
    data = make_data(model)
    T, V = entry.energy(model, data, model.q0, model.v0)
    for i in range(1, model.nb + 1):
        R, p = dynamics.body_pose(data, i)
        b = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, model.names[i])
        assert np.allclose(d.xpos[b], p, atol=1e-13)
        assert np.allclose(mujoco_common.quat_to_rot(d.xquat[b]), R, atol=1e-13)
        vel = np.zeros(6)                                       # [w; v] of the body origin, body frame (XBODY)
        mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_XBODY, b, vel, 1)
        assert np.allclose(vel, data.v[i], atol=1e-12)
    assert d.energy.sum() == pytest.approx(T + V, rel=1e-12)
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    k = model.jnt_vadr[model.index("arm")]                       # after the free joint (other layout)
    M_ref = entry.mass_matrix_system(model, data, model.q0)
    assert np.allclose(M[6:, 6:], M_ref[k:, k:], rtol=1e-12, atol=1e-12 * np.abs(M_ref).max())


def test_mujoco_accelerations_with_loads_match_flexmbd(tree):
    model = from_case(pinocchio_rigid.rigid_case(tree))
    m, d = mujoco_of(tree)
    mujoco_rigid.apply_loads(mujoco_rigid.model_loads(tree, m), m, d)
    mujoco.mj_forward(m, d)
    ref = forward_dynamics(model, make_data(model), model.q0, model.v0)
    # MuJoCo's free-joint acceleration is [dv_world/dt; dw/dt]: compare the other joints
    k = model.jnt_vadr[model.index("arm")]
    assert np.allclose(d.qacc[6:], ref[k:], rtol=1e-9, atol=1e-9)


# ---------------------------------------------------------------------------------------------
# the rigid peers against each other and against flexmbd


# The agreement check. The three integrate the same rigid equations (the peers with the
# lumped-mesh beam inertia that flexmbd integrates for a beam declared rigid) with their own
# integrators at tight tolerances (flexmbd: Adams, rtol 1e-8, atol 1e-10; pinocchio: DOP853 at
# 1e-12; mujoco: RK4, h = 1e-4 s). Observed at 2 s: end angles within 6e-10 rad, energies within
# 1e-10 J (of ~13 J kinetic energy), so the bounds leave a factor ~100 for the integrators'
# error growth in the swinging double pendulum. A model error moves the angles by far more: an
# inertia error d I / I changes the swing's time scale by d I / 2 I, i.e. an angle by about
# rate x t x d I / 2 I (1e-5 rad at 2 s for d I / I = 1e-5). The energy, conserved by each
# model, differs only where the models' energies of the initial state differ or are not
# conserved (both start at rest, horizontal: 0 J).
ANGLE_TOL = 1e-7                    # rad, end of the run
ENERGY_TOL = 1e-8                   # J, over the run


def agreement(case, t_end=None) -> dict:
    """flexmbd, pinocchio and mujoco on the case: the largest end-angle difference (rad) over the
    joint-angle channels and the pairs of solvers, the largest energy difference (J) of pinocchio
    from the other two over the run; both peers' differences from flexmbd separately."""
    runs = {s: registry.run(case, s, t_end) for s in ("flexmbd", "pinocchio", "mujoco")}
    assert all(r.ok for r in runs.values()), {s: r.status for s, r in runs.items()}
    angles = [c for c, ch in case.channels.items() if ch.kind == "joint_angle"]
    end = {s: np.array([r.channels[c][-1] for c in angles]) for s, r in runs.items()}
    e = {s: r.channels["energy"] for s, r in runs.items()}
    return {"peers_angle": np.abs(end["pinocchio"] - end["mujoco"]).max(),
            "pinocchio_angle": np.abs(end["pinocchio"] - end["flexmbd"]).max(),
            "mujoco_angle": np.abs(end["mujoco"] - end["flexmbd"]).max(),
            "peers_energy": np.abs(e["pinocchio"] - e["mujoco"]).max(),
            "pinocchio_energy": np.abs(e["pinocchio"] - e["flexmbd"]).max(),
            "mujoco_energy": np.abs(e["mujoco"] - e["flexmbd"]).max()}


def agrees(d: dict) -> bool:
    """The agreement check on `agreement`'s measures."""
    return all(v < (ANGLE_TOL if k.endswith("angle") else ENERGY_TOL) for k, v in d.items())


@pytest.mark.parametrize("name", ["pendulum", "double_pendulum"])
def test_rigid_peers_agree_with_flexmbd_on_beams_declared_rigid(name):
    d = agreement(rigid(name, LUMPED))
    assert agrees(d), d


def test_rigid_peers_as_prisms_agree_with_each_other_and_differ_from_the_lumped_beam_as_predicted():
    """With the default prism both peers still agree with each other to the same bounds; from
    flexmbd's lumped beam (100 elements: 1 / (2 n^2) = 5e-5 of the pivot's inertia) the pendulum's
    angle moves by about rate x t x 2.5e-5: at 0.5 s (rate ~4 rad/s) some 5e-5 rad (measured 5.3e-5)."""
    d = agreement(rigid("pendulum"), 0.5)
    assert d["peers_angle"] < ANGLE_TOL and d["peers_energy"] < ENERGY_TOL, d
    assert 5e-6 < d["pinocchio_angle"] < 1e-4 and 5e-6 < d["mujoco_angle"] < 1e-4, d


def test_rigid_peers_run_the_flexible_case_as_its_rigid_limit():
    a = registry.run(cases.load("pendulum"), "pinocchio", 0.5)
    b = registry.run(rigid("pendulum"), "pinocchio", 0.5)
    assert a.ok and np.array_equal(a.channels["joint_angle"], b.channels["joint_angle"])
    assert np.all(a.channels["tip_deflection"] == 0.0) and np.all(a.channels["stress_vm"] == 0.0)


def test_missing_engine_is_unavailable(monkeypatch):
    monkeypatch.setitem(registry.MODULES, "mujoco", "flexmbd.solvers.no_such_engine")
    assert registry.status_for(cases.load("pendulum"), "mujoco").startswith("unavailable")


def test_engine_error_is_a_failed_result(monkeypatch):
    monkeypatch.setattr(mujoco_rod, "mjcf", lambda *a: ("<mujoco><worldbody><body/></mujoco>", 0.0))
    r = registry.run(cases.load("cantilever_step"), "mujoco-rod", 0.01)
    assert r.status.kind == "failed" and "XML" in r.status.why


# ---------------------------------------------------------------------------------------------
# mujoco-rod


def test_rod_round_trip_of_root_frame_and_masses():
    """A rotated, offset support (w-first quaternion in the MJCF) reads back as an undeformed rod
    in the root frame; the vertex and root masses add up to rho A L."""
    case = cases.load("pendulum", ["joints.pivot.rpy=[0.3, -0.2, 0.9]", "joints.pivot.q0=0.4"])
    ne = mujoco_rod.SETTINGS["edges"][1]
    m, q0 = mujoco_rod.compile_rod(case, ne, 1e-4, 1e-6, "discrete")
    d = mujoco.MjData(m)
    d.qpos[m.jnt_qposadr[m.joint("pivot").id]] = q0
    mujoco.mj_forward(m, d)
    s, l = mujoco_rod.rod_points(1.5, ne)
    row = mujoco_rod.sample(case, m, d, ne, l)
    out = {k: v[0] for k, v in channels.channels(case, mujoco_rod.trajectory(case, [row], np.zeros(1), s)).items()}
    assert abs(out["tip_deflection"]) < 1e-12 and out["stress_vm"] < 1e-3
    assert out["joint_angle"] == 0.4
    R, _ = mujoco_rod.root_frame(m, d)
    Rz = np.array([[np.cos(0.4), -np.sin(0.4), 0], [np.sin(0.4), np.cos(0.4), 0], [0, 0, 1]])
    assert np.allclose(R, spatial.rotation_rpy([0.3, -0.2, 0.9]) @ Rz, atol=1e-12)
    rod_mass = m.body_subtreemass[m.body("root").id]
    assert rod_mass == pytest.approx(7820.0 * 0.01 * 0.015 * 1.5, rel=1e-12)


def test_rod_static_tip_deflection_matches_euler_bernoulli():
    """Clamped rod, constant 12 N tip load, default edge count: settles to P L^3 / 3 E I within 0.5 %.
    A large discrete step damps the vibration numerically (backward Euler), which is what we want here."""
    case = cases.load("cantilever_step", ["integrator.output_dt=0.01", "solvers.mujoco-rod.dt=0.01"])
    r = registry.run(case, "mujoco-rod", 3.0)
    assert r.ok
    EB = 12.0 * 1.5 ** 3 / (3 * 2.06e11 * 0.01 * 0.015 ** 3 / 12)
    y = r.channels["tip_deflection"]
    assert abs(y[-1] - y[-11]) < 1e-6                               # settled
    assert abs(-y[-1] / EB - 1.0) < 0.005, (y[-1], EB)
    sigma = 12.0 * (1.5 - 0.03) * 0.0075 / (0.01 * 0.015 ** 3 / 12)
    assert abs(r.channels["stress_vm"][-1] / sigma - 1.0) < 0.01


def test_rod_stops_at_the_first_sample_beyond_the_divergence_rule(monkeypatch):
    """The rule checked at every output sample (`channels.failure`), here with a 1 cm bound on the tip
    deflection (the rod reaches 2.3 cm): the run stops at the sample the rule after the run cuts at,
    and keeps the full run's samples before it."""
    case = cases.load("cantilever_step", ["integrator.output_dt=0.01", "solvers.mujoco-rod.dt=0.01"])
    monkeypatch.setattr(channels, "bounds", lambda case: {"tip_deflection": 0.01})
    r = registry.run(case, "mujoco-rod", 1.0)
    monkeypatch.setattr(channels, "failure", lambda case, traj: None)   # the same run, integrated to its end
    full = registry.run(case, "mujoco-rod", 1.0)
    k = len(full.t)                                                      # the first sample beyond the bound
    assert r.status == full.status and "beyond 0.01 m" in r.status.why and 0 < k < 100
    assert r.status.t == pytest.approx(k * 0.01) and r.steps == k < full.steps
    np.testing.assert_array_equal(r.channels["tip_deflection"], full.channels["tip_deflection"])


def first_frequency(t, y):
    """Frequency (Hz) of the largest spectral peak of y - mean, refined by parabolic interpolation."""
    n = 16 * t.size
    Y = np.abs(np.fft.rfft((y - y.mean()) * np.hanning(t.size), n))
    f = np.fft.rfftfreq(n, t[1] - t[0])
    k = int(np.argmax(Y[1:])) + 1
    a, b, c = np.log(Y[k - 1:k + 2])
    return f[k] + 0.5 * (a - c) / (a - 2 * b + c) * (f[1] - f[0])


@pytest.mark.slow
def test_rod_cantilever_step_agrees_with_flexmbd():
    case = cases.load("cantilever_step")
    a, b = registry.run(case, "flexmbd"), registry.run(case, "mujoco-rod")
    assert a.ok and b.ok
    x, y = a.channels["tip_deflection"], b.channels["tip_deflection"]
    fa, fb = first_frequency(a.t, x), first_frequency(b.t, y)
    assert abs(fb / fa - 1.0) < 0.01, (fa, fb)
    EB = 12.0 * 1.5 ** 3 / (3 * 2.06e11 * 0.01 * 0.015 ** 3 / 12)
    assert abs(-y.mean() / EB - 1.0) < 0.02, (y.mean(), EB)
    assert np.sqrt(np.mean((x - y) ** 2)) < 0.10 * np.abs(x).max()
