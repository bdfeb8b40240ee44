"""Time integration of the Model's equations: y = [q; v], dy/dt = [qdot(q, v); aba(q, v)].

Methods (the case's `[integrator] method`):
  dopri5  Dormand-Prince 5(4), variable step, compiled as a whole (`dopri5`): the step loop and
          every right-hand-side evaluation run without returning to Python
  fox-goodwin  Newmark beta = 1/12, gamma = 1/2, fixed step `dt`, compiled as a whole: Newton
          on the accelerations with a reused finite-difference iteration matrix (rtol/atol are
          its tolerance). Phase error (w h)^4/480, stable for w_max h < sqrt(6) like an explicit
          method, but one or two evaluations per step
  adams   variable-step, variable-order (1-12) Adams-Moulton predictor-corrector with
          functional iteration (PECE), as in the paper: ODEPACK's VODE through scipy
  rk45, dop853   explicit embedded Runge-Kutta pairs (scipy's solve_ivp), for comparison
  rk4     classical fixed-step Runge-Kutta, step `dt`
A state or acceleration that is not finite, or a velocity beyond DIVERGED (results.DIVERGED_V,
the divergence rule's bound on a velocity state), ends the run with a failed status at the time
it happened; every output instant reached before it is kept. A caller's `check` of the output
samples (the divergence rule on the channels: `solver.watch`) ends it too, at the first sample it
fails (kept, for the rule after the run to cut), judged as the samples come: after each chunk of
the compiled integrators, at each sample of the Python loops (adams, rk4).
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field

import numpy as np
from scipy import integrate as scipy_ivp
from scipy.integrate import ode, solve_ivp

from flexmbd import results
from flexmbd.dense import mv
from flexmbd.jit import compiling, njit
from flexmbd.kernel.bound import bind
from flexmbd.kernel.entry import handle, rhs
from flexmbd.model import Model, make_data
from flexmbd.progress import Progress

DIVERGED = results.DIVERGED_V    # |v| beyond this (rad/s, m/s, modal units) counts as divergence


class Stop(Exception):
    """Raised inside the right-hand side to end a run that has failed; args[0] is its Status."""


@dataclass
class Simulation:
    t: np.ndarray                   # (n,) output instants, s
    q: np.ndarray                   # (n, nq)
    v: np.ndarray                   # (n, nv)
    status: results.Status = field(default_factory=results.Status)
    steps: int = 0
    rhs_evals: int = 0
    wall_s: float = 0.0
    settings: dict = field(default_factory=dict)


def rhs_function(model: Model):
    """f(t, y) for y = [q; v] (the compiled `kernel.entry.rhs` behind a Python call), and a counter
    of its evaluations."""
    b, nq = bind(model, make_data(model)), model.nq
    ev = handle(b)
    count = [0]

    def f(t, y):
        count[0] += 1
        yd = rhs(ev, float(t), y, nq)
        if not np.all(np.isfinite(yd)):
            raise Stop(results.failed(NON_FINITE[1], t))
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


@njit
def dopri5(ev, nq, y, t_out, Y, h, rtol, atol, max_step, counts):
    """Integrate from (t_out[0], y) through the instants t_out, writing the state at each into
    Y[1:], the right-hand side evaluated through `ev` (`kernel.entry.handle`); steps are cut to
    land on them. Step size by the error of the embedded 4th-order
    solution (RMS norm, weights atol + rtol |y|) with Hairer's PI controller (alpha 0.17, beta 0.04).

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
            hs = min(h, max_step, t_out[k] - t)
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
                t += hs
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
             max_step: float = 1e-3, dt: float = 1e-4, output_dt: float = 1e-3, progress: bool = True,
             label: str = "", check=None) -> Simulation:
    """Integrate from (model.q0, model.v0) over [0, t_end]; states sampled every output_dt.
    check(t (m,), Q (m, nq), V (m, nv)) -> (i, Status) | None: the first of new output samples at
    which the run has failed (`judge`); the run ends there, that sample its last."""
    n = int(round(t_end / output_dt))
    t_out = np.linspace(0.0, n * output_dt, n + 1)
    f, count = rhs_function(model)
    y0 = np.concatenate([model.q0, model.v0])
    settings = {"method": method, "rtol": rtol, "atol": atol, "max_step": max_step, "output_dt": output_dt}
    if method == "rk4":
        settings = {"method": method, "dt": dt, "output_dt": output_dt}
    if method == "fox-goodwin":
        settings = {"method": method, "dt": dt, "rtol": rtol, "atol": atol, "output_dt": output_dt}
    bar = Progress(t_end, label) if progress else None
    Y = np.full((t_out.size, y0.size), np.nan)
    Y[0] = y0
    start = time.perf_counter()
    status, steps, k = results.Status(), 0, 0
    judged = None if check is None else lambda k0, k1: judge(check, t_out, Y, model.nq, k0, k1)
    try:
        if y0.size == 0:                # nothing moves (every joint fixed, no modes): every sample is the start
            k = t_out.size - 1
        elif method == "fox-goodwin":
            k, steps, evals, status = _fox_goodwin(model, y0, t_out, Y, dt, rtol, atol, bar, judged=judged)
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
        status = results.failed(WHY[code], t_out[k])
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
        raise Stop(results.failed("fox-goodwin needs q and v aligned (no spherical or free joints)", 0.0))
    b, nq = bind(model, make_data(model)), model.nq
    ev = handle(b)
    acc = np.ascontiguousarray(rhs(ev, 0.0, y0, nq)[nq:])
    if not (np.all(np.isfinite(y0)) and np.all(np.isfinite(acc))):
        return 0, 0, 1, results.failed("non-finite state", 0.0)
    y, counts = y0.copy(), np.zeros(3, dtype=np.int64)
    Jinv = np.ascontiguousarray(newmark_matrix(ev, nq, 0.0, y0, dt, 1.0 / 12.0, 0.5))
    counts[2] += y0.size + 2
    return _in_chunks(lambda k, k1: fox_goodwin(ev, nq, y, acc, t_out[k:k1 + 1], Y[k:k1 + 1], dt, rtol, atol,
                                                Jinv, counts), t_out, counts, bar, chunk, judged)


