"""Time integration of the Model's equations: y = [q; v], dy/dt = [qdot(q, v); aba(q, v)].

Methods (the case's `[integrator] method`):
  adams   variable-step, variable-order (1-12) Adams-Moulton predictor-corrector with
          functional iteration (PECE), as in the paper: ODEPACK's VODE through scipy
  rk45, dop853   explicit embedded Runge-Kutta pairs (scipy's solve_ivp), for comparison
  rk4     classical fixed-step Runge-Kutta, step `dt`
A state or acceleration that is not finite, or a velocity beyond DIVERGED, ends the run with
status 'failed: <why> at t = ...'; everything computed up to then is kept.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import ode, solve_ivp

from flexmbd import dynamics
from flexmbd.jit import njit
from flexmbd.model import FREE, SPHERICAL, Model, make_data
from flexmbd.spatial import quat_rate, quat_to_rot

DIVERGED = 1e8          # |v| beyond this (rad/s, m/s, modal units) counts as divergence


class Stop(Exception):
    """Raised inside the right-hand side to end a run that has failed."""


@dataclass
class Simulation:
    t: np.ndarray                   # (n,) output instants, s
    q: np.ndarray                   # (n, nq)
    v: np.ndarray                   # (n, nv)
    status: str = "ok"
    steps: int = 0
    rhs_evals: int = 0
    wall_s: float = 0.0
    settings: dict = field(default_factory=dict)


@njit
def qdot(M, q, v, out):
    """dq/dt (nq,) into `out`: v for 1-DOF joints and modes, quaternion rates for spherical and
    free joints (angular velocity in the body frame), R v for the free joint's position."""
    for i in range(1, M.parent.size):
        k, kv = M.jnt_qadr[i], M.jnt_vadr[i]
        if M.jnt_type[i] == SPHERICAL:
            out[k:k + 4] = quat_rate(q[k:k + 4], v[kv:kv + 3])
        elif M.jnt_type[i] == FREE:
            out[k:k + 4] = quat_rate(q[k:k + 4], v[kv:kv + 3])
            out[k + 4:k + 7] = quat_to_rot(q[k:k + 4]) @ v[kv + 3:kv + 6]
        elif M.jnt_nv[i] == 1:
            out[k] = v[kv]
        a, nm = M.body_madr[i], M.body_nm[i]
        out[a:a + nm] = v[a:a + nm]
    return out


def rhs_function(model: Model):
    """f(t, y) for y = [q; v], and a counter of its evaluations."""
    data = make_data(model)
    tau = np.zeros(model.nv)
    nq = model.nq
    dq = np.zeros(nq)
    count = [0]

    def f(t, y):
        count[0] += 1
        q, v, qdd_p, scale = dynamics.inputs(model, t, y[:nq], y[nq:])
        qdd = dynamics.aba(model.arrays, data, q, v, tau, scale, qdd_p)
        if not np.all(np.isfinite(qdd)):
            raise Stop(f"failed: non-finite acceleration at t = {t:.6g} s")
        qdot(model.arrays, q, v, dq)
        return np.concatenate([dq, qdd])

    return f, count


def simulate(model: Model, t_end: float, method: str = "adams", rtol: float = 1e-8, atol: float = 1e-10,
             max_step: float = 1e-3, dt: float = 1e-4, output_dt: float = 1e-3, progress: bool = True,
             label: str = "") -> Simulation:
    """Integrate from (model.q0, model.v0) over [0, t_end]; states sampled every output_dt."""
    n = int(round(t_end / output_dt))
    t_out = np.linspace(0.0, n * output_dt, n + 1)
    f, count = rhs_function(model)
    y0 = np.concatenate([model.q0, model.v0])
    settings = {"method": method, "rtol": rtol, "atol": atol, "max_step": max_step, "output_dt": output_dt}
    if method == "rk4":
        settings = {"method": method, "dt": dt, "output_dt": output_dt}
    bar = Progress(t_end, label) if progress else None
    Y = np.full((t_out.size, y0.size), np.nan)
    Y[0] = y0
    start = time.perf_counter()
    status, steps, k = "ok", 0, 0
    try:
        if method == "adams":
            k, steps, status = _adams(f, y0, t_out, Y, rtol, atol, max_step, bar)
        elif method == "rk4":
            k, steps = _rk4(f, y0, t_out, Y, dt, bar)
        else:
            k, steps, status = _solve_ivp(f, y0, t_out, Y, method, rtol, atol, max_step)
    except Stop as e:
        status = str(e)
    wall = time.perf_counter() - start
    if bar:
        bar.close()
    keep = slice(0, k + 1)
    if status == "ok" and np.abs(Y[k, model.nq:]).max(initial=0.0) > DIVERGED:
        status = f"failed: diverged (|v| > {DIVERGED:g}) at t = {t_out[k]:.6g} s"
    return Simulation(t=t_out[keep], q=Y[keep, :model.nq], v=Y[keep, model.nq:], status=status,
                      steps=steps, rhs_evals=count[0], wall_s=wall, settings=settings)


