"""A flexmbd rigid Model rebuilt as a Pinocchio model (programmatically, no URDF).

Conventions converted here and nowhere else: Pinocchio's spatial vectors are [linear; angular],
its quaternions [x, y, z, w] (flexmbd: [w, x, y, z]), its free-flyer configuration
[position; quaternion] (flexmbd: [quaternion; position]) and velocity [v; w] (flexmbd: [w; v]).
Fixed joints have no Pinocchio joint: the child's inertia is appended to the parent's joint with
the composed placement, and the child's children hang from that joint with it.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from flexmbd import spatial
from flexmbd.joints import FIXED, FREE, PRISMATIC, REVOLUTE, SPHERICAL
from flexmbd.model import Model


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
