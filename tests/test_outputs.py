"""Channels measured geometrically from the deformed nodes."""

import numpy as np
import pytest

from flexmbd import cases, flexbody, outputs


@pytest.mark.parametrize("name,body", [("cantilever_step", "beam"), ("double_pendulum", "beam1")])
def test_deflection_reduces_to_the_modal_translation(name, body):
    """Clamped root or hinged ends: the root frame / chord frame is the body frame."""
    fb = flexbody.for_case(cases.load(name))[body]
    eta = np.random.default_rng(0).normal(size=fb.n_modes) * 1e-4
    p = fb.node_at(0.75)
    for axis in (1, 2):
        assert outputs.deflection(fb, p, axis, eta) == pytest.approx(fb.Phi[p, 3 + axis] @ eta, rel=1e-9)


def test_chord_frame_turns_x_onto_the_chord():
    e = np.array([0.6, 0.8, 0.0])
    R = outputs.chord_frame(e)
    assert np.allclose(R @ [1, 0, 0], e) and np.allclose(R.T @ R, np.eye(3))
    assert np.allclose(R @ [0, 0, 1], [0, 0, 1])            # a planar chord keeps z


def test_reactions_are_each_states_joint_forces():
    """One Bound for every state gives what a fresh forward_dynamics per state leaves in data.f,
    with the load profiles at each state's time."""
    from flexmbd import dynamics, model as M
    m = M.from_case(cases.load("cantilever_step"))
    rng = np.random.default_rng(5)
    t = np.array([0.0, 0.3, 1.1])
    Q, V = rng.normal(size=(3, m.nq)) * 1e-3, rng.normal(size=(3, m.nv)) * 1e-2
    f = outputs.reactions(m, t, Q, V)
    for k in range(3):
        data = M.make_data(m)
        dynamics.forward_dynamics(m, data, Q[k], V[k], t=t[k])
        assert np.array_equal(f[k], data.f)
    assert not np.allclose(f[0], f[2])
