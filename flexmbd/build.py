"""Case -> Model: the Model arrays (model.Arrays) of a case's bodies, joints and loads, and the
cut joints (`constraints.Cut`) of its loops on that Model."""

from __future__ import annotations

import numpy as np

from flexmbd import flexbody
from flexmbd.mbd import constraints, invariants, profiles, spatial
from flexmbd.cases import Rigid
from flexmbd.mbd.joints import JOINT_CODES, NQ, NV, initial_q
from flexmbd.mbd.constraints import ROWS, Cut, Side, axis_basis
from flexmbd.mbd.model import Arrays, Model, empty_arrays, empty_loads


def from_case(case, bodies: dict | None = None) -> Model:
    """Build the Model of a resolved case (`cases.Resolved`: the tree as given, every beam whole;
    the modal model of a Case is that of `case.modelled`); `bodies`: reduced flexible bodies by
    name (built when None)."""
    if bodies is None:
        bodies = flexbody.for_case(case)
    order = case.order
    index = {name: k + 1 for k, name in enumerate(order)}
    nb = len(order)
    nm = max([fb.n_modes for fb in bodies.values()] + [0])

    A = {k: x for k, x in empty_arrays(nb, nm).items() if not k.startswith("jnt_motion") and k != "jnt_q0"}
    invs = [None] * (nb + 1)
    motion, jnames, q0, v0 = [None] * (nb + 1), [""] * (nb + 1), [], []
    nq = nv = 0
    for name in order:
        i = index[name]
        j = case.joint_of(name)
        jnames[i], motion[i] = j.name, j.motion
        A["jnt_prescribed"][i] = j.motion is not None
        A["parent"][i] = 0 if j.parent == "ground" else index[j.parent]
        t = JOINT_CODES[j.type]
        A["jnt_type"][i], A["jnt_nv"][i] = t, NV[t]
        A["jnt_axis"][i] = j.axis
        attach(A, i, j, case.bodies.get(j.parent), bodies.get(j.parent))
        A["jnt_qadr"][i], A["jnt_vadr"][i] = nq, nv
        q0.extend(initial_q(t, list(j.q0)))
        v0.extend(j.qd0)
        nq, nv = nq + NQ[t], nv + NV[t]

        body = case.bodies[name]
        if isinstance(body, Rigid):                     # a point mass too: its com at the origin, no inertia
            A["body_inertia"][i] = spatial.inertia(body.mass, np.asarray(body.com, dtype=float),
                                                   inertia_matrix(body.inertia))
            A["body_mass"][i] = body.mass
        elif body.rigid:
            fb = flexbody.undeformed(name, body)
            A["body_inertia"][i] = rigid_inertia_of_beam(fb)
            A["body_mass"][i] = fb.m.sum()
        else:
            fb = bodies[name]
            k = fb.n_modes
            invs[i] = invariants.invariants(fb, body.stiffening)
            A["body_mass"][i] = fb.m.sum()
            A["body_madr"][i], A["body_nm"][i] = nq, k
            A["flex_K"][i, :k, :k], A["flex_C"][i, :k, :k] = fb.Km, fb.Cm
            q0.extend([0.0] * k)
            v0.extend([0.0] * k)
            nq, nv = nq + k, nv + k

    A.update(motion_arrays(motion, A["jnt_qadr"], A["jnt_nv"], q0))
    loads = point_loads(case, index, bodies, nm)
    arrays = Arrays(**A, inv=invariants.stack(invs, nm), **loads[0],
                    gravity=np.asarray(case.gravity, dtype=float))
    return Model(nb=nb, nq=nq, nv=nv, arrays=arrays, names=("ground",) + tuple(order),
                 jnt_names=tuple(jnames), jnt_motion=tuple(motion), load_profiles=loads[1],
                 bodies=dict(bodies), q0=np.array(q0, dtype=float), v0=np.array(v0, dtype=float))


def loops(model: Model, case) -> constraints.Loops | None:
    """The loops of a resolved case (`case.loops`: its cut joints) on its Model; None without."""
    return constraints.Loops(model, cuts(model, case)) if case.loops else None


def cuts(model: Model, case) -> list:
    """The Cuts of the case's loop joints (`case.loops`) on `model` (built from `case`): each side
    on its body's node (a flexible beam: the node's mode block, foreshortening and position) or at
    its offset, turned so that the joint axis is the side frame's third (`constraints.axis_basis`)."""
    out = []
    for j in case.loops.values():
        if j.type not in ROWS:
            raise ValueError(f"joint {j.name!r}: a {j.type} joint cannot close a loop (it constrains nothing)")
        B = axis_basis(j.axis)
        triad = np.array(j.triad)                       # rows: the triad's axes in the parent frame
        P = side(model, case, j.parent, j.point, j.offset, triad.T @ B)
        C = side(model, case, j.child, j.child_point, j.child_offset, B)
        pos, rot = ROWS[j.type]
        out.append(Cut(name=j.name, type=j.type, P=P, C=C, pos=pos, rot=rot))
    return out


