"""`analytic`: Euler–Bernoulli closed forms for a beam clamped at its root.

The continuous cantilever's modes (1 + cos(bL) cosh(bL) = 0) are summed for the undamped (or
modally damped) response to loads switched on at t0 and then held:
    w(x, t) = sum_n psi_n(x) eta_n(t),   eta_n'' + 2 zeta_n w_n eta_n' + w_n^2 eta_n = psi_n(a) P H(t - t0)
with zeta_n = zeta + beta w_n / 2 (modal damping zeta, material damping beta: C = beta K)
with psi_n mass-normalised (int rho A psi_n^2 dx = 1). Bending in the two planes is superposed;
stress at the fibre (y, z) is sigma = -E (y w_y'' + z w_z''), von Mises |sigma| (no torsion or
axial force under transverse loads through the axis). Also: frequencies of clamped-free and
pinned-pinned beams, and the static tip deflection.
"""

from __future__ import annotations

import time

import numpy as np
from scipy.optimize import brentq

from flexmbd import cases
from flexmbd.harness import channels, cost
from flexmbd.solvers import common

SETTINGS = {"modes": ("int+", 200)}     # continuous modes summed per bending plane
STYLE = {"color": "#8c564b", "marker": "D"}     # on the figures (report.figures.looks), solid lines


def version() -> str:
    return "1"


def applies(case) -> str:
    name, why = common.clamped_beam(case)
    if why:
        return why
    if case.bodies[name].shear:
        return "Euler–Bernoulli closed forms have no shear deformation"
    for lname, ld in case.loads.items():
        if ld.profile["type"] not in ("constant", "step"):
            return f"load {lname!r}: closed form only for constant and step loads"
        if abs(common.body_force(case, ld)[0]) > 0:
            return f"load {lname!r}: closed form only for transverse loads"
    if abs(common.gravity_body(case)[0]) > 0:
        return "closed form only for transverse gravity"
    for cname, c in case.channels.items():
        if c.kind not in ("deflection", *cases.STRESS_KINDS) or c.component == "x":
            return f"channel {cname!r} has no closed form here"
    return ""


def stages(case, t_end, settings) -> list:
    """The costly stages of a run (`cost.stages`). Closed forms: modes per plane x output samples
    (the modal responses) and x 4001 quadrature points (the modal loads of gravity), two planes."""
    n, k = settings["modes"], cost.samples(case, t_end)
    key = "solvers.analytic.modes" if n > 200 else cost.time_key(case, t_end, "integrator.output_dt",
                                                                   case.integrator.output_dt, 1e-3)
    return [cost.Stage(f"summing {n} continuous modes per plane over {k} samples", key,
                       memory=8.0 * n * (6 * k + 3 * 4001), seconds=2e-7 * n * k + 2e-4 * n)]


# ---------------------------------------------------------------------------------------------
# closed forms


def clamped_free_roots(n: int) -> np.ndarray:
    """First n roots b_n L of 1 + cos(z) cosh(z) = 0 (1.8751, 4.6941, 7.8548, ...)."""
    f = lambda z: np.cos(z) + 2.0 * np.exp(-z) / (1.0 + np.exp(-2.0 * z))    # 1/cosh(z), no overflow
    mids = (np.arange(1, n + 1) - 0.5) * np.pi
    return np.array([brentq(f, max(z - 0.6, 0.1), z + 0.6, xtol=1e-15) for z in mids])


def clamped_free_frequencies(E, I, rho, A, L, n) -> np.ndarray:
    """Natural frequencies (Hz) of a clamped-free Euler–Bernoulli beam."""
    bL = clamped_free_roots(n)
    return (bL / L) ** 2 * np.sqrt(E * I / (rho * A)) / (2.0 * np.pi)


def pinned_pinned_frequencies(E, I, rho, A, L, n) -> np.ndarray:
    """Natural frequencies (Hz) of a pinned-pinned Euler–Bernoulli beam."""
    k = np.arange(1, n + 1) * np.pi / L
    return k ** 2 * np.sqrt(E * I / (rho * A)) / (2.0 * np.pi)


def static_tip_deflection(P, E, I, L) -> float:
    """P L^3 / (3 E I)."""
    return P * L ** 3 / (3.0 * E * I)


def cantilever_shapes(bL: float, x: np.ndarray, L: float):
    """phi(x) and phi''(x)/b^2 of a clamped-free mode, normalised to int_0^L phi^2 dx = L.

    phi = cosh(bx) - cos(bx) - s (sinh(bx) - sin(bx)), rewritten with decaying exponentials so it
    stays exact for high modes (cosh(bL) overflows the significant digits beyond ~12 modes).
    """
    a = bL * x / L
    e = np.exp(-bL)
    den = 1.0 - e * e + 2.0 * e * np.sin(bL)
    s = (1.0 + e * e + 2.0 * e * np.cos(bL)) / den
    c2 = (np.sin(bL) - np.cos(bL) - e) / den          # (1 - s) e^{bL} / 2
    c1 = 0.5 * (1.0 + s)
    grow = c2 * np.exp(a - bL)
    decay = c1 * np.exp(-a)
    phi = decay + grow - np.cos(a) + s * np.sin(a)
    d2 = decay + grow + np.cos(a) - s * np.sin(a)
    return phi, d2


