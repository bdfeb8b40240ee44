"""The integrators stepped from Python: VODE's Adams (`_adams`), classical Runge-Kutta in equal
steps (`_rk4`), and scipy's embedded pairs (`_solve_ivp`: rk45, dop853)."""

from __future__ import annotations

import warnings

import numpy as np
from scipy.integrate import ode, solve_ivp

from flexmbd.mbd.integrate.base import Ended, Stop, _check, failed


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


def _solve_ivp(f, y0, t_out, Y, method, rtol, atol, max_step):
    sol = solve_ivp(f, (0.0, t_out[-1]), y0, method={"rk45": "RK45", "dop853": "DOP853"}[method],
                    t_eval=t_out, rtol=rtol, atol=atol, max_step=max_step)
    k = sol.y.shape[1] - 1
    Y[:k + 1] = sol.y.T
    stages = {"rk45": 6, "dop853": 12}[method]
    status = Ended() if sol.success else failed(sol.message, sol.t[-1])
    return k, sol.nfev // stages, status
