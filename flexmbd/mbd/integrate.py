"""Time integration of the Model's equations: y = [q; v], dy/dt = [qdot(q, v); aba(q, v)].

Methods (the case's `[integrator] method`):
  dopri5  Dormand-Prince 5(4), variable step, compiled as a whole (`dopri5`): the step loop and
          every right-hand-side evaluation run without returning to Python
  fox-goodwin  Newmark beta = 1/12, gamma = 1/2, fixed step `dt`, compiled as a whole: Newton
          on the accelerations with a reused finite-difference iteration matrix (rtol/atol are
          its tolerance). Phase error (w h)^4/480, stable for w_max h < sqrt(6) like an explicit
          method, but one or two evaluations per step
  exp-adams  exponential Adams predictor-corrector (PECE, order 3), fixed step `dt`, compiled
          (`exp_adams`): f(y) = L y + N(y) with L the Jacobian, re-linearized every `refresh`
          steps, the case's `integrator.refresh` (default EXP_REFRESH): where dq/dt = v,
          [[0, I], [d(qdd)/dq, 0]] each time; else every EXP_FULL-th time in full, between only
          its fast eigenvalues. L is integrated exactly in its eigenbasis (its products by the
          m x m blocks of the second-order one) and N through the polynomial of its last values; two
          evaluations a step, stable and phase-exact for the modes of L at any step, so the step
          is set by the accuracy of the slow motion and of the remainder (docs/formulation.md §6)
  adams   variable-step, variable-order (1-12) Adams-Moulton predictor-corrector with
          functional iteration (PECE), as in the paper: ODEPACK's VODE through scipy
  rk45, dop853   explicit embedded Runge-Kutta pairs (scipy's solve_ivp), for comparison
  rk4     classical fixed-step Runge-Kutta, step `dt`
A state or acceleration that is not finite, or a velocity beyond DIVERGED (the divergence rule's
bound on a velocity state), ends the run as failed (`Ended`: why, and when) at the time it
happened; every output instant reached before it is kept. A caller's `check` of the output
samples (the divergence rule on the channels: `solver.watch`) ends it too, at the first sample it
fails (kept, for the rule after the run to cut), judged as the samples come: after each chunk of
the compiled integrators, at each sample of the Python loops (adams, rk4).
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from scipy import integrate as scipy_ivp
from scipy.integrate import ode, solve_ivp

from flexmbd.mbd.compiled.dense import mv
from flexmbd.mbd.compiled.jit import compiling, njit
from flexmbd.mbd.compiled.bound import bind
from flexmbd.mbd.compiled.entry import handle, rhs
from flexmbd.mbd.model import Model, make_data

DIVERGED = 1e8      # |v| beyond this (rad/s, m/s, modal units) counts as divergence: the divergence rule's
                    # bound on a velocity state, the same for every solver (`results.first_failure` its others)


class Ended(NamedTuple):
    """How a run of the integrators ended: `ok`, or failed for `why` at `t` (s; None: not known).
    The harness makes it a run's status (`solver.run`)."""

    ok: bool = True
    why: str = ""
    t: float | None = None


def failed(why: str, t=None) -> Ended:
    return Ended(False, why, None if t is None else float(t))


class Stop(Exception):
    """Raised inside the right-hand side to end a run that has failed; args[0] is its `Ended`."""


@dataclass
class Simulation:
    t: np.ndarray                   # (n,) output instants, s
    q: np.ndarray                   # (n, nq)
    v: np.ndarray                   # (n, nv)
    status: Ended = field(default_factory=Ended)
    steps: int = 0
    rhs_evals: int = 0
    wall_s: float = 0.0
    settings: dict = field(default_factory=dict)


def rhs_function(model: Model):
    """f(t, y) for y = [q; v] (the compiled `compiled.entry.rhs` behind a Python call), and a counter
    of its evaluations."""
    b, nq = bind(model, make_data(model)), model.nq
    ev = handle(b)
    count = [0]

    def f(t, y):
        count[0] += 1
        yd = rhs(ev, float(t), y, nq)
        if not np.all(np.isfinite(yd)):
            raise Stop(failed(NON_FINITE[1], t))
        return yd

    f.bound = b                 # alive as long as f: the compiled code reaches it by address
    return f, count


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

OK, NONFINITE, DIVERGING, TOO_SMALL, NEWTON = 0, 1, 2, 3, 4


@njit
def state_code(y, nq):
    """The divergence rule of every integrator on a state y = [q; v]: NONFINITE when an entry is
    not finite, DIVERGING when a velocity |v_i| exceeds DIVERGED, else OK. The compiled step loops
    call it after every step, the others through `_check` (the message: WHY)."""
    for i in range(y.size):
        if not np.isfinite(y[i]):
            return NONFINITE
    for i in range(nq, y.size):
        if abs(y[i]) > DIVERGED:
            return DIVERGING
    return OK


LANDING = 1e-12      # a step within this (relative to the instant) of an output instant lands on it


@njit
def dopri5(ev, nq, y, t_out, Y, h, rtol, atol, max_step, counts):
    """Integrate from (t_out[0], y) through the instants t_out, writing the state at each into
    Y[1:], the right-hand side evaluated through `ev` (`compiled.entry.handle`); steps are cut to
    land on them. Step size by the error of the embedded 4th-order
    solution (RMS norm, weights atol + rtol |y|) with Hairer's PI controller (alpha 0.17, beta 0.04).
    A step that would stop within LANDING of an instant goes to the instant itself, and the
    landing step sets t to it exactly: steps of max_step summed to an instant (0.001 s a hundred
    times is not 0.1 s in floating point) leave no sliver of 1e-16 s to step.

    Returns (k, h, status, t): the last instant reached, the next step size, a status code
    (OK, NONFINITE, DIVERGING, TOO_SMALL) and the time it refers to. counts (3,) += accepted
    steps, rejected steps, evaluations.
    """
    n = y.size
    K = np.empty((7, n))
    t = t_out[0]
    K[0] = rhs(ev, t, y, nq)
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
                K[s] = rhs(ev, t + _C[s] * hs, ys, nq)
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
        Y[k] = y
    return t_out.size - 1, h, OK, t


