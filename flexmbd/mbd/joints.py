"""Joints: the one switch over joint types (codes, coordinate counts, transform and motion
subspace, coordinate rates, initial coordinates).

A joint connects its input triad to the child's body frame (docs/formulation.md §2). Coordinates:
revolute and prismatic one each; spherical a unit quaternion [w, x, y, z] (velocity: angular
velocity in the body frame); free a quaternion and the position of the body origin in the triad
(velocity [w; v] in the body frame).
"""

from __future__ import annotations

import numpy as np

from flexmbd.mbd import spatial
from flexmbd.mbd.compiled.jit import njit
from flexmbd.mbd.spatial import plux, quat_rate, quat_to_rot, xlt, xrot

# each joint type's (coordinates, velocities): one each for revolute and prismatic, a quaternion and
# the angular velocity for spherical, a quaternion and a position and [w; v] for free
JOINT_COORDS = {"fixed": (0, 0), "revolute": (1, 1), "prismatic": (1, 1), "spherical": (4, 3), "free": (7, 6)}
FIXED, REVOLUTE, PRISMATIC, SPHERICAL, FREE = range(5)
JOINT_CODES = {"fixed": FIXED, "revolute": REVOLUTE, "prismatic": PRISMATIC,
               "spherical": SPHERICAL, "free": FREE}
NQ = {JOINT_CODES[k]: nq for k, (nq, _) in JOINT_COORDS.items()}   # spherical: quaternion [w,x,y,z]; free: quat, pos
NV = {JOINT_CODES[k]: nv for k, (_, nv) in JOINT_COORDS.items()}   # free: [w; v] in the body frame


@njit
def jcalc(jtype, axis, q, k, XJ, S):
    """Joint transform XJ (6, 6), triad -> body, and motion subspace S (6, 6; first nv columns)
    of a joint of type jtype with unit axis (3,) and coordinates q[k:], written into XJ and S."""
    XJ[:] = 0.0
    S[:] = 0.0
    if jtype == REVOLUTE:                               # E = exp(q axis~)^T
        c, s = np.cos(q[k]), np.sin(q[k])
        x, y, z = axis[0], axis[1], axis[2]
        XJ[0, 0], XJ[0, 1], XJ[0, 2] = c + (1 - c) * x * x, (1 - c) * x * y + s * z, (1 - c) * x * z - s * y
        XJ[1, 0], XJ[1, 1], XJ[1, 2] = (1 - c) * y * x - s * z, c + (1 - c) * y * y, (1 - c) * y * z + s * x
        XJ[2, 0], XJ[2, 1], XJ[2, 2] = (1 - c) * z * x + s * y, (1 - c) * z * y - s * x, c + (1 - c) * z * z
        for a in range(3):
            for b in range(3):
                XJ[3 + a, 3 + b] = XJ[a, b]
            S[a, 0] = axis[a]
    elif jtype == PRISMATIC:
        XJ[:] = xlt(axis * q[k])
        S[3:, 0] = axis
    elif jtype == SPHERICAL:
        XJ[:] = xrot(quat_to_rot(q[k:k + 4]).T)
        for a in range(3):
            S[a, a] = 1.0
    elif jtype == FREE:
        XJ[:] = plux(quat_to_rot(q[k:k + 4]).T, q[k + 4:k + 7])
        for a in range(6):
            S[a, a] = 1.0
    else:
        for a in range(6):
            XJ[a, a] = 1.0


@njit
def qdot(model, q, v, out):
    """dq/dt (nq,) into `out`: v for 1-DOF joints and modes, quaternion rates for spherical and
    free joints (angular velocity in the body frame), R v for the free joint's position."""
    for i in range(1, model.parent.size):
        k, kv = model.jnt_qadr[i], model.jnt_vadr[i]
        if model.jnt_type[i] == SPHERICAL:
            out[k:k + 4] = quat_rate(q[k:k + 4], v[kv:kv + 3])
        elif model.jnt_type[i] == FREE:
            out[k:k + 4] = quat_rate(q[k:k + 4], v[kv:kv + 3])
            out[k + 4:k + 7] = quat_to_rot(q[k:k + 4]) @ v[kv + 3:kv + 6]
        elif model.jnt_nv[i] == 1:
            out[k] = v[kv]
        a, nm = model.body_madr[i], model.body_nm[i]
        out[a:a + nm] = v[a:a + nm]
    return out


def initial_q(jtype: int, values) -> list:
    """Case initial values -> q entries (rotation vectors become quaternions)."""
    if jtype == SPHERICAL:
        return list(spatial.rotvec_to_quat(np.asarray(values, dtype=float)))
    if jtype == FREE:
        return list(spatial.rotvec_to_quat(np.asarray(values[:3], dtype=float))) + list(values[3:])
    return list(values)
