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

from flexmbd import profiles
from flexmbd.flexbody import mass_matrix, quadratic_forces
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
    theta, theta_d = Pr @ eta, Pr @ eta_d
    E = expm_so3(theta).T
    Xn = plux(E, x0 + Pt @ eta)
    Jl = jac_left_so3(theta)
    Sn = np.vstack((E @ (Jl @ Pr), E @ Pt))
    w_rel = Jl @ theta_d
    cn = np.concatenate((E @ jac_left_so3_dot(theta, theta_d), -(E @ np.cross(w_rel, Pt @ eta_d))))
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
        vJ = S[:, :nvj] @ v[kv:kv + nvj]
        XJT = XJ @ M.jnt_Xtriad[i]
        D.U[i] = 0.0
        if M.jnt_node[i] >= 0:                          # triad on a node of a flexible parent
            a, nm = M.body_madr[lam], M.body_nm[lam]
            eta_d = v[a:a + nm]
            Xn, Sn, cn = node_kinematics(M.jnt_Phi[i, :, :nm], M.jnt_x0[i], q[a:a + nm], eta_d)
            vn_rel = Sn @ eta_d
            vn = Xn @ D.v[lam] + vn_rel
            D.Xup[i] = XJT @ Xn
            D.U[i, :, :nm] = XJT @ Sn
            D.v[i] = XJT @ vn + vJ
            D.c[i] = XJT @ (cn + cross_motion(vn, vn_rel)) + cross_motion(D.v[i], vJ)
        else:
            D.Xup[i] = XJT
            D.v[i] = XJT @ D.v[lam] + vJ
            D.c[i] = cross_motion(D.v[i], vJ)
        D.S[i] = S
        D.X0[i] = D.Xup[i] @ D.X0[lam]


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
            f = D.X0[i, :3, :3] @ f
        r = M.load_point[k] + Pt @ q[a:a + nm]
        F[i, :3] += np.cross(r, f)
        F[i, 3:6] += f
        F[i, 6:6 + nm] += Pt.T @ f
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
            D.pA[i, :6] = cross_force(D.v[i], I @ D.v[i]) - F[i, :6]
        else:
            eta, eta_d = q[a:a + nm], v[a:a + nm]
            D.MA[i, :6 + nm, :6 + nm] = mass_matrix(M.inv, i, eta)
            h = quadratic_forces(M.inv, i, eta, D.v[i], eta_d)
            h[6:] += M.flex_K[i, :nm, :nm] @ eta + M.flex_C[i, :nm, :nm] @ eta_d
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
            L = np.linalg.cholesky(MA[6:, 6:])
            D.DiBt[i, :nm] = chol_solve(L, np.ascontiguousarray(B.T))
            D.Dip[i, :nm] = chol_solve(L, pA[6:].copy().reshape(nm, 1))[:, 0]
            IA = MA[:6, :6] - B @ D.DiBt[i, :nm]
            pa = pA[:6] - B @ D.Dip[i, :nm]
        else:
            IA, pa = MA[:6, :6].copy(), pA[:6].copy()
        S, c = D.S[i, :, :M.jnt_nv[i]], D.c[i]
        kv = M.jnt_vadr[i]
        if M.jnt_prescribed[i]:
            Ia, pa_up = IA, pa + IA @ (c + S @ qdd_prescribed[kv:kv + S.shape[1]])
        elif S.shape[1] > 0:
            Uj = IA @ S
            dinv = np.linalg.inv(S.T @ Uj)
            u = tau[kv:kv + S.shape[1]] - S.T @ pa
            D.Uj[i, :, :S.shape[1]] = Uj
            D.dinv[i, :S.shape[1], :S.shape[1]] = dinv
            D.u[i, :S.shape[1]] = u
            Ia = IA - Uj @ dinv @ Uj.T
            pa_up = pa + Ia @ c + Uj @ (dinv @ u)
        else:
            Ia, pa_up = IA, pa + IA @ c

        lam = M.parent[i]
        if lam == 0:
            continue
        n = 6 + M.body_nm[lam] if M.jnt_node[i] >= 0 else 6
        G = np.zeros((6, n))
        G[:, :6] = D.Xup[i]
        G[:, 6:] = D.U[i, :, :n - 6]
        D.MA[lam, :n, :n] += G.T @ Ia @ G
        D.pA[lam, :n] += G.T @ pa_up

    # pass 3: root to leaves
    D.a[0, :3] = 0.0
    D.a[0, 3:] = -M.gravity
    for i in range(1, nb + 1):
        lam = M.parent[i]
        a = D.Xup[i] @ D.a[lam] + D.c[i]
        if M.jnt_node[i] >= 0:
            ma, nml = M.body_madr[lam], M.body_nm[lam]
            a += D.U[i, :, :nml] @ D.qdd[ma:ma + nml]
        kv, nvj = M.jnt_vadr[i], M.jnt_nv[i]
        if M.jnt_prescribed[i]:
            D.qdd[kv:kv + nvj] = qdd_prescribed[kv:kv + nvj]
        elif nvj > 0:
            D.qdd[kv:kv + nvj] = D.dinv[i, :nvj, :nvj] @ (D.u[i, :nvj] - D.Uj[i, :, :nvj].T @ a)
        a += D.S[i, :, :nvj] @ D.qdd[kv:kv + nvj]
        D.a[i] = a
        nm = M.body_nm[i]
        if nm > 0:
            ma = M.body_madr[i]
            D.qdd[ma:ma + nm] = -(D.DiBt[i, :nm] @ a + D.Dip[i, :nm])

        # joint reaction: the reference rows of MA_i [a_i; eta_dd_i] + pA_i = [f_i; 0]
        D.f[i] = D.MA[i, :6, :6] @ a + D.pA[i, :6]
        if nm > 0:
            D.f[i] += D.MA[i, :6, 6:6 + nm] @ D.qdd[M.body_madr[i]:M.body_madr[i] + nm]
    return D.qdd.copy()