def simulate(model: Model, t_end: float, method: str = "adams", rtol: float = 1e-8, atol: float = 1e-10,
             max_step: float = 1e-3, dt: float = 1e-4, output_dt: float = 1e-3, progress=None,
             check=None, refresh: int | None = None) -> Simulation:
    """Integrate from (model.q0, model.v0) over [0, t_end]; states sampled every output_dt.
    check(t (m,), Q (m, nq), V (m, nv)) -> (i, status) | None: the first of new output samples at
    which the run has failed (`judge`; the status's `why` and `t` are kept); the run ends there,
    that sample its last. refresh: exp-adams' steps between two linearizations (None:
    EXP_REFRESH). progress: told the time reached (`update(t)`, `tracking(f)`: f wrapped to tell
    it at each evaluation; `close()` at the end), as `progress.Progress` is; None: nothing told."""
    refresh = EXP_REFRESH if refresh is None else refresh
    n = int(round(t_end / output_dt))
    t_out = np.linspace(0.0, n * output_dt, n + 1)
    f, count = rhs_function(model)
    y0 = np.concatenate([model.q0, model.v0])
    settings = {"method": method, "rtol": rtol, "atol": atol, "max_step": max_step, "output_dt": output_dt}
    if method == "rk4":
        settings = {"method": method, "dt": dt, "output_dt": output_dt}
    if method == "fox-goodwin":
        settings = {"method": method, "dt": dt, "rtol": rtol, "atol": atol, "output_dt": output_dt}
    if method == "exp-adams":
        settings = {"method": method, "dt": dt, "refresh": refresh, "output_dt": output_dt}
    bar = progress or None
    Y = np.full((t_out.size, y0.size), np.nan)
    Y[0] = y0
    start = time.perf_counter()
    status, steps, k = Ended(), 0, 0
    judged = None if check is None else lambda k0, k1: judge(check, t_out, Y, model.nq, k0, k1)
    try:
        if y0.size == 0:                # nothing moves (every joint fixed, no modes): every sample is the start
            k = t_out.size - 1
        elif method == "fox-goodwin":
            k, steps, evals, status = _fox_goodwin(model, y0, t_out, Y, dt, rtol, atol, bar, judged=judged)
            count[0] += evals
        elif method == "exp-adams":
            k, steps, evals, status = _exp_adams(model, y0, t_out, Y, dt, output_dt, bar, judged=judged,
                                                 refresh=refresh)
            count[0] += evals
        elif method == "dopri5":
            k, steps, evals, status = _dopri5(model, y0, t_out, Y, rtol, atol, max_step, bar, judged=judged)
            count[0] += evals
        elif method == "adams":         # the bar moves with every evaluation: VODE's steps may collapse
            k, steps, status = _adams(bar.tracking(f) if bar else f, y0, t_out, Y, rtol, atol, max_step, bar, model.nq,
                                      judged)
        elif method == "rk4":
            k, steps, status = _rk4(bar.tracking(f) if bar else f, y0, t_out, Y, dt, bar, model.nq, judged)
        else:
            k, steps, status = _solve_ivp(f, y0, t_out, Y, method, rtol, atol, max_step)
    except Stop as e:
        status = e.args[0]
        k = reached(Y)
    wall = time.perf_counter() - start
    if bar:
        bar.close()
    keep = slice(0, k + 1)
    code = state_code(Y[k], model.nq) if status.ok else OK     # the integrators without a check of their own
    if code != OK:
        status = failed(WHY[code], t_out[k])
    return Simulation(t=t_out[keep], q=Y[keep, :model.nq], v=Y[keep, model.nq:], status=status,
                      steps=steps, rhs_evals=count[0], wall_s=wall, settings=settings)


# ---------------------------------------------------------------------------------------------
# Fox-Goodwin (Newmark beta = 1/12, gamma = 1/2), implicit, fixed step, compiled


@njit
def newmark_matrix(ev, nq, t, y, h, beta, gamma):
    """(I - beta h^2 da/dq - gamma h da/dv)^-1 (nv, nv) at (t, y) by forward differences of the
    accelerations; q and v must be aligned (nq == nv, no quaternion joints)."""
    n = y.size - nq
    a0 = rhs(ev, t, y, nq)[nq:]
    J = np.eye(n)
    for k in range(y.size):
        yp = y.copy()
        d = 1e-7 * max(abs(y[k]), 1.0)
        yp[k] += d
        col = (rhs(ev, t, yp, nq)[nq:] - a0) / d
        w, j = (beta * h * h, k) if k < nq else (gamma * h, k - nq)
        for r in range(n):
            J[r, j] -= w * col[r]
    return np.linalg.inv(J)


