"""Self-checks of the independent Lagrangian oracle (tests/oracle_lagrange.py).

The oracle is checked against a closed-form pendulum, Pinocchio's ABA on a
rigid tree, energy conservation / power balance of flexible trees, the
linear modal equations, and scipy's matrix exponential.
"""

import os
import sys

import numpy as np
import pytest
import scipy.linalg
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import oracle_lagrange as ol  # noqa: E402

pytestmark = pytest.mark.kernel_free


# ----------------------------------------------------------------------------
# random model builders
# ----------------------------------------------------------------------------

def random_rotation(rng):
    return Rotation.random(random_state=rng).as_matrix()


def random_unit(rng):
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def random_inertia(rng, size=1.0):
    """Physically valid inertia (triangle inequality) in random axes."""
    a, b, c = rng.uniform(0.2, 1.0, size=3) * size
    R = random_rotation(rng)
    return R @ np.diag([b + c, a + c, a + b]) @ R.T


def random_rigid(rng):
    return {"mass": rng.uniform(0.5, 3.0), "com": rng.normal(scale=0.4, size=3),
            "inertia": random_inertia(rng, 0.2)}


def random_flex(rng, n_nodes=8, nm=3, omega_range=(6.0, 20.0)):
    """Random flexible body: nodes along a 1 m beam, random modes, Km chosen
    so that the linear modal frequencies lie roughly in omega_range."""
    x0 = np.zeros((n_nodes, 3))
    x0[:, 0] = np.linspace(0.1, 1.0, n_nodes)
    x0[:, 1:] = rng.normal(scale=0.05, size=(n_nodes, 2))
    m = rng.uniform(0.2, 1.0, size=n_nodes)
    J = np.array([random_inertia(rng, 0.01) for _ in range(n_nodes)])
    Phi = rng.normal(scale=0.4, size=(n_nodes, 6, nm))
    Mmm = modal_mass(J, m, Phi)
    # Km = Mmm^(1/2) U diag(w^2) U^T Mmm^(1/2): SPD with prescribed frequencies
    L = np.linalg.cholesky(Mmm)
    U = random_rotation(rng)[:nm, :nm] if nm == 3 else np.linalg.qr(rng.normal(size=(nm, nm)))[0]
    w = rng.uniform(*omega_range, size=nm)
    Km = L @ U @ np.diag(w**2) @ U.T @ L.T
    Km = 0.5 * (Km + Km.T)
    A = rng.normal(size=(nm, nm))
    Cm = 0.05 * (A @ A.T)
    return {"x0": x0, "m": m, "J": J, "Phi": Phi, "Km": Km, "Cm": Cm}


def modal_mass(J, m, Phi):
    """M_mm = sum_p Phi_p^T diag(J_p, m_p I) Phi_p."""
    Mmm = 0.0
    for Jp, mp, Pp in zip(J, m, Phi):
        D = np.zeros((6, 6))
        D[:3, :3] = Jp
        D[3:, 3:] = mp * np.eye(3)
        Mmm = Mmm + Pp.T @ D @ Pp
    return Mmm


def body(rng, parent, joint, node=None, flex=None):
    b = {"parent": parent, "joint": joint, "axis": random_unit(rng), "node": node,
         "triad_pos": rng.normal(scale=0.5, size=3), "triad_rot": random_rotation(rng)}
    if flex is not None:
        b["flex"] = flex
    else:
        b["rigid"] = random_rigid(rng)
    return b


def undamped(tree):
    for b in tree["bodies"]:
        if "flex" in b:
            b["flex"]["Cm"] = np.zeros_like(b["flex"]["Cm"])
    return tree


def random_state(rng, tree, q_scale=1.0, eta_scale=0.05, qd_scale=1.0, etad_scale=0.3):
    _, n = ol.coordinate_layout(tree)
    mod = ol.modal_indices(tree)
    q = rng.uniform(-q_scale, q_scale, size=n)
    qd = rng.uniform(-qd_scale, qd_scale, size=n)
    q[mod] = rng.normal(scale=eta_scale, size=len(mod))
    qd[mod] = rng.normal(scale=etad_scale, size=len(mod))
    return q, qd


# ----------------------------------------------------------------------------
# 1. closed-form pendulum
# ----------------------------------------------------------------------------

