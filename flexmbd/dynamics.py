"""The recursive algorithms, compiled, as free functions of the Model's arrays M and a Data D.

docs/formulation.md §4-§5. Forward dynamics is the articulated-body algorithm extended to modal
flexible bodies:
  pass 1 (root -> leaves): joint and node transforms, velocities, velocity-product terms, and
      each body's own inertia, velocity-product, elastic and external forces;
  pass 2 (leaves -> root): articulated inertias over (a_i, eta_dd_i); a flexible body's own
      modal accelerations are eliminated first, then its joint's; what remains is projected
      into the parent's reference *and modal* equations through the connecting node;
  pass 3 (root -> leaves): joint accelerations, spatial accelerations, modal accelerations.
Gravity enters as a fictitious base acceleration a_0 = [0; -g].

The compiled entry points take a `model.Bound` b, the Model's arrays M = b.M and a Data D = b.D
as one object: numba passes it as a single pointer where the pair would cross every call as some
600 scalars, and M and D are structrefs, so reading a field takes a reference to that one array
(docs/performance.md). The passes inlined into `aba` take (M, D), and work on the NamedTuples
too. The Python-level entry points at the bottom take the Model, or a Bound (`forward`).
"""

from __future__ import annotations

import numpy as np

from flexmbd.dense import (back_subst_vec, cholesky, congruence_add_into, forward_subst, inv_spd, mm, mm_into, mtm,
                           mtv, mtv_add_into, mv, mv_add_into, mv_into)
from flexmbd.flexbody import inertia_and_forces_into, mass_matrix
from flexmbd.jit import PURE_PYTHON, njit
from flexmbd.model import FREE, PRISMATIC, REVOLUTE, SPHERICAL, Bound, Data, Model, bind, bound_at
from flexmbd.profiles import load_at, motion_at
from flexmbd.spatial import (cross_force_into, cross_motion, cross_motion_into, expm_so3, inertia_parts, jac_left_so3,
                             jac_left_so3_dot, plux, plux_parts, quat_to_rot, xlt, xmul_into, xrot)


# ---------------------------------------------------------------------------------------------
# kinematics of one joint and of one node


@njit(inline="always")
def jcalc(jtype, axis, q, k, XJ, S):
    """Joint transform XJ (6, 6), triad -> body, and motion subspace S (6, 6; first nv columns),
    written into XJ and S."""
    XJ[:] = 0.0
    S[:] = 0.0
    if jtype == REVOLUTE:                               # E = exp(q axis~)^T
        c, s = np.cos(q[k]), np.sin(q[k])
        x, y, z = axis[0], axis[1], axis[2]
        XJ[0, 0], XJ[0, 1], XJ[0, 2] = c + (1 - c) * x * x, (1 - c) * x * y + s * z, (1 - c) * x * z - s * y
        XJ[1, 0], XJ[1, 1], XJ[1, 2] = (1 - c) * y * x - s * z, c + (1 - c) * y * y, (1 - c) * y * z + s * x
        XJ[2, 0], XJ[2, 1], XJ[2, 2] = (1 - c) * z * x + s * y, (1 - c) * z * y - s * x, c + (1 - c) * z * z
        for a in range(3):
            for b in range(3):
                XJ[3 + a, 3 + b] = XJ[a, b]
            S[a, 0] = axis[a]
    elif jtype == PRISMATIC:
        XJ[:] = xlt(axis * q[k])
        S[3:, 0] = axis
    elif jtype == SPHERICAL:
        XJ[:] = xrot(quat_to_rot(q[k:k + 4]).T)
        for a in range(3):
            S[a, a] = 1.0
    elif jtype == FREE:
        XJ[:] = plux(quat_to_rot(q[k:k + 4]).T, q[k + 4:k + 7])
        for a in range(6):
            S[a, a] = 1.0
    else:
        for a in range(6):
            XJ[a, a] = 1.0


