"""Closed kinematic loops: the cut joints' constraints on the tree's coordinates, the consistent
initial state, and the constrained forward dynamics (docs/formulation.md §9).

A cut joint joins a frame P on its parent (the input triad: on a rigid body at its offset, on a
flexible body on the deformed node frame, rotated by the triad and then by B = [n1 n2 a], which
turns the joint axis a into the triad's third axis) and a frame C on its child (the child's frame
moved to `child_offset`, or the deformed node frame there). With R the world rotation of P's
triad, d = x_C - x_P and w_P, w_C the frames' angular velocities (world), its constraints are rows
of
    position   r = R^T d                          velocity  R^T (v_C - v_P + d x w_P)
    rotation   (axis alignment, relative rotation) velocity  R^T (w_C - w_P)
selected by the joint type: revolute every position row and the rotation rows about n1, n2;
spherical the position rows; fixed all; prismatic the position rows along n1, n2 and every
rotation row. The velocity rows are G v (G (m, nv), from the tree's body Jacobians, which the
recursion's Xup, U, S build: J_i = Xup_i J_lam + U_i P_lam + S_i P_i) and their time derivative
G qdd + gamma (gamma from the velocity-product accelerations c_i of the same recursion).

Forward dynamics (the tree's mass matrix is never formed): qdd = qdd_0 + K lam with qdd_0 the
articulated-body accelerations of the tree and K = M^-1 G^T, each column one more articulated-body
pass with G^T e_k as generalized force (the response is linear in it); the multipliers solve
(G K) lam = -gamma - G qdd_0 in the least-squares, least-norm sense, so that a planar loop's
redundant rows (out of plane) are harmless. G^T lam is the constraint force: lam's position rows,
R lam_r, are the force from the parent onto the child at C (world), its rotation rows the moment.

Drift: after every output interval the dependent coordinates are corrected by Newton on the
position rows and the velocities projected onto G v = 0 (coordinate partitioning: the dependent
coordinates are one-coordinate tree joints, chosen from the last in q backwards while they add to
G's rank; the independent ones - the first, prescribed and modal - keep their values).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flexmbd.mbd import profiles, spatial
from flexmbd.mbd.dynamics import node_kinematics
from flexmbd.mbd.compiled import entry
from flexmbd.mbd.model import Model, make_data

ROWS = {"revolute": ((0, 1, 2), (0, 1)), "spherical": ((0, 1, 2), ()), "fixed": ((0, 1, 2), (0, 1, 2)),
        "prismatic": ((0, 1), (0, 1, 2))}       # (position rows, rotation rows) in the B-rotated triad
CLOSED = 1e-12          # m (rad): a loop counts as closed when its largest position-row residual is below
RANK = 1e-9             # singular values of G below RANK times the largest are treated as zero


class NotClosed(Exception):
    """A loop that cannot close: args (joint name, residual (m or rad))."""


@dataclass(frozen=True)
class Side:
    """One side of a cut joint: body index, and either a node of a flexible body (its mode block
    Phi (6, nm) [rot; trans], foreshortening D (nm, nm), undeformed position x0 (3,)) or a fixed
    offset (3,) in the body frame; E (3, 3): the side frame's constant rotation from the body (or
    node) frame (the triad's, then B, on the parent side; identity on the child)."""

    body: int
    E: np.ndarray
    offset: np.ndarray
    Phi: np.ndarray | None = None
    D: np.ndarray | None = None
    x0: np.ndarray | None = None


@dataclass(frozen=True)
class Cut:
    name: str
    type: str
    P: Side
    C: Side
    pos: tuple
    rot: tuple


def axis_basis(axis) -> np.ndarray:
    """B (3, 3) = [n1 n2 a]: a right-handed basis whose third column is the unit axis a."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    t = np.eye(3)[np.argmin(np.abs(a))]
    n1 = cross(t, a)
    n1 /= np.linalg.norm(n1)
    return np.column_stack([n1, cross(a, n1), a])


def pick(J, names: list, scale=None) -> list:
    """The first of `names` (columns of J) that each add to J's rank, up to its rank. `scale` (n,),
    when given, is each column's own size (what its coordinate can move the rows by at most): a
    column whose part outside the span of those before it is below 1e-9 of its own size adds
    nothing, so a mode's round-off out of its plane (1e-12 of its slope) is never taken for a
    direction it moves in."""
    J = np.asarray(J, dtype=float)
    if scale is not None:
        J = J / np.maximum(np.asarray(scale, dtype=float), np.abs(J).max(axis=0, initial=0.0) + 1e-300)
    tol = 1e-9 * max(np.abs(J).max(initial=0.0), 1e-300)
    full, out = np.linalg.matrix_rank(J, tol=tol) if J.size else 0, []
    for c, name in enumerate(names):
        if len(out) == full:
            break
        if np.linalg.matrix_rank(J[:, [names.index(n) for n in out] + [c]], tol=tol) == len(out) + 1:
            out.append(name)
    return out


# ---------------------------------------------------------------------------------------------
# kinematics of the cut frames, from one evaluation's Data


def tree_jacobians(model: Model, data):
    """J (nb+1, 6, nv): body velocities v_i = J_i v (body frame), and a0 (nb+1, 6): the spatial
    accelerations at qdd = 0 without gravity (the velocity-product part), from data.Xup, U, S, c
    of an evaluation at the state."""
    nb, nv = model.nb, model.nv
    J, a0 = np.zeros((nb + 1, 6, nv)), np.zeros((nb + 1, 6))
    for i in range(1, nb + 1):
        lam = model.parent[i]
        J[i] = data.Xup[i] @ J[lam]
        a0[i] = data.Xup[i] @ a0[lam] + data.c[i]
        if model.jnt_node[i] >= 0:
            a, nm = model.body_madr[lam], model.body_nm[lam]
            J[i][:, a:a + nm] += data.U[i, :, :nm]
        kv, n = model.jnt_vadr[i], model.jnt_nv[i]
        J[i][:, kv:kv + n] += data.S[i, :, :n]
    return J, a0


@dataclass
class Frame:
    """A side frame at one state, world components: rotation R (3, 3) (frame -> world), origin x
    (3,), angular and linear velocity w, v (3,), their Jacobians Jw, Jv (3, nv), and the
    velocity-product angular and (classical) linear accelerations al0, ac0 (3,)."""

    R: np.ndarray
    x: np.ndarray
    w: np.ndarray
    v: np.ndarray
    Jw: np.ndarray
    Jv: np.ndarray
    al0: np.ndarray
    ac0: np.ndarray


def frame(model: Model, data, J, a0, s: Side, q, v) -> Frame:
    i = s.body
    Ei, ri = data.X0[i, :3, :3], body_origin(data.X0[i])          # global -> body rotation, origin
    if s.Phi is not None:
        a, nm = model.body_madr[i], model.body_nm[i]
        Xn, Sn, cn = node_kinematics(np.ascontiguousarray(s.Phi), np.ascontiguousarray(s.D), s.x0,
                                     q[a:a + nm].copy(), v[a:a + nm].copy())
        Jf = Xn @ J[i]
        Jf[:, a:a + nm] += Sn
        vrel = Sn @ v[a:a + nm]
        vf = Xn @ data.v[i] + vrel
        af0 = Xn @ a0[i] + cn + spatial.cross_motion(vf, vrel)
    else:
        Xn = spatial.plux(np.eye(3), s.offset)
        Jf, vf, af0 = Xn @ J[i], Xn @ data.v[i], Xn @ a0[i]
    En, rn = Xn[:3, :3], body_origin(Xn)
    Rn = Ei.T @ En.T                                                 # node frame -> world
    R = Rn @ s.E
    return Frame(R=R, x=ri + Ei.T @ rn, w=Rn @ vf[:3], v=Rn @ vf[3:], Jw=Rn @ Jf[:3], Jv=Rn @ Jf[3:],
                 al0=Rn @ af0[:3], ac0=Rn @ (af0[3:] + cross(vf[:3], vf[3:])))


def cross(a, b) -> np.ndarray:
    """a x b of two 3-vectors (numpy's general cross costs ten times more on these)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def body_origin(X) -> np.ndarray:
    """r (3,): the origin of frame B in frame A, from X_{B<-A} = plux(E, r)."""
    rx = -X[:3, :3].T @ X[3:, :3]
    return np.array([rx[2, 1], rx[0, 2], rx[1, 0]])


def rows(c: Cut, P: Frame, C: Frame):
    """The cut's rows at one state: residual r (m,), G (m, nv), gamma (m,) (G qdd + gamma is the
    rows' second time derivative), R (3, 3) (P's triad -> world)."""
    R = P.R
    d, dd = C.x - P.x, C.v - P.v
    wT = R.T @ P.w
    rdot_p = R.T @ (dd + cross(d, P.w))
    G_p = R.T @ (C.Jv - P.Jv + spatial.skew(d) @ P.Jw)
    g_p = R.T @ (C.ac0 - P.ac0 + cross(dd, P.w) + cross(d, P.al0)) - cross(wT, rdot_p)
    rho = R.T @ (C.w - P.w)
    G_r = R.T @ (C.Jw - P.Jw)
    g_r = R.T @ (C.al0 - P.al0) - cross(wT, rho)
    Q = R.T @ C.R                                   # child side in the triad (identity when closed)
    if c.type == "revolute":                        # a x (Q a): the axis's misalignment
        r_r = np.array([-Q[1, 2], Q[0, 2], 0.0])
    else:                                           # the relative rotation's small-angle vector
        r_r = 0.5 * np.array([Q[2, 1] - Q[1, 2], Q[0, 2] - Q[2, 0], Q[1, 0] - Q[0, 1]])
    p, o = list(c.pos), list(c.rot)
    return (np.concatenate([(R.T @ d)[p], r_r[o]]), np.vstack([G_p[p], G_r[o]]),
            np.concatenate([g_p[p], g_r[o]]), R)


# ---------------------------------------------------------------------------------------------
# the constrained system


class Loops:
    """The cut joints (`Cut`s: a case's are `build.cuts`) on a Model: evaluation, assembly and
    projection."""

    NotClosed = NotClosed

    def __init__(self, model: Model, cuts: list):
        self.model, self.cuts = model, list(cuts)
        self.data = make_data(model)
        self.zero = np.zeros(model.nv)
        self.dep = None

    def state(self, t, q, v):
        """One tree evaluation at (t, q, v): ([dq/dt; qdd_0] (nq+nv,), r, G, gamma, frames per cut)."""
        m, data = self.model, self.data
        q, v = np.ascontiguousarray(q, dtype=float), np.ascontiguousarray(v, dtype=float)
        rates = entry.rates(m, data, float(t), q, v, self.zero)
        J, a0 = tree_jacobians(m, data)                 # (modal coordinates are never prescribed)
        parts, frames = [], []
        for c in self.cuts:
            P, C = frame(m, data, J, a0, c.P, q, v), frame(m, data, J, a0, c.C, q, v)
            parts.append(rows(c, P, C))
            frames.append((P, C))
        r, G, g = (np.concatenate([x[k] for x in parts]) for k in range(3))
        return rates, r, G, g, frames

    def prescribed(self, t, q, v):
        """q, v with the prescribed joints on their profiles at t (as the evaluation sees them)."""
        m = self.model
        if not m.jnt_prescribed.any():
            return q, v
        q, v = np.array(q, dtype=float), np.array(v, dtype=float)
        for i in np.flatnonzero(m.jnt_prescribed):
            q[m.jnt_qadr[i]], v[m.jnt_vadr[i]], _ = profiles.motion(m.jnt_motion[i], t, m.jnt_q0[i])
        return q, v

    def rates(self, t, q, v):
        """([dq/dt; qdd] (nq+nv,), lam (m,), G (m, nv), frames): the constrained state rates, the
        multipliers and the rows' Jacobian (G^T lam: the constraint forces, generalized)."""
        rates, r, G, g, frames = self.state(t, q, v)
        qdd0 = rates[self.model.nq:]
        K = np.empty((self.model.nv, G.shape[0]))
        q, v = np.ascontiguousarray(q, dtype=float), np.ascontiguousarray(v, dtype=float)
        for k in range(G.shape[0]):             # the response is linear in tau: a large force s G_k keeps the
            s = 1e6 / max(np.abs(G[k]).max(), 1e-300)   # difference from qdd_0 free of qdd_0's round-off
            tau = np.ascontiguousarray(s * G[k])
            K[:, k] = (entry.forward(self.model, self.data, float(t), q, v, tau) - qdd0) / s
        lam = np.linalg.lstsq(G @ K, -g - G @ qdd0, rcond=RANK)[0]
        rates[self.model.nq:] += K @ lam
        return rates, lam, G, frames

    # -- assembly and projection on the dependent coordinates

    def partition(self, q, v, t=0.0) -> np.ndarray:
        """Indices into v (= into q) of the dependent coordinates: one-coordinate tree joints from
        the last backwards, then modal coordinates from the last backwards (a flexible side's
        rows that no joint can meet, such as a planar loop's out-of-plane slope), each taken
        while it adds to G's rank."""
        m = self.model
        _, _, G, _, _ = self.state(t, q, v)
        cand = [m.jnt_vadr[i] for i in range(m.nb, 0, -1)
                if m.jnt_nv[i] == 1 and not m.jnt_prescribed[i] and m.jnt_qadr[i] == m.jnt_vadr[i]]
        cand += [k for i in range(m.nb, 0, -1) if m.jnt_qadr[i] == m.jnt_vadr[i]
                 for k in range(m.body_madr[i] + m.body_nm[i] - 1, m.body_madr[i] - 1, -1)]
        dep = pick(G[:, cand], cand, [self.size(k) for k in cand])
        return np.array(sorted(dep), dtype=int)

    def size(self, k: int) -> float:
        """The most coordinate k (an index into v) can move the cut frames by, per unit: a modal
        coordinate's largest entry (slope or translation) in the mode blocks of the cut sides on
        its body; 0 for a joint coordinate (its column is its own size)."""
        m = self.model
        for i in range(1, m.nb + 1):
            a, nm = m.body_madr[i], m.body_nm[i]
            if m.jnt_qadr[i] == m.jnt_vadr[i] and a <= k < a + nm:
                blocks = [s.Phi[:, k - a] for c in self.cuts for s in (c.P, c.C) if s.body == i and s.Phi is not None]
                return float(max((np.abs(b).max() for b in blocks), default=0.0))
        return 0.0

    def close(self, t, q, v, iterations: int = 30):
        """(q, v) with the dependent coordinates corrected: Newton on the position rows, then the
        velocities projected onto G v = 0. Raises NotClosed (joint, residual) when it fails."""
        q, v = np.array(q, dtype=float), np.array(v, dtype=float)
        if self.dep is None:
            self.dep = self.partition(q, v, t)
        dep = self.dep
        for _ in range(iterations):
            _, r, G, _, _ = self.state(t, q, v)
            if np.abs(r).max() < CLOSED:
                break
            q[dep] -= np.linalg.lstsq(G[:, dep], r, rcond=RANK)[0]
        _, r, G, _, _ = self.state(t, q, v)
        if not np.all(np.isfinite(r)) or np.abs(r).max() >= 1e3 * CLOSED:
            k = int(np.nanargmax(np.abs(r))) if np.any(np.isfinite(r)) else 0
            raise NotClosed(self.row_joint(k), float(np.abs(r).max()))
        q, v = self.prescribed(t, q, v)
        v[dep] -= np.linalg.lstsq(G[:, dep], G @ v, rcond=RANK)[0]
        return q, v

    def row_joint(self, k: int) -> str:
        """The name of the cut joint that row k belongs to."""
        for c in self.cuts:
            n = len(c.pos) + len(c.rot)
            if k < n:
                return c.name
            k -= n
        return self.cuts[-1].name

    def violation(self, t, q, v) -> tuple[float, float]:
        """(largest position-row residual, largest velocity-row residual) at one state."""
        _, r, G, _, _ = self.state(t, q, v)
        return float(np.abs(r).max()), float(np.abs(G @ self.prescribed(t, q, v)[1]).max())

    def wrenches(self, lam, frames) -> list:
        """Per cut joint (name, force f (3,), moment n (3,), point x (3,)), world components: what
        the cut exerts on its child at C (the parent side takes -f, -n at the same point)."""
        out, k = [], 0
        for c, (P, C) in zip(self.cuts, frames):
            f, n = np.zeros(3), np.zeros(3)
            f[list(c.pos)] = lam[k:k + len(c.pos)]
            k += len(c.pos)
            n[list(c.rot)] = lam[k:k + len(c.rot)]
            k += len(c.rot)
            out.append((c.name, P.R @ f, P.R @ n, C.x))
        return out

    def reactions(self, lam, frames) -> dict:
        """{cut joint: (6,) [moment; force]}: what the cut transmits from its parent side onto its
        child, at the joint point, in the child's body frame (of the last evaluation)."""
        return {name: np.concatenate([self.data.X0[c.C.body, :3, :3] @ n, self.data.X0[c.C.body, :3, :3] @ f])
                for c, (name, f, n, _) in zip(self.cuts, self.wrenches(lam, frames))}
