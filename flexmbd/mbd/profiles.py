"""Time profiles of the case file: load factors and prescribed joint motion.

Every solver takes its time dependence from here, so a profile means the same thing everywhere.
A profile table of the case is encoded once into plain numbers (a kind code, up to four
parameters and, for a motion table, the cubic spline's breakpoints and coefficients); the
compiled `load_at` and `motion_at` evaluate them, inside the solver's integrator loop as well as
from Python through `load_factor` and `motion`.
"""

from __future__ import annotations

import numpy as np

from flexmbd.mbd.compiled.jit import njit

LOAD_KINDS = {"constant": 0, "step": 1, "ramp": 2, "harmonic": 3}
MOTION_KINDS = {"constant_rate": 0, "harmonic": 1, "spin_up": 2, "table": 3}


@njit
def load_at(kind, par, t):
    """Load factor at time t (s). par: step [t0], ramp [t0, t1], harmonic [t0, frequency, phase]."""
    if kind == 1:
        return 1.0 if t >= par[0] else 0.0
    if kind == 2:
        return min(max((t - par[0]) / (par[1] - par[0]), 0.0), 1.0)
    if kind == 3:
        return np.sin(2.0 * np.pi * par[1] * (t - par[0]) + par[2]) if t >= par[0] else 0.0
    return 1.0


@njit
def motion_at(kind, par, tx, tc, t, q0):
    """Prescribed joint (q, qd, qdd) at time t (s); q0 is the start value.

    constant_rate  par [rate]:                    q = q0 + rate t
    harmonic       par [amplitude, frequency, phase, offset]: q = q0 + offset + A sin(w t + phase)
    spin_up        par [W, T]:  q = q0 + (W/T) (t^2/2 + (T/2pi)^2 (cos(2pi t/T) - 1))  for t < T,
                                q = q0 + W (t - T/2)                                     after
    table          tx (n,) breakpoints, tc (4, n-1) coefficients of the cubic pieces in (t - tx_i)
                   (scipy's CubicSpline layout), extrapolated with the end pieces
    """
    if kind == 0:
        return q0 + par[0] * t, par[0], 0.0
    if kind == 1:
        a, w, ph = par[0], 2.0 * np.pi * par[1], par[2]
        s, c = np.sin(w * t + ph), np.cos(w * t + ph)
        return q0 + par[3] + a * s, a * w * c, -a * w * w * s
    if kind == 2:
        W, T = par[0], par[1]
        if t >= T:
            return q0 + W * (t - T / 2.0), W, 0.0
        k = 2.0 * np.pi / T
        q = q0 + (W / T) * (t * t / 2.0 + (np.cos(k * t) - 1.0) / (k * k))
        return q, (W / T) * (t - np.sin(k * t) / k), (W / T) * (1.0 - np.cos(k * t))
    i = min(max(np.searchsorted(tx, t, side="right") - 1, 0), tx.size - 2)
    x = t - tx[i]
    c0, c1, c2, c3 = tc[0, i], tc[1, i], tc[2, i], tc[3, i]
    return (q0 + ((c0 * x + c1) * x + c2) * x + c3, (3.0 * c0 * x + 2.0 * c1) * x + c2,
            6.0 * c0 * x + 2.0 * c1)


def encode_load(p: dict) -> tuple[int, np.ndarray]:
    """(kind code, parameters (4,)) of a load profile table."""
    kind = p["type"]
    par = np.zeros(4)
    if kind == "step":
        par[0] = p["t0"]
    elif kind == "ramp":
        par[:2] = p["t0"], p["t1"]
    elif kind == "harmonic":
        par[:3] = p["t0"], p["frequency"], p["phase"]
    elif kind != "constant":
        raise ValueError(f"load profile {kind!r}")
    return LOAD_KINDS[kind], par


def encode_motion(p: dict) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
    """(kind code, parameters (4,), breakpoints (n,), coefficients (4, n-1)) of a motion profile;
    the breakpoints and coefficients are a table profile's natural cubic spline through (t, q)."""
    kind = p["type"]
    par, tx, tc = np.zeros(4), np.zeros(2), np.zeros((4, 1))
    if kind == "constant_rate":
        par[0] = p["rate"]
    elif kind == "harmonic":
        par[:] = p["amplitude"], p["frequency"], p["phase"], p["offset"]
    elif kind == "spin_up":
        par[:2] = p["W"], p["T"]
    elif kind == "table":
        from scipy.interpolate import CubicSpline
        data = np.loadtxt(p["file"], delimiter=",", skiprows=1, ndmin=2)
        s = CubicSpline(data[:, 0], data[:, 1], bc_type="natural")
        tx, tc = np.ascontiguousarray(s.x), np.ascontiguousarray(s.c)
    else:
        raise ValueError(f"motion profile {kind!r}")
    return MOTION_KINDS[kind], par, tx, tc


def load_factor(p: dict, t):
    """Scale factor of a point load at time(s) `t` (s) for a load profile table of the case."""
    kind, par = encode_load(p)
    t = np.asarray(t, dtype=float)
    return np.array([load_at(kind, par, x) for x in t.ravel()]).reshape(t.shape)


def motion(p: dict, t: float, q0: float = 0.0) -> tuple[float, float, float]:
    """Prescribed joint (q, qd, qdd) at time `t` for a motion profile table; q0 is the start value."""
    key = id(p)
    if key not in _ENCODED or _ENCODED[key][0] is not p:
        _ENCODED[key] = (p, encode_motion(p))
    kind, par, tx, tc = _ENCODED[key][1]
    return motion_at(kind, par, tx, tc, float(t), float(q0))


_ENCODED: dict = {}