@njit
def node_kinematics(Phi, x0, eta, eta_d):
    """Deformed node with mode block Phi (6, nm) and undeformed position x0 (3,): Xn (6, 6) body ->
    node frame, Sn (6, nm) modal motion subspace in the node frame, cn (6,) velocity product.

    Node frame: origin r = x0 + Phi_t eta, rotation exp(theta~), theta = Phi_r eta. Relative
    velocity (node frame): [E J(theta) theta_d; E Phi_t eta_d], E = exp(theta~)^T, J the left
    Jacobian of exp; cn = [E J'(theta) theta_d; -E (w_rel x Phi_t eta_d)].
    """
    Pr, Pt = Phi[:3], Phi[3:]
    theta, theta_d = mv(Pr, eta), mv(Pr, eta_d)
    E = expm_so3(theta).T
    Xn = plux(E, x0 + mv(Pt, eta))
    Jl = jac_left_so3(theta)
    Sn = np.empty((6, eta.size))
    Sn[:3] = mm(E, mm(Jl, Pr))
    Sn[3:] = mm(E, Pt)
    w_rel = mv(Jl, theta_d)
    cn = np.empty(6)
    cn[:3] = mv(E, jac_left_so3_dot(theta, theta_d))
    cn[3:] = -mv(E, np.cross(w_rel, mv(Pt, eta_d)))
    return Xn, Sn, cn


# ---------------------------------------------------------------------------------------------
# pass 1


@njit(inline="always")
def forward_kinematics(M, D, q, v):
    """Fill XJ, S, vJ, Xup, X0, U, v, c from (q, v)."""
    for i in range(1, M.parent.size):
        lam = M.parent[i]
        kv, nvj = M.jnt_vadr[i], M.jnt_nv[i]
        jcalc(M.jnt_type[i], M.jnt_axis[i], q, M.jnt_qadr[i], D.XJ[i], D.S[i])
        mv_into(D.S[i, :, :nvj], v[kv:kv + nvj], D.vJ[i])
        if M.jnt_node[i] >= 0:                          # triad on a node of a flexible parent
            XJT = mm(D.XJ[i], M.jnt_Xtriad[i])
            a, nm = M.body_madr[lam], M.body_nm[lam]
            eta_d = v[a:a + nm]
            Xn, Sn, cn = node_kinematics(M.jnt_Phi[i, :, :nm], M.jnt_x0[i], q[a:a + nm], eta_d)
            vn_rel = mv(Sn, eta_d)
            vn = mv(Xn, D.v[lam]) + vn_rel
            mm_into(XJT, Xn, D.Xup[i])
            mm_into(XJT, Sn, D.U[i, :, :nm])
            D.v[i] = mv(XJT, vn) + D.vJ[i]
            D.c[i] = mv(XJT, cn + cross_motion(vn, vn_rel)) + cross_motion(D.v[i], D.vJ[i])
        else:
            xmul_into(D.XJ[i], M.jnt_Xtriad[i], D.Xup[i])
            mv_into(D.Xup[i], D.v[lam], D.v[i])
            for r in range(6):
                D.v[i, r] += D.vJ[i, r]
            cross_motion_into(D.v[i], D.vJ[i], D.c[i])
        xmul_into(D.Xup[i], D.X0[lam], D.X0[i])


@njit(inline="always")
def external_forces(M, D, q):
    """D.F (nb+1, 6+nm) <- generalized external forces of the point loads at their factors D.scale,
    body frame; after pass 1.

    A force f at the deformed point r = x0 + Phi_t eta: [r x f; f; Phi_t^T f].
    """
    F = D.F
    F[:] = 0.0
    for k in range(M.load_body.size):
        i = M.load_body[k]
        a, nm = M.body_madr[i], M.body_nm[i]
        Pt = M.load_Phi[k, 3:, :nm]
        f = M.load_force[k] * D.scale[k]
        if M.load_global[k]:
            f = mv(D.X0[i, :3, :3], f)
        r = M.load_point[k] + mv(Pt, q[a:a + nm])
        F[i, :3] += np.cross(r, f)
        F[i, 3:6] += f
        F[i, 6:6 + nm] += mtv(Pt, f)


