"""Channels measured geometrically from the deformed nodes; joint reactions from the momentum."""

import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from flexmbd import cases, flexbody, outputs
from flexmbd.build import from_case
from flexmbd.kernel.entry import forward_dynamics
from flexmbd.model import make_data


def moving_body(boundary, seed):
    """A 10-element beam whose 4 random modes move every node, node 0 included, by decimetres and
    tenths of a radian at unit amplitude (ends kept in the x-y plane for hinged-hinged)."""
    case = cases.load("cantilever_step", ["bodies.beam.elements=10", "bodies.beam.modes.count=4"])
    fb = flexbody.for_case(case)["beam"]
    Phi = np.random.default_rng(seed).normal(size=fb.Phi.shape) * 0.1
    if boundary == "hinged-hinged":
        Phi[[0, -1], 5] = 0.0
    return dataclasses.replace(fb, Phi=Phi, boundary=boundary)


def with_rigid_motion(fb, eta, Q, d):
    """(body, eta) with one more mode, at amplitude 1, carrying every node from its place at eta
    through rotation Q and translation d (node 0's rotation vector becomes that of Q R_0)."""
    r = fb.x0 + fb.Phi[:, 3:] @ eta
    theta0 = fb.Phi[0, :3] @ eta
    col = np.zeros((fb.n_nodes, 6, 1))
    col[:, 3:, 0] = r @ Q.T + d - r
    col[0, :3, 0] = Rotation.from_matrix(Q @ Rotation.from_rotvec(theta0).as_matrix()).as_rotvec() - theta0
    return dataclasses.replace(fb, Phi=np.concatenate([fb.Phi, col], axis=2)), np.r_[eta, 1.0]


def test_deflection_is_measured_in_the_deformed_root_node_frame():
    """Deflection against r_p - r_0 in node 0's rotated frame (scipy), and its rigid-motion invariance."""
    fb = moving_body("clamped-free", 0)
    eta = np.random.default_rng(1).normal(size=fb.n_modes)
    r = fb.x0 + fb.Phi[:, 3:] @ eta
    R0 = Rotation.from_rotvec(fb.Phi[0, :3] @ eta).as_matrix()
    assert np.linalg.norm(fb.Phi[0, :3] @ eta) > 0.1 and np.abs(r[0]).max() > 0.05
    Q, d = Rotation.from_rotvec([0.4, -0.7, 0.2]).as_matrix(), np.array([0.3, -1.0, 2.0])
    moved, eta_moved = with_rigid_motion(fb, eta, Q, d)
    rigid, eta_rigid = with_rigid_motion(fb, np.zeros(fb.n_modes), Q, d)
    for p in (3, 7, 10):
        for axis in range(3):
            ref = R0[:, axis] @ (r[p] - r[0]) - (fb.x0[p] - fb.x0[0])[axis]
            assert outputs.deflection(fb, p, axis, eta) == pytest.approx(ref, rel=1e-12, abs=1e-15)
            assert outputs.deflection(moved, p, axis, eta_moved) == pytest.approx(ref, rel=1e-10, abs=1e-13)
            assert abs(outputs.deflection(rigid, p, axis, eta_rigid)) <= 1e-13


def test_hinged_hinged_deflection_is_measured_from_the_chord():
    """Deflection against r_p - r_0 along a planar chord's axes, and its invariance under in-plane motions."""
    fb = moving_body("hinged-hinged", 2)
    eta = np.random.default_rng(3).normal(size=fb.n_modes)
    r = fb.x0 + fb.Phi[:, 3:] @ eta
    e = (r[-1] - r[0]) / np.linalg.norm(r[-1] - r[0])
    assert abs(np.arctan2(e[1], e[0])) > 0.05
    axes = np.array([e, [-e[1], e[0], 0.0], [0.0, 0.0, 1.0]])
    Q, d = Rotation.from_rotvec([0.0, 0.0, 0.6]).as_matrix(), np.array([0.3, -1.0, 2.0])
    moved, eta_moved = with_rigid_motion(fb, eta, Q, d)
    rigid, eta_rigid = with_rigid_motion(fb, np.zeros(fb.n_modes), Q, d)
    for p in (3, 7):
        for axis in range(3):
            ref = axes[axis] @ (r[p] - r[0]) - (fb.x0[p] - fb.x0[0])[axis]
            assert outputs.deflection(fb, p, axis, eta) == pytest.approx(ref, rel=1e-12, abs=1e-15)
            assert outputs.deflection(moved, p, axis, eta_moved) == pytest.approx(ref, rel=1e-10, abs=1e-13)
            assert abs(outputs.deflection(rigid, p, axis, eta_rigid)) <= 1e-13


def test_chord_frame_turns_x_onto_the_chord():
    e = np.array([0.6, 0.8, 0.0])
    R = outputs.chord_frame(e)
    assert np.allclose(R @ [1, 0, 0], e) and np.allclose(R.T @ R, np.eye(3))
    assert np.allclose(R @ [0, 0, 1], [0, 0, 1])            # a planar chord keeps z


def test_clamp_reactions_are_the_rate_of_momentum_less_the_applied_loads():
    """Clamp reactions against Newton-Euler over the nodes (node accelerations, gravity, tip load at t)."""
    case = cases.load("cantilever_step", ["gravity=[0.0, -9.81, 2.0]", 'loads.tip_force.profile={type="step", t0=0.5}'])
    m = from_case(case)
    fb, i = m.bodies["beam"], m.index("beam")
    a, n = m.body_madr[i], m.body_nm[i]
    rng = np.random.default_rng(5)
    t = np.array([0.0, 0.3, 1.1])
    Q, V = rng.normal(size=(3, m.nq)) * 1e-3, rng.normal(size=(3, m.nv)) * 1e-2
    f = outputs.reactions(m, t, Q, V)
    g, F = np.array(case["gravity"]), np.array([0.0, -12.0, 0.0]) * (t >= 0.5)[:, None]
    for k in range(3):
        eta_dd = forward_dynamics(m, make_data(m), Q[k], V[k], t=t[k])[a:a + n]
        r = fb.x0 + fb.Phi[:, 3:] @ Q[k, a:a + n]
        ma = fb.m[:, None] * (fb.Phi[:, 3:] @ eta_dd - g)                   # m_p (a_p - g)
        force = ma.sum(axis=0) - F[k]
        rotary = np.einsum("pab,pb->a", fb.J, fb.Phi[:, :3] @ eta_dd)          # J_p Phi_r,p eta_dd
        moment = np.cross(r, ma).sum(axis=0) + rotary - np.cross(r[-1], F[k])
        assert np.abs(f[k, i, 3:] - force).max() <= 1e-11 * np.abs(force).max()
        assert np.abs(f[k, i, :3] - moment).max() <= 1e-11 * np.abs(moment).max()
    assert not np.allclose(f[0], f[2])
