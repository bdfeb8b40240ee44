"""The peer adapters: `pinocchio` and `mujoco` (rigid limit) and `mujoco-rod` (elastic rod).

Each adapter's convention conversions are checked by a round trip; the rigid peers against each
other and against `flexmbd` on beams declared rigid; the rod against Euler–Bernoulli statics and,
in the slow suite, against `flexmbd` on cantilever_step.
"""

import numpy as np
import pytest

from flexmbd import cases, channels, dynamics, solvers, spatial
from flexmbd.build import from_case
from flexmbd.kernel.entry import forward_dynamics
from flexmbd.model import make_data

pin = pytest.importorskip("pinocchio")
mujoco = pytest.importorskip("mujoco")

from flexmbd.adapters import mujoco_common, mujoco_rigid, mujoco_rod, pinocchio_model, pinocchio_rigid  # noqa: E402

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


def rigid(name):
    return cases.load(name, [f"bodies.{b}.rigid=true" for b in cases.load(name)["bodies"]])


def spatial_to_pin_matrix(I6):
    """flexmbd [angular; linear] spatial inertia -> Pinocchio's [linear; angular] ordering."""
    P = np.block([[np.zeros((3, 3)), np.eye(3)], [np.eye(3), np.zeros((3, 3))]])
    return P @ I6 @ P


# ---------------------------------------------------------------------------------------------
# pinocchio


def test_pinocchio_round_trip_of_inertia_placement_and_state(tree):
    model = from_case(pinocchio_rigid.rigid_case(tree))
    for i in range(1, model.nb + 1):
        I6 = model.body_inertia[i]
        assert np.allclose(pinocchio_model.inertia(I6).matrix(), spatial_to_pin_matrix(I6), atol=1e-14)
        X = model.jnt_Xtriad[i]
        M = pinocchio_model.se3(X)                               # [linear; angular] action matrix
        P = np.block([[np.zeros((3, 3)), np.eye(3)], [np.eye(3), np.zeros((3, 3))]])
        assert np.allclose(P @ M.inverse().toActionMatrix() @ P, X, atol=1e-14)
    q = pinocchio_model.to_pin_q(model, model.q0)
    v = pinocchio_model.to_pin_v(model, model.v0)
    assert np.array_equal(pinocchio_model.from_pin_v(model, v), model.v0)
    # flexmbd's kinetic and potential energy equal Pinocchio's at the converted state
    eng = pinocchio_rigid.Rigid(model)
    T, V = dynamics.energy(model, make_data(model), model.q0, model.v0)
    assert eng.energy(q, v) == pytest.approx(T + V, rel=1e-12, abs=1e-12)


def test_pinocchio_accelerations_with_loads_match_flexmbd(tree):
    """External forces converted to Pinocchio's joint frames give flexmbd's accelerations."""
    model = from_case(pinocchio_rigid.rigid_case(tree))
    eng = pinocchio_rigid.Rigid(model)
    q = pinocchio_model.to_pin_q(model, model.q0)
    v = pinocchio_model.to_pin_v(model, model.v0)
    a, _, _ = eng.qdd(0.0, q, v)
    ref = forward_dynamics(model, make_data(model), model.q0, model.v0)
    assert np.allclose(pinocchio_model.from_pin_v(model, a), ref, rtol=1e-10, atol=1e-10)


def test_pinocchio_prescribed_spin_up_follows_its_profile():
    case = cases.load("pendulum", ['joints.pivot.motion={type="spin_up", W=2.0, T=0.2}'])
    r = solvers.run(case, "pinocchio", 0.3)
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
    eng = pinocchio_rigid.Rigid(from_case(case))
    q, v = np.array([0.2, -0.7]), np.array([0.4, 1.1])
    a, q, v = eng.qdd(0.13, q, v)
    tau = pin.rnea(eng.pm, eng.pd, q, v, a)
    assert abs(tau[1]) < 1e-12 and abs(tau[0]) > 1e-3
    assert a[0] == pytest.approx(-0.3 * (3 * np.pi) ** 2 * np.sin(3 * np.pi * 0.13), rel=1e-12)


# ---------------------------------------------------------------------------------------------
# mujoco (rigid)


def test_mujoco_round_trip_of_state_and_body_poses(tree):
    """flexmbd (q, v) -> MuJoCo -> flexmbd is the identity; MuJoCo's body poses (w-first
    quaternions) and energies equal flexmbd's forward kinematics."""
    model = from_case(pinocchio_rigid.rigid_case(tree))
    m = mujoco.MjModel.from_xml_string(mujoco_rigid.mjcf(model, 1e-4))
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = mujoco_rigid.to_mj_state(model, m, model.q0, model.v0)
    q, v = mujoco_rigid.from_mj_state(model, m, d.qpos, d.qvel)
    assert np.allclose(q, model.q0, atol=1e-14) and np.allclose(v, model.v0, atol=1e-14)
    mujoco.mj_forward(m, d)
    data = make_data(model)
    T, V = dynamics.energy(model, data, model.q0, model.v0)
    for i in range(1, model.nb + 1):
        R, p = dynamics.body_pose(data, i)
        b = m.body(f"b{i}").id
        assert np.allclose(d.xpos[b], p, atol=1e-13)
        assert np.allclose(mujoco_common.quat_to_rot(d.xquat[b]), R, atol=1e-13)
    assert d.energy.sum() == pytest.approx(T + V, rel=1e-12)