@njit(inline="always")
def body_forces(M, D, q, v):
    """MA_i, pA_i <- each body's own inertia and its velocity-product, elastic and external (D.F)
    forces (the leading 6+nm_i block; the rest of the padded row is never read)."""
    for i in range(1, M.parent.size):
        a, nm = M.body_madr[i], M.body_nm[i]
        MA, pA = D.MA[i, :6 + nm, :6 + nm], D.pA[i, :6 + nm]
        if nm == 0:
            MA[:] = M.body_inertia[i]
            mv_into(MA, D.v[i], D.Iv[i])
            cross_force_into(D.v[i], D.Iv[i], pA)
        else:
            eta, eta_d = q[a:a + nm], v[a:a + nm]
            inertia_and_forces_into(M.inv, i, eta, D.v[i], eta_d, MA, pA)
            mv_add_into(M.flex_K[i, :nm, :nm], eta, pA[6:])
            mv_add_into(M.flex_C[i, :nm, :nm], eta_d, pA[6:])
        for r in range(6 + nm):
            pA[r] -= D.F[i, r]


# ---------------------------------------------------------------------------------------------
# forward dynamics


@njit
def aba(b, q, v, tau):
    """Generalized accelerations (nv,) — joint and modal — by the articulated-body algorithm:
    the workspace's D.qdd itself (copy it to keep it).

    b: a `model.Bound` (arrays M, workspace D); tau (nv,): joint forces (modal entries ignored).
    Set by `prescribed` first: D.scale (nl,), the point loads' profile factors, and D.qdd_p (nv,),
    the accelerations of joints with jnt_prescribed set.
    """
    M, D = b.M, b.D
    nb = M.parent.size - 1
    forward_kinematics(M, D, q, v)
    external_forces(M, D, q)
    body_forces(M, D, q, v)

    # pass 2: leaves to root
    for i in range(nb, 0, -1):
        nm = M.body_nm[i]
        MA, pA = D.MA[i, :6 + nm, :6 + nm], D.pA[i, :6 + nm]
        IA, pa = D.Ia[i], D.pa[i]
        for r in range(6):
            pa[r] = pA[r]
            for k in range(6):
                IA[r, k] = MA[r, k]
        if nm > 0:                                      # eliminate the body's own modes
            L = cholesky(MA[6:, 6:])                    # D = L L^T
            W = forward_subst(L, MA[6:, :6])            # L^-1 B^T
            y = forward_subst(L, pA[6:].reshape(nm, 1))[:, 0]
            D.Lm[i, :nm, :nm] = L
            D.W[i, :nm] = W
            D.y[i, :nm] = y
            IA -= mtm(W, W)                             # A - B D^-1 B^T
            pa -= mtv(W, y)                             # p_r - B D^-1 p_m
        c, kv, nvj = D.c[i], M.jnt_vadr[i], M.jnt_nv[i]
        if M.jnt_prescribed[i]:
            mv_add_into(IA, c + mv(D.S[i, :, :nvj], D.qdd_p[kv:kv + nvj]), pa)
        elif nvj == 1:                                  # the same, with scalar d and u
            S, Uj = D.S[i, :, 0], D.Uj[i, :, 0]
            d, u = 0.0, tau[kv]
            for r in range(6):
                s = 0.0
                for k in range(6):
                    s += IA[r, k] * S[k]
                Uj[r] = s
                d += S[r] * s
                u -= S[r] * pa[r]
            dinv = 1.0 / d
            D.dinv[i, 0, 0], D.u[i, 0] = dinv, u
            for r in range(6):
                for k in range(6):
                    IA[r, k] -= Uj[r] * Uj[k] * dinv
            mv_add_into(IA, c, pa)
            for r in range(6):
                pa[r] += Uj[r] * u * dinv
        elif nvj > 1:
            S = D.S[i, :, :nvj]
            Uj, dinv, u = D.Uj[i, :, :nvj], D.dinv[i, :nvj, :nvj], D.u[i, :nvj]
            mm_into(IA, S, Uj)
            dinv[:] = inv_spd(mtm(S, Uj))
            u[:] = tau[kv:kv + nvj] - mtv(S, pa)
            IA -= mm(Uj, mm(dinv, Uj.T))                # Ia = IA - U d^-1 U^T
            mv_add_into(IA, c, pa)                      # pa + Ia c + U d^-1 u
            mv_add_into(Uj, mv(dinv, u), pa)
        else:
            mv_add_into(IA, c, pa)

        # project into the parent: G = [Xup, U] onto (a_lam, eta_dd_lam)
        lam = M.parent[i]
        if lam == 0:
            continue
        if M.jnt_node[i] >= 0:
            n = 6 + M.body_nm[lam]
            G = np.empty((6, n))
            G[:, :6] = D.Xup[i]
            G[:, 6:] = D.U[i, :, :n - 6]
        else:
            n, G = 6, D.Xup[i]
        congruence_add_into(G, IA, D.MA[lam, :n, :n], D.IG[:, :n])
        mtv_add_into(G, pa, D.pA[lam, :n])

    # pass 3: root to leaves
    D.a[0, :3] = 0.0
    D.a[0, 3:] = -M.gravity
    for i in range(1, nb + 1):
        lam, a = M.parent[i], D.a[i]
        mv_into(D.Xup[i], D.a[lam], a)
        for r in range(6):
            a[r] += D.c[i, r]
        if M.jnt_node[i] >= 0:
            ma, nml = M.body_madr[lam], M.body_nm[lam]
            mv_add_into(D.U[i, :, :nml], D.qdd[ma:ma + nml], a)
        kv, nvj = M.jnt_vadr[i], M.jnt_nv[i]
        if M.jnt_prescribed[i]:
            D.qdd[kv:kv + nvj] = D.qdd_p[kv:kv + nvj]
        elif nvj == 1:
            s = D.u[i, 0]
            for r in range(6):
                s -= D.Uj[i, r, 0] * a[r]
            D.qdd[kv] = D.dinv[i, 0, 0] * s
        elif nvj > 1:
            D.qdd[kv:kv + nvj] = mv(D.dinv[i, :nvj, :nvj], D.u[i, :nvj] - mtv(D.Uj[i, :, :nvj], a))
        mv_add_into(D.S[i, :, :nvj], D.qdd[kv:kv + nvj], a)
        nm = M.body_nm[i]
        if nm > 0:                                      # eta_dd = -D^-1 (B^T a + p_m) = -L^-T (W a + y)
            ma = M.body_madr[i]
            D.qdd[ma:ma + nm] = -back_subst_vec(D.Lm[i, :nm, :nm], mv(D.W[i, :nm], a) + D.y[i, :nm])

        # joint reaction: the reference rows of MA_i [a_i; eta_dd_i] + pA_i = [f_i; 0]
        mv_into(D.MA[i, :6, :6], a, D.f[i])
        for r in range(6):
            D.f[i, r] += D.pA[i, r]
        if nm > 0:
            mv_add_into(D.MA[i, :6, 6:6 + nm], D.qdd[M.body_madr[i]:M.body_madr[i] + nm], D.f[i])
    return D.qdd


