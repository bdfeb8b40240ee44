"""The recursive algorithms, as free functions of the Model's arrays `model` and a Data `data`.

docs/formulation.md §4-§5. Forward dynamics is the articulated-body algorithm extended to modal
flexible bodies, in Featherstone's names (Xup, S, vJ, c, IA, pA, and Uj = IA S, d, u of a joint)
and the paper's (a body's mass matrix M(eta) with blocks A = M_rr, B = M_rm, D = M_mm; U maps
the parent's modal velocities to the body's, G = [Xup, U]):
  pass 1 (root -> leaves, `forward_kinematics`, `external_forces`, `body_forces`): joint and node
      transforms, velocities, velocity-product terms, and each body's own inertia, velocity-product,
      elastic and external forces;
  pass 2 (leaves -> root, `articulated_inertias`): articulated inertias over (a_i, eta_dd_i); a
      flexible body's own modal accelerations are eliminated first, then its joint's; what remains
      is projected into the parent's reference *and modal* equations through the connecting node;
  pass 3 (root -> leaves, `accelerations`): joint, spatial and modal accelerations, joint reactions.
Gravity enters as a fictitious base acceleration a_0 = [0; -g].

`model` and `data` are read by field name only: the NamedTuples `model.Arrays` and `model.Data`,
or the kernel's structrefs with the same fields. The functions are compiled with `njit` and run
as they are in the pure-Python mode; the one compiled entry that evaluates them, and the call from
Python, are the kernel's (`compiled.entry.forward`). Per-body arrays are zero-padded to the largest
mode count, so a body's blocks are the leading slices `[:6 + nm]`.
"""

from __future__ import annotations

import numpy as np

from flexmbd.mbd.compiled.dense import (back_subst_vec, cholesky, congruence_add_into, forward_subst, inv_spd, mm,
                                        mm_into, mtm, mtv, mtv_add_into, mv, mv_add_into, mv_into)
from flexmbd.mbd.invariants import first_moment, inertia_and_forces_into
from flexmbd.mbd.compiled.jit import njit
from flexmbd.mbd.joints import jcalc
from flexmbd.mbd.model import Model
from flexmbd.mbd.profiles import load_at, motion_at
from flexmbd.mbd.spatial import (cross_force_into, cross_motion, cross_motion_into, expm_so3, inertia_parts,
                                 jac_left_so3, jac_left_so3_dot, mv6_add_into, mv6_into, plux, plux_parts,
                                 xcongruence_add_into, xmul_into, xmv_into, xtv_add_into)


# ---------------------------------------------------------------------------------------------
# kinematics of one node


@njit
def node_kinematics(Phi, D, x0, eta, eta_d, stiff=True):
    """Deformed node with mode block Phi (6, nm), foreshortening matrix D (nm, nm) and undeformed
    position x0 (3,) on the beam axis: Xn (6, 6) body -> node frame, Sn (6, nm) modal motion
    subspace in the node frame, cn (6,) velocity product. `stiff` False: D is zero (no geometric
    stiffening) and its terms are skipped.

    Node frame: origin r = x0 + Phi_t eta - 1/2 (eta^T D eta) e_x, rotation exp(theta~),
    theta = Phi_r eta. The origin moves with T(eta) eta_d, T = Phi_t - e_x (D eta)^T. Relative
    velocity (node frame): [E J(theta) theta_d; E T eta_d], E = exp(theta~)^T, J the left Jacobian
    of exp; cn = [E J'(theta) theta_d; -E (w_rel x T eta_d) - E e_x (eta_d^T D eta_d)].
    """
    nm = eta.size
    theta, theta_d, r, rd = np.empty(3), np.empty(3), x0.copy(), np.empty(3)
    for a in range(3):                                  # Phi_r eta, Phi_r eta_d, Phi_t eta, Phi_t eta_d
        t, td, p, pd = 0.0, 0.0, 0.0, 0.0
        for l in range(nm):
            t += Phi[a, l] * eta[l]
            td += Phi[a, l] * eta_d[l]
            p += Phi[3 + a, l] * eta[l]
            pd += Phi[3 + a, l] * eta_d[l]
        theta[a], theta_d[a] = t, td
        r[a] += p
        rd[a] = pd
    De = np.zeros(nm)
    shorten = 0.0
    if stiff:
        mv_into(D, eta, De)
        r[0] -= 0.5 * (eta @ De)
        rd[0] -= De @ eta_d                             # rd = T eta_d
        shorten = eta_d @ mv(D, eta_d)
    E = expm_so3(theta).T
    Jl = jac_left_so3(theta)
    EJ = mm(E, Jl)
    Sn = np.empty((6, nm))
    for a in range(3):                                  # [E J Phi_r; E T]
        for l in range(nm):
            s, st = 0.0, 0.0
            for b in range(3):
                s += EJ[a, b] * Phi[b, l]
                st += E[a, b] * Phi[3 + b, l]
            Sn[a, l] = s
            Sn[3 + a, l] = st - E[a, 0] * De[l]
    w_rel = mv(Jl, theta_d)
    g = np.cross(w_rel, rd)
    g[0] += shorten
    cn = np.empty(6)
    cn[:3] = mv(E, jac_left_so3_dot(theta, theta_d))
    for a in range(3):
        cn[3 + a] = -(E[a, 0] * g[0] + E[a, 1] * g[1] + E[a, 2] * g[2])
    return plux(E, r), Sn, cn


