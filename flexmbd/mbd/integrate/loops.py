"""Closed loops: the constrained right-hand side integrated by a one-step method, the state
projected onto the constraints at every output instant (`simulate_loops`): dopri5 and
fox-goodwin compiled as a whole (`dopri5.dopri5`, `fox_goodwin.fox_goodwin` with the cuts), the
others one output interval at a time from Python on `constraints.Loops.rates`."""

from __future__ import annotations

import time

import numpy as np
from scipy import integrate as scipy_ivp

from flexmbd.mbd.integrate.base import NOT_CLOSED, WHY, Ended, Simulation, Stop, _check, failed, reached
from flexmbd.mbd.integrate.dopri5 import _dopri5
from flexmbd.mbd.integrate.fox_goodwin import _fox_goodwin
from flexmbd.mbd.integrate.stepping import _rk4_interval


# ---------------------------------------------------------------------------------------------
# closed loops: the constrained right-hand side, projected at every output instant

PROJECTED = {"dopri5": None, "fox-goodwin": None, "rk45": "RK45", "dop853": "DOP853", "rk4": None}  # -> scipy's
COMPILED = ("dopri5", "fox-goodwin")        # compiled as a whole, the cuts' rates and projection inside


def simulate_loops(loops, t_end: float, method: str = "dopri5", rtol: float = 1e-8, atol: float = 1e-10,
                   max_step: float = 1e-3, output_dt: float = 1e-3, progress=None,
                   dt: float = 1e-4) -> Simulation:
    """Integrate a tree closed by cut joints (`constraints.Loops`) from its assembled start
    (the case's values closed by `loops.close`) over [0, t_end], sampled every output_dt: compiled
    as a whole by the Dormand-Prince pair (`dopri5`, its step size going on across the instants)
    or by Fox-Goodwin in equal steps <= dt (`fox-goodwin`, Newton to rtol, atol), or each output
    interval from Python by scipy's embedded pairs (rk45, dop853, continuing with the last step
    size) or classical Runge-Kutta in equal steps <= dt (`rk4`), on the constrained rates
    (`progress` told as `simulate`'s); the state is projected onto the constraints
    (`constraints.project`) at every output instant, where they therefore hold to its tolerance.
    Only the one-step methods (PROJECTED) restart cleanly after a projection."""
    model = loops.model
    n = int(round(t_end / output_dt))
    t_out = np.linspace(0.0, n * output_dt, n + 1)
    settings = {"method": method, "output_dt": output_dt, "constraints": "projected at every output instant",
                **({"dt": dt} if method == "rk4" else {"dt": dt, "rtol": rtol, "atol": atol}
                   if method == "fox-goodwin" else {"rtol": rtol, "atol": atol, "max_step": max_step})}
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
        if method in COMPILED:
            y0, cuts = Y[0].copy(), loops.arrays
            k, steps, count[0], status = (
                _dopri5(model, y0, t_out, Y, rtol, atol, max_step, bar, cuts=cuts) if method == "dopri5"
                else _fox_goodwin(model, y0, t_out, Y, dt, rtol, atol, bar, cuts=cuts))
            if status.why == WHY[NOT_CLOSED]:
                fail = loops.arrays.fail
                status = failed(not_closed(loops.row_joint(int(fail[1])), fail[0], k + 1), status.t)
        else:
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
        status = failed(not_closed(e.args[0], e.args[1], k), t_out[k])
        k = max(k - 1, 0)
    if bar:
        bar.close()
    keep = slice(0, k + 1 if np.all(np.isfinite(Y[0])) else 0)
    return Simulation(t=t_out[keep], q=Y[keep, :nq], v=Y[keep, nq:], status=status, steps=steps,
                      rhs_evals=count[0], wall_s=time.perf_counter() - start, settings=settings)


def not_closed(joint: str, residual: float, k: int) -> str:
    """Why a run ended when the loop of `joint` did not close at output instant k (0: the start)
    to within `residual` (m or rad)."""
    when = "cannot close at the initial values" if k == 0 else "no longer closes"
    return f"the loop of joint {joint!r} {when} (residual {residual:.3g})"