# ---------------------------------------------------------------------------------------------
# energies (after forward_kinematics)


@njit
def kinetic_energy(M, D, q, v):
    """1/2 sum_i [v_i; eta_d_i]^T M_i [v_i; eta_d_i]."""
    T = 0.0
    for i in range(1, M.parent.size):
        a, nm = M.body_madr[i], M.body_nm[i]
        if nm == 0:
            T += 0.5 * D.v[i] @ (M.body_inertia[i] @ D.v[i])
        else:
            vv = np.concatenate((D.v[i], v[a:a + nm]))
            T += 0.5 * vv @ (mass_matrix(M.inv, i, q[a:a + nm]) @ vv)
    return T


@njit
def body_pose(D, i):
    """(R (3, 3) body -> global, p (3,) body origin in global) from X0[i]."""
    p, R = plux_parts(D.X0[i])
    return R, p


@njit
def potential_energy(M, D, q):
    """Gravitational (-g . sum m x) plus strain (1/2 eta^T Km eta) energy."""
    V = 0.0
    for i in range(1, M.parent.size):
        R, p = body_pose(D, i)
        a, nm = M.body_madr[i], M.body_nm[i]
        if nm == 0:
            m, c, _ = inertia_parts(M.body_inertia[i])
            first = m * c
        else:
            eta = q[a:a + nm]
            first = M.inv.I4[i] + M.inv.I5[i, :, :nm] @ eta
            V += 0.5 * eta @ (M.flex_K[i, :nm, :nm] @ eta)
        V -= M.gravity @ (M.body_mass[i] * p + R @ first)
    return V