# ---------------------------------------------------------------------------------------------
# the profiles at time t


@njit(inline="always")
def prescribed(model, data, t, q, v):
    """The profiles at time t: q, v with the prescribed joints set (copies if there are any, the
    arrays given otherwise), those joints' accelerations into data.qdd_p (nv,), and the point
    loads' factors into data.scale (nl,)."""
    copied = False
    for i in range(1, model.parent.size):
        kind = model.jnt_motion_kind[i]
        if kind >= 0:
            if not copied:
                q, v, copied = q.copy(), v.copy(), True
            n = model.jnt_motion_n[i]
            k, kv = model.jnt_qadr[i], model.jnt_vadr[i]
            q[k], v[kv], data.qdd_p[kv] = motion_at(kind, model.jnt_motion_par[i], model.jnt_motion_x[i, :n],
                                                    model.jnt_motion_c[i, :, :max(n - 1, 1)], t, model.jnt_q0[i])
    for k in range(data.scale.size):
        data.scale[k] = load_at(model.load_kind[k], model.load_par[k], t)
    return q, v


# ---------------------------------------------------------------------------------------------
# pass 1


@njit(inline="always")
def forward_kinematics(model, data, q, v):
    """data.XJ, S, vJ, Xup, X0, U, v, c from (q, v): v_i = Xup_i v_lam + U_i eta_d_lam + S_i qd_i."""
    for i in range(1, model.parent.size):
        lam = model.parent[i]
        kv, nvj = model.jnt_vadr[i], model.jnt_nv[i]
        jcalc(model.jnt_type[i], model.jnt_axis[i], q, model.jnt_qadr[i], data.XJ[i], data.S[i])
        mv_into(data.S[i, :, :nvj], v[kv:kv + nvj], data.vJ[i])
        if model.jnt_node[i] >= 0:                      # triad on a node of a flexible parent
            XJT = np.empty((6, 6))
            xmul_into(data.XJ[i], model.jnt_Xtriad[i], XJT)
            a, nm = model.body_madr[lam], model.body_nm[lam]
            eta_d = v[a:a + nm]
            Xn, Sn, cn = node_kinematics(model.jnt_Phi[i, :, :nm], model.jnt_D[i, :nm, :nm], model.jnt_x0[i],
                                         q[a:a + nm], eta_d, model.inv.stiff[lam] != 0.0)
            vn_rel = mv(Sn, eta_d)
            vn = mv(Xn, data.v[lam]) + vn_rel
            xmul_into(XJT, Xn, data.Xup[i])
            mm_into(XJT, Sn, data.U[i, :, :nm])
            data.v[i] = mv(XJT, vn) + data.vJ[i]
            data.c[i] = mv(XJT, cn + cross_motion(vn, vn_rel)) + cross_motion(data.v[i], data.vJ[i])
        else:
            xmul_into(data.XJ[i], model.jnt_Xtriad[i], data.Xup[i])
            xmv_into(data.Xup[i], data.v[lam], data.v[i])
            for r in range(6):
                data.v[i, r] += data.vJ[i, r]
            cross_motion_into(data.v[i], data.vJ[i], data.c[i])
        xmul_into(data.Xup[i], data.X0[lam], data.X0[i])