def test_rigid_pendulum_closed_form():
    m, l, g, Izz = 2.0, 0.7, 9.81, 0.3
    tree = {"gravity": (0.0, -g, 0.0), "bodies": [{
        "parent": -1, "joint": "revolute", "axis": (0.0, 0.0, 1.0), "node": None,
        "triad_pos": np.zeros(3), "triad_rot": np.eye(3),
        "rigid": {"mass": m, "com": (l, 0.0, 0.0), "inertia": np.diag([0.1, 0.2, Izz])}}]}
    for q0, qd0, tau in [(0.4, 1.3, 0.5), (-2.0, -3.0, 0.0), (1.2, 0.0, -4.0)]:
        q, qd = np.array([q0]), np.array([qd0])
        qdd = ol.accelerations(tree, q, qd, np.array([tau]))[0]
        exact = (tau - m * g * l * np.cos(q0)) / (Izz + m * l**2)
        assert abs(qdd - exact) <= 1e-10 * abs(exact)
        # energies and kinematics
        assert ol.kinetic_energy(tree, q, qd) == pytest.approx(0.5 * (Izz + m * l**2) * qd0**2, rel=1e-14)
        assert ol.potential_energy(tree, q) == pytest.approx(m * g * l * np.sin(q0), rel=1e-13)
        R, p = ol.forward_kinematics(tree, q)[0]
        assert np.allclose(R, Rotation.from_rotvec([0, 0, q0]).as_matrix(), atol=1e-15)
        assert np.allclose(p, 0.0)


# ----------------------------------------------------------------------------
# 2. rigid tree against Pinocchio ABA
# ----------------------------------------------------------------------------

def pinocchio_model(tree):
    """Pinocchio model of a rigid tree; fixed bodies are merged into the
    joint that carries their parent."""
    pin = pytest.importorskip("pinocchio")
    model = pin.Model()
    model.gravity = pin.Motion(np.asarray(tree["gravity"], float), np.zeros(3))
    joint_of, frame_in_joint = [], []   # per body: joint id, body frame in joint frame
    for i, b in enumerate(tree["bodies"]):
        assert b.get("node") is None and "rigid" in b
        if b["parent"] == -1:
            pj, pM = 0, pin.SE3.Identity()
        else:
            pj, pM = joint_of[b["parent"]], frame_in_joint[b["parent"]]
        triad = pM * pin.SE3(np.asarray(b["triad_rot"], float), np.asarray(b["triad_pos"], float))
        axis = np.asarray(b["axis"], float)
        if b["joint"] == "fixed":
            jid, M = pj, triad
        else:
            jm = (pin.JointModelRevoluteUnaligned(axis) if b["joint"] == "revolute"
                  else pin.JointModelPrismaticUnaligned(axis))
            jid, M = model.addJoint(pj, jm, triad, "joint%d" % i), pin.SE3.Identity()
        r = b["rigid"]
        inertia = pin.Inertia(float(r["mass"]), np.asarray(r["com"], float),
                              np.asarray(r["inertia"], float))
        model.appendBodyToJoint(jid, inertia, M)
        joint_of.append(jid)
        frame_in_joint.append(M)
    return model


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_rigid_tree_against_pinocchio(seed):
    pin = pytest.importorskip("pinocchio")
    rng = np.random.default_rng(seed)
    structure = [(-1, "revolute"), (0, "prismatic"), (1, "fixed"),
                 (0, "revolute"), (2, "revolute"), (4, "prismatic"), (2, "revolute")]
    if seed > 0:   # random parents, same joint mix
        structure = [(int(rng.integers(-1, i)), j) for i, (_, j) in enumerate(structure)]
    tree = {"gravity": rng.normal(scale=5.0, size=3),
            "bodies": [body(rng, p, j) for p, j in structure]}
    model = pinocchio_model(tree)
    data = model.createData()
    _, n = ol.coordinate_layout(tree)
    assert model.nq == n
    for _ in range(3):
        q, qd = random_state(rng, tree, q_scale=2.0, qd_scale=2.0)
        tau = rng.normal(scale=3.0, size=n)
        a_oracle = ol.accelerations(tree, q, qd, tau)
        a_pin = pin.aba(model, data, q, qd, tau)
        err = np.max(np.abs(a_oracle - a_pin)) / max(1.0, np.max(np.abs(a_pin)))
        assert err < 1e-8, err
        # mass matrix columns from RNEA (CRBA assumes depth-first joint
        # numbering, which body-order numbering of a random tree is not)
        zero = np.zeros(n)
        b = pin.rnea(model, data, q, zero, zero)
        M_pin = np.column_stack([pin.rnea(model, data, q, zero, e) - b for e in np.eye(n)])
        assert np.allclose(ol.mass_matrix(tree, q), M_pin, rtol=1e-12, atol=1e-12)


# ----------------------------------------------------------------------------
# 3. single flexible body on a revolute joint
# ----------------------------------------------------------------------------