# ---------------------------------------------------------------------------------------------
# Python-level entry points


@njit(inline="always")
def prescribed(M, D, t, q, v):
    """The profiles at time t: q, v with the prescribed joints set (copies if there are any, the
    arrays given otherwise), those joints' accelerations into D.qdd_p (nv,), and the point loads'
    factors into D.scale (nl,)."""
    copied = False
    for i in range(1, M.parent.size):
        kind = M.jnt_motion_kind[i]
        if kind >= 0:
            if not copied:
                q, v, copied = q.copy(), v.copy(), True
            n = M.jnt_motion_n[i]
            k, kv = M.jnt_qadr[i], M.jnt_vadr[i]
            q[k], v[kv], D.qdd_p[kv] = motion_at(kind, M.jnt_motion_par[i], M.jnt_motion_x[i, :n],
                                                 M.jnt_motion_c[i, :, :max(n - 1, 1)], t, M.jnt_q0[i])
    for k in range(D.scale.size):
        D.scale[k] = load_at(M.load_kind[k], M.load_par[k], t)
    return q, v


@njit
def forward_at(address, t, q, v, tau):
    """`forward` for the Bound at `address` (`model.Bound.address`)."""
    b = bound_at(address)
    q, v = prescribed(b.M, b.D, t, q, v)
    return aba(b, q, v, tau)


def forward(b: Bound, t: float, q, v, tau) -> np.ndarray:
    """Generalized accelerations (nv,) at time t for a `model.Bound` b: profiles applied, then
    `aba`. The cheap call from Python: q, v, tau C-contiguous float arrays, t a float. Returns the
    workspace's D.qdd itself, as Pinocchio's `aba` returns `data.ddq`: copy it to keep it."""
    return forward_at(b.address, t, q, v, tau)


if PURE_PYTHON:                                         # a PlainBound: no address to pass
    def forward(b, t: float, q, v, tau) -> np.ndarray:  # noqa: F811
        """`forward` uncompiled (jit.PURE_PYTHON): the same passes on the NamedTuples."""
        q, v = prescribed(b.M, b.D, t, q, v)
        return aba(b, q, v, tau)


def forward_dynamics(model: Model, data: Data, q, v, tau=None, t: float = 0.0) -> np.ndarray:
    """Generalized accelerations (nv,) at time t (profiles of loads and prescribed joints applied),
    a copy of data.qdd."""
    tau = np.zeros(model.nv) if tau is None else np.asarray(tau, dtype=float)
    return forward(bind(model, data), float(t), np.asarray(q, dtype=float), np.asarray(v, dtype=float), tau).copy()


def energy(model: Model, data: Data, q, v) -> tuple[float, float]:
    """(kinetic, potential) energy of the state."""
    forward_kinematics(model.arrays, data, q, v)
    return kinetic_energy(model.arrays, data, q, v), potential_energy(model.arrays, data, q)
