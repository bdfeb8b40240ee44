"""The recursive algorithms, compiled, as free functions of (model arrays M, data D, ...).

docs/formulation.md §4-§5. Forward dynamics is the articulated-body algorithm extended to modal
flexible bodies:
  pass 1 (root -> leaves): joint and node transforms, velocities, velocity-product terms, and
      each body's own inertia, velocity-product, elastic and external forces;
  pass 2 (leaves -> root): articulated inertias over (a_i, eta_dd_i); a flexible body's own
      modal accelerations are eliminated first, then its joint's; what remains is projected
      into the parent's reference *and modal* equations through the connecting node;
  pass 3 (root -> leaves): joint accelerations, spatial accelerations, modal accelerations.
Gravity enters as a fictitious base acceleration a_0 = [0; -g].

`M` is `Model.arrays`, `D` a `Data`; the Python-level entry points at the bottom take the Model.
"""

from __future__ import annotations

import numpy as np

from flexmbd.profiles import load_at, motion_at
from flexmbd.dense import chol_solve, chol_solve_vec, cholesky, congruence_add_into, inv_spd, mm, mtm, mtv, mv
from flexmbd.flexbody import inertia_and_forces, mass_matrix
from flexmbd.jit import njit
from flexmbd.model import FREE, PRISMATIC, REVOLUTE, SPHERICAL, Data, Model
from flexmbd.spatial import (cross_force, cross_motion, expm_so3, inertia_parts, jac_left_so3, jac_left_so3_dot,
                             plux, plux_parts, quat_to_rot, rot_axis, xlt, xrot)


# ---------------------------------------------------------------------------------------------
# kinematics of one joint and of one node


@njit
def jcalc(jtype, axis, q, k):
    """Joint transform XJ (6, 6), triad -> body, and motion subspace S (6, 6; first nv columns)."""
    S = np.zeros((6, 6))
    if jtype == REVOLUTE:
        S[:3, 0] = axis
        return xrot(rot_axis(axis, q[k]).T), S
    if jtype == PRISMATIC:
        S[3:, 0] = axis
        return xlt(axis * q[k]), S
    if jtype == SPHERICAL:
        S[:3, :3] = np.eye(3)
        return xrot(quat_to_rot(q[k:k + 4]).T), S
    if jtype == FREE:
        return plux(quat_to_rot(q[k:k + 4]).T, q[k + 4:k + 7]), np.eye(6)
    return np.eye(6), S


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


@njit
def forward_kinematics(M, D, q, v):
    """Fill Xup, X0, S, U, v, c from (q, v)."""
    for i in range(1, M.parent.size):
        lam = M.parent[i]
        XJ, S = jcalc(M.jnt_type[i], M.jnt_axis[i], q, M.jnt_qadr[i])
        kv, nvj = M.jnt_vadr[i], M.jnt_nv[i]
        vJ = mv(S[:, :nvj], v[kv:kv + nvj])
        XJT = mm(XJ, M.jnt_Xtriad[i])
        D.U[i] = 0.0
        if M.jnt_node[i] >= 0:                          # triad on a node of a flexible parent
            a, nm = M.body_madr[lam], M.body_nm[lam]
            eta_d = v[a:a + nm]
            Xn, Sn, cn = node_kinematics(M.jnt_Phi[i, :, :nm], M.jnt_x0[i], q[a:a + nm], eta_d)
            vn_rel = mv(Sn, eta_d)
            vn = mv(Xn, D.v[lam]) + vn_rel
            D.Xup[i] = mm(XJT, Xn)
            D.U[i, :, :nm] = mm(XJT, Sn)
            D.v[i] = mv(XJT, vn) + vJ
            D.c[i] = mv(XJT, cn + cross_motion(vn, vn_rel)) + cross_motion(D.v[i], vJ)
        else:
            D.Xup[i] = XJT
            D.v[i] = mv(XJT, D.v[lam]) + vJ
            D.c[i] = cross_motion(D.v[i], vJ)
        D.S[i] = S
        D.X0[i] = mm(D.Xup[i], D.X0[lam])