def _check(y, t):
    if not np.all(np.isfinite(y)):
        raise Stop(f"failed: non-finite state at t = {t:.6g} s")
    if np.abs(y).max() > DIVERGED:
        raise Stop(f"failed: diverged (|y| > {DIVERGED:g}) at t = {t:.6g} s")


def _adams(f, y0, t_out, Y, rtol, atol, max_step, bar):
    """VODE, Adams family (method flag MF = 10: functional iteration, no Jacobian)."""
    r = ode(f).set_integrator("vode", method="adams", with_jacobian=False, rtol=rtol, atol=atol,
                              order=12, max_step=max_step, nsteps=10 ** 8)
    r.set_initial_value(y0, 0.0)
    k = 0
    for k in range(1, t_out.size):
        y = r.integrate(t_out[k])
        if not r.successful():
            return k - 1, int(r._integrator.iwork[10]), \
                f"failed: VODE return code {r.get_return_code()} at t = {r.t:.6g} s"
        _check(y, t_out[k])
        Y[k] = y
        if bar:
            bar.update(t_out[k])
    return k, int(r._integrator.iwork[10]), "ok"


def _rk4(f, y0, t_out, Y, dt, bar):
    """Classical Runge-Kutta with the largest step <= dt that divides each output interval."""
    y, steps = y0.copy(), 0
    k = 0
    for k in range(1, t_out.size):
        t0, t1 = t_out[k - 1], t_out[k]
        m = max(int(np.ceil((t1 - t0) / dt - 1e-9)), 1)
        h = (t1 - t0) / m
        for s in range(m):
            t = t0 + s * h
            k1 = f(t, y)
            k2 = f(t + h / 2, y + h / 2 * k1)
            k3 = f(t + h / 2, y + h / 2 * k2)
            k4 = f(t + h, y + h * k3)
            y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        steps += m
        _check(y, t1)
        Y[k] = y
        if bar:
            bar.update(t1)
    return k, steps


def _solve_ivp(f, y0, t_out, Y, method, rtol, atol, max_step):
    sol = solve_ivp(f, (0.0, t_out[-1]), y0, method={"rk45": "RK45", "dop853": "DOP853"}[method],
                    t_eval=t_out, rtol=rtol, atol=atol, max_step=max_step)
    k = sol.y.shape[1] - 1
    Y[:k + 1] = sol.y.T
    stages = {"rk45": 6, "dop853": 12}[method]
    status = "ok" if sol.success else f"failed: {sol.message} at t = {sol.t[-1]:.6g} s"
    return k, sol.nfev // stages, status


class Progress:
    """A progress bar on stderr for runs that take longer than a couple of seconds."""

    def __init__(self, t_end: float, label: str, after_s: float = 2.0, every_s: float = 0.5):
        self.t_end, self.label, self.after, self.every = t_end, label, after_s, every_s
        self.start = self.last = time.perf_counter()
        self.shown = False
        self.tty = sys.stderr.isatty()
        if not self.tty:
            self.every = 10.0

    def update(self, t: float) -> None:
        now = time.perf_counter()
        if now - self.start < self.after or now - self.last < self.every:
            return
        self.last, self.shown = now, True
        frac = t / self.t_end
        bar = "#" * int(30 * frac)
        eta = (now - self.start) * (1 - frac) / max(frac, 1e-9)
        end = "\r" if self.tty else "\n"
        sys.stderr.write(f"{self.label} [{bar:<30}] t = {t:.3f}/{self.t_end:g} s, {now - self.start:.0f} s, "
                         f"~{eta:.0f} s left{end}")
        sys.stderr.flush()

    def close(self) -> None:
        if self.shown and self.tty:
            sys.stderr.write("\n")