def energy_drift(tree, q0, qd0, t_end=0.5):
    """Max |E(t) - E(0)| over a DOP853 integration, relative to a
    characteristic energy scale (|E0| + max kinetic energy)."""
    _, n = ol.coordinate_layout(tree)
    sol = solve_ivp(ol.state_derivative(tree), (0.0, t_end), np.concatenate([q0, qd0]),
                    method="DOP853", rtol=1e-11, atol=1e-12)
    assert sol.success
    E = np.array([ol.total_energy(tree, y[:n], y[n:]) for y in sol.y.T])
    T = np.array([ol.kinetic_energy(tree, y[:n], y[n:]) for y in sol.y.T])
    # the motion must be non-trivial for the check to mean something
    assert np.ptp(T) > 0.1 * np.max(T)
    return np.max(np.abs(E - E[0])) / (abs(E[0]) + np.max(T))


def single_flex_tree(rng):
    return {"gravity": np.array([0.0, -9.81, 0.0]),
            "bodies": [body(rng, -1, "revolute", flex=random_flex(rng))]}


def test_single_flex_energy_conservation():
    rng = np.random.default_rng(10)
    tree = undamped(single_flex_tree(rng))
    q0, qd0 = random_state(rng, tree, qd_scale=2.0)
    drift = energy_drift(tree, q0, qd0)
    assert drift < 1e-8, drift


def test_single_flex_locked_joint_modal_equations():
    rng = np.random.default_rng(11)
    tree = undamped(single_flex_tree(rng))
    tree["gravity"] = np.zeros(3)
    f = tree["bodies"][0]["flex"]
    Mmm = modal_mass(f["J"], f["m"], f["Phi"])
    for _ in range(3):
        q, _ = random_state(rng, tree, q_scale=3.0, eta_scale=0.2)
        qd = np.zeros_like(q)
        eta = q[1:]
        M = ol.mass_matrix(tree, q)
        rhs = ol.rhs(tree, q, qd)
        assert np.allclose(M[1:, 1:], Mmm, rtol=1e-13, atol=1e-14)
        assert np.allclose(rhs[1:], -f["Km"] @ eta, rtol=1e-12, atol=1e-12)
        # joint locked: M_mm eta_dd + Km eta = 0
        eta_dd = np.linalg.solve(M[1:, 1:], rhs[1:])
        assert np.allclose(eta_dd, -np.linalg.solve(Mmm, f["Km"] @ eta), rtol=1e-11, atol=1e-12)
        # joint free: the joint row must carry the coupling, not a zero row
        assert np.linalg.norm(M[0, 1:]) > 1e-3


# ----------------------------------------------------------------------------
# 4. flexible parent with a rigid child on one of its nodes
# ----------------------------------------------------------------------------

def flex_parent_rigid_child_tree(rng, node=5):
    return {"gravity": np.array([0.0, 0.0, -9.81]),
            "bodies": [body(rng, -1, "revolute", flex=random_flex(rng)),
                       body(rng, 0, "revolute", node=node)]}


def test_flex_parent_rigid_child_energy_and_mass_matrix():
    rng = np.random.default_rng(20)
    tree = undamped(flex_parent_rigid_child_tree(rng))
    for _ in range(3):
        q, _ = random_state(rng, tree, q_scale=3.0, eta_scale=0.2)
        M = ol.mass_matrix(tree, q)
        assert np.array_equal(M, M.T)
        assert np.min(np.linalg.eigvalsh(M)) > 1e-6 * np.max(np.linalg.eigvalsh(M))
        np.linalg.cholesky(M)
    q0, qd0 = random_state(rng, tree, qd_scale=2.0)
    drift = energy_drift(tree, q0, qd0)
    assert drift < 1e-8, drift


def test_child_triad_follows_deformed_node_frame():
    """The child's frame is built on the deformed node frame R_b expm(skew(theta_p))."""
    rng = np.random.default_rng(21)
    node = 5
    tree = flex_parent_rigid_child_tree(rng, node)
    q, _ = random_state(rng, tree, eta_scale=0.3)
    (R0, p0), (R1, p1) = ol.forward_kinematics(tree, q)
    f, c = tree["bodies"][0]["flex"], tree["bodies"][1]
    eta = q[1:4]
    theta = f["Phi"][node, 0:3] @ eta
    Rn = R0 @ scipy.linalg.expm(ol.skew(theta))
    xn = p0 + R0 @ (f["x0"][node] + f["Phi"][node, 3:6] @ eta)
    Rt = Rn @ c["triad_rot"]
    assert np.allclose(R1, Rt @ Rotation.from_rotvec(c["axis"] * q[4]).as_matrix(), atol=1e-14)
    assert np.allclose(p1, xn + Rn @ c["triad_pos"], atol=1e-14)


# ----------------------------------------------------------------------------
# power balance on a mixed tree (damping, torques, flexible-on-flexible)
# ----------------------------------------------------------------------------

