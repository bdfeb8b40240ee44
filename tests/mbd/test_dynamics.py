"""The recursion against Pinocchio (rigid trees) and the Lagrangian oracle (flexible trees)."""

import numpy as np
import pinocchio as pin
import pytest

from flexmbd.mbd import joints, spatial
from flexmbd.solvers.build import from_case
from flexmbd.mbd.compiled import entry
from flexmbd.mbd.compiled.entry import forward_dynamics
from flexmbd.mbd.model import make_data
from flexmbd.solvers import pinocchio_model
from trees import random_case, random_state

ALL_JOINTS = ["revolute", "prismatic", "fixed", "spherical", "free"]


@pytest.mark.parametrize("seed", range(4))
def test_rigid_tree_matches_pinocchio_aba(seed):
    rng = np.random.default_rng(seed)
    case = random_case(rng, 12, ALL_JOINTS)
    model = from_case(case)
    data = make_data(model)
    pm, _ = pinocchio_model.build(model)
    pd = pm.createData()
    for _ in range(3):
        q, v = random_state(rng, model)
        tau = rng.normal(size=model.nv)
        qdd = forward_dynamics(model, data, q, v, tau)
        ref = pin.aba(pm, pd, pinocchio_model.to_pin_q(model, q), pinocchio_model.to_pin_v(model, v),
                      pinocchio_model.to_pin_v(model, tau))
        ref = pinocchio_model.from_pin_v(model, ref)
        assert np.abs(qdd - ref).max() <= 1e-9 * np.abs(ref).max(), np.abs(qdd - ref).max()


def test_pinocchio_conventions_roundtrip():
    rng = np.random.default_rng(7)
    model = from_case(random_case(rng, 6, ALL_JOINTS))
    v = rng.normal(size=model.nv)
    assert np.array_equal(pinocchio_model.from_pin_v(model, pinocchio_model.to_pin_v(model, v)), v)
    pm, _ = pinocchio_model.build(model)
    assert pm.nq == model.nq and pm.nv == model.nv


# ---------------------------------------------------------------------------------------------
# flexible trees against the independent point-mass Lagrangian oracle

import oracle_lagrange as ol  # noqa: E402


def oracle_tree(model):
    """The oracle's plain description of a flexmbd Model (constants only, no flexmbd algorithms)."""
    bodies = []
    for i in range(1, model.nb + 1):
        pos, rot = spatial.plux_parts(model.jnt_Xtriad[i])
        jt = {joints.REVOLUTE: "revolute", joints.PRISMATIC: "prismatic", joints.FIXED: "fixed"}[int(model.jnt_type[i])]
        b = {"parent": int(model.parent[i]) - 1, "joint": jt, "axis": model.jnt_axis[i],
             "node": None if model.jnt_node[i] < 0 else int(model.jnt_node[i]),
             "triad_pos": pos, "triad_rot": rot}
        if model.body_nm[i] == 0:
            m, c, I_c = spatial.inertia_parts(model.body_inertia[i])
            b["rigid"] = {"mass": m, "com": c, "inertia": I_c}
        else:
            fb = model.bodies[model.names[i]]
            b["flex"] = {"x0": fb.x0, "m": fb.m, "J": fb.J, "Phi": fb.Phi, "Km": fb.Km, "Cm": fb.Cm}
        bodies.append(b)
    return {"gravity": np.asarray(model.gravity), "bodies": bodies}


@pytest.mark.parametrize("seed", range(6))
def test_flexible_tree_matches_lagrangian_oracle(seed):
    rng = np.random.default_rng(100 + seed)
    case = random_case(rng, 6, ["revolute", "prismatic", "fixed"], flexible=0.5)
    model = from_case(case)
    data = make_data(model)
    tree = oracle_tree(model)
    q, v = random_state(rng, model, scale_eta=0.2)
    tau = rng.normal(size=model.nv)
    for i in range(1, model.nb + 1):               # torques on joints only; modes are unforced
        a, n = model.body_madr[i], model.body_nm[i]
        tau[a:a + n] = 0.0
    qdd = forward_dynamics(model, data, q, v, tau)
    ref = ol.accelerations(tree, q, v, tau)
    assert np.abs(qdd - ref).max() <= 1e-6 * np.abs(ref).max(), (np.abs(qdd - ref).max(), np.abs(ref).max())


@pytest.mark.parametrize("seed", range(3))
def test_system_mass_matrix_matches_the_oracle(seed):
    """entry.mass_matrix_system (polarization of flexmbd's kinetic energy) against the oracle's
    mass matrix, formed from its own node velocities."""
    from flexmbd.mbd import dynamics
    rng = np.random.default_rng(200 + seed)
    model = from_case(random_case(rng, 5, ["revolute", "prismatic", "fixed"], flexible=0.6))
    q, _ = random_state(rng, model, scale_eta=0.2)
    M = entry.mass_matrix_system(model, make_data(model), q)
    ref = ol.mass_matrix(oracle_tree(model), q)
    assert np.abs(M - ref).max() <= 1e-9 * np.abs(ref).max()
    assert dynamics.free_velocities(model).size == model.nv