# ---------------------------------------------------------------------------------------------
# the solver


def modal_response(t, w, zeta, t0):
    """Response eta(t) / (static value) of a mode to a unit step at t0 (zeta: scalar or per mode):
    underdamped 1 - e^{-zw t}(cos w_d t + z w / w_d sin w_d t); overdamped (z > 1, a mode that
    material damping beta w / 2 makes so) 1 - [(1 + z/s) e^{(-z+s) w t} + (1 - z/s) e^{(-z-s) w t}] / 2,
    s = sqrt(z^2 - 1), both exponents negative (no overflow)."""
    tau = np.clip(t - t0, 0.0, None)
    zeta = np.broadcast_to(np.asarray(zeta, dtype=float), np.shape(w))
    under = zeta < 1.0
    z_u = np.where(under, zeta, 0.0)
    wd = w * np.sqrt(1.0 - z_u ** 2)
    h_u = 1.0 - np.exp(-z_u * w * tau) * (np.cos(wd * tau) + z_u * w / wd * np.sin(wd * tau))
    z_o = np.where(under, 2.0, zeta)
    s = np.sqrt(z_o ** 2 - 1.0)
    h_o = 1.0 - 0.5 * ((1 + z_o / s) * np.exp((-z_o + s) * w * tau) + (1 - z_o / s) * np.exp((-z_o - s) * w * tau))
    return np.where(under, h_u, h_o) * (t >= t0)


def trajectory(case, name: str, t, eta: dict, bL) -> channels.Trajectory:
    """The channels' view of the modal responses eta {axis: ((n, modes), norm)}: positions
    x + (0, u_y, u_z) in the body frame (the clamp's), curvatures kappa_z = u_y'', kappa_y = -u_z''."""
    L = case.bodies[name].length
    shapes = lambda x: [cantilever_shapes(z, np.array([x]), L) for z in bL]
    u = lambda x, axis: eta[axis][0] @ (np.array([s[0][0] for s in shapes(x)]) * eta[axis][1])
    d2 = lambda x, axis: eta[axis][0] @ (np.array([s[1][0] for s in shapes(x)]) * (bL / L) ** 2 * eta[axis][1])
    xs = channels.points_needed(case, name)
    zero = np.zeros(len(t))
    beam = channels.Beam(
        length=L, points={x: np.column_stack([np.full(len(t), x), u(x, 1), u(x, 2)]) for x in xs},
        x0={x: np.array([x, 0.0, 0.0]) for x in xs}, root=np.tile(np.eye(3), (len(t), 1, 1)),
        strains={float(c.at): np.column_stack([zero, -d2(c.at, 2), d2(c.at, 1), zero])
                 for c in case.channels.values() if c.kind in cases.STRESS_KINDS})
    return channels.Trajectory(t=t, beams={name: beam})


def run(case, t_end, settings):
    from flexmbd.harness.results import Result
    t_start = time.perf_counter()
    name, _ = common.clamped_beam(case)
    body = case.bodies[name]
    sec = body.geometry
    E, rho, A, L = body.material.E, body.material.rho, sec.A, body.length
    beta = body.stiffness_damping                       # material damping: zeta_n = zeta + beta w_n / 2
    n = settings.get("modes", SETTINGS["modes"][1])
    bL = clamped_free_roots(n)
    t = common.sample_times(case, t_end)
    setup_s = time.perf_counter() - t_start

    t_solve = time.perf_counter()
    # modal loads per plane (axis 1: y, bending about z with Iz; axis 2: z, about y with Iy)
    xq = np.linspace(0.0, L, 4001)
    g = common.gravity_body(case)
    eta = {}
    for axis, I in ((1, sec.Iz), (2, sec.Iy)):
        w = (bL / L) ** 2 * np.sqrt(E * I / (rho * A))
        norm = 1.0 / np.sqrt(rho * A * L)
        zeta = body.damping_ratio + 0.5 * beta * w
        resp = np.zeros((t.size, n))
        for ld in case.loads.values():
            P = common.body_force(case, ld)[axis]
            if P == 0.0:
                continue
            p = ld.profile
            t0 = p["t0"] if p["type"] == "step" else 0.0
            # the continuous beam's load acts where the case puts it (not snapped to a node)
            psi_a = np.array([cantilever_shapes(z, np.array([ld.point.x]), L)[0][0] for z in bL]) * norm
            resp += modal_response(t[:, None], w, zeta, t0) * (psi_a * P / w ** 2)
        if g[axis] != 0.0:
            integral = np.array([np.trapezoid(cantilever_shapes(z, xq, L)[0], xq) for z in bL]) * norm
            resp += modal_response(t[:, None], w, zeta, 0.0) * (rho * A * g[axis] * integral / w ** 2)
        eta[axis] = (resp, norm)

    traj = trajectory(case, name, t, eta, bL)
    wall_s = time.perf_counter() - t_solve
    return Result(solver="analytic", case=case.name, t=t, wall_s=wall_s,
                  setup_s=setup_s, steps=int(t.size), rhs_evals=0,
                  settings={"modes_per_plane": n, "theory": "Euler-Bernoulli, continuous"}, trajectory=traj)
