"""Case -> Model: a case's bodies, joints and loads in the solver's terms (`mbd.tree`), and the
cut joints (`constraints.Cut`) of its loops on that Model."""

from __future__ import annotations

import numpy as np

from flexmbd.fe import flexbody
from flexmbd.cases import Rigid
from flexmbd.mbd import constraints, invariants, profiles, spatial, tree
from flexmbd.mbd.constraints import ROWS, Cut, Side, axis_basis
from flexmbd.mbd.model import Model, empty_loads


def from_case(case, bodies: dict | None = None) -> Model:
    """Build the Model of a resolved case (`cases.Resolved`: the tree as given, every beam whole;
    the modal model of a Case is that of `case.modelled`); `bodies`: reduced flexible bodies by
    name (built when None). The case's bodies and joints in the solver's terms (`body`, `joint`),
    the Model from them (`mbd.tree.model`)."""
    if bodies is None:
        bodies = flexbody.for_case(case)
    index = {name: k + 1 for k, name in enumerate(case.order)}
    nm = max([fb.n_modes for fb in bodies.values()] + [0])
    joints = [case.joint_of(name) for name in case.order]
    return tree.model([body(case, name, bodies) for name in case.order],
                      [joint(j, index, case.bodies.get(j.parent)) for j in joints],
                      case.gravity, point_loads(case, index, bodies, nm))


def body(case, name: str, bodies: dict) -> tree.Body:
    """A case's body as the solver takes it: a rigid body's (a point mass's: no inertia) and a beam
    declared rigid's spatial inertia at its origin, or a flexible body's reduced arrays."""
    b = case.bodies[name]
    if isinstance(b, Rigid):
        return tree.Body(name, inertia=spatial.inertia(b.mass, np.asarray(b.com, dtype=float), inertia_matrix(b.inertia)),
                         mass=b.mass)
    if b.rigid:
        fb = flexbody.undeformed(name, b)
        return tree.Body(name, inertia=rigid_inertia_of_beam(fb), mass=fb.m.sum())
    return tree.Body(name, flex=bodies[name], stiffening=b.stiffening)


def joint(j, index: dict, pbody) -> tree.Joint:
    """A case's joint (`cases.Joint`) as the solver takes it, on its parent `pbody` (None: ground):
    on a flexible body at its snapped node, elsewhere at its offset (`triad`)."""
    on_node = not (pbody is None or isinstance(pbody, Rigid) or pbody.rigid)
    return tree.Joint(j.name, 0 if j.parent == "ground" else index[j.parent], j.type, axis=tuple(j.axis),
                      Xtriad=triad(j, on_node), node=j.point.node if on_node else -1, q0=tuple(j.q0),
                      qd0=tuple(j.qd0), motion=j.motion)


def triad(j, on_node: bool) -> np.ndarray:
    """The input triad of joint j (6, 6): its rotation (`j.triad`, rows) at its offset in the
    parent frame, or at the origin of the node frame it sits on."""
    R = np.array(j.triad)
    return spatial.plux(R.T, np.zeros(3) if on_node else np.asarray(j.offset, dtype=float))


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