@njit
def external_forces(M, D, q, load_scale):
    """Generalized external forces (nb+1, 6+nm) from the point loads, body frame; after pass 1.

    A force f at the deformed point r = x0 + Phi_t eta: [r x f; f; Phi_t^T f].
    """
    nm_max = M.jnt_Phi.shape[2]
    F = np.zeros((M.parent.size, 6 + nm_max))
    for k in range(M.load_body.size):
        i = M.load_body[k]
        a, nm = M.body_madr[i], M.body_nm[i]
        Pt = M.load_Phi[k, 3:, :nm]
        f = M.load_force[k] * load_scale[k]
        if M.load_global[k]:
            f = mv(D.X0[i, :3, :3], f)
        r = M.load_point[k] + mv(Pt, q[a:a + nm])
        F[i, :3] += np.cross(r, f)
        F[i, 3:6] += f
        F[i, 6:6 + nm] += mtv(Pt, f)
    return F


@njit
def body_forces(M, D, q, v, F):
    """MA_i, pA_i <- each body's own inertia and its velocity-product, elastic and external forces."""
    for i in range(1, M.parent.size):
        a, nm = M.body_madr[i], M.body_nm[i]
        D.MA[i] = 0.0
        D.pA[i] = 0.0
        if nm == 0:
            I = M.body_inertia[i]
            D.MA[i, :6, :6] = I
            D.pA[i, :6] = cross_force(D.v[i], mv(I, D.v[i])) - F[i, :6]
        else:
            eta, eta_d = q[a:a + nm], v[a:a + nm]
            D.MA[i, :6 + nm, :6 + nm], h = inertia_and_forces(M.inv, i, eta, D.v[i], eta_d)
            h[6:] += mv(M.flex_K[i, :nm, :nm], eta) + mv(M.flex_C[i, :nm, :nm], eta_d)
            D.pA[i, :6 + nm] = h - F[i, :6 + nm]


# ---------------------------------------------------------------------------------------------
# forward dynamics


@njit
def aba(M, D, q, v, tau, load_scale, qdd_prescribed):
    """Generalized accelerations (nv,) — joint and modal — by the articulated-body algorithm.

    tau (nv,): joint forces (modal entries ignored); load_scale (nl,): profile factor of each
    point load; qdd_prescribed (nv,): accelerations of joints with jnt_prescribed set.
    """
    nb = M.parent.size - 1
    forward_kinematics(M, D, q, v)
    body_forces(M, D, q, v, external_forces(M, D, q, load_scale))

    # pass 2: leaves to root
    for i in range(nb, 0, -1):
        nm = M.body_nm[i]
        MA, pA = D.MA[i, :6 + nm, :6 + nm], D.pA[i, :6 + nm]
        if nm > 0:                                      # eliminate the body's own modes
            B = MA[:6, 6:]
            L = cholesky(MA[6:, 6:])
            D.DiBt[i, :nm] = chol_solve(L, B.T)
            D.Dip[i, :nm] = chol_solve_vec(L, pA[6:])
            IA = MA[:6, :6] - mm(B, D.DiBt[i, :nm])
            pa = pA[:6] - mv(B, D.Dip[i, :nm])
        else:
            IA, pa = MA[:6, :6].copy(), pA[:6].copy()
        S, c = D.S[i, :, :M.jnt_nv[i]], D.c[i]
        kv = M.jnt_vadr[i]
        if M.jnt_prescribed[i]:
            Ia, pa_up = IA, pa + mv(IA, c + mv(S, qdd_prescribed[kv:kv + S.shape[1]]))
        elif S.shape[1] > 0:
            Uj = mm(IA, S)
            dinv = inv_spd(mtm(S, Uj))
            u = tau[kv:kv + S.shape[1]] - mtv(S, pa)
            D.Uj[i, :, :S.shape[1]] = Uj
            D.dinv[i, :S.shape[1], :S.shape[1]] = dinv
            D.u[i, :S.shape[1]] = u
            Ia = IA - mm(Uj, mm(dinv, Uj.T))
            pa_up = pa + mv(Ia, c) + mv(Uj, mv(dinv, u))
        else:
            Ia, pa_up = IA, pa + mv(IA, c)

        lam = M.parent[i]
        if lam == 0:
            continue
        n = 6 + M.body_nm[lam] if M.jnt_node[i] >= 0 else 6
        G = np.zeros((6, n))
        G[:, :6] = D.Xup[i]
        G[:, 6:] = D.U[i, :, :n - 6]
        congruence_add_into(G, Ia, D.MA[lam, :n, :n])
        D.pA[lam, :n] += mtv(G, pa_up)

    # pass 3: root to leaves
    D.a[0, :3] = 0.0
    D.a[0, 3:] = -M.gravity
    for i in range(1, nb + 1):
        lam = M.parent[i]
        a = mv(D.Xup[i], D.a[lam]) + D.c[i]
        if M.jnt_node[i] >= 0:
            ma, nml = M.body_madr[lam], M.body_nm[lam]
            a += mv(D.U[i, :, :nml], D.qdd[ma:ma + nml])
        kv, nvj = M.jnt_vadr[i], M.jnt_nv[i]
        if M.jnt_prescribed[i]:
            D.qdd[kv:kv + nvj] = qdd_prescribed[kv:kv + nvj]
        elif nvj > 0:
            D.qdd[kv:kv + nvj] = mv(D.dinv[i, :nvj, :nvj], D.u[i, :nvj] - mtv(D.Uj[i, :, :nvj], a))
        a += mv(D.S[i, :, :nvj], D.qdd[kv:kv + nvj])
        D.a[i] = a
        nm = M.body_nm[i]
        if nm > 0:
            ma = M.body_madr[i]
            D.qdd[ma:ma + nm] = -(mv(D.DiBt[i, :nm], a) + D.Dip[i, :nm])

        # joint reaction: the reference rows of MA_i [a_i; eta_dd_i] + pA_i = [f_i; 0]
        D.f[i] = mv(D.MA[i, :6, :6], a) + D.pA[i, :6]
        if nm > 0:
            D.f[i] += mv(D.MA[i, :6, 6:6 + nm], D.qdd[M.body_madr[i]:M.body_madr[i] + nm])
    return D.qdd.copy()


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


