"""MuJoCo conventions, converted here and in the MuJoCo adapters only.

MuJoCo quaternions are [w, x, y, z] and map child-frame coordinates to parent-frame coordinates
(body `quat` in MJCF); flexmbd's Plücker transforms X_{B<-A} hold E, which maps A coordinates to
B coordinates, so the body quaternion is that of E^T. A free joint's qvel is [v (world); w (body)]
while flexmbd's is [w; v], both in the body frame. Floats are written with 17 significant digits
so that the MJCF text round-trips exactly.
"""

from __future__ import annotations

import numpy as np


def fmt(*xs) -> str:
    """Numbers as MJCF text, round-trip exact."""
    return " ".join(f"{float(x):.17g}" for x in np.ravel(xs))


def rot_to_quat(R) -> np.ndarray:
    """MuJoCo quaternion [w, x, y, z] of a rotation matrix R (3, 3) (R maps child to parent)."""
    import mujoco
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(R, dtype=float).ravel())
    return q


def quat_to_rot(q) -> np.ndarray:
    """Rotation matrix (3, 3) of a MuJoCo quaternion [w, x, y, z]."""
    import mujoco
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, np.asarray(q, dtype=float))
    return R.reshape(3, 3)
