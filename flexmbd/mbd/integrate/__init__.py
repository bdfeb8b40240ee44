"""Time integration of the Model's equations: y = [q; v], dy/dt = [qdot(q, v); aba(q, v)].

Methods (the case's `[integrator] method`):
  dopri5  Dormand-Prince 5(4), variable step, compiled as a whole (`dopri5`): the step loop and
          every right-hand-side evaluation run without returning to Python
  fox-goodwin  Newmark beta = 1/12, gamma = 1/2, fixed step `dt`, compiled as a whole: Newton
          on the accelerations with a reused finite-difference iteration matrix (rtol/atol are
          its tolerance). Phase error (w h)^4/480, stable for w_max h < sqrt(6) like an explicit
          method, but one or two evaluations per step. dopri5 and fox-goodwin also integrate a
          tree closed by cut joints (`simulate_loops`), with the loops' rates and projection inside
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
samples (the divergence rule on the channels: `inhouse.watch`) ends it too, at the first sample it
fails (kept, for the rule after the run to cut), judged as the samples come: after each chunk of
the compiled integrators, at each sample of the Python loops (adams, rk4).
"""

from __future__ import annotations

import time

import numpy as np

from flexmbd.mbd.compiled.bound import bind
from flexmbd.mbd.compiled.entry import handle
from flexmbd.mbd.compiled.jit import compiling
from flexmbd.mbd.integrate.base import (DIVERGED, DIVERGING, NEWTON, NON_FINITE, NONFINITE, OK, TOO_SMALL, WHY, Ended,
                                        Simulation, Stop, failed, judge, rates, reached, rhs_function, state_code)
from flexmbd.mbd.integrate.dopri5 import _dopri5, dopri5
from flexmbd.mbd.integrate.exp_adams import (EXP_REFRESH, NOT_DIAGONAL, _exp_adams, cmv, cmv_real,
                                             second_order_basis)
from flexmbd.mbd.integrate.fox_goodwin import _fox_goodwin, fox_goodwin, newmark_matrix
from flexmbd.mbd.integrate.loops import COMPILED as COMPILED_LOOPS, PROJECTED, simulate_loops
from flexmbd.mbd.integrate.stepping import _adams, _rk4, _solve_ivp
from flexmbd.mbd.model import Model, make_data

__all__ = ["COMPILED_LOOPS", "DIVERGED", "EXP_REFRESH", "NON_FINITE", "PROJECTED", "Ended", "Simulation", "Stop",
           "failed", "simulate", "simulate_loops", "warm_up", "cmv", "cmv_real", "second_order_basis",
           "OK", "NONFINITE", "DIVERGING", "TOO_SMALL", "NEWTON", "NOT_DIAGONAL", "WHY"]   # a run's end codes, their words


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


def warm_up(model: Model, method: str = "", loops=None) -> None:
    """Compile (or load from the cache) the kernel's entry, `rhs` and the compiled integrator of
    `method` ("dopri5", "fox-goodwin", "exp-adams"; none for any other), so that no compilation lands inside a
    timed run. Only what the run uses: each integrator compiles on its first use. With `loops`
    (`constraints.Loops`): its closure at the start, and dopri5 or fox-goodwin on its constrained
    rates (their first evaluation alone, no projection)."""
    with compiling():
        b, nq = bind(model, make_data(model)), model.nq
        ev = handle(b)
        y0 = np.concatenate([model.q0, model.v0])
        rhs_function(model)[0](0.0, y0)
        t, Y, counts = np.zeros(2), np.zeros((2, y0.size)), np.zeros(3, dtype=np.int64)
        cuts = None if loops is None else loops.arrays
        if loops is not None:
            try:
                loops.close(0.0, model.q0, model.v0)
            except loops.NotClosed:                 # the run says so
                pass
            rates(ev, cuts, 0.0, y0, nq)             # as the drivers call it, from Python
            t = t[:1]                                # the first evaluation alone: y0 is not closed
        if method == "dopri5":
            dopri5(ev, nq, y0.copy(), t, Y, 1e-6, 1e-6, 1e-8, 1e-3, counts, cuts)
        if method == "fox-goodwin" and model.nq == model.nv and model.nv:   # nothing to compile for: no states
            newmark_matrix(ev, nq, 0.0, y0, 1e-4, 1.0 / 12.0, 0.5, cuts)
            fox_goodwin(ev, nq, y0.copy(), np.zeros(model.nv), t, Y, 1e-4, 1e-6, 1e-8, np.eye(model.nv), counts,
                        cuts)
        if method == "exp-adams" and y0.size:      # one short step compiles it
            _exp_adams(model, y0, np.array([0.0, 1e-6]), np.zeros((2, y0.size)), 1e-6, 1e-6, None)