@njit
def fox_goodwin(ev, nq, y, acc, t_out, Y, h, rtol, atol, Jinv, counts):
    """Newmark with beta = 1/12, gamma = 1/2 (phase error (w h)^4/480, no numerical damping,
    stable for w_max h < sqrt(6)) from (t_out[0], y, acc) through the instants t_out, writing
    Y[1:]. Each step solves A - a(t+h, q(A), v(A)) = 0 for the new accelerations A by Newton with
    the iteration matrix Jinv, refreshed when an iteration stalls.

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
            Jinv[:] = newmark_matrix(ev, nq, t, y, h, beta, gamma)
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
                    r = A - rhs(ev, t + h, y1, nq)[nq:]
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
                Jinv[:] = newmark_matrix(ev, nq, t, y, h, beta, gamma)
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
        Y[k] = y
    return t_out.size - 1, OK, t


def _fox_goodwin(model, y0, t_out, Y, dt, rtol, atol, bar, chunk=50, judged=None):
    """Drive the compiled `fox_goodwin` over chunks of output instants."""
    if model.nq != model.nv:
        raise Stop(failed("fox-goodwin needs q and v aligned (no spherical or free joints)", 0.0))
    b, nq = bind(model, make_data(model)), model.nq
    ev = handle(b)
    acc = np.ascontiguousarray(rhs(ev, 0.0, y0, nq)[nq:])
    if not (np.all(np.isfinite(y0)) and np.all(np.isfinite(acc))):
        return 0, 0, 1, failed("non-finite state", 0.0)
    y, counts = y0.copy(), np.zeros(3, dtype=np.int64)
    Jinv = np.ascontiguousarray(newmark_matrix(ev, nq, 0.0, y0, dt, 1.0 / 12.0, 0.5))
    counts[2] += y0.size + 2
    return _in_chunks(lambda k, k1: fox_goodwin(ev, nq, y, acc, t_out[k:k1 + 1], Y[k:k1 + 1], dt, rtol, atol,
                                                Jinv, counts), t_out, counts, bar, chunk, judged)


def warm_up(model: Model, method: str = "") -> None:
    """Compile (or load from the cache) the kernel's entry, `rhs` and the compiled integrator of
    `method` ("dopri5", "fox-goodwin", "exp-adams"; none for any other), so that no compilation lands inside a
    timed run. Only what the run uses: each integrator compiles on its first use."""
    with compiling():
        b, nq = bind(model, make_data(model)), model.nq
        ev = handle(b)
        y0 = np.concatenate([model.q0, model.v0])
        rhs_function(model)[0](0.0, y0)
        t, Y, counts = np.zeros(2), np.zeros((2, y0.size)), np.zeros(3, dtype=np.int64)
        if method == "dopri5":
            dopri5(ev, nq, y0.copy(), t, Y, 1e-6, 1e-6, 1e-8, 1e-3, counts)
        if method == "fox-goodwin" and model.nq == model.nv and model.nv:   # nothing to compile for: no states
            newmark_matrix(ev, nq, 0.0, y0, 1e-4, 1.0 / 12.0, 0.5)
            fox_goodwin(ev, nq, y0.copy(), np.zeros(model.nv), t, Y, 1e-4, 1e-6, 1e-8, np.eye(model.nv), counts)
        if method == "exp-adams" and y0.size:      # one short step compiles it
            _exp_adams(model, y0, np.array([0.0, 1e-6]), np.zeros((2, y0.size)), 1e-6, 1e-6, None)


def _dopri5(model, y0, t_out, Y, rtol, atol, max_step, bar, chunk=50, judged=None):
    """Drive the compiled `dopri5` over chunks of output instants (progress and failures between)."""
    b, nq = bind(model, make_data(model)), model.nq
    ev = handle(b)
    f0 = rhs(ev, 0.0, y0, nq)
    if not (np.all(np.isfinite(y0)) and np.all(np.isfinite(f0))):
        return 0, 0, 1, failed("non-finite state", 0.0)
    w = atol + rtol * np.abs(y0)
    d0, d1 = np.sqrt(np.mean((y0 / w) ** 2)), np.sqrt(np.mean((f0 / w) ** 2))
    h = min(0.01 * d0 / d1 if min(d0, d1) > 1e-5 else 1e-6, max_step)      # Hairer's first guess
    y, counts = y0.copy(), np.zeros(3, dtype=np.int64)
    step = [h]

    def advance(k, k1):
        j, step[0], code, t = dopri5(ev, nq, y, t_out[k:k1 + 1], Y[k:k1 + 1], step[0], rtol, atol, max_step,
                                     counts)
        return j, code, t

    return _in_chunks(advance, t_out, counts, bar, chunk, judged)


WHY = {NONFINITE: "non-finite state", DIVERGING: f"diverged (|v| > {DIVERGED:g})", TOO_SMALL: "step size too small",
       NEWTON: "Newton did not converge with a fresh iteration matrix"}
NON_FINITE = (WHY[NONFINITE], "non-finite acceleration")     # the whys of a run that ended in non-finite values


def _in_chunks(advance, t_out, counts, bar, chunk, judged=None):
    """Run a compiled integrator, `advance(k, k1) -> (instants done, status code, t)` over
    t_out[k:k1+1], chunk by chunk, with progress and failures in between (the state's, and
    `judged`'s of the chunk's samples: `judge`): (k, steps, evaluations, status)."""
    k = 0
    while k < t_out.size - 1:
        k1 = min(k + chunk, t_out.size - 1)
        j, code, t = advance(k, k1)
        k0, k = k, k + j
        if code != OK:
            return k, int(counts[0]), int(counts[2]), failed(WHY[code], t)
        hit = judged(k0 + 1, k) if judged and k > k0 else None
        if hit is not None:
            return hit[0], int(counts[0]), int(counts[2]), hit[1]
        if bar:
            bar.update(t_out[k])
    return k, int(counts[0]), int(counts[2]), Ended()


def judge(check, t_out, Y, nq, k0, k1):
    """`check` (simulate's) of the output samples k0..k1 (rows of Y): (the first failed sample's
    index, its `Ended`) or None."""
    hit = check(t_out[k0:k1 + 1], Y[k0:k1 + 1, :nq], Y[k0:k1 + 1, nq:])
    return None if hit is None else (k0 + hit[0], failed(hit[1].why, hit[1].t))


def reached(Y) -> int:
    """The last output instant (row of Y, NaN where not reached) with a finite state."""
    ok = np.flatnonzero(np.all(np.isfinite(Y), axis=1))
    return int(ok[-1]) if ok.size else 0


def _check(y, t, nq):
    """Stop a run whose state y = [q; v] breaks the divergence rule (`state_code`)."""
    code = state_code(y, nq)
    if code != OK:
        raise Stop(failed(WHY[code], t))


def _adams(f, y0, t_out, Y, rtol, atol, max_step, bar, nq, judged=None):
    """VODE, Adams family (method flag MF = 10: functional iteration, no Jacobian)."""
    r = ode(f).set_integrator("vode", method="adams", with_jacobian=False, rtol=rtol, atol=atol,
                              order=12, max_step=max_step, nsteps=10 ** 8)
    r.set_initial_value(y0, 0.0)
    k = 0
    for k in range(1, t_out.size):
        with warnings.catch_warnings(record=True) as said:     # VODE's own words go into the status
            warnings.simplefilter("always")
            try:
                y = r.integrate(t_out[k])
            except Stop as e:                   # raised by f: keep VODE's step count
                return k - 1, int(r._integrator.iwork[10]), e.args[0]
        if not r.successful():
            why = str(said[-1].message).removeprefix("vode: ").split(" (Perhaps")[0].rstrip(". ") if said else ""
            return k - 1, int(r._integrator.iwork[10]), \
                failed(f"VODE return code {r.get_return_code()}{': ' + why if why else ''}", r.t)
        _check(y, t_out[k], nq)
        Y[k] = y
        if bar:
            bar.update(t_out[k])
        hit = judged(k, k) if judged else None
        if hit is not None:
            return k, int(r._integrator.iwork[10]), hit[1]
    return k, int(r._integrator.iwork[10]), Ended()


def _rk4(f, y0, t_out, Y, dt, bar, nq, judged=None):
    """Classical Runge-Kutta with the largest step <= dt that divides each output interval:
    (last instant reached, steps, status)."""
    y, steps = y0.copy(), 0
    try:
        for k in range(1, t_out.size):
            steps += _rk4_interval(f, y, t_out[k - 1], t_out[k], dt, nq)
            Y[k] = y
            if bar:
                bar.update(t_out[k])
            hit = judged(k, k) if judged else None
            if hit is not None:
                return k, steps, hit[1]
    except Stop as e:
        return k - 1, steps, e.args[0]
    return t_out.size - 1, steps, Ended()


def _rk4_interval(f, y, t0, t1, dt, nq) -> int:
    """Advance y (in place) from t0 to t1 in equal steps <= dt; the number of steps."""
    m = max(int(np.ceil((t1 - t0) / dt - 1e-9)), 1)
    h = (t1 - t0) / m
    for s in range(m):
        t = t0 + s * h
        k1 = f(t, y)
        k2 = f(t + h / 2, y + h / 2 * k1)
        k3 = f(t + h / 2, y + h / 2 * k2)
        k4 = f(t + h, y + h * k3)
        y[:] = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    _check(y, t1, nq)
    return m


# ---------------------------------------------------------------------------------------------
# closed loops: the constrained right-hand side, projected at every output instant

PROJECTED = {"dopri5": "RK45", "rk45": "RK45", "dop853": "DOP853", "rk4": None}  # case method -> scipy's


def simulate_loops(loops, t_end: float, method: str = "dopri5", rtol: float = 1e-8, atol: float = 1e-10,
                   max_step: float = 1e-3, output_dt: float = 1e-3, progress=None,
                   dt: float = 1e-4) -> Simulation:
    """Integrate a tree closed by cut joints (`constraints.Loops`) from its assembled start
    (the case's values closed by `loops.close`) over [0, t_end], sampled every output_dt: each
    output interval by an explicit embedded Runge-Kutta pair (scipy's, continuing with the last
    step size) or by classical Runge-Kutta in equal steps <= dt (`rk4`) on the constrained
    rates (`progress` told as `simulate`'s), then the state projected onto the constraints (`loops.close`), which therefore hold
    to its tolerance at every output instant. Only the one-step methods (PROJECTED) restart
    cleanly after a projection."""
    model = loops.model
    n = int(round(t_end / output_dt))
    t_out = np.linspace(0.0, n * output_dt, n + 1)
    settings = {"method": method, "output_dt": output_dt, "constraints": "projected at every output instant",
                **({"dt": dt} if method == "rk4" else {"rtol": rtol, "atol": atol, "max_step": max_step})}
    nq = model.nq
    Y = np.full((t_out.size, nq + model.nv), np.nan)
    count = [0]
    start = time.perf_counter()
    if method not in PROJECTED:
        return Simulation(t=t_out[:0], q=Y[:0, :nq], v=Y[:0, nq:], settings=settings, status=failed(
            f"integrator {method!r} cannot restart after each projection onto a closed loop's constraints "
            f"(use {', '.join(list(PROJECTED)[:-1])} or {list(PROJECTED)[-1]})", 0.0))

    def f(t, y):
        count[0] += 1
        return loops.rates(t, y[:nq], y[nq:])[0]

    bar = progress or None
    status, steps, h, k = Ended(), 0, None, 0
    try:
        Y[0] = np.concatenate(loops.close(0.0, model.q0, model.v0))
        for k in range(1, t_out.size):
            if method == "rk4":                       # checks the state itself (`_rk4_interval`)
                y = Y[k - 1].copy()
                steps += _rk4_interval(f, y, t_out[k - 1], t_out[k], dt, nq)
            else:
                first = None if h is None else min(h, t_out[k] - t_out[k - 1])
                r = getattr(scipy_ivp, PROJECTED[method])(f, t_out[k - 1], Y[k - 1], t_out[k], rtol=rtol,
                                                         atol=atol, max_step=max_step, first_step=first)
                while r.status == "running":
                    r.step()
                    steps += 1
                if r.status == "failed":
                    status = failed(r.message, r.t)
                    k -= 1
                    break
                h, y = r.step_size or None, r.y
                _check(y, t_out[k], nq)
            Y[k] = np.concatenate(loops.close(t_out[k], y[:nq], y[nq:]))
            if bar:
                bar.update(t_out[k])
    except Stop as e:
        status, k = e.args[0], reached(Y)
    except loops.NotClosed as e:
        when = "cannot close at the initial values" if k == 0 else "no longer closes"
        status = failed(f"the loop of joint {e.args[0]!r} {when} (residual {e.args[1]:.3g})", t_out[k])
        k = max(k - 1, 0)
    if bar:
        bar.close()
    keep = slice(0, k + 1 if np.all(np.isfinite(Y[0])) else 0)
    return Simulation(t=t_out[keep], q=Y[keep, :nq], v=Y[keep, nq:], status=status, steps=steps,
                      rhs_evals=count[0], wall_s=time.perf_counter() - start, settings=settings)


def _solve_ivp(f, y0, t_out, Y, method, rtol, atol, max_step):
    sol = solve_ivp(f, (0.0, t_out[-1]), y0, method={"rk45": "RK45", "dop853": "DOP853"}[method],
                    t_eval=t_out, rtol=rtol, atol=atol, max_step=max_step)
    k = sol.y.shape[1] - 1
    Y[:k + 1] = sol.y.T
    stages = {"rk45": 6, "dop853": 12}[method]
    status = Ended() if sol.success else failed(sol.message, sol.t[-1])
    return k, sol.nfev // stages, status


# ---------------------------------------------------------------------------------------------
# Exponential Adams (predictor-corrector) on a refreshed linearization, fixed step, compiled

EXP_ORDER = 3       # nodes of the predictor's and the corrector's polynomials (order 3 each)
EXP_REFRESH = 25    # steps between two linearizations (`exp_linearize`) unless the case sets integrator.refresh
EXP_FULL = 8        # every EXP_FULL-th of them in full (Jacobian, eigenbasis), between only the fast eigenvalues,
EXP_TURN = 0.02     # unless a fast eigenvector has turned by more than this (|J v - lam v| / |lam v|)
NOT_DIAGONAL, STALE = 5, 6      # status codes: the linearization has no eigenbasis; it is due again


@njit
def jacobian_columns(ev, nq, t, y, m):
    """The first m columns of df/dy (n, m) of the right-hand side at (t, y) by forward
    differences (m + 1 evaluations)."""
    f0 = rhs(ev, t, y, nq)
    J = np.empty((y.size, m))
    for k in range(m):
        yp = y.copy()
        d = 1e-7 * max(abs(y[k]), 1.0)
        yp[k] += d
        J[:, k] = (rhs(ev, t, yp, nq) - f0) / d
    return J


@njit
def jacobian(ev, nq, t, y):
    """df/dy (n, n) of the right-hand side at (t, y) (n + 1 evaluations)."""
    return jacobian_columns(ev, nq, t, y, y.size)


@njit
def position_jacobian(ev, nq, t, y):
    """A = d(qdd)/dq (nq, nq) at (t, y) (nq + 1 evaluations): the lower-left block of the
    Jacobian of y = [q; v] when dq/dt = v."""
    return np.ascontiguousarray(jacobian_columns(ev, nq, t, y, nq)[nq:])


@njit
def phi_functions(z, kmax):
    """phi_0..phi_kmax (kmax+1, n) of the complex numbers z (n,): phi_0 = exp, phi_j(z) =
    (phi_{j-1}(z) - 1/(j-1)!) / z, phi_j(0) = 1/j!; the Taylor series where |z| < 1/2."""
    out = np.empty((kmax + 1, z.size), dtype=np.complex128)
    for i in range(z.size):
        x = z[i]
        if abs(x) < 0.5:
            for j in range(kmax + 1):
                term = 1.0 + 0.0j
                for m in range(1, j + 1):
                    term /= m
                s = 0.0 + 0.0j
                for m in range(25):
                    s += term
                    term = term * x / (j + m + 1)
                out[j, i] = s
        else:
            out[0, i] = np.exp(x)
            fact = 1.0
            for j in range(1, kmax + 1):
                out[j, i] = (out[j - 1, i] - 1.0 / fact) / x
                fact *= j
    return out


@njit
def exp_weights(lam, h, nodes, frac):
    """The exponential Adams formula from a step's start to frac h (0 < frac <= 1), in the
    eigenbasis of the linear part (eigenvalues lam (n,)): w(frac h) = E w + Σ_j W[j] Nw_j, where
    Nw_j (n,) is the remainder f - L y at the node nodes[j] h (in eigen-coordinates) and the
    remainder between nodes is their interpolating polynomial. Returns E (n,), W (k, n), complex:
    W[j] = frac h Σ_m m! phi_{m+1}(frac h lam) a[m, j], a the monomial coefficients (in units of
    frac h) of the Lagrange basis polynomial of node j."""
    k = nodes.size
    V = np.empty((k, k))
    for i in range(k):
        for m in range(k):
            V[i, m] = (nodes[i] / frac) ** m
    A = np.linalg.inv(V)                    # A[m, j]: coefficient of s^m in node j's basis polynomial
    P = phi_functions(frac * h * lam, k)
    W = np.zeros((k, lam.size), dtype=np.complex128)
    for j in range(k):
        fact = 1.0
        for m in range(k):
            W[j] += fact * A[m, j] * P[m + 1]
            fact *= m + 1
        W[j] *= frac * h
    return P[0].copy(), W


def eigenbasis(J):
    """J = V diag(lam) V^-1: (lam (n,), V, Vi (n, n)), complex, or None when J has no eigenbasis
    that reproduces it (`reproduces`) or is not finite."""
    try:
        lam, V = np.linalg.eig(J)
        Vi = np.linalg.inv(V)
    except np.linalg.LinAlgError:
        return None
    x = np.linspace(1.0, 2.0, J.shape[0])
    return reproduces(J @ x, np.abs(J).max(), x, lam.astype(np.complex128), V.astype(np.complex128),
                      Vi.astype(np.complex128))


def second_order_basis(A):
    """The eigenbasis of L = [[0, I], [A, 0]] (2m, 2m) from that of A = X diag(mu) X^-1 (m, m):
    L [x; s x] = s [x; s x] for s^2 = mu, so lam = [s; -s] (s = sqrt(mu)), V = [[X, X], [X S, -X S]]
    and Vi = 1/2 [[X^-1, S^-1 X^-1], [X^-1, -S^-1 X^-1]] (S = diag(s)): an m x m eigenproblem
    for the 2m x 2m one. None as `eigenbasis` (mu = 0, a coordinate with no restoring force,
    makes L's block [[0, 1], [0, 0]] defective)."""
    m = A.shape[0]
    try:
        mu, X = np.linalg.eig(A)
        Xi = np.linalg.inv(X)
    except np.linalg.LinAlgError:
        return None
    sq = np.sqrt(mu.astype(np.complex128))
    if not np.all(sq != 0.0):
        return None
    X, Xi = X.astype(np.complex128), Xi.astype(np.complex128)
    XS, SXi = X * sq, Xi / sq[:, None]
    V = np.empty((2 * m, 2 * m), dtype=np.complex128)
    V[:m, :m] = V[:m, m:] = X
    V[m:, :m], V[m:, m:] = XS, -XS
    Vi = np.empty_like(V)
    Vi[:m, :m] = Vi[m:, :m] = 0.5 * Xi
    Vi[:m, m:], Vi[m:, m:] = 0.5 * SXi, -0.5 * SXi
    x = np.linspace(1.0, 2.0, 2 * m)
    return reproduces(np.concatenate([x[m:], A @ x[:m]]), max(np.abs(A).max(), 1.0), x,
                      np.concatenate([sq, -sq]), V, Vi)


def reproduces(Jx, size, x, lam, V, Vi):
    """(lam, V, Vi) if they are finite and V diag(lam) Vi x is Jx, J's product with the test
    vector x, to 1e-6 of |J| |x| (size: |J|, the largest magnitude of its entries), else None (a
    defective or nearly defective J has no eigenbasis that does)."""
    if not np.all(np.isfinite(Vi)) or \
            np.linalg.norm(V @ (lam * (Vi @ x)) - Jx) > 1e-6 * size * np.linalg.norm(x):
        return None
    return lam, V, Vi


@njit
def cmv_real(V, w, out, half=0):
    """out (n,) = Re(V w), V (n, n) and w (n,) complex. half = m > 0: V is `second_order_basis`'
    [[X, X], [X S, -X S]] (n = 2m), taken through its blocks: Re([X (w1 + w2); X S (w1 - w2)]),
    half the products."""
    n = w.size
    if half:
        c, d = w[:half] + w[half:], w[:half] - w[half:]
        for i in range(half):
            s, sd = 0.0, 0.0
            for k in range(half):
                s += V[i, k].real * c[k].real - V[i, k].imag * c[k].imag
                sd += V[half + i, k].real * d[k].real - V[half + i, k].imag * d[k].imag
            out[i], out[half + i] = s, sd
        return
    for i in range(n):
        s = 0.0
        for m in range(n):
            s += V[i, m].real * w[m].real - V[i, m].imag * w[m].imag
        out[i] = s


@njit
def cmv(Vi, x, half=0):
    """Vi x (n,) complex for x (n,) real. half = m > 0: Vi is `second_order_basis`'
    1/2 [[X^-1, S^-1 X^-1], [X^-1, -S^-1 X^-1]] (n = 2m), taken through its blocks: with
    a = Vi[:m, :m] x1 and b = Vi[:m, m:] x2, [a + b; a - b], half the products."""
    n = x.size
    out = np.empty(n, dtype=np.complex128)
    if half:
        for i in range(half):
            a, b = 0.0 + 0.0j, 0.0 + 0.0j
            for k in range(half):
                a += Vi[i, k] * x[k]
                b += Vi[i, half + k] * x[half + k]
            out[i], out[half + i] = a + b, a - b
        return out
    for i in range(n):
        s = 0.0 + 0.0j
        for m in range(n):
            s += Vi[i, m] * x[m]
        out[i] = s
    return out


@njit
def exp_adams(ev, nq, Yh, Fh, basis, Wz, G, t_out, Y, h, m, p, st, clock, counts):
    """Exponential Adams, predictor-corrector (PECE), fixed step h, from t_out[0] through the
    instants t_out, writing Y[1:]. f(y) = L y + N(y) with L a finite-difference linearization
    (`exp_linearize`) taken every st[3] steps; L is integrated exactly through its eigenbasis and N by the
    polynomial through its last values (EXP_ORDER nodes: the predictor at 0, -h, -2h, the
    corrector at h, 0, -h), so each step costs two evaluations whatever the frequencies of L.

    Steps of h = m output intervals (m >= 1, the instants between from the corrector's formula at
    fractions j/m) or 1/p of one (p >= 1). Yh, Fh (EXP_ORDER, n): the last states and their
    right-hand sides, newest first; basis (2n+1, n) complex: [lam; V; Vi] of the last
    linearization, Wz and G (EXP_ORDER, n) complex: V^-1 Yh and V^-1 Fh; st (int64): [steps
    taken, history length, the step of the last linearization (-1: none), steps between two
    linearizations]; clock (1,): the time
    of Yh[0] (between two instants when p > 1). Returns (k, status,
    t) as `dopri5`, status STALE when the linearization is due (`exp_linearize`, then call
    again from instant k); counts (3,) += steps, evaluations."""
    K = EXP_ORDER
    n = Yh.shape[1]
    half = nq if 2 * nq == n else 0                     # the second-order basis: its products by blocks
    t = clock[0]
    y1 = np.empty(n)
    lam, V, Vi = basis[0], basis[1:n + 1], basis[n + 1:]
    Ep = Ec = np.zeros(n, dtype=np.complex128)
    Wp = Wc = np.zeros((K, n), dtype=np.complex128)
    Ed = np.zeros((max(m - 1, 1), n), dtype=np.complex128)
    Wd = np.zeros((max(m - 1, 1), K, n), dtype=np.complex128)
    order = -1
    k = 0
    while k < t_out.size - 1:
        if st[2] < 0 or st[0] - st[2] >= st[3]:
            clock[0] = t
            return k, STALE, t
        kp = min(st[1], K)                              # the order ramps up over the first steps
        if kp != order:
            order = kp
            Ep, Wp = exp_weights(lam, h, -np.arange(kp).astype(np.float64), 1.0)
            cn = 1.0 - np.arange(min(kp + 1, K)).astype(np.float64)
            Ec, Wc = exp_weights(lam, h, cn, 1.0)
            for j in range(1, m):
                Ej, Wj = exp_weights(lam, h, cn, j / m)
                Ed[j - 1], Wd[j - 1, :cn.size] = Ej, Wj
        kc = min(kp + 1, K)
        Nw = np.empty((kc, n), dtype=np.complex128)     # remainders at the corrector's nodes
        for j in range(kc - 1):
            Nw[j + 1] = G[j] - lam * Wz[j]
        wp = Ep * Wz[0]
        for j in range(kp):
            wp += Wp[j] * (G[j] - lam * Wz[j])
        cmv_real(V, wp, y1, half)
        gp = cmv(Vi, rhs(ev, t + h, y1, nq), half)
        Nw[0] = gp - lam * wp
        w1 = Ec * Wz[0]
        for j in range(kc):
            w1 += Wc[j] * Nw[j]
        for j in range(1, m):                          # the output instants inside the step
            if k + j <= t_out.size - 1:
                wd = Ed[j - 1] * Wz[0]
                for i in range(kc):
                    wd += Wd[j - 1, i] * Nw[i]
                cmv_real(V, wd, Y[k + j], half)
        cmv_real(V, w1, y1, half)
        f1 = rhs(ev, t + h, y1, nq)
        counts[2] += 2
        for j in range(K - 1, 0, -1):
            Yh[j], Fh[j], Wz[j], G[j] = Yh[j - 1], Fh[j - 1], Wz[j - 1], G[j - 1]
        Yh[0], Fh[0], Wz[0], G[0] = y1, f1, cmv(Vi, y1, half), cmv(Vi, f1, half)    # the real state's coordinates
        st[0] += 1
        st[1] = min(st[1] + 1, K)
        counts[0] += 1
        t = t + h
        code = state_code(y1, nq)
        if code == OK and not np.all(np.isfinite(f1)):
            code = NONFINITE
        clock[0] = t
        if code != OK:
            return k, code, t
        if st[0] % p == 0:
            if k + m <= t_out.size - 1:
                k += m
                Y[k] = y1
            else:                                       # the last step overran the last instant
                k = t_out.size - 1
            t = clock[0] = t_out[k]
    return t_out.size - 1, OK, t


@njit
def directional(ev, nq, t, y, f0, U):
    """J U (n, r) by forward differences of the right-hand side along the columns of U (n, r)
    at (t, y), f0 = rhs(t, y): r evaluations."""
    out = np.empty(U.shape)
    for c in range(U.shape[1]):
        d = 1e-7 * max(np.abs(y).max(), 1.0) / max(np.abs(U[:, c]).max(), 1e-300)
        out[:, c] = (rhs(ev, t, y + d * U[:, c], nq) - f0) / d
    return out


def exp_linearize(ev, nq, t, h, Yh, Fh, basis, Wz, G, st, counts, made) -> bool:
    """A new linear part L for `exp_adams` at (t, Yh[0]) (its eigenbasis into basis, the history
    into it: Wz, G).

    Where every coordinate's rate is its velocity (dq/dt = v: no quaternion, so 2 nq = n), L =
    [[0, I], [A, 0]] with A = d(qdd)/dq (`position_jacobian`, nq + 1 evaluations) and its eigenbasis
    from A's (`second_order_basis`), each time: the velocity coupling d(qdd)/dv (gyroscopic and
    Coriolis terms, proportional to the slow motion's rates) is left to the remainder N, which
    follows it as it follows any slow term. A with a zero eigenvalue gets the stiffness below.

    Otherwise every EXP_FULL-th time (and the first) the finite-difference Jacobian J and
    its eigenbasis; between, only the fast eigenvalues move (|lam h| > 1, where the remainder
    polynomial cannot follow a change of L): lam_i = w_i J v_i from two evaluations along the
    real and imaginary parts of each such eigenvector v_i (w_i its row of V^-1), the eigenvectors
    kept, unless one of them has turned (|J v_i - lam_i v_i| > EXP_TURN |lam_i v_i|): then in full.
    A J with no eigenbasis (`eigenbasis`: a defective one, as [[0, 1], [0, 0]] of a coordinate
    with no restoring force) gets a stiffness (0.01 / h)^2 on every coordinate (q and v aligned),
    which the remainder N = f - L y takes back; False when that has none either. made (1,):
    linearizations so far.
    counts (3,) += -, linearizations, evaluations."""
    n = Yh.shape[1]
    lam, V, Vi = basis[0], basis[1:n + 1], basis[n + 1:]
    if 2 * nq == n:
        A = position_jacobian(ev, nq, t, Yh[0])
        counts[2] += nq + 1
        e = second_order_basis(A)
        if e is None:                                   # the stiffness (0.01 / h)^2, as below
            e = second_order_basis(A - (0.01 / h) ** 2 * np.eye(nq))
        if e is None:
            return False
        lam[:], V[:], Vi[:] = e
        return _relinearized(Yh, Fh, Vi, Wz, G, st, counts, made)
    full = made[0] % EXP_FULL == 0
    if not full:
        fast = np.flatnonzero((np.abs(lam * h) > 1.0) & (lam.imag > 0.0))     # one of each conjugate pair
        if fast.size:
            JU = directional(ev, nq, t, Yh[0], Fh[0], np.ascontiguousarray(
                np.concatenate([V[:, fast].real, V[:, fast].imag], axis=1)))
            counts[2] += 2 * fast.size
            Jv = JU[:, :fast.size] + 1j * JU[:, fast.size:]
            new = np.einsum("ij,ji->i", Vi[fast], Jv)
            turned = np.linalg.norm(Jv - V[:, fast] * new, axis=0) / (np.abs(new) * np.linalg.norm(V[:, fast], axis=0))
            full = turned.max() > EXP_TURN     # the eigenvectors have turned: linearize in full
            if not full:
                old = lam[fast]
                lam[fast] = new
                for i, o in zip(fast, old):             # its conjugate partner
                    lam[np.argmin(np.abs(lam - np.conj(o)))] = np.conj(lam[i])
    if full:
        J = jacobian(ev, nq, t, Yh[0])
        counts[2] += n + 1
        e = eigenbasis(J)
        if e is None and 2 * nq == n:                  # a coordinate with no restoring force: give
            J[nq:, :nq] -= (0.01 / h) ** 2 * np.eye(nq)  # L one at w h = 0.01 (N takes it back)
            e = eigenbasis(J)
        if e is None:
            return False
        lam[:], V[:], Vi[:] = e
    return _relinearized(Yh, Fh, Vi, Wz, G, st, counts, made)


def _relinearized(Yh, Fh, Vi, Wz, G, st, counts, made) -> bool:
    """The history in the new eigen-coordinates (Wz, G) and the linearization counted: True."""
    Wz[:st[1]] = Yh[:st[1]] @ Vi.T
    G[:st[1]] = Fh[:st[1]] @ Vi.T
    made[0] += 1
    counts[1] += 1
    st[2] = st[0]
    return True


def _exp_adams(model, y0, t_out, Y, dt, output_dt, bar, chunk=50, judged=None, refresh=EXP_REFRESH):
    """Drive the compiled `exp_adams` over chunks of whole steps, linearizing between its calls
    every `refresh` steps: steps of m output intervals (m = round(dt / output_dt) when
    dt >= output_dt) or of 1/p of one (p = ceil(output_dt / dt))."""
    b, nq = bind(model, make_data(model)), model.nq
    ev = handle(b)
    f0 = rhs(ev, 0.0, y0, nq)
    if not (np.all(np.isfinite(y0)) and np.all(np.isfinite(f0))):
        return 0, 0, 1, failed("non-finite state", 0.0)
    m, p = (max(int(round(dt / output_dt)), 1), 1) if dt >= output_dt else (1, int(np.ceil(output_dt / dt - 1e-9)))
    h, n = output_dt * m / p, y0.size
    Yh, Fh = np.zeros((EXP_ORDER, n)), np.zeros((EXP_ORDER, n))
    Yh[0], Fh[0] = y0, f0
    basis = np.zeros((2 * n + 1, n), dtype=np.complex128)
    Wz, G = np.zeros((EXP_ORDER, n), dtype=np.complex128), np.zeros((EXP_ORDER, n), dtype=np.complex128)
    st = np.array([0, 1, -1, refresh], dtype=np.int64)
    clock, counts, made = np.zeros(1), np.zeros(3, dtype=np.int64), np.zeros(1, dtype=np.int64)
    counts[2] += 1

    def advance(k, k1):
        j = 0
        while True:
            i, code, t = exp_adams(ev, nq, Yh, Fh, basis, Wz, G, t_out[k + j:k1 + 1], Y[k + j:k1 + 1], h, m, p,
                                   st, clock, counts)
            j += i
            if code != STALE:
                return j, code, t
            if not exp_linearize(ev, nq, t, h, Yh, Fh, basis, Wz, G, st, counts, made):
                return j, NOT_DIAGONAL, t

    return _in_chunks(advance, t_out, counts, bar, m * int(np.ceil(chunk / m)), judged)


WHY[NOT_DIAGONAL] = "exp-adams: the linearization has no eigenbasis (a defective Jacobian)"
