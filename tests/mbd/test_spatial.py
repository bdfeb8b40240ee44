"""Spatial algebra against definitions: transforms, cross operators, exponential map and its rates."""

import numpy as np
import pytest
from scipy.linalg import expm

from flexmbd.mbd import spatial as sp
from oracles import crf, crm

pytestmark = pytest.mark.kernel_free


def random_X(rng):
    E = expm(sp.skew(rng.normal(size=3)))
    return sp.plux(E, rng.normal(size=3))


def test_plux_composes_rotation_and_translation():
    rng = np.random.default_rng(0)
    E, r = expm(sp.skew(rng.normal(size=3))), rng.normal(size=3)
    assert np.allclose(sp.plux(E, r), sp.xrot(E) @ sp.xlt(r))
    X = sp.plux(E, r)
    assert np.allclose(sp.inv(X) @ X, np.eye(6))


def test_force_transform_preserves_power():
    rng = np.random.default_rng(1)
    X = random_X(rng)
    v, f = rng.normal(size=6), rng.normal(size=6)
    assert (X @ v) @ (sp.force_transform(X) @ f) == pytest.approx(v @ f)


def test_cross_operators():
    """cross_motion, cross_force and their in-place forms against the block matrices v x, v x*;
    v x is the rate -dX/dt X^-1 of a frame moving with velocity v, and v x* its dual."""
    rng = np.random.default_rng(2)
    v, m, f = rng.normal(size=6), rng.normal(size=6), rng.normal(size=6)
    out = np.empty(6)
    assert np.allclose(sp.cross_motion(v, m), crm(v) @ m)
    assert np.allclose(sp.cross_force(v, f), crf(v) @ f)
    sp.cross_motion_into(v, m, out)
    assert np.allclose(out, crm(v) @ m)
    sp.cross_force_into(v, f, out)
    assert np.allclose(out, crf(v) @ f)
    assert np.allclose(crf(v), -crm(v).T)
    w, u = rng.normal(size=3), rng.normal(size=3)
    h = 1e-6
    Xh = sp.plux(expm(sp.skew(w * h)).T, u * h)        # frame moving with velocity [w; u]
    assert np.allclose((Xh - np.eye(6)) / h, -crm(np.r_[w, u]), atol=1e-5)


def test_spatial_inertia_is_the_kinetic_energy_of_the_body():
    rng = np.random.default_rng(3)
    m, c = 2.5, rng.normal(size=3)
    A = rng.normal(size=(3, 3))
    Ic = A @ A.T
    I = sp.inertia(m, c, Ic)
    v = rng.normal(size=6)
    w, u = v[:3], v[3:]
    vc = u + np.cross(w, c)
    assert 0.5 * v @ I @ v == pytest.approx(0.5 * m * vc @ vc + 0.5 * w @ Ic @ w)


@pytest.mark.parametrize("scale", [0.0, 1e-9, 1e-3, 0.5, 2.5])
def test_exponential_map_and_its_jacobian(scale):
    rng = np.random.default_rng(4)
    th = rng.normal(size=3)
    th = th / np.linalg.norm(th) * scale if scale else np.zeros(3)
    thd, thdd = rng.normal(size=3), rng.normal(size=3)
    assert np.allclose(sp.expm_so3(th), expm(sp.skew(th)), atol=1e-15)
    # (J th_d)~ = dR/dt R^T, by central differences of R(th + t th_d)
    h = 1e-6
    dR = (expm(sp.skew(th + h * thd)) - expm(sp.skew(th - h * thd))) / (2 * h)
    W = dR @ expm(sp.skew(th)).T
    assert np.allclose(sp.jac_left_so3(th) @ thd, [W[2, 1], W[0, 2], W[1, 0]], atol=1e-8)
    # J'(th) th_d = d/dt (J(th(t))) th_d along th(t) = th + t th_d
    Jd = (sp.jac_left_so3(th + h * thd) - sp.jac_left_so3(th - h * thd)) / (2 * h)
    assert np.allclose(sp.jac_left_so3_dot(th, thd), Jd @ thd, atol=1e-7)


def test_quaternions():
    rng = np.random.default_rng(5)
    r = rng.normal(size=3)
    q = sp.rotvec_to_quat(r)
    assert np.allclose(sp.quat_to_rot(q), expm(sp.skew(r)))
    w = rng.normal(size=3)                              # body-frame angular velocity
    h = 1e-6
    R1 = sp.quat_to_rot(q + h * sp.quat_rate(q, w))
    R0 = sp.quat_to_rot(q - h * sp.quat_rate(q, w))
    W = sp.quat_to_rot(q).T @ (R1 - R0) / (2 * h)
    assert np.allclose([W[2, 1], W[0, 2], W[1, 0]], w, atol=1e-7)


def test_parts_invert_plux_and_inertia():
    rng = np.random.default_rng(6)
    E, r = expm(sp.skew(rng.normal(size=3))), rng.normal(size=3)
    r2, R = sp.plux_parts(sp.plux(E, r))
    assert np.allclose(r2, r) and np.allclose(R, E.T)
    A = rng.normal(size=(3, 3))
    m, c, Ic = sp.inertia_parts(sp.inertia(1.7, np.array([0.1, -0.2, 0.3]), A @ A.T))
    assert m == pytest.approx(1.7) and np.allclose(c, [0.1, -0.2, 0.3]) and np.allclose(Ic, A @ A.T)
