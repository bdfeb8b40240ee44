"""Time profiles: load factors and prescribed motion, against their definitions."""

import numpy as np
import pytest

from flexmbd.mbd import profiles

pytestmark = pytest.mark.kernel_free


def test_load_factors():
    t = np.array([0.0, 0.5, 1.0, 1.5, 3.0])
    assert profiles.load_factor({"type": "constant"}, t).tolist() == [1, 1, 1, 1, 1]
    assert profiles.load_factor({"type": "step", "t0": 1.0}, t).tolist() == [0, 0, 1, 1, 1]
    assert profiles.load_factor({"type": "ramp", "t0": 1.0, "t1": 2.0}, t).tolist() == [0, 0, 0, 0.5, 1]
    h = profiles.load_factor({"type": "harmonic", "t0": 0.0, "frequency": 0.25, "phase": 0.0}, t)
    assert h == pytest.approx(np.sin(2 * np.pi * 0.25 * t))


def test_spin_up_is_smooth_and_reaches_its_rate():
    p = {"type": "spin_up", "W": 3.0, "T": 0.4}
    q0, v0, a0 = profiles.motion(p, 0.0)
    assert (q0, v0, a0) == (0.0, 0.0, 0.0)
    for t in (0.1, 0.3, 0.4 - 1e-9, 0.4, 0.7):                # derivatives by central differences
        h = 1e-6
        qa, va, _ = profiles.motion(p, t - h)
        qb, vb, _ = profiles.motion(p, t + h)
        q, v, a = profiles.motion(p, t)
        assert (qb - qa) / (2 * h) == pytest.approx(v, abs=1e-6)
        assert (vb - va) / (2 * h) == pytest.approx(a, abs=1e-4)
    assert profiles.motion(p, 1.0) == pytest.approx((3.0 * (1.0 - 0.2), 3.0, 0.0))


def test_constant_rate_and_harmonic():
    assert profiles.motion({"type": "constant_rate", "rate": 2.0}, 1.5, q0=1.0) == (4.0, 2.0, 0.0)
    p = {"type": "harmonic", "amplitude": 0.2, "frequency": 2.0, "phase": 0.3, "offset": 0.1}
    q, v, a = profiles.motion(p, 0.7)
    w = 4 * np.pi
    assert (q, v, a) == pytest.approx((0.1 + 0.2 * np.sin(w * 0.7 + 0.3), 0.2 * w * np.cos(w * 0.7 + 0.3),
                                       -0.2 * w * w * np.sin(w * 0.7 + 0.3)))
