"""Closed loops: the constrained right-hand side (`constraints.Loops.rates`) integrated one output
interval at a time by a one-step method, the state projected onto the constraints at every
output instant (`simulate_loops`)."""

from __future__ import annotations

import time

import numpy as np
from scipy import integrate as scipy_ivp

from flexmbd.mbd.integrate.base import Ended, Simulation, Stop, _check, failed, reached
from flexmbd.mbd.integrate.stepping import _rk4_interval


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
