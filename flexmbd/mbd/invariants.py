"""The inertia shape invariants of a reduced flexible body (docs/formulation.md §3): the
precompute `invariants(fb)` (node sums, once per body), `stack` (several bodies on one leading
axis, as the Model holds them), and the runtime terms rebuilt from them at every evaluation in
O(nm^2), with no loop over nodes: the contractions, the mass matrix M(eta) and the centrifugal
and Coriolis forces.

Node p of the deformed body sits at r_p = x0_p + Phi_t,p eta (body frame); its kinetic energy
is 1/2 m_p |v + w x r_p + Phi_t,p eta_d|^2 + 1/2 (w + Phi_r,p eta_d)^T J_p (w + Phi_r,p eta_d).
a~ is the skew matrix of a, and Phi_k = Phi_t,p[:, k] the translation of node p in mode k.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from flexmbd.mbd.compiled.jit import njit
from flexmbd.mbd.spatial import cross_force_into, skew, skew_rows


class Invariants(NamedTuple):
    """Invariants of one or more bodies, stacked on a leading body axis b and zero-padded to the
    largest mode count nm; in the formulas below the body index is dropped."""

    I1: np.ndarray     # (nb, 3, 3)          sum J_p - m_p x0~ x0~: rotational inertia of the undeformed body
    I2: np.ndarray     # (nb, nm, 3, 3)      -sum m_p (x0~ Phi_k~ + Phi_k~ x0~): its first-order change per mode
    I3: np.ndarray     # (nb, nm, nm, 3, 3)  -sum m_p Phi_k~ Phi_l~: its second-order change
    I4: np.ndarray     # (nb, 3)             sum m_p x0_p: first moment of mass of the undeformed body
    I5: np.ndarray     # (nb, 3, nm)         sum m_p Phi_t,p: change of the first moment per mode
    I6: np.ndarray     # (nb, 3, nm)         sum m_p x0~ Phi_t,p: rotation-mode coupling, translational part
    I7: np.ndarray     # (nb, nm, 3, nm)     sum m_p Phi_k~ Phi_t,p: change of the coupling (column k is zero)
    I8: np.ndarray     # (nb,)               sum m_p: mass
    I9: np.ndarray     # (nb, nm, nm)        sum Phi_r^T J_p Phi_r + m_p Phi_t^T Phi_t: modal mass
    I10: np.ndarray    # (nb, 3, nm)         sum J_p Phi_r,p: rotation-mode coupling, rotary part
    Db: np.ndarray     # (nb, nm, nm)        sum m_p D_p: foreshortening of the first moment (zero: no stiffening)
    Dh: np.ndarray     # (nb, nm, nm)        sum m_p x_p D_p: foreshortening of the inertia about y and z
    stiff: np.ndarray  # (nb,)               1.0 where Db, Dh are set (stiffening), 0.0 where they are zero and
    #                                          the terms they enter are skipped


def invariants(fb, stiffening: bool = False) -> Invariants:
    """The inertia shape invariants I1..I10 of one reduced body (leading axis of size 1), and with
    `stiffening` the foreshortening sums Db, Dh (docs/formulation.md §4b; zero without). `fb` holds
    the body's arrays by name, as `flexbody.FlexBody` does: node positions x0 (N, 3), masses m (N,),
    rotary inertias J (N, 3, 3), mode blocks Phi (N, 6, nm), and what the reduction adds (a solid's
    consistent-mass sums Mx0, MPt; the foreshortening D)."""
    m, x0 = fb.m, fb.x0
    Pt = fb.Phi[:, 3:, :]                                            # (N, 3, nm)
    if fb.Mx0.shape[0]:                                             # a consistent mass (a solid)
        I = mass_sums(x0, Pt, m, fb.Mx0, fb.MPt)
    else:
        I = mass_sums(x0, Pt, m, m[:, None] * x0, m[:, None, None] * Pt, fb.J, fb.Phi[:, :3, :])
    one = lambda a: np.ascontiguousarray(a, dtype=float)[None]
    Db = np.einsum("p,pkl->kl", m, fb.D) if stiffening else np.zeros((fb.n_modes, fb.n_modes))
    Dh = np.einsum("p,p,pkl->kl", m, x0[:, 0], fb.D) if stiffening else np.zeros((fb.n_modes, fb.n_modes))
    return Invariants(*(one(a) for a in I[:7]), np.array([I[7]]), one(I[8]), one(I[9]), Db=one(Db), Dh=one(Dh),
                      stiff=np.array([1.0 if stiffening else 0.0]))


def mass_sums(x0, Pt, m, Mx0, MPt, J=None, Pr=None) -> tuple:
    """I1..I10 of a body whose mass is a symmetric matrix Ms (N, N) over its nodes, given as the
    mass-weighted fields (docs/formulation.md §3): m = Ms 1 (N,), Mx0 = Ms x0 (N, 3) and
    MPt = Ms Pt (N, 3, nm), with x0 (N, 3) and Pt (N, 3, nm) the node positions and mode
    translations; J (N, 3, 3) and Pr (N, 3, nm) the rotary inertias and mode rotations of nodes
    that have them. A lumped body has Ms = diag(m); a solid its consistent scalar mass, so that
    every sum is the exact integral of rho over the interpolated fields.

    Each sum over p of m_p a_p b_p^T becomes sum_pq Ms_pq a_p b_q^T = sum_p a_p (Ms b)_p^T.
    """
    eye = np.eye(3)
    # second moments of the mass: x0 x0, x0 Phi_k, Phi_k Phi_l
    Q0 = np.einsum("pa,pb->ab", x0, Mx0)
    Q1 = np.einsum("pa,pbk->kab", x0, MPt)                          # (nm, 3, 3): sum m x0 Phi_k^T
    Q2 = np.einsum("pak,pbl->klab", Pt, MPt)                        # (nm, nm, 3, 3): sum m Phi_k Phi_l^T
    Q0 = 0.5 * (Q0 + Q0.T)

    # a~ b~ = b a^T - (a . b) I turns the skew products into second moments
    I1 = np.trace(Q0) * eye - Q0 + (0.0 if J is None else J.sum(axis=0))
    tr1 = np.trace(Q1, axis1=1, axis2=2)
    I2 = 2.0 * tr1[:, None, None] * eye - Q1 - Q1.transpose(0, 2, 1)
    tr2 = np.trace(Q2, axis1=2, axis2=3)
    I3 = tr2[:, :, None, None] * eye - Q2.transpose(1, 0, 2, 3)

    I4 = m @ x0
    I5 = np.einsum("p,pak->ak", m, Pt)
    I6 = np.einsum("pab,pbk->ak", skew_rows(x0), MPt)
    I7 = np.einsum("pkab,pbl->kal", skew_rows(Pt.transpose(0, 2, 1)), MPt)
    I9 = np.einsum("pak,pal->kl", Pt, MPt)
    I10 = np.zeros((3, Pt.shape[2]))
    if J is not None:
        I9 = I9 + np.einsum("pak,pab,pbl->kl", Pr, J, Pr)
        I10 = np.einsum("pab,pbk->ak", J, Pr)
    return I1, I2, I3, I4, I5, I6, I7, float(m.sum()), 0.5 * (I9 + I9.T), I10


def stack(invs: list, nm: int) -> Invariants:
    """Stack single-body invariants (None for a rigid body) into one, zero-padded to nm modes."""
    out = []
    for name, shape in zip(Invariants._fields, INV_SHAPES):
        full = np.zeros((len(invs),) + tuple(nm if d == "m" else d for d in shape))
        for b, inv in enumerate(invs):
            if inv is not None:
                x = getattr(inv, name)[0]
                full[(b,) + tuple(slice(0, n) for n in np.shape(x))] = x
        out.append(full)
    return Invariants(*out)


INV_SHAPES = [(3, 3), ("m", 3, 3), ("m", "m", 3, 3), (3,), (3, "m"), (3, "m"), ("m", 3, "m"), (),
              ("m", "m"), (3, "m"), ("m", "m"), ("m", "m"), ()]


# ---------------------------------------------------------------------------------------------
# the body-level terms, rebuilt from the invariants each evaluation (compiled; no node loops)


@njit(inline="always")
def contractions(inv, j, eta, eta_d, w):
    """The O(nm^2) contractions of I3 and I7 that the mass matrix, its rate and the quadratic
    forces share, for body j at modal state (eta, eta_d) and angular velocity w (3,).

    P_k = sum_l eta_l I3_kl; since I3_lk = I3_kl^T (I3_kl = sum_p m_p Phi_t,k~^T Phi_t,l~),
        I_O(eta)   = I1 + sum_k eta_k (I2_k + P_k)        rotational inertia about the origin (3, 3)
        N2_k(eta)  = dI_O/deta_k = I2_k + P_k + P_k^T
        I_O'       = sum_k eta_d_k N2_k                   (3, 3)
        wN2w_k     = w^T N2_k w                           (nm,)
        N1(eta)    = I6 + I10 + sum_k eta_k I7_k          rotation-mode block (3, nm)
        N1'        = sum_k eta_d_k I7_k                   (3, nm)
        wI7e_k     = w^T I7_k eta_d                       (nm,)

    Each sum runs with its innermost loop along the contiguous axis of I3 (a, b) and I7 (l),
    accumulating whole rows rather than one element at a time: 1.35 -> 0.93 us on the pendulum's
    12-mode beam in a compiled loop. The sums are the same, in the same order, but for wI7e_k,
    now summed over l row by row.
    """
    nm = eta.size
    I2, I3, I7 = inv.I2[j], inv.I3[j], inv.I7[j]
    P = np.zeros((nm, 3, 3))
    for k in range(nm):
        for l in range(nm):
            e = eta[l]
            for a in range(3):
                for b in range(3):
                    P[k, a, b] += e * I3[k, l, a, b]
    IO = inv.I1[j].copy()
    IOd = np.zeros((3, 3))
    wN2w = np.empty(nm)
    for k in range(nm):
        e, ed = eta[k], eta_d[k]
        s = 0.0
        for a in range(3):
            for b in range(3):
                n2 = I2[k, a, b] + P[k, a, b]
                IO[a, b] += e * n2
                n2 += P[k, b, a]                        # N2_k
                IOd[a, b] += ed * n2
                s += w[a] * n2 * w[b]
        wN2w[k] = s
    N1 = np.empty((3, nm))                              # I6 + I10, the body's own nm of the padded columns
    for a in range(3):
        for l in range(nm):
            N1[a, l] = inv.I6[j, a, l] + inv.I10[j, a, l]
    N1d = np.zeros((3, nm))
    wI7e = np.zeros(nm)
    for k in range(nm):
        e, ed = eta[k], eta_d[k]
        for a in range(3):
            s = 0.0
            for l in range(nm):
                x = I7[k, a, l]
                N1[a, l] += e * x
                N1d[a, l] += ed * x
                s += x * eta_d[l]
            wI7e[k] += w[a] * s
    return IO, IOd, wN2w, N1, N1d, wI7e


@njit(inline="always")
def first_moment(inv, j, eta):
    """c = I4 + I5 eta - 1/2 (eta^T Db eta) e_x (3,): the body's mass times its centre of mass,
    body frame (the last term: the foreshortening of the nodes, zero without stiffening)."""
    c = inv.I4[j].copy()
    for a in range(3):
        for k in range(eta.size):
            c[a] += inv.I5[j, a, k] * eta[k]
    if inv.stiff[j]:
        c[0] -= 0.5 * quadratic(inv.Db[j], eta, eta)
    return c


@njit(inline="always")
def quadratic(A, x, y):
    """x^T A y for A (nm, nm) (a zero-padded block is read to x's length)."""
    s = 0.0
    for k in range(x.size):
        for l in range(x.size):
            s += x[k] * A[k, l] * y[l]
    return s


@njit(inline="always")
def foreshortened(inv, j, eta, IO, N1x):
    """Add the foreshortening terms of a straight beam (docs/formulation.md §4b) to I_O (3, 3) and
    write the x row of dc/deta, I5_x - (Db eta)^T, into N1x (nm,): I_O gains
    -(eta^T Dh eta) diag(0, 1, 1), the beam's inertia about y and z lost as it shortens."""
    for l in range(eta.size):
        N1x[l] = inv.I5[j, 0, l]
    if not inv.stiff[j]:
        return
    sh = quadratic(inv.Dh[j], eta, eta)
    IO[1, 1] -= sh
    IO[2, 2] -= sh
    for l in range(eta.size):
        for k in range(eta.size):
            N1x[l] -= inv.Db[j, l, k] * eta[k]


@njit(inline="always")
def mass_matrix_into(inv, j, IO, c, N1, N1x, M):
    """Assemble M (6+nm, 6+nm) over [w; v; eta_d] from I_O, c, N1 and the x row N1x of dc/deta
    (I5 plus the foreshortening), into M:

        M = [ I_O(eta)   c~        N1(eta)  ]
            [ c~^T       I8 1      dc/deta  ]
            [ N1^T       (.)^T     I9       ]
    """
    nm = N1.shape[1]
    C = skew(c)
    for a in range(3):
        for b in range(3):
            M[a, b] = IO[a, b]
            M[a, 3 + b] = C[a, b]
            M[3 + b, a] = C[a, b]
            M[3 + a, 3 + b] = inv.I8[j] if a == b else 0.0
        for l in range(nm):
            M[a, 6 + l] = N1[a, l]
            M[6 + l, a] = N1[a, l]
            M[3 + a, 6 + l] = N1x[l] if a == 0 else inv.I5[j, a, l]
            M[6 + l, 3 + a] = M[3 + a, 6 + l]
    for k in range(nm):
        for l in range(nm):
            M[6 + k, 6 + l] = inv.I9[j, k, l]


@njit
def mass_matrix(inv, j, eta):
    """M(eta) (6+nm, 6+nm) over [w; v; eta_d] in the body frame (v: velocity of the body origin)."""
    z = np.zeros(eta.size)
    IO, _, _, N1, _, _ = contractions(inv, j, eta, z, np.zeros(3))
    N1x = np.empty(eta.size)
    foreshortened(inv, j, eta, IO, N1x)
    M = np.empty((6 + eta.size, 6 + eta.size))
    mass_matrix_into(inv, j, IO, first_moment(inv, j, eta), N1, N1x, M)
    return M


@njit
def inertia_and_forces_into(inv, j, eta, v, eta_d, M, h):
    """M(eta) (6+nm, 6+nm) and the centrifugal and Coriolis forces h (6+nm,) of the free body,
    from Lagrange's equations, sharing one set of contractions; written into M and h.

    Reference rows:  v x* (M_r. [v; eta_d]) + (dM_r./dt) [v; eta_d]      (momentum form)
    Modal rows:      N1'^T w - dT/deta,  dT/deta_k = 1/2 w^T N2_k w + w . (c_k x u) + w^T I7_k eta_d
    with c_k = dc/deta_k = I5_k - (Db eta)_k e_x; the (v_x, eta) block's rate -(Db eta_d)^T
    contributes -(Db eta_d)_k u_x to both d/dt dT/deta_d and dT/deta and cancels.
    """
    nm = eta.size
    w, u = v[:3], v[3:]
    IO, IOd, wN2w, N1, N1d, wI7e = contractions(inv, j, eta, eta_d, w)
    N1x = np.empty(nm)
    foreshortened(inv, j, eta, IO, N1x)
    c = first_moment(inv, j, eta)
    cd = np.zeros(3)                                    # c' = (dc/deta) eta_d
    for a in range(3):
        for k in range(nm):
            cd[a] += (N1x[k] if a == 0 else inv.I5[j, a, k]) * eta_d[k]
    # foreshortening rates: I_O' gains -2 (eta^T Dh eta_d) diag(0, 1, 1); w^T N2_k w gains
    # -2 (Dh eta)_k (w_y^2 + w_z^2); the (v_x, eta) block's rate adds -(eta_d^T Db eta_d) to p'_x
    if inv.stiff[j]:
        rh = quadratic(inv.Dh[j], eta, eta_d)
        IOd[1, 1] -= 2.0 * rh
        IOd[2, 2] -= 2.0 * rh
        wyz = w[1] * w[1] + w[2] * w[2]
        for k in range(nm):
            s = 0.0
            for l in range(nm):
                s += inv.Dh[j, k, l] * eta[l]
            wN2w[k] -= 2.0 * s * wyz
    mass_matrix_into(inv, j, IO, c, N1, N1x, M)
    # momentum p = M_r. [v; eta_d] and its rate through M only: pd = (dM_r./dt) [v; eta_d]
    p = np.empty(6)
    pd = np.empty(6)
    for a in range(6):
        s = 0.0
        for b in range(6):
            s += M[a, b] * v[b]
        for l in range(nm):
            s += M[a, 6 + l] * eta_d[l]
        p[a] = s
    for a in range(3):
        s = 0.0
        for b in range(3):
            s += IOd[a, b] * w[b]
        for l in range(nm):
            s += N1d[a, l] * eta_d[l]
        pd[a] = s
    pd[0] += cd[1] * u[2] - cd[2] * u[1]                # c~' u = c' x u
    pd[1] += cd[2] * u[0] - cd[0] * u[2]
    pd[2] += cd[0] * u[1] - cd[1] * u[0]
    pd[3] = w[1] * cd[2] - w[2] * cd[1] - quadratic(inv.Db[j], eta_d, eta_d)   # c~'^T w = w x c'
    pd[4] = w[2] * cd[0] - w[0] * cd[2]
    pd[5] = w[0] * cd[1] - w[1] * cd[0]
    cross_force_into(v, p, h)
    for a in range(6):
        h[a] += pd[a]
    wxu = np.cross(w, u)
    for k in range(nm):
        dT = 0.5 * wN2w[k] + wI7e[k]
        n1dw = 0.0
        for a in range(3):
            dT -= (N1x[k] if a == 0 else inv.I5[j, a, k]) * wxu[a]   # w . (c_k x u), c_k = dc/deta_k
            n1dw += N1d[a, k] * w[a]
        h[6 + k] = n1dw - dT