@njit(inline="always")
def external_forces(model, data, q):
    """data.F (nb+1, 6+nm) <- generalized external forces of the point loads at their factors
    data.scale, body frame; after pass 1.

    A force f at the deformed point r = x0 + Phi_t eta - 1/2 (eta^T D eta) e_x:
    [r x f; f; Phi_t^T f - f_x D eta].
    """
    F = data.F
    F[:] = 0.0
    for k in range(model.load_body.size):
        i = model.load_body[k]
        a, nm = model.body_madr[i], model.body_nm[i]
        Pt = model.load_Phi[k, 3:, :nm]
        f = model.load_force[k] * data.scale[k]
        if model.load_global[k]:
            f = mv(data.X0[i, :3, :3], f)
        eta = q[a:a + nm]
        De = mv(model.load_D[k, :nm, :nm], eta)
        r = model.load_point[k] + mv(Pt, eta)
        r[0] -= 0.5 * (eta @ De)
        F[i, :3] += np.cross(r, f)
        F[i, 3:6] += f
        F[i, 6:6 + nm] += mtv(Pt, f) - f[0] * De


@njit(inline="always")
def body_forces(model, data, q, v, tau):
    """MA_i, pA_i <- each body's own inertia M_i(eta) and its velocity-product, elastic and external
    (data.F, and tau's modal entries: generalized forces on the modal coordinates) forces (the
    leading 6+nm_i block; the rest of the padded row is never read)."""
    for i in range(1, model.parent.size):
        a, nm = model.body_madr[i], model.body_nm[i]
        MA, pA = data.MA[i, :6 + nm, :6 + nm], data.pA[i, :6 + nm]
        if nm == 0:
            MA[:] = model.body_inertia[i]
            mv6_into(model.body_inertia[i], data.v[i], data.Iv[i])
            cross_force_into(data.v[i], data.Iv[i], pA)
        else:
            eta, eta_d = q[a:a + nm], v[a:a + nm]
            inertia_and_forces_into(model.inv, i, eta, data.v[i], eta_d, MA, pA)
            mv_add_into(model.flex_K[i, :nm, :nm], eta, pA[6:])
            mv_add_into(model.flex_C[i, :nm, :nm], eta_d, pA[6:])
        for r in range(6 + nm):
            pA[r] -= data.F[i, r]
        for r in range(nm):
            pA[6 + r] -= tau[a + r]


# ---------------------------------------------------------------------------------------------
# pass 2