def warm_up(model: Model, method: str = "") -> None:
    """Compile (or load from the cache) the kernel's entry, `rhs` and the compiled integrator of
    `method` ("dopri5", "fox-goodwin"; none for any other), so that no compilation lands inside a
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


def _dopri5(model, y0, t_out, Y, rtol, atol, max_step, bar, chunk=50, judged=None):
    """Drive the compiled `dopri5` over chunks of output instants (progress and failures between)."""
    b, nq = bind(model, make_data(model)), model.nq
    ev = handle(b)
    f0 = rhs(ev, 0.0, y0, nq)
    if not (np.all(np.isfinite(y0)) and np.all(np.isfinite(f0))):
        return 0, 0, 1, results.failed("non-finite state", 0.0)
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
            return k, int(counts[0]), int(counts[2]), results.failed(WHY[code], t)
        hit = judged(k0 + 1, k) if judged and k > k0 else None
        if hit is not None:
            return hit[0], int(counts[0]), int(counts[2]), hit[1]
        if bar:
            bar.update(t_out[k])
    return k, int(counts[0]), int(counts[2]), results.Status()


def judge(check, t_out, Y, nq, k0, k1):
    """`check` (simulate's) of the output samples k0..k1 (rows of Y): (the first failed sample's
    index, its Status) or None."""
    hit = check(t_out[k0:k1 + 1], Y[k0:k1 + 1, :nq], Y[k0:k1 + 1, nq:])
    return None if hit is None else (k0 + hit[0], hit[1])


def reached(Y) -> int:
    """The last output instant (row of Y, NaN where not reached) with a finite state."""
    ok = np.flatnonzero(np.all(np.isfinite(Y), axis=1))
    return int(ok[-1]) if ok.size else 0


def _check(y, t, nq):
    """Stop a run whose state y = [q; v] breaks the divergence rule (`state_code`)."""
    code = state_code(y, nq)
    if code != OK:
        raise Stop(results.failed(WHY[code], t))


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
                results.failed(f"VODE return code {r.get_return_code()}{': ' + why if why else ''}", r.t)
        _check(y, t_out[k], nq)
        Y[k] = y
        if bar:
            bar.update(t_out[k])
        hit = judged(k, k) if judged else None
        if hit is not None:
            return k, int(r._integrator.iwork[10]), hit[1]
    return k, int(r._integrator.iwork[10]), results.Status()


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
    return t_out.size - 1, steps, results.Status()


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

PROJECTED = {"dopri5": "RK45", "rk45": "RK45", "dop853": "DOP853"}     # case method -> scipy's


def simulate_loops(loops, t_end: float, method: str = "dopri5", rtol: float = 1e-8, atol: float = 1e-10,
                   max_step: float = 1e-3, output_dt: float = 1e-3, progress: bool = True,
                   label: str = "") -> Simulation:
    """Integrate a tree closed by cut joints (`constraints.Loops`) from its assembled start
    (the case's values closed by `loops.close`) over [0, t_end], sampled every output_dt: each
    output interval by an explicit embedded Runge-Kutta pair (scipy's, continuing with the last
    step size) on the constrained rates, then the state projected onto the constraints
    (`loops.close`), which therefore hold to its tolerance at every output instant. Only the
    one-step methods (PROJECTED) restart cleanly after a projection."""
    model = loops.model
    n = int(round(t_end / output_dt))
    t_out = np.linspace(0.0, n * output_dt, n + 1)
    settings = {"method": method, "rtol": rtol, "atol": atol, "max_step": max_step, "output_dt": output_dt,
                "constraints": "projected at every output instant"}
    nq = model.nq
    Y = np.full((t_out.size, nq + model.nv), np.nan)
    count = [0]
    start = time.perf_counter()
    if method not in PROJECTED:
        return Simulation(t=t_out[:0], q=Y[:0, :nq], v=Y[:0, nq:], settings=settings, status=results.failed(
            f"integrator {method!r} cannot restart after each projection onto a closed loop's constraints "
            f"(use {', '.join(list(PROJECTED)[:-1])} or {list(PROJECTED)[-1]})", 0.0))

    def f(t, y):
        count[0] += 1
        return loops.rates(t, y[:nq], y[nq:])[0]

    bar = Progress(t_end, label) if progress else None
    status, steps, h, k = results.Status(), 0, None, 0
    try:
        Y[0] = np.concatenate(loops.close(0.0, model.q0, model.v0))
        for k in range(1, t_out.size):
            first = None if h is None else min(h, t_out[k] - t_out[k - 1])
            r = getattr(scipy_ivp, PROJECTED[method])(f, t_out[k - 1], Y[k - 1], t_out[k], rtol=rtol, atol=atol,
                                                     max_step=max_step, first_step=first)
            while r.status == "running":
                r.step()
                steps += 1
            if r.status == "failed":
                status = results.failed(r.message, r.t)
                k -= 1
                break
            h = r.step_size or None
            _check(r.y, t_out[k], nq)
            Y[k] = np.concatenate(loops.close(t_out[k], r.y[:nq], r.y[nq:]))
            if bar:
                bar.update(t_out[k])
    except Stop as e:
        status, k = e.args[0], reached(Y)
    except loops.NotClosed as e:
        when = "cannot close at the initial values" if k == 0 else "no longer closes"
        status = results.failed(f"the loop of joint {e.args[0]!r} {when} (residual {e.args[1]:.3g})", t_out[k])
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
    status = results.Status() if sol.success else results.failed(sol.message, sol.t[-1])
    return k, sol.nfev // stages, status