def test_mujoco_accelerations_with_loads_match_flexmbd(tree):
    model = from_case(pinocchio_rigid.rigid_case(tree))
    m = mujoco.MjModel.from_xml_string(mujoco_rigid.mjcf(model, 1e-4))
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = mujoco_rigid.to_mj_state(model, m, model.q0, model.v0)
    mujoco_rigid.apply_loads(model, m, d)
    mujoco.mj_forward(m, d)
    ref = forward_dynamics(model, make_data(model), model.q0, model.v0)
    # MuJoCo's free-joint acceleration is [dv_world/dt; dw/dt]: compare the other joints
    k = model.jnt_vadr[model.index("arm")]
    assert np.allclose(d.qacc[6:], ref[k:], rtol=1e-9, atol=1e-9)


# ---------------------------------------------------------------------------------------------
# the rigid peers against each other and against flexmbd


@pytest.mark.parametrize("name", ["pendulum", "double_pendulum"])
def test_rigid_peers_agree_with_flexmbd_on_beams_declared_rigid(name):
    case = rigid(name)
    runs = {s: solvers.run(case, s) for s in ("flexmbd", "pinocchio", "mujoco")}
    assert all(r.ok for r in runs.values()), {s: r.status for s, r in runs.items()}
    angles = [c for c in case["channels"] if c.startswith("joint_angle")]
    for ch in angles:
        end = {s: r.channels[ch][-1] for s, r in runs.items()}
        assert abs(end["pinocchio"] - end["mujoco"]) < 1e-7, (ch, end)
        assert abs(end["pinocchio"] - end["flexmbd"]) < 1e-7, (ch, end)
        assert abs(end["mujoco"] - end["flexmbd"]) < 1e-7, (ch, end)
    e = runs["pinocchio"].channels["energy"]
    assert np.abs(e - runs["flexmbd"].channels["energy"]).max() < 1e-8
    assert np.abs(e - runs["mujoco"].channels["energy"]).max() < 1e-8


def test_rigid_peers_run_the_flexible_case_as_its_rigid_limit():
    a = solvers.run(cases.load("pendulum"), "pinocchio", 0.5)
    b = solvers.run(rigid("pendulum"), "pinocchio", 0.5)
    assert a.ok and np.array_equal(a.channels["joint_angle"], b.channels["joint_angle"])
    assert np.all(a.channels["tip_deflection"] == 0.0) and np.all(a.channels["stress_vm"] == 0.0)


def test_missing_engine_is_unavailable(monkeypatch):
    monkeypatch.setitem(solvers.MODULES, "mujoco", "flexmbd.adapters.no_such_engine")
    assert solvers.status_for(cases.load("pendulum"), "mujoco").startswith("unavailable")


def test_engine_error_is_a_failed_result(monkeypatch):
    monkeypatch.setattr(mujoco_rod, "mjcf", lambda *a: ("<mujoco><worldbody><body/></mujoco>", 0.0))
    r = solvers.run(cases.load("cantilever_step"), "mujoco-rod", 0.01)
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
    r = solvers.run(case, "mujoco-rod", 3.0)
    assert r.ok
    EB = 12.0 * 1.5 ** 3 / (3 * 2.06e11 * 0.01 * 0.015 ** 3 / 12)
    y = r.channels["tip_deflection"]
    assert abs(y[-1] - y[-11]) < 1e-6                               # settled
    assert abs(-y[-1] / EB - 1.0) < 0.005, (y[-1], EB)
    sigma = 12.0 * (1.5 - 0.03) * 0.0075 / (0.01 * 0.015 ** 3 / 12)
    assert abs(r.channels["stress_vm"][-1] / sigma - 1.0) < 0.01


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
    a, b = solvers.run(case, "flexmbd"), solvers.run(case, "mujoco-rod")
    assert a.ok and b.ok
    x, y = a.channels["tip_deflection"], b.channels["tip_deflection"]
    fa, fb = first_frequency(a.t, x), first_frequency(b.t, y)
    assert abs(fb / fa - 1.0) < 0.01, (fa, fb)
    EB = 12.0 * 1.5 ** 3 / (3 * 2.06e11 * 0.01 * 0.015 ** 3 / 12)
    assert abs(-y.mean() / EB - 1.0) < 0.02, (y.mean(), EB)
    assert np.sqrt(np.mean((x - y) ** 2)) < 0.10 * np.abs(x).max()
