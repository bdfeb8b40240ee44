"""Fox-Goodwin (Newmark beta = 1/12, gamma = 1/2), implicit, fixed step, compiled: Newton on the
accelerations with a reused finite-difference iteration matrix. On a tree closed by cut joints
the accelerations are the constrained ones and the state is projected onto the constraints at
every output instant (`constraints.constrained_rates`, `constraints.project`)."""

from __future__ import annotations

import numpy as np

from flexmbd.mbd.compiled.bound import bind
from flexmbd.mbd.compiled.dense import mv
from flexmbd.mbd.compiled.entry import handle
from flexmbd.mbd.compiled.jit import njit
from flexmbd.mbd.constraints import project
from flexmbd.mbd.integrate.base import (CLOSING, NEWTON, NONFINITE, NOT_CLOSED, OK, Stop, _in_chunks, failed, rates,
                                        state_code)
from flexmbd.mbd.model import make_data


# ---------------------------------------------------------------------------------------------
# Fox-Goodwin (Newmark beta = 1/12, gamma = 1/2), implicit, fixed step, compiled


@njit
def newmark_matrix(ev, nq, t, y, h, beta, gamma, cuts):
    """(I - beta h^2 da/dq - gamma h da/dv)^-1 (nv, nv) at (t, y) by forward differences of the
    accelerations (constrained by cuts unless None: `base.rates`); q and v must be aligned
    (nq == nv, no quaternion joints)."""
    n = y.size - nq
    a0 = rates(ev, cuts, t, y, nq)[nq:]
    J = np.eye(n)
    for k in range(y.size):
        yp = y.copy()
        d = 1e-7 * max(abs(y[k]), 1.0)
        yp[k] += d
        col = (rates(ev, cuts, t, yp, nq)[nq:] - a0) / d
        w, j = (beta * h * h, k) if k < nq else (gamma * h, k - nq)
        for r in range(n):
            J[r, j] -= w * col[r]
    return np.linalg.inv(J)


@njit
def fox_goodwin(ev, nq, y, acc, t_out, Y, h, rtol, atol, Jinv, counts, cuts):
    """Newmark with beta = 1/12, gamma = 1/2 (phase error (w h)^4/480, no numerical damping,
    stable for w_max h < sqrt(6)) from (t_out[0], y, acc) through the instants t_out, writing
    Y[1:]. Each step solves A - a(t+h, q(A), v(A)) = 0 for the new accelerations A by Newton with
    the iteration matrix Jinv, refreshed when an iteration stalls. With cuts (None for a tree) a is
    constrained (`base.rates`) and each instant's state projected, its a evaluated anew (`dopri5`).

    Newton stops when the remaining error, estimated from the contraction rate as
    theta/(1-theta) times the last correction (Hairer & Wanner IV.8), moves q and v by less than
    atol + rtol |.|.
    Returns (k, status, t) as `dopri5`; counts (3,) += steps, Jacobian refreshes, evaluations.
    """
    beta, gamma = 1.0 / 12.0, 0.5
    n = acc.size
    eta = 1.0
    t = t_out[0]
    y1 = np.empty(y.size)
    for k in range(1, t_out.size):
        m = max(int(np.ceil((t_out[k] - t) / h - 1e-9)), 1)
        hs = (t_out[k] - t) / m
        if abs(hs - h) > 1e-6 * h:                      # a new step: the one that divides this interval
            h = hs
            Jinv[:] = newmark_matrix(ev, nq, t, y, h, beta, gamma, cuts)
            counts[1] += 1
            counts[2] += y.size + 1
        for _ in range(m):
            qp = y[:nq] + h * y[nq:] + h * h * (0.5 - beta) * acc
            vp = y[nq:] + h * (1.0 - gamma) * acc
            A = acc.copy()
            done = False
            for attempt in range(2):
                eta = max(eta, 1e-16) ** 0.8            # Hairer's estimate from the last step
                err_old = 1.0
                for it in range(10):
                    y1[:nq] = qp + beta * h * h * A
                    y1[nq:] = vp + gamma * h * A
                    r = A - rates(ev, cuts, t + h, y1, nq)[nq:]
                    counts[2] += 1
                    dA = mv(Jinv, r)
                    A -= dA
                    err = 0.0                           # the correction's size in q and v
                    for i in range(n):
                        err = max(err, gamma * h * abs(dA[i]) / (atol + rtol * abs(y1[nq + i])),
                                  beta * h * h * abs(dA[i]) / (atol + rtol * abs(y1[i])))
                    if not np.isfinite(err):
                        return k - 1, NONFINITE, t
                    if it > 0:                          # contraction rate theta: stop when the
                        theta = err / max(err_old, 1e-300)  # remaining error theta/(1-theta) err is small
                        if theta >= 0.9:
                            break
                        eta = theta / (1.0 - theta)
                    err_old = err
                    if eta * err <= 1.0:
                        done = True
                        break
                if done:
                    break
                eta = 1.0
                Jinv[:] = newmark_matrix(ev, nq, t, y, h, beta, gamma, cuts)
                counts[1] += 1
                counts[2] += y.size + 1
                A = acc.copy()
            if not done:
                return k - 1, NEWTON, t
            y[:nq] = qp + beta * h * h * A
            y[nq:] = vp + gamma * h * A
            acc[:] = A
            t += h
            counts[0] += 1
            code = state_code(y, nq)
            if code != OK:
                return k - 1, code, t
        t = t_out[k]
        if cuts is not None:
            if not project(ev, cuts, t, y[:nq], y[nq:], CLOSING):
                return k - 1, NOT_CLOSED, t
            acc[:] = rates(ev, cuts, t, y, nq)[nq:]     # the projected state's
            counts[2] += 1
        Y[k] = y
    return t_out.size - 1, OK, t


def _fox_goodwin(model, y0, t_out, Y, dt, rtol, atol, bar, chunk=50, judged=None, cuts=None):
    """Drive the compiled `fox_goodwin` over chunks of output instants; cuts
    (`constraints.CutArrays`): the loops that constrain it, y0 on them."""
    if model.nq != model.nv:
        raise Stop(failed("fox-goodwin needs q and v aligned (no spherical or free joints)", 0.0))
    b, nq = bind(model, make_data(model)), model.nq
    ev = handle(b)
    acc = np.ascontiguousarray(rates(ev, cuts, 0.0, y0, nq)[nq:])
    if not (np.all(np.isfinite(y0)) and np.all(np.isfinite(acc))):
        return 0, 0, 1, failed("non-finite state", 0.0)
    y, counts = y0.copy(), np.zeros(3, dtype=np.int64)
    Jinv = np.ascontiguousarray(newmark_matrix(ev, nq, 0.0, y0, dt, 1.0 / 12.0, 0.5, cuts))
    counts[2] += y0.size + 2
    return _in_chunks(lambda k, k1: fox_goodwin(ev, nq, y, acc, t_out[k:k1 + 1], Y[k:k1 + 1], dt, rtol, atol,
                                                Jinv, counts, cuts), t_out, counts, bar, chunk, judged)