@njit(inline="always")
def articulated_inertias(model, data, tau):
    """Leaves to root: for each body, eliminate its modes (MA = [A B; B^T D], D = L L^T), then its
    joint (IA, pA -> Ia, pa), and add G^T Ia G, G^T pa to its parent's MA, pA, G = [Xup, U]."""
    for i in range(model.parent.size - 1, 0, -1):
        nm = model.body_nm[i]
        MA, pA = data.MA[i, :6 + nm, :6 + nm], data.pA[i, :6 + nm]
        IA, pa = data.Ia[i], data.pa[i]
        for r in range(6):
            pa[r] = pA[r]
            for k in range(6):
                IA[r, k] = MA[r, k]
        if nm > 0:                                      # eliminate the body's own modes
            L = cholesky(MA[6:, 6:])                    # D = L L^T
            W = forward_subst(L, MA[6:, :6])            # L^-1 B^T
            y = forward_subst(L, pA[6:].reshape(nm, 1))[:, 0]
            data.Lm[i, :nm, :nm] = L
            data.W[i, :nm] = W
            data.y[i, :nm] = y
            IA -= mtm(W, W)                             # A - B D^-1 B^T
            pa -= mtv(W, y)                             # p_r - B D^-1 p_m
        c, kv, nvj = data.c[i], model.jnt_vadr[i], model.jnt_nv[i]
        if model.jnt_prescribed[i]:
            mv_add_into(IA, c + mv(data.S[i, :, :nvj], data.qdd_p[kv:kv + nvj]), pa)
        elif nvj == 1:                                  # the general case below, with scalar d and u
            S, Uj = data.S[i, :, 0], data.Uj[i, :, 0]
            d, u = 0.0, tau[kv]
            for r in range(6):
                s = 0.0
                for k in range(6):
                    s += IA[r, k] * S[k]
                Uj[r] = s
                d += S[r] * s
                u -= S[r] * pa[r]
            dinv = 1.0 / d
            data.dinv[i, 0, 0], data.u[i, 0] = dinv, u
            for r in range(6):
                for k in range(6):
                    IA[r, k] -= Uj[r] * Uj[k] * dinv
            mv6_add_into(IA, c, pa)
            for r in range(6):
                pa[r] += Uj[r] * u * dinv
        elif nvj > 1:
            S = data.S[i, :, :nvj]
            Uj, dinv, u = data.Uj[i, :, :nvj], data.dinv[i, :nvj, :nvj], data.u[i, :nvj]
            mm_into(IA, S, Uj)                          # Uj = IA S
            dinv[:] = inv_spd(mtm(S, Uj))               # d^-1 = (S^T Uj)^-1
            u[:] = tau[kv:kv + nvj] - mtv(S, pa)        # u = tau - S^T pA
            IA -= mm(Uj, mm(dinv, Uj.T))                # Ia = IA - Uj d^-1 Uj^T
            mv_add_into(IA, c, pa)                      # pa = pA + Ia c + Uj d^-1 u
            mv_add_into(Uj, mv(dinv, u), pa)
        else:
            mv6_add_into(IA, c, pa)

        # project into the parent: G = [Xup, U] onto (a_lam, eta_dd_lam)
        lam = model.parent[i]
        if lam == 0:
            continue
        if model.jnt_node[i] >= 0:
            n = 6 + model.body_nm[lam]
            G = np.empty((6, n))
            G[:, :6] = data.Xup[i]
            G[:, 6:] = data.U[i, :, :n - 6]
            congruence_add_into(G, IA, data.MA[lam, :n, :n], data.IG[:, :n])
            mtv_add_into(G, pa, data.pA[lam, :n])
        else:                                           # G = Xup, a Plücker transform
            xcongruence_add_into(data.Xup[i], IA, data.MA[lam], data.IG)
            xtv_add_into(data.Xup[i], pa, data.pA[lam])


# ---------------------------------------------------------------------------------------------
# pass 3


