"""Independent checks for geometric stiffening: the rotating cantilever written from the beam
equation in the rotating frame and nothing of flexmbd (its frequencies against the rate, and
the spin-up beam).

    rho A (v_tt - th_d^2 v) + E I v'''' - (N v')' = -rho A x th_dd,   N(x) = rho A th_d^2 (L^2 - x^2) / 2

(Euler-Bernoulli, hub radius 0, inextensible axis), on cubic Hermite elements with consistent
mass, the hub angle th on the spin-up profile of Kane, Ryan & Banerjee (1987):
th_d = (W / T) (t - sin(2 pi t / T) T / (2 pi)) for t < T, then W. Without the -(N v')' term it is
the linear floating-frame model, whose in-plane stiffness E I k^4 - rho A th_d^2 turns negative
once th_d passes the first bending frequency.

    python references/rotating_beam.py      # frequencies against the rate; spin-up peaks

Frequencies at a constant rate W (rotating frame, hub radius 0; Southwell): flapwise (out of the
plane of rotation) the eigenvalues of K + W^2 G against M, chordwise (in the plane) of
K + W^2 (G - M). Nondimensional (L = E I = rho A = 1), 200 elements: the first flapwise frequency
3.5160 at rest, 4.7973 at W = 3, 8.2996 at W = 7; chordwise 3.7435 and 4.4591.

Printed (20 and 40 elements agree to 4 digits at W = 6): Kane's beam (L 10 m, EI 1.4e4 N m^2,
rho A 1.2 kg/m, T 15 s): 0.2067 / 0.4003 / 0.5744 m at W = 2 / 4 / 6 rad/s with stiffening;
0.2298 m at W = 2 without (W = 4 and 6 grow without bound). tests/mbd/test_stiffening.py compares
flexmbd's peaks and frequencies with these.
"""

import numpy as np
from scipy.integrate import solve_ivp


def matrices(L: float, EI: float, rhoA: float, ne: int):
    """(K, M, G, f) of the clamped beam: stiffness, consistent mass, geometric stiffness per unit
    th_d^2 and load per unit th_dd (root DOFs removed; DOFs [v, v'] per node)."""
    h, n = L / ne, 2 * (ne + 1)
    K, M, G, f = np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n)), np.zeros(n)
    ke = EI / h ** 3 * np.array([[12, 6 * h, -12, 6 * h], [6 * h, 4 * h * h, -6 * h, 2 * h * h],
                                 [-12, -6 * h, 12, -6 * h], [6 * h, 2 * h * h, -6 * h, 4 * h * h]])
    me = rhoA * h / 420 * np.array([[156, 22 * h, 54, -13 * h], [22 * h, 4 * h * h, 13 * h, -3 * h * h],
                                    [54, 13 * h, 156, -22 * h], [-13 * h, -3 * h * h, -22 * h, 4 * h * h]])
    xg, wg = np.polynomial.legendre.leggauss(6)
    for e in range(ne):
        idx = [2 * e, 2 * e + 1, 2 * e + 2, 2 * e + 3]
        for xi, wi in zip(xg, wg):
            s = (xi + 1) / 2
            x = e * h + s * h
            N = np.array([1 - 3 * s * s + 2 * s ** 3, h * (s - 2 * s * s + s ** 3), 3 * s * s - 2 * s ** 3,
                          h * (-s * s + s ** 3)])
            dN = np.array([(-6 * s + 6 * s * s) / h, 1 - 4 * s + 3 * s * s, (6 * s - 6 * s * s) / h, -2 * s + 3 * s * s])
            G[np.ix_(idx, idx)] += wi * h / 2 * rhoA * 0.5 * (L * L - x * x) * np.outer(dN, dN)
            f[idx] += wi * h / 2 * rhoA * x * N
        K[np.ix_(idx, idx)] += ke
        M[np.ix_(idx, idx)] += me
    free = slice(2, n)
    return K[free, free], M[free, free], G[free, free], f[free]


def hub(t: float, W: float, T: float) -> tuple[float, float]:
    """(th_d, th_dd) of the spin-up profile."""
    if t >= T:
        return W, 0.0
    k = 2 * np.pi / T
    return W / T * (t - np.sin(k * t) / k), W / T * (1 - np.cos(k * t))


def tip(L, EI, rhoA, W, T, t_end, stiffening=True, ne=20):
    """(t, tip deflection) of the spin-up, 3001 samples."""
    K, M, G, f = matrices(L, EI, rhoA, ne)
    Minv, n = np.linalg.inv(M), f.size

    def rhs(t, y):
        wd, wdd = hub(t, W, T)
        Keff = K - wd * wd * M + (wd * wd * G if stiffening else 0.0)
        return np.concatenate([y[n:], Minv @ (-f * wdd - Keff @ y[:n])])
    sol = solve_ivp(rhs, (0.0, t_end), np.zeros(2 * n), t_eval=np.linspace(0.0, t_end, 3001), method="DOP853",
                    rtol=1e-9, atol=1e-12)
    return sol.t, sol.y[n - 2]


def rotating_frequencies(W_bar: float, ne: int = 200) -> tuple[np.ndarray, np.ndarray]:
    """(flapwise, chordwise) nondimensional frequencies omega sqrt(rho A L^4 / E I), lowest 3, of
    the cantilever rotating at W_bar = W sqrt(rho A L^4 / E I)."""
    K, M, G, _ = matrices(1.0, 1.0, 1.0, ne)
    flap = np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(M, K + W_bar ** 2 * G)).real)[:3])
    chord = np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(M, K + W_bar ** 2 * (G - M))).real)[:3])
    return flap, chord


if __name__ == "__main__":
    for W_bar in range(8):
        flap, chord = rotating_frequencies(W_bar)
        print(f"W_bar = {W_bar}: flapwise {np.round(flap, 4)}, chordwise {np.round(chord, 4)}")
    for W in (2.0, 4.0, 6.0):
        for stiffening in (True, False):
            t, v = tip(10.0, 1.4e4, 1.2, W, 15.0, 30.0, stiffening)
            print(f"W = {W:g} rad/s, stiffening {stiffening!s:5}: largest |tip| {np.abs(v).max():.4g} m"
                  f" (to t = {t[-1]:.1f} s)")