@pytest.mark.parametrize("seed", range(2))
def test_joint_reactions_match_pinocchio_rnea(seed):
    rng = np.random.default_rng(50 + seed)
    case = random_case(rng, 8, ["revolute", "prismatic", "spherical", "free"])
    model = from_case(case)
    data = make_data(model)
    pm, jid = pinocchio_model.build(model)
    pd = pm.createData()
    q, v = random_state(rng, model)
    qdd = forward_dynamics(model, data, q, v, rng.normal(size=model.nv))
    pin.rnea(pm, pd, pinocchio_model.to_pin_q(model, q), pinocchio_model.to_pin_v(model, v),
             pinocchio_model.to_pin_v(model, qdd))
    for i in range(1, model.nb + 1):
        ref = pd.f[jid[i]]
        mine = data.f[i]
        assert np.allclose(mine[3:], ref.linear, atol=1e-9 * (1 + np.abs(ref.linear).max()))
        assert np.allclose(mine[:3], ref.angular, atol=1e-9 * (1 + np.abs(ref.angular).max()))


def test_flexible_reactions_project_to_joint_forces():
    rng = np.random.default_rng(60)
    model = from_case(random_case(rng, 5, ["revolute", "prismatic"], flexible=0.6))
    data = make_data(model)
    q, v = random_state(rng, model, scale_eta=0.1)
    tau = rng.normal(size=model.nv)
    forward_dynamics(model, data, q, v, tau)
    for i in range(1, model.nb + 1):
        k = model.jnt_vadr[i]
        # S^T f = tau is a cancellation of forces of size |f| (elastic forces reach 1e6 N here)
        assert abs(data.S[i, :, 0] @ data.f[i] - tau[k]) <= 1e-12 * np.abs(data.f[i]).max()


def inverse_mass_check(model, q, v, tau, t=0.0):
    """(response, M_ff^-1 tau_f on the free coordinates, zero on the prescribed ones): the entry's
    RESPONSE after an evaluation at (t, q, v), and the solve with the system mass matrix
    (`entry.mass_matrix_system`: polarization of the kinetic energy)."""
    from flexmbd.mbd import dynamics
    from flexmbd.mbd.compiled import bound
    b = bound.bind(model, make_data(model))            # kept alive here: the entry reaches it by address
    k = entry.handle(b)
    entry.call(k, t, q, v, np.zeros(model.nv), np.empty(model.nq + model.nv), entry.RATES)
    got = np.empty(model.nv)
    entry.call(k, t, q, v, tau, got, entry.RESPONSE)
    free = dynamics.free_velocities(model)
    M = entry.mass_matrix_system(model, make_data(model), q)
    ref = np.zeros(model.nv)
    ref[free] = np.linalg.solve(M[np.ix_(free, free)], tau[free])
    return got, ref, np.linalg.cond(M[np.ix_(free, free)])


@pytest.mark.parametrize("seed", range(3))
def test_response_is_the_inverse_mass_matrix(seed):
    """dynamics.response (the entry's RESPONSE) is M^-1 tau at the evaluated state: against the
    polarized mass matrix's solve, to 1e-12 x its condition number of the largest entry (the
    polarization's and the solve's round-off; measured 1.3e-15 at condition numbers 9 to 3e3)."""
    rng = np.random.default_rng(300 + seed)
    model = from_case(random_case(rng, 5, ["revolute", "prismatic", "fixed"], flexible=0.6))
    q, v = random_state(rng, model, scale_eta=0.2)
    got, ref, cond = inverse_mass_check(model, q, v, rng.normal(size=model.nv))
    assert np.abs(got - ref).max() <= 1e-12 * cond * np.abs(ref).max(), (np.abs(got - ref).max(), cond)


def test_response_leaves_a_prescribed_joint_at_rest():
    """On the slider-crank's tree (the crank driven): the crank's entry of the response is 0, the
    free ones M_ff^-1 tau_f (tolerance as above; measured 3e-17 at condition number 50)."""
    from flexmbd import cases
    from flexmbd.fe import flexbody
    case = cases.load("slider_crank").modelled
    model = from_case(case, flexbody.for_case(case))
    rng = np.random.default_rng(5)
    q = model.q0 + np.r_[0.0, 0.1 * rng.normal(size=model.nq - 1)]     # the crank on its profile at t = 0
    got, ref, cond = inverse_mass_check(model, q, rng.normal(size=model.nv), rng.normal(size=model.nv))
    crank = model.jnt_vadr[model.index("crank")]
    assert got[crank] == 0.0
    assert np.abs(got - ref).max() <= 1e-12 * cond * np.abs(ref).max(), (np.abs(got - ref).max(), cond)