@njit(inline="always")
def accelerations(model, data):
    """Root to leaves: a_i = Xup_i a_lam + U_i eta_dd_lam + c_i, joint accelerations
    qdd_i = d^-1 (u - Uj^T a_i), a_i += S_i qdd_i, modal accelerations eta_dd_i = -D^-1 (B^T a_i + p_m),
    and the joint reaction f_i from the reference rows of MA_i [a_i; eta_dd_i] + pA_i = [f_i; 0]."""
    qdd = data.qdd
    data.a[0, :3] = 0.0
    data.a[0, 3:] = -model.gravity
    for i in range(1, model.parent.size):
        lam, a = model.parent[i], data.a[i]
        xmv_into(data.Xup[i], data.a[lam], a)
        for r in range(6):
            a[r] += data.c[i, r]
        if model.jnt_node[i] >= 0:
            ma, nml = model.body_madr[lam], model.body_nm[lam]
            mv_add_into(data.U[i, :, :nml], qdd[ma:ma + nml], a)
        kv, nvj = model.jnt_vadr[i], model.jnt_nv[i]
        if model.jnt_prescribed[i]:
            qdd[kv:kv + nvj] = data.qdd_p[kv:kv + nvj]
        elif nvj == 1:
            s = data.u[i, 0]
            for r in range(6):
                s -= data.Uj[i, r, 0] * a[r]
            qdd[kv] = data.dinv[i, 0, 0] * s
        elif nvj > 1:
            qdd[kv:kv + nvj] = mv(data.dinv[i, :nvj, :nvj], data.u[i, :nvj] - mtv(data.Uj[i, :, :nvj], a))
        mv_add_into(data.S[i, :, :nvj], qdd[kv:kv + nvj], a)
        nm = model.body_nm[i]
        if nm > 0:                                      # eta_dd = -D^-1 (B^T a + p_m) = -L^-T (W a + y)
            ma = model.body_madr[i]
            qdd[ma:ma + nm] = -back_subst_vec(data.Lm[i, :nm, :nm], mv(data.W[i, :nm], a) + data.y[i, :nm])

        # joint reaction: the reference rows of MA_i [a_i; eta_dd_i] + pA_i = [f_i; 0]
        mv6_into(data.MA[i], a, data.f[i])
        for r in range(6):
            data.f[i, r] += data.pA[i, r]
        if nm > 0:
            mv_add_into(data.MA[i, :6, 6:6 + nm], qdd[model.body_madr[i]:model.body_madr[i] + nm], data.f[i])


# ---------------------------------------------------------------------------------------------
# forward dynamics


@njit(inline="always")
def aba(model, data, q, v, tau):
    """Generalized accelerations (nv,) — joint and modal — by the articulated-body algorithm:
    data.qdd itself (copy it to keep it).

    tau (nv,): generalized forces, joint and modal (a prescribed joint's entries are ignored). Set by `prescribed` first: data.scale (nl,),
    the point loads' profile factors, and data.qdd_p (nv,), the accelerations of the joints with
    jnt_prescribed set.
    """
    pass1(model, data, q, v, tau)
    return passes23(model, data, tau)


@njit(inline="always")
def pass1(model, data, q, v, tau):
    """`aba`'s pass 1: kinematics, then each body's own inertia M_i(eta) (into data.MA's leading
    block) and forces."""
    forward_kinematics(model, data, q, v)
    external_forces(model, data, q)
    body_forces(model, data, q, v, tau)


@njit(inline="always")
def passes23(model, data, tau):
    """`aba`'s passes 2 and 3, after `pass1`: the accelerations, data.qdd itself."""
    articulated_inertias(model, data, tau)
    accelerations(model, data)
    return data.qdd


# ---------------------------------------------------------------------------------------------
# the response to a generalized force (after `aba`)


