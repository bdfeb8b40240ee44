"""Dormand-Prince 5(4), variable step, compiled as a whole: the step loop and every right-hand
side evaluation run without returning to Python (`dopri5`), driven over chunks of output
instants from Python (`_dopri5`). On a tree closed by cut joints the right-hand side is the
constrained one and the state is projected onto the constraints at every output instant
(`constraints.constrained_rates`, `constraints.project`)."""

from __future__ import annotations

import numpy as np

from flexmbd.mbd.compiled.bound import bind
from flexmbd.mbd.compiled.entry import handle
from flexmbd.mbd.compiled.jit import njit
from flexmbd.mbd.constraints import project
from flexmbd.mbd.integrate.base import (CLOSING, NONFINITE, NOT_CLOSED, OK, TOO_SMALL, _in_chunks, failed, rates,
                                        state_code)
from flexmbd.mbd.model import make_data


# ---------------------------------------------------------------------------------------------
# Dormand-Prince 5(4), compiled: the whole step loop runs without returning to Python

_C = np.array([0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0, 1.0])
_A = np.array([
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [1 / 5, 0.0, 0.0, 0.0, 0.0, 0.0],
    [3 / 40, 9 / 40, 0.0, 0.0, 0.0, 0.0],
    [44 / 45, -56 / 15, 32 / 9, 0.0, 0.0, 0.0],
    [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0.0, 0.0],
    [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656, 0.0],
    [35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84]])
_E = np.array([71 / 57600, 0.0, -71 / 16695, 71 / 1920, -17253 / 339200, 22 / 525, -1 / 40])   # b5 - b4

LANDING = 1e-12      # a step within this (relative to the instant) of an output instant lands on it


@njit
def dopri5(ev, nq, y, t_out, Y, h, rtol, atol, max_step, counts, cuts):
    """Integrate from (t_out[0], y) through the instants t_out, writing the state at each into
    Y[1:], the right-hand side evaluated through `ev` (`compiled.entry.handle`) and, with cuts
    (`constraints.CutArrays`; None for a tree), constrained by them (`rates`); steps are cut to
    land on them. With cuts, the state reached at each instant is projected onto the constraints
    (`constraints.project`: the rows hold to its tolerance at every output instant; status
    NOT_CLOSED, cuts.fail saying where, when that fails) and the integration goes on from it, its
    rates evaluated anew. Step size by the error of the embedded 4th-order solution (RMS norm,
    weights atol + rtol |y|) with Hairer's PI controller (alpha 0.17, beta 0.04).
    A step that would stop within LANDING of an instant goes to the instant itself, and the
    landing step sets t to it exactly: steps of max_step summed to an instant (0.001 s a hundred
    times is not 0.1 s in floating point) leave no sliver of 1e-16 s to step.

    Returns (k, h, status, t): the last instant reached, the next step size, a status code
    (OK, NONFINITE, DIVERGING, TOO_SMALL, NOT_CLOSED) and the time it refers to. counts (3,) +=
    accepted steps, rejected steps, evaluations.
    """
    n = y.size
    K = np.empty((7, n))
    t = t_out[0]
    K[0] = rates(ev, cuts, t, y, nq)
    counts[2] += 1
    err_old = 1e-4
    yn = np.empty(n)
    for k in range(1, t_out.size):
        while t < t_out[k]:
            rest = t_out[k] - t
            hs = min(h, max_step, rest)
            if rest - hs <= LANDING * max(abs(t_out[k]), 1.0):
                hs = rest                               # land: no sliver of roundoff left to step
            if hs < 1e-14 * max(abs(t), 1.0):
                return k - 1, h, TOO_SMALL, t
            for s in range(1, 7):
                ys = y.copy()
                for r in range(s):
                    if _A[s, r] != 0.0:
                        ys += hs * _A[s, r] * K[r]
                K[s] = rates(ev, cuts, t + _C[s] * hs, ys, nq)
            yn[:] = ys                                  # stage 7 is at the 5th-order solution (FSAL)
            counts[2] += 6
            err = 0.0
            for i in range(n):
                e = 0.0
                for r in range(7):
                    e += _E[r] * K[r, i]
                w = atol + rtol * max(abs(y[i]), abs(yn[i]))
                err += (hs * e / w) ** 2
            err = np.sqrt(err / n)
            if not np.isfinite(err):
                if not np.all(np.isfinite(yn)):
                    return k - 1, h, NONFINITE, t
                err = 1e10
            if err <= 1.0:
                t = t_out[k] if hs == rest else t + hs
                y[:] = yn
                K[0] = K[6]
                counts[0] += 1
                fac = min(max(0.9 * err ** -0.17 * err_old ** 0.04, 0.2), 10.0) if err > 0.0 else 10.0
                err_old = max(err, 1e-4)
                h = max(h, hs * fac) if hs < h else hs * fac   # a step cut to land is not a verdict
                code = state_code(y, nq)
                if code != OK:
                    return k - 1, h, code, t
            else:
                counts[1] += 1
                h = hs * max(0.9 * err ** -0.2, 0.2)
        if cuts is not None:
            if not project(ev, cuts, t, y[:nq], y[nq:], CLOSING):
                return k - 1, h, NOT_CLOSED, t
            K[0] = rates(ev, cuts, t, y, nq)         # the projected state's
            counts[2] += 1
        Y[k] = y
    return t_out.size - 1, h, OK, t


def _dopri5(model, y0, t_out, Y, rtol, atol, max_step, bar, chunk=50, judged=None, cuts=None):
    """Drive the compiled `dopri5` over chunks of output instants (progress and failures between);
    cuts (`constraints.CutArrays`): the loops that constrain it, y0 on them."""
    b, nq = bind(model, make_data(model)), model.nq
    ev = handle(b)
    f0 = rates(ev, cuts, 0.0, y0, nq)
    if not (np.all(np.isfinite(y0)) and np.all(np.isfinite(f0))):
        return 0, 0, 1, failed("non-finite state", 0.0)
    w = atol + rtol * np.abs(y0)
    d0, d1 = np.sqrt(np.mean((y0 / w) ** 2)), np.sqrt(np.mean((f0 / w) ** 2))
    h = min(0.01 * d0 / d1 if min(d0, d1) > 1e-5 else 1e-6, max_step)      # Hairer's first guess
    y, counts = y0.copy(), np.zeros(3, dtype=np.int64)
    step = [h]

    def advance(k, k1):
        j, step[0], code, t = dopri5(ev, nq, y, t_out[k:k1 + 1], Y[k:k1 + 1], step[0], rtol, atol, max_step,
                                     counts, cuts)
        return j, code, t

    return _in_chunks(advance, t_out, counts, bar, chunk, judged)