@njit
def chol_solve(L, B):
    """Solve (L L^T) X = B for X (n, k), L lower triangular (n, n)."""
    n, k = B.shape
    Y = np.zeros((n, k))
    for j in range(k):
        for r in range(n):
            s = B[r, j]
            for c in range(r):
                s -= L[r, c] * Y[c, j]
            Y[r, j] = s / L[r, r]
        for r in range(n - 1, -1, -1):
            s = Y[r, j]
            for c in range(r + 1, n):
                s -= L[c, r] * Y[c, j]
            Y[r, j] = s / L[r, r]
    return Y


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


def inputs(model: Model, t: float, q, v):
    """q, v with prescribed joints set from their profiles, qdd of those joints (nv,), load factors (nl,)."""
    q, v = np.array(q, dtype=float), np.array(v, dtype=float)
    qdd = np.zeros(model.nv)
    for i in range(1, model.nb + 1):
        p = model.jnt_motion[i]
        if p is not None:
            k, kv = model.jnt_qadr[i], model.jnt_vadr[i]
            q[k], v[kv], qdd[kv] = profiles.motion(p, t, model.q0[k])
    scale = np.array([float(profiles.load_factor(p, t)) for p in model.load_profiles])
    return q, v, qdd, scale


def forward_dynamics(model: Model, data: Data, q, v, tau=None, t: float = 0.0) -> np.ndarray:
    """Generalized accelerations (nv,) at time t (profiles of loads and prescribed joints applied)."""
    q, v, qdd_p, scale = inputs(model, t, q, v)
    tau = np.zeros(model.nv) if tau is None else np.asarray(tau, dtype=float)
    return aba(model.arrays, data, q, v, tau, scale, qdd_p)


def energy(model: Model, data: Data, q, v) -> tuple[float, float]:
    """(kinetic, potential) energy of the state."""
    forward_kinematics(model.arrays, data, q, v)
    return kinetic_energy(model.arrays, data, q, v), potential_energy(model.arrays, data, q)