def side(model: Model, case, body: str, point, offset, E) -> Side:
    """One side of a cut joint on `body`: at a flexible beam's node, or at `offset` in its frame."""
    i = model.index(body)
    b = case.bodies[body]
    if b.type == "beam" and b.flexible and point is not None:
        fb, p, nm = model.bodies[body], point.node, model.body_nm[i]
        D = fb.D[p] if b.stiffening else np.zeros((nm, nm))
        return Side(body=i, E=E, offset=np.zeros(3), Phi=fb.Phi[p], D=D, x0=fb.x0[p])
    return Side(body=i, E=E, offset=np.asarray(offset, dtype=float))


def attach(A: dict, i: int, j, pbody, fb: flexbody.FlexBody | None) -> None:
    """Input triad of joint i (`cases.Joint` j, its triad's rotation in the parent frame): on ground,
    a rigid body or a beam declared rigid at its offset (a beam's snapped node); on a flexible beam
    at its snapped node, which carries it."""
    R = np.array(j.triad)
    if pbody is None or isinstance(pbody, Rigid) or pbody.rigid:
        A["jnt_Xtriad"][i] = spatial.plux(R.T, np.asarray(j.offset, dtype=float))
    else:
        p = j.point.node
        A["jnt_Xtriad"][i] = spatial.plux(R.T, np.zeros(3))
        A["jnt_node"][i], A["jnt_x0"][i] = p, fb.x0[p]
        A["jnt_Phi"][i, :, :fb.n_modes] = fb.Phi[p]
        if pbody.stiffening:
            A["jnt_D"][i, :fb.n_modes, :fb.n_modes] = fb.D[p]


def motion_arrays(motion: list, qadr, nv, q0: list) -> dict:
    """The jnt_motion_* arrays and jnt_q0 from the joints' motion profiles (None: free joint)."""
    codes = [profiles.encode_motion(p) if p is not None else None for p in motion]
    nt = max([c[2].size for c in codes if c is not None] + [2])
    M = {k: x for k, x in empty_arrays(len(motion) - 1, 0, nt).items() if k.startswith("jnt_motion") or k == "jnt_q0"}
    for i, c in enumerate(codes):
        if nv[i] == 1:
            M["jnt_q0"][i] = q0[qadr[i]]
        if c is not None:
            kind, par, tx, tc = c
            M["jnt_motion_kind"][i], M["jnt_motion_par"][i] = kind, par
            M["jnt_motion_n"][i] = tx.size
            M["jnt_motion_x"][i, :tx.size], M["jnt_motion_c"][i, :, :tc.shape[1]] = tx, tc
    return M


def point_loads(case, index: dict, bodies: dict, nm: int):
    """Load arrays (see Arrays.load_*) and their time profiles."""
    loads = list(case.loads.values())
    nl = len(loads)
    L = empty_loads(nl, nm)
    for k, ld in enumerate(loads):
        L["load_body"][k] = index[ld.body]
        L["load_force"][k] = ld.force
        L["load_global"][k] = ld.frame == "global"
        L["load_kind"][k], L["load_par"][k] = profiles.encode_load(ld.profile)
        body = case.bodies[ld.body]
        if isinstance(body, Rigid) or body.rigid:       # a beam declared rigid: its snapped node
            L["load_point"][k] = ld.offset
        else:
            fb = bodies[ld.body]
            p = ld.point.node
            L["load_point"][k] = fb.x0[p]
            L["load_Phi"][k, :, :fb.n_modes] = fb.Phi[p]
            if body.stiffening:
                L["load_D"][k, :fb.n_modes, :fb.n_modes] = fb.D[p]
    return L, tuple(ld.profile for ld in loads)


def rigid_inertia_of_beam(fb: flexbody.FlexBody) -> np.ndarray:
    """Spatial inertia (6, 6) at the body origin of a beam declared rigid: the undeformed invariants."""
    inv = invariants.invariants(fb)
    I = np.zeros((6, 6))
    I[:3, :3] = inv.I1[0]
    I[:3, 3:] = spatial.skew(inv.I4[0])
    I[3:, :3] = spatial.skew(inv.I4[0]).T
    I[3:, 3:] = inv.I8[0] * np.eye(3)
    return I


def inertia_matrix(six) -> np.ndarray:
    """[Ixx, Iyy, Izz, Ixy, Ixz, Iyz] -> symmetric (3, 3)."""
    xx, yy, zz, xy, xz, yz = six
    return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
