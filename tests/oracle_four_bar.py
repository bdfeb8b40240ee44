"""A planar four-bar of rigid bars as one equation in the crank angle, for the loop tests.

Imports nothing from flexmbd. Ground pivots O = (0, 0) and D = (d, 0); crank a (angle th), coupler
b (absolute angle th3), rocker c (absolute angle th4), closed by a e^{i th} + b e^{i th3} =
d + c e^{i th4} on the branch with the coupler pin above the line B D. Bar k has mass m_k, its
centre of mass at half its length and inertia Ic_k about it (the plane's normal); gravity -g y.

The velocity coefficients k3 = dth3/dth, k4 = dth4/dth solve the loop's derivative, their
derivatives k3', k4' its second derivative; with the centres' coefficients u_k = dc_k/dth and
u'_k, the generalized inertia I(th) = sum m |u|^2 + Ic k^2 and Lagrange's equation
    I th'' + 1/2 I'(th) th'^2 + dV/dth = 0,   I' = 2 sum (m u . u' + Ic k k'),  V = g sum m c_y.
"""

import numpy as np
from scipy.integrate import solve_ivp


def angles(th, a, b, c, d):
    """(th3, th4): the coupler's and rocker's absolute angles at crank angle th."""
    B = a * np.array([np.cos(th), np.sin(th)])
    BD = np.array([d, 0.0]) - B
    L = np.hypot(*BD)
    x = (b * b - c * c + L * L) / (2 * L)
    h = np.sqrt(b * b - x * x)
    e = BD / L
    C = B + x * e + h * np.array([-e[1], e[0]])
    return np.arctan2(C[1] - B[1], C[0] - B[0]), np.arctan2(C[1], C[0] - d)


def coefficients(th, a, b, c, d):
    """(th3, th4, k3, k4, k3', k4')."""
    th3, th4 = angles(th, a, b, c, d)
    # i a e^{i th} + i b k3 e^{i th3} = i c k4 e^{i th4}, real and imaginary parts
    A = np.array([[-b * np.sin(th3), c * np.sin(th4)], [b * np.cos(th3), -c * np.cos(th4)]])
    k3, k4 = np.linalg.solve(A, [a * np.sin(th), -a * np.cos(th)])
    # -a e^{i th} + (i b k3' - b k3^2) e^{i th3} = (i c k4' - c k4^2) e^{i th4}
    rhs = np.array([a * np.cos(th) + b * k3 ** 2 * np.cos(th3) - c * k4 ** 2 * np.cos(th4),
                    a * np.sin(th) + b * k3 ** 2 * np.sin(th3) - c * k4 ** 2 * np.sin(th4)])
    k3d, k4d = np.linalg.solve(A, rhs)
    return th3, th4, k3, k4, k3d, k4d


def rates(th, a, b, c, d):
    """Per bar (u (2,), u' (2,), k, k', c_y coefficient u_y): the centre's coefficients."""
    th3, th4, k3, k4, k3d, k4d = coefficients(th, a, b, c, d)
    e = lambda p: np.array([np.cos(p), np.sin(p)])          # noqa: E731
    n = lambda p: np.array([-np.sin(p), np.cos(p)])         # noqa: E731
    crank = (a / 2 * n(th), -a / 2 * e(th), 1.0, 0.0)
    uB, uBd = a * n(th), -a * e(th)
    coupler = (uB + b / 2 * k3 * n(th3), uBd + b / 2 * (k3d * n(th3) - k3 ** 2 * e(th3)), k3, k3d)
    rocker = (c / 2 * k4 * n(th4), c / 2 * (k4d * n(th4) - k4 ** 2 * e(th4)), k4, k4d)
    return crank, coupler, rocker


def acceleration(th, w, lengths, masses, inertias, g):
    """th'' at crank angle th and rate w."""
    I = dI = dV = 0.0
    for (u, ud, k, kd), m, Ic in zip(rates(th, *lengths), masses, inertias):
        I += m * u @ u + Ic * k * k
        dI += 2 * (m * u @ ud + Ic * k * kd)
        dV += g * m * u[1]
    return -(0.5 * dI * w * w + dV) / I


def crank_angle(t, th0, w0, lengths, masses, inertias, g, rtol=1e-13):
    """(n,) the crank angle at instants t from (th0, w0), DOP853."""
    sol = solve_ivp(lambda _, y: [y[1], acceleration(y[0], y[1], lengths, masses, inertias, g)],
                    (t[0], t[-1]), [th0, w0], method="DOP853", t_eval=t, rtol=rtol, atol=rtol)
    return sol.y[0]