@njit
def prescribed(M, t, q, v):
    """q, v (copies) with the prescribed joints set from their profiles at time t, those joints'
    accelerations (nv,), and the point loads' profile factors (nl,)."""
    q, v = q.copy(), v.copy()
    qdd = np.zeros(v.size)
    for i in range(1, M.parent.size):
        kind = M.jnt_motion_kind[i]
        if kind >= 0:
            n = M.jnt_motion_n[i]
            k, kv = M.jnt_qadr[i], M.jnt_vadr[i]
            q[k], v[kv], qdd[kv] = motion_at(kind, M.jnt_motion_par[i], M.jnt_motion_x[i, :n],
                                             M.jnt_motion_c[i, :, :max(n - 1, 1)], t, M.jnt_q0[i])
    scale = np.empty(M.load_kind.size)
    for k in range(scale.size):
        scale[k] = load_at(M.load_kind[k], M.load_par[k], t)
    return q, v, qdd, scale


@njit
def forward(M, D, t, q, v, tau):
    """Generalized accelerations (nv,) at time t: profiles applied, then `aba`."""
    q, v, qdd_p, scale = prescribed(M, t, q, v)
    return aba(M, D, q, v, tau, scale, qdd_p)


def inputs(model: Model, t: float, q, v):
    """q, v with prescribed joints set from their profiles, qdd of those joints (nv,), load factors (nl,)."""
    return prescribed(model.arrays, float(t), np.asarray(q, dtype=float), np.asarray(v, dtype=float))


def forward_dynamics(model: Model, data: Data, q, v, tau=None, t: float = 0.0) -> np.ndarray:
    """Generalized accelerations (nv,) at time t (profiles of loads and prescribed joints applied)."""
    tau = np.zeros(model.nv) if tau is None else np.asarray(tau, dtype=float)
    return forward(model.arrays, data, float(t), np.asarray(q, dtype=float), np.asarray(v, dtype=float), tau)


def energy(model: Model, data: Data, q, v) -> tuple[float, float]:
    """(kinetic, potential) energy of the state."""
    forward_kinematics(model.arrays, data, q, v)
    return kinetic_energy(model.arrays, data, q, v), potential_energy(model.arrays, data, q)
