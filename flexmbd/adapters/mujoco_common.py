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


def plux_parts(X) -> tuple[np.ndarray, np.ndarray]:
    """(position r (3,) of frame B in A, rotation R (3, 3) B -> A) from a Plücker transform X_{B<-A}."""
    E = X[:3, :3]
    rx = -E.T @ X[3:, :3]
    return np.array([rx[2, 1], rx[0, 2], rx[1, 0]]), E.T.copy()


def inertial(I6) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass, centre of mass (3,), inertia about it (3, 3)) from a flexmbd spatial inertia at the origin."""
    m = I6[3, 3]
    c = np.array([I6[2, 4], I6[0, 5], I6[1, 3]]) / m
    C = np.array([[0, -c[2], c[1]], [c[2], 0, -c[0]], [-c[1], c[0], 0]])
    return m, c, I6[:3, :3] - m * C @ C.T
