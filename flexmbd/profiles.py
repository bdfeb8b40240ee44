"""Time profiles of the case file: load factors and prescribed joint motion.

Every solver takes its time dependence from here, so a profile means the same thing everywhere.
"""

from __future__ import annotations

import numpy as np


def load_factor(p: dict, t):
    """Scale factor of a point load at time(s) `t` (s) for a load profile table of the case."""
    t = np.asarray(t, dtype=float)
    kind = p["type"]
    if kind == "constant":
        return np.ones_like(t)
    if kind == "step":
        return (t >= p["t0"]).astype(float)
    if kind == "ramp":
        return np.clip((t - p["t0"]) / (p["t1"] - p["t0"]), 0.0, 1.0)
    if kind == "harmonic":
        return (t >= p["t0"]) * np.sin(2.0 * np.pi * p["frequency"] * (t - p["t0"]) + p["phase"])
    raise ValueError(f"load profile {kind!r}")


def motion(p: dict, t: float, q0: float = 0.0) -> tuple[float, float, float]:
    """Prescribed joint (q, qd, qdd) at time `t` for a motion profile table; q0 is the start value.

    spin_up:  q = q0 + (W/T) (t^2/2 + (T/2pi)^2 (cos(2pi t/T) - 1))  for t < T,
              q = q0 + W (t - T/2)                                     after.
    """
    kind = p["type"]
    if kind == "constant_rate":
        return q0 + p["rate"] * t, p["rate"], 0.0
    if kind == "harmonic":
        w = 2.0 * np.pi * p["frequency"]
        a, ph = p["amplitude"], p["phase"]
        return (q0 + p["offset"] + a * np.sin(w * t + ph), a * w * np.cos(w * t + ph),
                -a * w * w * np.sin(w * t + ph))
    if kind == "spin_up":
        W, T = p["W"], p["T"]
        if t >= T:
            return q0 + W * (t - T / 2.0), W, 0.0
        k = 2.0 * np.pi / T
        q = q0 + (W / T) * (t * t / 2.0 + (np.cos(k * t) - 1.0) / (k * k))
        return q, (W / T) * (t - np.sin(k * t) / k), (W / T) * (1.0 - np.cos(k * t))
    if kind == "table":
        return _table(p["file"], t, q0)
    raise ValueError(f"motion profile {kind!r}")


_TABLES: dict = {}


def _table(path: str, t: float, q0: float):
    """Tabulated q(t) (CSV columns t, q), interpolated by a cubic spline with natural ends."""
    if path not in _TABLES:
        from scipy.interpolate import CubicSpline
        data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
        _TABLES[path] = CubicSpline(data[:, 0], data[:, 1], bc_type="natural", extrapolate=True)
    s = _TABLES[path]
    return q0 + float(s(t)), float(s(t, 1)), float(s(t, 2))
