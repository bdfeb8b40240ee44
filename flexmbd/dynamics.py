"""The recursive algorithms, as free functions of (model, data, ...). docs/formulation.md §4-§5.

Forward dynamics is the articulated-body algorithm extended to modal flexible bodies:
  pass 1 (root -> leaves): joint and node transforms, velocities, velocity-product terms;
  pass 2 (leaves -> root): articulated inertias over (a_i, eta_dd_i); a flexible body's own
      modal accelerations are eliminated first, then its joint's; what remains is projected
      into the parent's reference *and modal* equations through the connecting node;
  pass 3 (root -> leaves): joint accelerations, spatial accelerations, modal accelerations.
Gravity enters as a fictitious base acceleration a_0 = [0; -g].
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from flexmbd import flexbody, profiles, spatial
from flexmbd.model import FIXED, FREE, PRISMATIC, REVOLUTE, SPHERICAL, Data, Model


# ---------------------------------------------------------------------------------------------
# kinematics of one joint and of one node


def jcalc(model: Model, i: int, q) -> tuple[np.ndarray, np.ndarray]:
    """Joint transform XJ (6, 6), triad -> body, and motion subspace S (6, nv_i) in the body frame."""
    t, a, k = model.jnt_type[i], model.jnt_axis[i], model.jnt_qadr[i]
    if t == REVOLUTE:
        return spatial.xrot(spatial.rot_axis(a, q[k]).T), np.concatenate([a, np.zeros(3)])[:, None]
    if t == PRISMATIC:
        return spatial.xlt(a * q[k]), np.concatenate([np.zeros(3), a])[:, None]
    if t == SPHERICAL:
        R = spatial.quat_to_rot(q[k:k + 4])
        return spatial.xrot(R.T), np.eye(6)[:, :3]
    if t == FREE:
        R = spatial.quat_to_rot(q[k:k + 4])
        return spatial.plux(R.T, q[k + 4:k + 7]), np.eye(6)
    return np.eye(6), np.zeros((6, 0))


def node_kinematics(flex, p: int, eta, eta_d):
    """Deformed node p of a flexible body: Xn (6, 6) body -> node frame, Sn (6, nm) modal motion
    subspace in the node frame, cn (6,) its velocity-product term.

    Node frame: origin r = x0_p + Phi_t,p eta, rotation exp(theta~), theta = Phi_r,p eta.
    Relative velocity (node frame): [E J(theta) theta_d; E Phi_t,p eta_d], E = exp(theta~)^T,
    J the left Jacobian of exp; cn = [E J'(theta) theta_d; -E (w_rel x Phi_t,p eta_d)].
    """
    Pr, Pt = flex.Phi[p, :3], flex.Phi[p, 3:]
    theta, theta_d = Pr @ eta, Pr @ eta_d
    E = spatial.expm_so3(theta).T
    Xn = spatial.plux(E, flex.x0[p] + Pt @ eta)
    Jl = spatial.jac_left_so3(theta)
    Sn = np.vstack([E @ Jl @ Pr, E @ Pt])
    w_rel = Jl @ theta_d
    cn = np.concatenate([E @ spatial.jac_left_so3_dot(theta, theta_d), -E @ np.cross(w_rel, Pt @ eta_d)])
    return Xn, Sn, cn


def modal(model: Model, i: int, x) -> np.ndarray:
    """The modal block of body i in a q- or v-sized vector."""
    a = model.body_madr[i]
    return x[a:a + model.body_nm[i]]


# ---------------------------------------------------------------------------------------------
# prescribed motion


def apply_motion(model: Model, t: float, q, v):
    """q, v with prescribed joints set from their profiles; returns (q, v, {i: qdd})."""
    q, v = np.array(q, dtype=float), np.array(v, dtype=float)
    qdd = {}
    for i in range(1, model.nb + 1):
        p = model.jnt_motion[i]
        if p is None:
            continue
        k, kv = model.jnt_qadr[i], model.jnt_vadr[i]
        q[k], v[kv], qdd[i] = profiles.motion(p, t, model.q0[k])
    return q, v, qdd


# ---------------------------------------------------------------------------------------------
# pass 1: kinematics and the bodies' own inertias


def forward_kinematics(model: Model, data: Data, q, v) -> None:
    """Fill Xup, X0, S, U, v, c from (q, v)."""
    for i in range(1, model.nb + 1):
        lam = model.parent[i]
        XJ, S = jcalc(model, i, q)
        vJ = S @ v[model.jnt_vadr[i]:model.jnt_vadr[i] + S.shape[1]]
        XT = model.jnt_Xtriad[i]
        if model.jnt_node[i] >= 0:                     # triad on a node of a flexible parent
            fl = model.body_flex[lam]
            eta, eta_d = modal(model, lam, q), modal(model, lam, v)
            Xn, Sn, cn = node_kinematics(fl, model.jnt_node[i], eta, eta_d)
            XJT = XJ @ XT
            vn_rel = Sn @ eta_d
            vn = Xn @ data.v[lam] + vn_rel
            data.Xup[i] = XJT @ Xn
            data.U[i] = XJT @ Sn
            data.v[i] = XJT @ vn + vJ
            data.c[i] = XJT @ (cn + spatial.cross_motion(vn, vn_rel)) + spatial.cross_motion(data.v[i], vJ)
        else:
            data.Xup[i] = XJ @ XT
            data.U[i] = None
            data.v[i] = data.Xup[i] @ data.v[lam] + vJ
            data.c[i] = spatial.cross_motion(data.v[i], vJ)
        data.S[i] = S
        data.X0[i] = data.Xup[i] @ data.X0[lam]


def body_inertias(model: Model, data: Data, q, v, f_ext) -> None:
    """Initialise MA_i, pA_i with each body's own inertia, velocity-product, elastic and external
    forces. f_ext[i]: generalized external force on body i, (6,) or (6+nm,), body frame."""
    for i in range(1, model.nb + 1):
        fl = model.body_flex[i]
        if fl is None:
            I = model.body_inertia[i]
            data.MA[i] = I.copy()
            data.pA[i] = spatial.cross_force(data.v[i], I @ data.v[i]) - f_ext[i]
        else:
            eta, eta_d = modal(model, i, q), modal(model, i, v)
            data.MA[i] = flexbody.mass_matrix(fl.inv, eta)
            h = flexbody.quadratic_forces(fl.inv, eta, data.v[i], eta_d)
            h[6:] += fl.Km @ eta + fl.Cm @ eta_d
            data.pA[i] = h - f_ext[i]


# ---------------------------------------------------------------------------------------------
# forward dynamics


def aba(model: Model, data: Data, q, v, tau=None, f_ext=None, qdd_prescribed=None) -> np.ndarray:
    """Generalized accelerations (nv,) — joint and modal — by the articulated-body algorithm."""
    nb = model.nb
    tau = np.zeros(model.nv) if tau is None else tau
    f_ext = f_ext if f_ext is not None else zero_forces(model)
    qdd_prescribed = qdd_prescribed or {}
    forward_kinematics(model, data, q, v)
    body_inertias(model, data, q, v, f_ext)

    # pass 2: leaves to root
    keep = [None] * (nb + 1)
    for i in range(nb, 0, -1):
        MA, pA = data.MA[i], data.pA[i]
        modal_elim = None
        if model.body_flex[i] is not None:             # eliminate the body's own modes
            A, B, D = MA[:6, :6], MA[:6, 6:], MA[6:, 6:]
            Dc = cho_factor(D)
            DiBt, Dip = cho_solve(Dc, B.T), cho_solve(Dc, pA[6:])
            IA, pa = A - B @ DiBt, pA[:6] - B @ Dip
            modal_elim = (DiBt, Dip)
        else:
            IA, pa = MA, pA
        S, c = data.S[i], data.c[i]
        if i in qdd_prescribed:
            Ia, pa_up = IA, pa + IA @ (c + S[:, 0] * qdd_prescribed[i])
            joint = None
        elif S.shape[1]:
            Uj = IA @ S
            d = S.T @ Uj
            u = tau[model.jnt_vadr[i]:model.jnt_vadr[i] + S.shape[1]] - S.T @ pa
            dinv = np.linalg.inv(d)
            Ia = IA - Uj @ dinv @ Uj.T
            pa_up = pa + Ia @ c + Uj @ (dinv @ u)
            joint = (Uj, dinv, u)
        else:
            Ia, pa_up, joint = IA, pa + IA @ c, None
        keep[i] = (modal_elim, joint)

        lam = model.parent[i]
        if lam == 0:
            continue
        G = data.Xup[i] if data.U[i] is None else np.hstack([data.Xup[i], data.U[i]])
        n = G.shape[1]
        data.MA[lam][:n, :n] += G.T @ Ia @ G
        data.pA[lam][:n] += G.T @ pa_up

    # pass 3: root to leaves
    data.a[0] = np.concatenate([np.zeros(3), -model.gravity])
    qdd = data.qdd
    for i in range(1, nb + 1):
        lam = model.parent[i]
        a = data.Xup[i] @ data.a[lam] + data.c[i]
        if data.U[i] is not None:
            a += data.U[i] @ modal(model, lam, qdd)
        modal_elim, joint = keep[i]
        S, kv = data.S[i], model.jnt_vadr[i]
        if i in qdd_prescribed:
            qj = np.array([qdd_prescribed[i]])
        elif joint is not None:
            Uj, dinv, u = joint
            qj = dinv @ (u - Uj.T @ a)
        else:
            qj = np.zeros(0)
        qdd[kv:kv + qj.size] = qj
        a = a + S @ qj
        data.a[i] = a
        if modal_elim is not None:
            DiBt, Dip = modal_elim
            ma = model.body_madr[i]
            qdd[ma:ma + model.body_nm[i]] = -(DiBt @ a + Dip)
    return qdd.copy()


def zero_forces(model: Model) -> list:
    """External generalized forces, all zero: (6,) per rigid body, (6+nm,) per flexible body."""
    return [np.zeros(6 + int(model.body_nm[i])) for i in range(model.nb + 1)]


# ---------------------------------------------------------------------------------------------
# composite quantities, for checks and outputs


def kinetic_energy(model: Model, data: Data, q, v) -> float:
    """1/2 sum_i [v_i; eta_d_i]^T M_i [v_i; eta_d_i] (after forward_kinematics)."""
    T = 0.0
    for i in range(1, model.nb + 1):
        fl = model.body_flex[i]
        if fl is None:
            T += 0.5 * data.v[i] @ model.body_inertia[i] @ data.v[i]
        else:
            vv = np.concatenate([data.v[i], modal(model, i, v)])
            T += 0.5 * vv @ flexbody.mass_matrix(fl.inv, modal(model, i, q)) @ vv
    return T


def body_pose(data: Data, i: int) -> tuple[np.ndarray, np.ndarray]:
    """(R (3, 3) body -> global, p (3,) body origin in global) from X0[i]."""
    E = data.X0[i][:3, :3]
    rx = -E.T @ data.X0[i][3:, :3]
    return E.T, np.array([rx[2, 1], rx[0, 2], rx[1, 0]])


def potential_energy(model: Model, data: Data, q) -> float:
    """Gravitational (-g . sum m x) plus strain (1/2 eta^T Km eta) energy (after forward_kinematics)."""
    V = 0.0
    for i in range(1, model.nb + 1):
        R, p = body_pose(data, i)
        fl = model.body_flex[i]
        if fl is None:
            I = model.body_inertia[i]
            first = np.array([I[2, 4], I[0, 5], I[1, 3]])      # m c from the m c~ block
        else:
            eta = modal(model, i, q)
            first = fl.inv.I4 + fl.inv.I5 @ eta
            V += 0.5 * eta @ fl.Km @ eta
        V -= model.gravity @ (model.body_mass[i] * p + R @ first)
    return V
