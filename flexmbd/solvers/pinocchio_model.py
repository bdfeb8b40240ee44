"""Pinocchio models: the `pinocchio` peer's, built from a case, and a flexmbd Model's, for tests.

The peer's model (`rigid_model`, `initial_state`, and `loop_constraints` closing its loops) is
built from the case's rigid limit as a user of Pinocchio would build it, through Pinocchio's model
API (`pin.Model.addJoint`, `appendBodyToJoint`, `pin.Inertia`, `pin.SE3`,
`pin.RigidConstraintModel`): the bodies, joints and loads of the case (`common.rigid_bodies`,
`case.loops`), never flexmbd's Model arrays, so an error in `build.from_case` shows up as a
disagreement. The API rather than URDF text: URDF has no spherical joint and only one
floating base (the cases may hold several free joints, and spherical ones), and the API takes the
numbers as floats, with no text round trip.

`build`, `build_frames`, `to_pin_q`, `to_pin_v`, `from_pin_v` convert a rigid flexmbd Model
itself; they serve the checks of flexmbd's recursive algorithms on given Model arrays
(tests/mbd/test_dynamics.py, tests/mbd/test_integrate.py, `flexmbd bench`), not the peer.

Conventions converted here and nowhere else: Pinocchio's spatial vectors are [linear; angular],
its quaternions [x, y, z, w] (flexmbd: [w, x, y, z]), its free-flyer configuration
[position; quaternion] (flexmbd: [quaternion; position]) and velocity [v; w] (flexmbd: [w; v]).
Fixed joints have no Pinocchio joint: the child's inertia is appended to the parent's joint with
the composed placement, and the child's children hang from that joint with it.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from flexmbd.mbd import spatial
from flexmbd.mbd.joints import FIXED, FREE, PRISMATIC, REVOLUTE, SPHERICAL
from flexmbd.mbd.model import Model


# ---------------------------------------------------------------------------------------------
# the peer: a case's rigid limit


def rigid_model(bodies, gravity) -> tuple["pin.Model", dict]:
    """Pinocchio model of a case's rigid limit (`common.rigid_bodies`, tree order) under gravity
    (3,); returns (model, frame) with frame[body name] = (pin joint id, placement of the body
    frame in that joint's frame): a body on a fixed joint lives in its parent's joint at the
    composed placement of its triad."""
    pm = pin.Model()
    pm.gravity.linear = np.asarray(gravity, dtype=float)
    frame = {"ground": (0, pin.SE3.Identity())}
    for b in bodies:
        jid_parent, off = frame[b.parent]
        placement = off * pin.SE3(b.R, b.r)                    # the input triad in the joint frame
        inertia = pin.Inertia(b.mass, b.com, b.inertia)         # body frame, about the com
        if b.type == "fixed":
            pm.appendBodyToJoint(jid_parent, inertia, placement)
            frame[b.name] = (jid_parent, placement)
            continue
        jm = {"revolute": lambda: pin.JointModelRevoluteUnaligned(b.axis),
              "prismatic": lambda: pin.JointModelPrismaticUnaligned(b.axis),
              "spherical": pin.JointModelSpherical, "free": pin.JointModelFreeFlyer}[b.type]()
        jid = pm.addJoint(jid_parent, jm, placement, b.joint)
        pm.appendBodyToJoint(jid, inertia, pin.SE3.Identity())  # the body frame is the joint frame
        frame[b.name] = (jid, pin.SE3.Identity())
    return pm, frame


def initial_state(pm, bodies, frame) -> tuple[np.ndarray, np.ndarray]:
    """(q, v) in Pinocchio's layout from the case's initial values: rotation vectors become
    quaternions [x, y, z, w] (`pin.exp3`), the free joint's [w; v] (body frame) becomes [v; w]."""
    q, v = pin.neutral(pm), np.zeros(pm.nv)
    for b in bodies:
        if b.type == "fixed":
            continue
        j = pm.joints[frame[b.name][0]]
        iq, iv = j.idx_q, j.idx_v
        if b.type in ("revolute", "prismatic"):
            q[iq], v[iv] = b.q0[0], b.qd0[0]
        elif b.type == "spherical":
            q[iq:iq + 4] = quaternion(b.q0)
            v[iv:iv + 3] = b.qd0
        else:
            q[iq:iq + 3], q[iq + 3:iq + 7] = b.q0[3:], quaternion(b.q0[:3])
            v[iv:iv + 3], v[iv + 3:iv + 6] = b.qd0[3:], b.qd0[:3]
    return q, v


def loop_constraints(pm, frame, loops) -> list:
    """Pinocchio's rigid constraints closing a case's cut joints (`case.loops`: name -> cases.Joint,
    revolute, spherical or fixed), one `pin.RigidConstraintModel` each, named as the joint.

    Side 1 (Pinocchio's joint1) is the child side: the child's body frame moved to
    `child_offset`, unrotated; side 2 the parent side: the input triad at `offset` in the parent
    frame, turned by `triad`. A fixed joint holds the two frames together (CONTACT_6D); a
    spherical or revolute one their origins (CONTACT_3D), which closes a revolute joint only on a
    loop whose hinges share its axis (the caller checks that). Reference frame LOCAL: the
    constraint force (`RigidConstraintData.contact_force`) is the one side 2 exerts on side 1, at
    its origin, in the child's body axes."""
    out = []
    for j in loops.values():
        jid_c, Xc = frame[j.child]
        jid_p, Xp = frame[j.parent]
        child_side = Xc * pin.SE3(np.eye(3), np.asarray(j.child_offset, dtype=float))
        parent_side = Xp * pin.SE3(np.array(j.triad, dtype=float), np.asarray(j.offset, dtype=float))
        kind = pin.ContactType.CONTACT_6D if j.type == "fixed" else pin.ContactType.CONTACT_3D
        c = pin.RigidConstraintModel(kind, pm, jid_c, child_side, jid_p, parent_side, pin.ReferenceFrame.LOCAL)
        c.name = j.name
        out.append(c)
    return out


def quaternion(rotvec) -> np.ndarray:
    """Pinocchio's quaternion [x, y, z, w] of a rotation vector (3,)."""
    return pin.Quaternion(pin.exp3(np.asarray(rotvec, dtype=float))).coeffs().copy()


# ---------------------------------------------------------------------------------------------
# a rigid flexmbd Model, for the checks of the recursive algorithms


def se3(X) -> "pin.SE3":
    """Pinocchio placement of frame B in A from the Plücker transform X_{B<-A} (6, 6)."""
    r, R = spatial.plux_parts(np.asarray(X, dtype=float))
    return pin.SE3(R, r)


def inertia(I6) -> "pin.Inertia":
    """Pinocchio inertia from a flexmbd spatial inertia (6, 6) at the body origin."""
    m, c, I_c = spatial.inertia_parts(np.asarray(I6, dtype=float))
    return pin.Inertia(m, c, I_c)


def build(model: Model) -> tuple["pin.Model", list]:
    """Pinocchio model of a rigid flexmbd Model; returns (pin model, pin joint id per body)."""
    pm, frame = build_frames(model)
    return pm, [f[0] for f in frame]


def build_frames(model: Model) -> tuple["pin.Model", list]:
    """Like `build`, but per body (0..nb) the pair (pin joint id, placement of the body frame in
    that joint's frame): a body on a fixed joint lives in its ancestor's joint at an offset."""
    if model.body_nm.any():
        raise ValueError("a Pinocchio model needs every body rigid")
    pm = pin.Model()
    pm.gravity.linear = np.asarray(model.gravity, dtype=float)
    # where each flexmbd body lives in Pinocchio: (joint id, placement of the body frame in it)
    frame = [(0, pin.SE3.Identity())] + [None] * model.nb
    for i in range(1, model.nb + 1):
        jid_parent, off = frame[model.parent[i]]
        placement = off * se3(model.jnt_Xtriad[i])
        t, a = model.jnt_type[i], model.jnt_axis[i]
        name = f"{model.jnt_names[i]}_{i}"
        if t == FIXED:
            pm.appendBodyToJoint(jid_parent, inertia(model.body_inertia[i]), placement)
            frame[i] = (jid_parent, placement)
            continue
        if t == REVOLUTE:
            jm = pin.JointModelRevoluteUnaligned(a)
        elif t == PRISMATIC:
            jm = pin.JointModelPrismaticUnaligned(a)
        elif t == SPHERICAL:
            jm = pin.JointModelSpherical()
        elif t == FREE:
            jm = pin.JointModelFreeFlyer()
        jid = pm.addJoint(jid_parent, jm, placement, name)
        pm.appendBodyToJoint(jid, inertia(model.body_inertia[i]), pin.SE3.Identity())
        frame[i] = (jid, pin.SE3.Identity())
    return pm, frame


def to_pin_q(model: Model, q) -> np.ndarray:
    """flexmbd q -> Pinocchio q (same joint order, quaternions and free-flyer reordered)."""
    out = []
    for i in range(1, model.nb + 1):
        t, k = model.jnt_type[i], model.jnt_qadr[i]
        if t in (REVOLUTE, PRISMATIC):
            out.append(q[k:k + 1])
        elif t == SPHERICAL:
            out.append(np.r_[q[k + 1:k + 4], q[k]])
        elif t == FREE:
            out.append(np.r_[q[k + 4:k + 7], q[k + 1:k + 4], q[k]])
    return np.concatenate(out) if out else np.zeros(0)


def to_pin_v(model: Model, v) -> np.ndarray:
    """flexmbd v (or a) -> Pinocchio v: free-flyer [w; v] becomes [v; w]."""
    return _swap_free(model, v)


def from_pin_v(model: Model, v) -> np.ndarray:
    """Pinocchio v (or a) -> flexmbd v."""
    return _swap_free(model, v)


def _swap_free(model: Model, v) -> np.ndarray:
    out = np.array(v, dtype=float)
    for i in range(1, model.nb + 1):
        if model.jnt_type[i] == FREE:
            k = model.jnt_vadr[i]
            out[k:k + 6] = np.r_[v[k + 3:k + 6], v[k:k + 3]]
    return out
