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
articulated-body accelerations of the tree and K = M^-1 G^T, each column the response of the same
evaluation's factored articulated inertias to G^T e_k as generalized force (`dynamics.response`);
the multipliers solve (G K) lam = -gamma - G qdd_0 in the least-squares, least-norm sense, so that
a planar loop's redundant rows (out of plane) are harmless. G^T lam is the constraint force: lam's
position rows, R lam_r, are the force from the parent onto the child at C (world), its rotation
rows the moment.

Drift: at every output instant the dependent coordinates are corrected by Newton on the position
rows and the velocities projected onto G v = 0 (coordinate partitioning: the dependent
coordinates are one-coordinate tree joints, chosen from the last in q backwards while they add to
G's rank; the independent ones - the first, prescribed and modal - keep their values).

The rows, the constrained accelerations and the projection are compiled functions of the cuts
packed as arrays (`CutArrays`) and an entry of the kernel (`compiled.entry.handle`), so that a
compiled integrator calls them without returning to Python (`integrate.dopri5`); `Loops` calls
the same functions from Python.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from flexmbd.mbd import profiles
from flexmbd.mbd.compiled.bound import bind
from flexmbd.mbd.compiled.dense import mm, mm_add_into, mm_into, mtm, mtv, mv, sym_lstsq
from flexmbd.mbd.compiled.entry import KINEMATICS, RATES, bound_of, call, handle
from flexmbd.mbd.compiled.jit import njit
from flexmbd.mbd.dynamics import node_kinematics, prescribed, response
from flexmbd.mbd.model import Model, make_data
from flexmbd.mbd.spatial import cross_motion, skew, xlt, xmv_into

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
# the cuts as arrays, for compiled code


class CutArrays(NamedTuple):
    """The cut joints (`Cut`s) of a Loops packed for compiled code: per cut c and side s (0 the
    parent's P, 1 the child's C), and per constraint row j; `dep` the dependent coordinates and
    `fail` where a projection that failed leaves its residual and row."""

    body: np.ndarray        # (nc, 2) the side's body
    node: np.ndarray        # (nc, 2) True: on a flexible body's node (Phi, D, x0), else at `offset`
    E: np.ndarray           # (nc, 2, 3, 3) the side frame's constant rotation from the body (or node) frame
    offset: np.ndarray      # (nc, 2, 3) a rigid side's offset in its body frame
    Phi: np.ndarray         # (nc, 2, 6, nm) a node's mode block [rot; trans], zero-padded to the model's nm
    D: np.ndarray           # (nc, 2, nm, nm) its foreshortening matrix
    x0: np.ndarray          # (nc, 2, 3) its undeformed position
    revolute: np.ndarray    # (nc,) True: the rotation rows are the axis's misalignment
    row_cut: np.ndarray     # (m,) the cut of each row
    row_kind: np.ndarray    # (m,) which of its rows: 0-2 position (R^T d), 3-5 rotation
    dep: np.ndarray         # (nd,) indices into v (= into q) of the dependent coordinates
    fail: np.ndarray        # (2,) a failed projection's largest residual (m or rad) and its row


def pack(model: Model, cuts: list) -> CutArrays:
    """The CutArrays of `cuts` on `model`, no dependent coordinates yet (`Loops.closing`)."""
    nc, nm = len(cuts), model.jnt_Phi.shape[2]
    out = CutArrays(body=np.zeros((nc, 2), dtype=np.int64), node=np.zeros((nc, 2), dtype=np.bool_),
                    E=np.zeros((nc, 2, 3, 3)), offset=np.zeros((nc, 2, 3)), Phi=np.zeros((nc, 2, 6, nm)),
                    D=np.zeros((nc, 2, nm, nm)), x0=np.zeros((nc, 2, 3)),
                    revolute=np.array([c.type == "revolute" for c in cuts], dtype=np.bool_),
                    row_cut=np.array([k for k, c in enumerate(cuts) for _ in (*c.pos, *c.rot)], dtype=np.int64),
                    row_kind=np.array([j for c in cuts for j in (*c.pos, *(3 + o for o in c.rot))], dtype=np.int64),
                    dep=np.zeros(0, dtype=np.int64), fail=np.zeros(2))
    for k, c in enumerate(cuts):
        for s, side in enumerate((c.P, c.C)):
            out.body[k, s], out.E[k, s], out.offset[k, s] = side.body, side.E, side.offset
            if side.Phi is not None:
                n = side.Phi.shape[1]
                out.node[k, s] = True
                out.Phi[k, s, :, :n], out.D[k, s, :n, :n], out.x0[k, s] = side.Phi, side.D, side.x0
    return out


# ---------------------------------------------------------------------------------------------
# kinematics of the cut frames, from one evaluation's Data (compiled)


@njit
def tree_jacobians(model, data, nv):
    """J (nb+1, 6, nv): body velocities v_i = J_i v (body frame), and a0 (nb+1, 6): the spatial
    accelerations at qdd = 0 without gravity (the velocity-product part), from data.Xup, U, S, c
    of an evaluation at the state."""
    n = model.parent.size
    J, a0 = np.zeros((n, 6, nv)), np.zeros((n, 6))
    for i in range(1, n):
        lam = model.parent[i]
        mm_into(data.Xup[i], J[lam], J[i])
        xmv_into(data.Xup[i], a0[lam], a0[i])
        a0[i] += data.c[i]
        if model.jnt_node[i] >= 0:
            a, nm = model.body_madr[lam], model.body_nm[lam]
            J[i, :, a:a + nm] += data.U[i, :, :nm]
        kv, nj = model.jnt_vadr[i], model.jnt_nv[i]
        J[i, :, kv:kv + nj] += data.S[i, :, :nj]
    return J, a0


@njit
def frame(model, data, J, a0, cuts, c, s, q, v):
    """Side s of cut c at one state: (Rn (3, 3) the body's or node's frame -> world, R (3, 3) the
    side frame's (Rn E), origin x (3,), angular and linear velocity w, u (3,), world, Jf (6, nv):
    [angular; linear] velocity Jacobian in the node (or offset) frame, and the velocity-product
    angular and (classical) linear accelerations al0, ac0 (3,), world)."""
    i = cuts.body[c, s]
    Ei = data.X0[i, :3, :3]                                         # global -> body rotation
    if cuts.node[c, s]:
        a, nm = model.body_madr[i], model.body_nm[i]
        eta_d = v[a:a + nm]
        Xn, Sn, cn = node_kinematics(cuts.Phi[c, s, :, :nm], cuts.D[c, s, :nm, :nm], cuts.x0[c, s], q[a:a + nm],
                                     eta_d)
        Jf = mm(Xn, J[i])
        Jf[:, a:a + nm] += Sn
        vrel = mv(Sn, eta_d)
        vf = mv(Xn, data.v[i]) + vrel
        af0 = mv(Xn, a0[i]) + cn + cross_motion(vf, vrel)
    else:
        Xn = xlt(cuts.offset[c, s])
        Jf, vf, af0 = mm(Xn, J[i]), mv(Xn, data.v[i]), mv(Xn, a0[i])
    Rn = mtm(Ei, Xn[:3, :3].T)                                       # node frame -> world
    x = body_origin(data.X0[i]) + mtv(Ei, body_origin(Xn))
    af0[3:] += cross(vf[:3], vf[3:])
    return (Rn, mm(Rn, cuts.E[c, s]), x, mv(Rn, vf[:3]), mv(Rn, vf[3:]), Jf, mv(Rn, af0[:3]),
            mv(Rn, af0[3:]))


@njit
def cross(a, b):
    """a x b of two 3-vectors (numpy's general cross costs ten times more on these)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


@njit
def body_origin(X):
    """r (3,): the origin of frame B in frame A, from X_{B<-A} = plux(E, r) = [E 0; -E r~ E]:
    r~ = -E^T F, F its lower-left block."""
    r = np.zeros(3)
    for l in range(3):
        r[0] -= X[l, 2] * X[3 + l, 1]
        r[1] -= X[l, 0] * X[3 + l, 2]
        r[2] -= X[l, 1] * X[3 + l, 0]
    return r


@njit
def rows(model, data, cuts, q, v):
    """The cuts' rows at one state, after an evaluation there (data: its kinematics): residual r
    (m,), G (m, nv), gamma (m,) (G qdd + gamma is the rows' second time derivative), and per cut
    R (nc, 3, 3) (P's triad -> world) and x_C (nc, 3) (C's origin, world).

    The velocity rows R^T (w_C - w_P) and R^T (v_C - v_P + d x w_P) take the sides' Jacobians
    in their own frames, Jf, turned by R^T Rn (3, 3) once, not each turned to the world and back."""
    nc, m, nv = cuts.body.shape[0], cuts.row_cut.size, v.size
    J, a0 = tree_jacobians(model, data, nv)
    r, G, g = np.empty(m), np.empty((m, nv)), np.empty(m)
    R, xc = np.empty((nc, 3, 3)), np.empty((nc, 3))
    r6, G6, g6 = np.empty(6), np.empty((6, nv)), np.empty(6)
    for c in range(nc):
        PRn, PR, Px, Pw, Pu, PJ, Pal, Pac = frame(model, data, J, a0, cuts, c, 0, q, v)
        CRn, CR, Cx, Cw, Cu, CJ, Cal, Cac = frame(model, data, J, a0, cuts, c, 1, q, v)
        d, dd = Cx - Px, Cu - Pu
        wT = mtv(PR, Pw)
        rdot_p = mtv(PR, dd + cross(d, Pw))
        rho = mtv(PR, Cw - Pw)
        Q = mtm(PR, CR)                             # child side in the triad (identity when closed)
        r6[:3] = mtv(PR, d)
        if cuts.revolute[c]:                        # a x (Q a): the axis's misalignment
            r6[3], r6[4], r6[5] = -Q[1, 2], Q[0, 2], 0.0
        else:                                       # the relative rotation's small-angle vector
            r6[3], r6[4], r6[5] = 0.5 * (Q[2, 1] - Q[1, 2]), 0.5 * (Q[0, 2] - Q[2, 0]), 0.5 * (Q[1, 0] - Q[0, 1])
        AC, AP = mtm(PR, CRn), -mtm(PR, PRn)        # each side's frame in the triad (P's taken away)
        G6[:] = 0.0
        mm_add_into(AC, CJ[3:], G6[:3])             # R^T (Ju_C - Ju_P + d~ Jw_P)
        mm_add_into(AP, PJ[3:], G6[:3])
        mm_add_into(mm(mtm(PR, skew(d)), PRn), PJ[:3], G6[:3])
        mm_add_into(AC, CJ[:3], G6[3:])             # R^T (Jw_C - Jw_P)
        mm_add_into(AP, PJ[:3], G6[3:])
        g6[:3] = mtv(PR, Cac - Pac + cross(dd, Pw) + cross(d, Pal)) - cross(wT, rdot_p)
        g6[3:] = mtv(PR, Cal - Pal) - cross(wT, rho)
        for j in range(m):
            if cuts.row_cut[j] == c:
                kind = cuts.row_kind[j]
                r[j], G[j], g[j] = r6[kind], G6[kind], g6[kind]
        R[c], xc[c] = PR, Cx
    return r, G, g, R, xc


# ---------------------------------------------------------------------------------------------
# the constrained accelerations and the projection (compiled; k is an entry, `compiled.entry.handle`)


@njit
def cut_state(k, cuts, t, q, v):
    """One tree evaluation at (t, q, v) through the entry k and the cuts' rows there: ([dq/dt;
    qdd_0] (nq+nv,), r, G, gamma, R, x_C) (`rows`). q, v C-contiguous."""
    b = bound_of(k)
    out = np.empty(q.size + v.size)
    call(k, t, q, v, np.zeros(v.size), out, RATES)
    r, G, g, R, xc = rows(b.model, b.data, cuts, q, v)
    return out, r, G, g, R, xc


@njit
def cut_rows(k, cuts, t, q, v):
    """The cuts' rows at (t, q, v) (`rows`) after the tree's kinematics alone (the entry's
    KINEMATICS: no inertia, no accelerations). q, v C-contiguous."""
    b = bound_of(k)
    call(k, t, q, v, v, v, KINEMATICS)               # (tau and out are not read)
    return rows(b.model, b.data, cuts, q, v)


@njit
def constrained_rates(k, cuts, t, q, v):
    """([dq/dt; qdd] (nq+nv,), lam (m,), G (m, nv), R, x_C): the constrained state rates at (t, q,
    v), the multipliers, the rows' Jacobian (G^T lam: the constraint forces, generalized) and the
    cut frames (`rows`). K = M^-1 G^T column by column from the evaluation's factored articulated
    inertias (`dynamics.response`); lam solves (G K) lam = -gamma - G qdd_0, least squares and
    least norm (singular values below RANK of the largest dropped: a planar loop's redundant
    rows; `dense.sym_lstsq`, nan when not finite)."""
    out, _, G, g, R, xc = cut_state(k, cuts, t, q, v)
    nq, nv, m = q.size, v.size, G.shape[0]
    b = bound_of(k)
    K = np.empty((nv, m))
    for j in range(m):                              # inlined: through the entry, the call costs as much
        K[:, j] = response(b.model, b.data, G[j])   # as the response
    lam = sym_lstsq(mm(G, K), -g - mv(G, out[nq:]), RANK)          # G K = G M^-1 G^T: symmetric
    out[nq:] += mv(K, lam)
    return out, lam, G, R, xc


@njit
def lstsq_dep(G, dep, b):
    """The least-squares, least-norm x (nd,) of G[:, dep] x = b (singular values below RANK of the
    largest dropped); nan where G or b is not finite (numpy's lstsq refuses them)."""
    A = np.empty((G.shape[0], dep.size))
    for j in range(dep.size):
        A[:, j] = G[:, dep[j]]
    if not (np.all(np.isfinite(A)) and np.all(np.isfinite(b))):
        return np.full(dep.size, np.nan)
    return np.linalg.lstsq(A, b, rcond=RANK)[0]


@njit
def project(k, cuts, t, q, v, iterations):
    """Close the loops at time t in place: Newton on the position rows over the dependent
    coordinates cuts.dep (the others keep their values; at most `iterations` corrections), then
    the prescribed joints on their profiles and the velocities projected onto G v = 0 over the
    dependent ones. q, v C-contiguous. True when closed; False leaves the largest residual and its
    row in cuts.fail (q, v then partly corrected)."""
    dep = cuts.dep
    for it in range(iterations + 1):
        r, G = cut_rows(k, cuts, t, q, v)[:2]
        worst = np.abs(r).max()
        if not worst >= CLOSED or it == iterations:     # closed, not finite, or out of iterations
            break
        dq = lstsq_dep(G, dep, r)
        for j in range(dep.size):
            q[dep[j]] -= dq[j]
    if not np.isfinite(worst) or worst >= 1e3 * CLOSED:
        cuts.fail[0] = worst
        cuts.fail[1] = np.argmax(np.abs(r)) if np.isfinite(worst) else 0
        return False
    b = bound_of(k)
    qp, vp = prescribed(b.model, b.data, t, q, v)
    q[:] = qp
    v[:] = vp
    dv = lstsq_dep(G, dep, mv(G, v))
    for j in range(dep.size):
        v[dep[j]] -= dv[j]
    return True


# ---------------------------------------------------------------------------------------------
# the constrained system


class Loops:
    """The cut joints (`Cut`s: a case's are `build.cuts`) on a Model: evaluation, assembly and
    projection, through compiled code on the arrays (`arrays`, `CutArrays`) with a Data of its own."""

    NotClosed = NotClosed

    def __init__(self, model: Model, cuts: list):
        self.model, self.cuts = model, list(cuts)
        self.data = make_data(model)
        self.bound = bind(model, self.data)         # alive as long as the Loops: reached by address
        self.entry = handle(self.bound)
        self.arrays = pack(model, self.cuts)
        self.dep = None

    @staticmethod
    def _contiguous(q, v):
        """q, v as the compiled functions take them: C-contiguous float arrays."""
        return np.ascontiguousarray(q, dtype=float), np.ascontiguousarray(v, dtype=float)

    def state(self, t, q, v):
        """One tree evaluation at (t, q, v): ([dq/dt; qdd_0] (nq+nv,), r, G, gamma, frames), frames
        (R (nc, 3, 3), x_C (nc, 3)) as `rows` gives them."""
        rates, r, G, g, R, xc = cut_state(self.entry, self.arrays, float(t), *self._contiguous(q, v))
        return rates, r, G, g, (R, xc)

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
        multipliers and the rows' Jacobian (G^T lam: the constraint forces, generalized)
        (`constrained_rates`)."""
        rates, lam, G, R, xc = constrained_rates(self.entry, self.arrays, float(t), *self._contiguous(q, v))
        return rates, lam, G, (R, xc)

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

    def closing(self, t, q, v) -> CutArrays:
        """The arrays with the dependent coordinates, partitioned at (t, q, v) on the first call."""
        if self.dep is None:
            self.dep = self.partition(q, v, t)
            self.arrays = self.arrays._replace(dep=np.asarray(self.dep, dtype=np.int64))
        return self.arrays

    def close(self, t, q, v, iterations: int = 30):
        """(q, v) with the dependent coordinates corrected: Newton on the position rows, then the
        velocities projected onto G v = 0 (`project`). Raises NotClosed (joint, residual) when it
        fails."""
        q, v = np.array(q, dtype=float), np.array(v, dtype=float)
        arrays = self.closing(t, q, v)
        if not project(self.entry, arrays, float(t), q, v, iterations):
            raise NotClosed(self.row_joint(int(arrays.fail[1])), float(arrays.fail[0]))
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
        (R, xc), out, k = frames, [], 0
        for i, c in enumerate(self.cuts):
            f, n = np.zeros(3), np.zeros(3)
            f[list(c.pos)] = lam[k:k + len(c.pos)]
            k += len(c.pos)
            n[list(c.rot)] = lam[k:k + len(c.rot)]
            k += len(c.rot)
            out.append((c.name, R[i] @ f, R[i] @ n, xc[i]))
        return out

    def reactions(self, lam, frames) -> dict:
        """{cut joint: (6,) [moment; force]}: what the cut transmits from its parent side onto its
        child, at the joint point, in the child's body frame (of the last evaluation)."""
        return {name: np.concatenate([self.data.X0[c.C.body, :3, :3] @ n, self.data.X0[c.C.body, :3, :3] @ f])
                for c, (name, f, n, _) in zip(self.cuts, self.wrenches(lam, frames))}