@njit(inline="always")
def response(model, data, tau):
    """M^-1 tau (nv,) at the state of the last `aba`, from the articulated inertias it factored
    (data.Lm, W, Uj, dinv, Xup, U, S, which stay): what tau adds to that evaluation's
    accelerations, with no velocity product, gravity or profile (a prescribed joint's entry of
    tau is ignored and its acceleration is 0). Passes 2 and 3 on the bias alone, about a quarter
    of an evaluation; the bias workspace (data.pA, pa, y, u, a) and data.qdd are overwritten, and
    data.qdd is the result (copy it to keep it)."""
    qdd = data.qdd
    for i in range(1, model.parent.size):              # each body's own bias: tau's modal entries
        a, nm = model.body_madr[i], model.body_nm[i]
        data.pA[i, :6] = 0.0
        for r in range(nm):
            data.pA[i, 6 + r] = -tau[a + r]
    for i in range(model.parent.size - 1, 0, -1):     # pass 2 on the bias: modes, then the joint
        nm = model.body_nm[i]
        pA, pa = data.pA[i, :6 + nm], data.pa[i]
        pa[:] = pA[:6]
        if nm > 0:
            y = forward_subst(data.Lm[i, :nm, :nm], pA[6:].reshape(nm, 1))[:, 0]
            data.y[i, :nm] = y
            pa -= mtv(data.W[i, :nm], y)
        kv, nvj = model.jnt_vadr[i], model.jnt_nv[i]
        if not model.jnt_prescribed[i] and nvj > 0:   # a prescribed joint passes the bias on unchanged
            u = tau[kv:kv + nvj] - mtv(data.S[i, :, :nvj], pa)
            data.u[i, :nvj] = u
            mv_add_into(data.Uj[i, :, :nvj], mv(data.dinv[i, :nvj, :nvj], u), pa)
        lam = model.parent[i]
        if lam == 0:
            continue
        if model.jnt_node[i] >= 0:
            n = 6 + model.body_nm[lam]
            xtv_add_into(data.Xup[i], pa, data.pA[lam, :6])
            mtv_add_into(data.U[i, :, :n - 6], pa, data.pA[lam, 6:n])
        else:
            xtv_add_into(data.Xup[i], pa, data.pA[lam])
    data.a[0] = 0.0
    for i in range(1, model.parent.size):              # pass 3 from rest: no c, no gravity
        lam, a = model.parent[i], data.a[i]
        xmv_into(data.Xup[i], data.a[lam], a)
        if model.jnt_node[i] >= 0:
            ma, nml = model.body_madr[lam], model.body_nm[lam]
            mv_add_into(data.U[i, :, :nml], qdd[ma:ma + nml], a)
        kv, nvj = model.jnt_vadr[i], model.jnt_nv[i]
        if model.jnt_prescribed[i]:
            qdd[kv:kv + nvj] = 0.0
        elif nvj > 0:
            qdd[kv:kv + nvj] = mv(data.dinv[i, :nvj, :nvj], data.u[i, :nvj] - mtv(data.Uj[i, :, :nvj], a))
        mv_add_into(data.S[i, :, :nvj], qdd[kv:kv + nvj], a)
        nm = model.body_nm[i]
        if nm > 0:
            ma = model.body_madr[i]
            qdd[ma:ma + nm] = -back_subst_vec(data.Lm[i, :nm, :nm], mv(data.W[i, :nm], a) + data.y[i, :nm])
    return qdd


# ---------------------------------------------------------------------------------------------
# energies (after pass1; `compiled.entry.energy` evaluates them)


@njit
def kinetic_energy(model, data, v):
    """1/2 sum_i [v_i; eta_d_i]^T M_i [v_i; eta_d_i], after `pass1` (v_i = data.v[i], M_i(eta) the
    leading 6+nm block of data.MA[i]: the same mass matrix the dynamics uses)."""
    T = 0.0
    for i in range(1, model.parent.size):
        a, nm = model.body_madr[i], model.body_nm[i]
        for r in range(6 + nm):
            xr = data.v[i, r] if r < 6 else v[a + r - 6]
            s = 0.0
            for c in range(6 + nm):
                s += data.MA[i, r, c] * (data.v[i, c] if c < 6 else v[a + c - 6])
            T += 0.5 * xr * s
    return T


@njit
def body_pose(data, i):
    """(R (3, 3) body -> global, p (3,) body origin in global) from X0[i]."""
    p, R = plux_parts(data.X0[i])
    return R, p


@njit
def potential_energy(model, data, q):
    """Gravitational (-g . sum m x) plus strain (1/2 eta^T Km eta) energy."""
    V = 0.0
    for i in range(1, model.parent.size):
        R, p = body_pose(data, i)
        a, nm = model.body_madr[i], model.body_nm[i]
        if nm == 0:
            m, c, _ = inertia_parts(model.body_inertia[i])
            first = m * c
        else:
            eta = q[a:a + nm]
            first = first_moment(model.inv, i, eta)
            V += 0.5 * eta @ (model.flex_K[i, :nm, :nm] @ eta)
        V -= model.gravity @ (model.body_mass[i] * p + R @ first)
    return V


def free_velocities(model: Model) -> np.ndarray:
    """Indices into v of the coordinates that are not prescribed: free joints' and all modal."""
    keep = np.ones(model.nv, dtype=bool)
    for i in range(1, model.nb + 1):
        if model.jnt_prescribed[i]:
            keep[model.jnt_vadr[i]:model.jnt_vadr[i] + model.jnt_nv[i]] = False
    return np.flatnonzero(keep)