def mixed_tree(rng):
    return {"gravity": rng.normal(scale=5.0, size=3), "bodies": [
        body(rng, -1, "revolute", flex=random_flex(rng)),
        body(rng, 0, "prismatic", node=7),
        body(rng, 0, "revolute", node=3, flex=random_flex(rng, n_nodes=5, nm=2)),
        body(rng, 2, "fixed", node=4),
        body(rng, 3, "revolute"),
        body(rng, 1, "fixed", flex=random_flex(rng, n_nodes=4, nm=2)),
    ]}


def test_mixed_tree_energy_conservation():
    """Prismatic joint on a node, flexible child on a flexible parent, fixed
    joints on a node and on a rigid body."""
    rng = np.random.default_rng(32)
    tree = undamped(mixed_tree(rng))
    q0, qd0 = random_state(rng, tree, eta_scale=0.05)
    drift = energy_drift(tree, q0, qd0)
    assert drift < 1e-8, drift


def test_power_balance_mixed_tree():
    """dE/dt = tau . qd_joint - sum eta_dot^T Cm eta_dot at single states;
    dE/dt evaluated as a Richardson-extrapolated central difference of
    E(q + s qd, qd + s qdd)."""
    rng = np.random.default_rng(30)
    tree = mixed_tree(rng)
    layout, n = ol.coordinate_layout(tree)
    jidx = ol.joint_indices(tree)
    for _ in range(2):
        q, qd = random_state(rng, tree, eta_scale=0.1)
        tau = rng.normal(size=len(jidx))
        qdd = ol.accelerations(tree, q, qd, tau)
        power = tau @ qd[jidx]
        for b, (_, ms) in zip(tree["bodies"], layout):
            if "flex" in b:
                power -= qd[ms] @ b["flex"]["Cm"] @ qd[ms]
        h = 1e-3
        E = [ol.total_energy(tree, q + s * h * qd, qd + s * h * qdd) for s in ol._OFFSETS]
        dEdt = ol._richardson(np.array(E), h)
        scale = np.sum(np.abs(qd * (ol.mass_matrix(tree, q) @ qdd))) + abs(power)
        assert abs(dEdt - power) < 1e-9 * scale, (dEdt, power)


def test_derivative_terms_step_independent():
    """dT/dq and Mdot qd barely change when the finite-difference step is
    halved (they are Richardson-extrapolated), and Mdot qd agrees with the
    polarization identity qd^T Mdot qd = 2 dT/dq . qd."""
    rng = np.random.default_rng(31)
    tree = mixed_tree(rng)
    q, qd = random_state(rng, tree, eta_scale=0.1)
    g1, g2 = ol.kinetic_gradient(tree, q, qd), ol.kinetic_gradient(tree, q, qd, h=5e-3)
    m1, m2 = ol.mdot_qd(tree, q, qd), ol.mdot_qd(tree, q, qd, h=5e-3)
    assert np.max(np.abs(g1 - g2)) < 1e-11 * np.max(np.abs(g1))
    assert np.max(np.abs(m1 - m2)) < 1e-11 * np.max(np.abs(m1))
    assert qd @ m1 == pytest.approx(2 * g1 @ qd, rel=1e-11)
    # mass matrix is the Hessian of T in qd (polarization of kinetic_energy)
    M = ol.mass_matrix(tree, q)
    u, v = rng.normal(size=q.size), rng.normal(size=q.size)
    T = lambda x: ol.kinetic_energy(tree, q, x)  # noqa: E731
    assert u @ M @ v == pytest.approx(T(u + v) - T(u) - T(v), rel=1e-12, abs=1e-12)


# ----------------------------------------------------------------------------
# 5. Rodrigues formula
# ----------------------------------------------------------------------------

def test_expm_skew_matches_scipy():
    rng = np.random.default_rng(40)
    thetas = [np.zeros(3), 1e-9 * random_unit(rng), 1e-5 * random_unit(rng),
              0.09 * random_unit(rng), 0.11 * random_unit(rng), 0.1 * random_unit(rng)]
    thetas += [rng.normal(scale=s, size=3) for s in (0.01, 0.3, 1.0, 2.0)]
    for th in thetas:
        R = ol.expm_skew(th)
        assert np.max(np.abs(R - scipy.linalg.expm(ol.skew(th)))) < 1e-14
    # batched call and complex-step derivative (d/ds expm(skew(s a)) = skew(a) at s = 0)
    batch = np.array(thetas)
    assert np.allclose(ol.expm_skew(batch), [scipy.linalg.expm(ol.skew(t)) for t in thetas],
                       rtol=0, atol=1e-14)
    a = rng.normal(size=3)
    for th in (np.zeros(3), 0.7 * random_unit(rng)):
        dR = ol.expm_skew(th + 1e-20j * a).imag / 1e-20
        fd = (scipy.linalg.expm(ol.skew(th + 1e-6 * a)) - scipy.linalg.expm(ol.skew(th - 1e-6 * a))) / 2e-6
        assert np.allclose(dR, fd, atol=1e-9)
