"""Spatial (6-D) algebra, Featherstone's conventions: vectors are [angular; linear].

Motion vectors m = [w; v], force vectors f = [n; f]. X = X_{B<-A} maps motion vectors from A
coordinates to B coordinates; for B at position r (in A) with rotation E (B = E A, i.e. E maps
A-coordinates of a free vector to B-coordinates):

    X = [ E      0 ]        X* = X^{-T} maps force vectors.
        [ -E r~  E ]

Pure functions on numpy arrays; no model knowledge.
"""

from __future__ import annotations

import numpy as np

from flexmbd.mbd.compiled.dense import mm
from flexmbd.mbd.compiled.jit import njit


def skew_rows(a: np.ndarray) -> np.ndarray:
    """Skew matrices of the last axis: (..., 3) -> (..., 3, 3), a~ b = a x b."""
    S = np.zeros(a.shape + (3,))
    S[..., 0, 1], S[..., 0, 2] = -a[..., 2], a[..., 1]
    S[..., 1, 0], S[..., 1, 2] = a[..., 2], -a[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -a[..., 1], a[..., 0]
    return S


@njit
def skew(a) -> np.ndarray:
    """a~ (3, 3): a~ b = a x b."""
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


@njit
def expm_so3(theta) -> np.ndarray:
    """exp(theta~) (3, 3), Rodrigues' formula with series for small |theta|."""
    a, b = _ab(theta)
    out = np.empty((3, 3))
    rodrigues_into(theta, a, b, out)
    return out


@njit(inline="always")
def rodrigues_into(theta, a, b, out):
    """out = I + a theta~ + b theta~^2 (3, 3), with theta~^2 = theta theta^T - |theta|^2 I: exp(theta~)
    for (a, b) = `_ab` (its transpose for (-a, b)), the left Jacobian for `_cd`. No temporaries."""
    x, y, z = theta[0], theta[1], theta[2]
    out[0, 0] = 1.0 - b * (y * y + z * z)
    out[1, 1] = 1.0 - b * (x * x + z * z)
    out[2, 2] = 1.0 - b * (x * x + y * y)
    out[0, 1], out[1, 0] = b * x * y - a * z, b * x * y + a * z
    out[0, 2], out[2, 0] = b * x * z + a * y, b * x * z - a * y
    out[1, 2], out[2, 1] = b * y * z - a * x, b * y * z + a * x


@njit
def _ab(theta):
    """sin(s)/s and (1 - cos s)/s^2 for s = |theta|."""
    s2 = theta[0] * theta[0] + theta[1] * theta[1] + theta[2] * theta[2]
    if s2 < 1e-8:
        return 1.0 - s2 / 6.0 + s2 * s2 / 120.0, 0.5 - s2 / 24.0 + s2 * s2 / 720.0
    s = np.sqrt(s2)
    return np.sin(s) / s, (1.0 - np.cos(s)) / s2


@njit
def jac_left_so3(theta) -> np.ndarray:
    """Left Jacobian of exp on SO(3): d/dt exp(theta~) exp(theta~)^T = (J(theta) theta_dot)~.

    J = I + (1 - cos s)/s^2 theta~ + (s - sin s)/s^3 theta~^2,  s = |theta|.
    """
    a, b = _cd(theta)
    out = np.empty((3, 3))
    rodrigues_into(theta, a, b, out)
    return out


@njit
def _cd(theta):
    """(1 - cos s)/s^2 and (s - sin s)/s^3."""
    s2 = theta[0] * theta[0] + theta[1] * theta[1] + theta[2] * theta[2]
    if s2 < 1e-8:
        return 0.5 - s2 / 24.0 + s2 * s2 / 720.0, 1.0 / 6.0 - s2 / 120.0 + s2 * s2 / 5040.0
    s = np.sqrt(s2)
    return (1.0 - np.cos(s)) / s2, (s - np.sin(s)) / (s2 * s)


@njit
def jac_left_so3_dot(theta, theta_dot) -> np.ndarray:
    """(d/dt J(theta)) theta_dot (3,): the velocity-product term of the exponential map.

    With J = I + a theta~ + b theta~^2 and a, b functions of s = |theta|:
    J' theta_dot = a' (theta x theta_dot) + b' theta x (theta x theta_dot) + b theta_dot x (theta x theta_dot),
    a' = da/dt = (da/ds / s)(theta . theta_dot), likewise b'.
    """
    s2 = theta[0] * theta[0] + theta[1] * theta[1] + theta[2] * theta[2]
    if s2 < 1e-6:
        da_s, db_s = -1.0 / 12.0 + s2 / 180.0, -1.0 / 60.0 + s2 / 1260.0
        _, b = _cd(theta)
    else:
        s = np.sqrt(s2)
        a, b = _cd(theta)
        da_s = (np.sin(s) / s - 2.0 * a) / s2
        db_s = ((1.0 - np.cos(s)) / s2 - 3.0 * b) / s2
    sd = theta[0] * theta_dot[0] + theta[1] * theta_dot[1] + theta[2] * theta_dot[2]
    c = np.cross(theta, theta_dot)
    return da_s * sd * c + db_s * sd * np.cross(theta, c) + b * np.cross(theta_dot, c)


@njit
def xrot(E) -> np.ndarray:
    """Pure rotation X (6, 6) with E (3, 3): B-coords = E A-coords."""
    X = np.zeros((6, 6))
    X[:3, :3] = E
    X[3:, 3:] = E
    return X


@njit
def xlt(r) -> np.ndarray:
    """Pure translation X (6, 6): B origin at r (3,) in A, axes parallel."""
    X = np.eye(6)
    X[3:, :3] = -skew(r)
    return X


@njit
def plux(E, r) -> np.ndarray:
    """X_{B<-A} (6, 6) from E (3, 3) and r (3,): rotation of B relative to A, origin of B in A."""
    X = np.zeros((6, 6))
    X[:3, :3] = E
    X[3:, 3:] = E
    X[3:, :3] = -mm(E, skew(r))
    return X


@njit(inline="always")
def xmul_into(X1, X2, out):
    """out = X1 X2 (6, 6) for Plücker transforms [E 0; F E]: E = E1 E2, F = F1 E2 + E1 F2
    (81 multiply-adds instead of 216); out must not overlap X1 or X2."""
    for i in range(3):
        for j in range(3):
            e, f = 0.0, 0.0
            for l in range(3):
                e += X1[i, l] * X2[l, j]
                f += X1[3 + i, l] * X2[l, j] + X1[i, l] * X2[3 + l, j]
            out[i, j] = e
            out[3 + i, 3 + j] = e
            out[3 + i, j] = f
            out[i, 3 + j] = 0.0


@njit(inline="always")
def xmv_into(X, m, out):
    """out = X m (6,) for a Plücker transform X = [E 0; F E] (6, 6) and a motion vector m (6,):
    [E w; F w + E u], 27 multiply-adds with fixed loop bounds (unrolled)."""
    for i in range(3):
        e, f = 0.0, 0.0
        for l in range(3):
            e += X[i, l] * m[l]
            f += X[3 + i, l] * m[l] + X[i, l] * m[3 + l]
        out[i] = e
        out[3 + i] = f


@njit(inline="always")
def xtv_add_into(X, f, out):
    """out += X^T f (6,) for a Plücker transform X = [E 0; F E]: a force vector f back into the
    frame X maps from, [E^T n + F^T f; E^T f]."""
    for i in range(3):
        a, b = 0.0, 0.0
        for l in range(3):
            a += X[l, i] * f[l] + X[3 + l, i] * f[3 + l]
            b += X[l, i] * f[3 + l]
        out[i] += a
        out[3 + i] += b


@njit(inline="always")
def xcongruence_add_into(X, I, out, Y):
    """out (6, 6) += X^T I X for a Plücker transform X = [E 0; F E] and a symmetric I (6, 6): an
    articulated inertia carried back into the frame X maps from. Y (6, 6): workspace (I X).
    270 multiply-adds against 342 for the dense product (X's zero block skipped, one triangle)."""
    for r in range(6):
        for j in range(3):
            y, z = 0.0, 0.0
            for l in range(3):
                y += I[r, l] * X[l, j] + I[r, 3 + l] * X[3 + l, j]
                z += I[r, 3 + l] * X[3 + l, 3 + j]
            Y[r, j] = y
            Y[r, 3 + j] = z
    for i in range(6):
        for j in range(i, 6):
            s = 0.0
            if i < 3:
                for l in range(6):
                    s += X[l, i] * Y[l, j]
            else:
                for l in range(3, 6):
                    s += X[l, i] * Y[l, j]
            out[i, j] += s
            if j != i:
                out[j, i] += s


@njit(inline="always")
def mv6_add_into(A, x, out):
    """out += A x for A (6, 6), x (6,): fixed loop bounds (unrolled)."""
    for i in range(6):
        s = 0.0
        for l in range(6):
            s += A[i, l] * x[l]
        out[i] += s


@njit(inline="always")
def mv6_into(A, x, out):
    """out = A x for A (6, 6), x (6,) (`mv6_add_into` on a zeroed out)."""
    for i in range(6):
        out[i] = 0.0
    mv6_add_into(A, x, out)


@njit
def plux_parts(X):
    """(r (3,), R (3, 3)) of X_{B<-A}: B's origin in A and the rotation B -> A (R = E^T); inverse of plux."""
    E = X[:3, :3]
    rx = -E.T @ X[3:, :3]
    return np.array([rx[2, 1], rx[0, 2], rx[1, 0]]), E.T.copy()


@njit
def inv(X) -> np.ndarray:
    """X^{-1} (6, 6) of a Plücker transform."""
    E = X[:3, :3]
    Y = np.zeros((6, 6))
    Y[:3, :3] = E.T
    Y[3:, 3:] = E.T
    Y[3:, :3] = X[3:, :3].T
    return Y


@njit
def force_transform(X) -> np.ndarray:
    """X* = X^{-T} (6, 6): maps force vectors A -> B."""
    return inv(X).T


@njit
def cross_motion(v, m) -> np.ndarray:
    """v x m for motion vectors (6,)."""
    w, u = v[:3], v[3:]
    return np.concatenate((np.cross(w, m[:3]), np.cross(w, m[3:]) + np.cross(u, m[:3])))


@njit
def cross_force(v, f) -> np.ndarray:
    """v x* f for a force vector f (6,)."""
    w, u = v[:3], v[3:]
    return np.concatenate((np.cross(w, f[:3]) + np.cross(u, f[3:]), np.cross(w, f[3:])))


@njit(inline="always")
def cross_motion_into(v, m, out):
    """out = v x m for motion vectors (6,)."""
    w0, w1, w2, u0, u1, u2 = v[0], v[1], v[2], v[3], v[4], v[5]
    out[0] = w1 * m[2] - w2 * m[1]
    out[1] = w2 * m[0] - w0 * m[2]
    out[2] = w0 * m[1] - w1 * m[0]
    out[3] = w1 * m[5] - w2 * m[4] + u1 * m[2] - u2 * m[1]
    out[4] = w2 * m[3] - w0 * m[5] + u2 * m[0] - u0 * m[2]
    out[5] = w0 * m[4] - w1 * m[3] + u0 * m[1] - u1 * m[0]


@njit(inline="always")
def cross_force_into(v, f, out):
    """out = v x* f for a force vector f (6,)."""
    w0, w1, w2, u0, u1, u2 = v[0], v[1], v[2], v[3], v[4], v[5]
    out[0] = w1 * f[2] - w2 * f[1] + u1 * f[5] - u2 * f[4]
    out[1] = w2 * f[0] - w0 * f[2] + u2 * f[3] - u0 * f[5]
    out[2] = w0 * f[1] - w1 * f[0] + u0 * f[4] - u1 * f[3]
    out[3] = w1 * f[5] - w2 * f[4]
    out[4] = w2 * f[3] - w0 * f[5]
    out[5] = w0 * f[4] - w1 * f[3]


@njit
def inertia(mass: float, com, I_c) -> np.ndarray:
    """Spatial inertia (6, 6) at the frame origin, from mass, centre of mass c (3,), I_c (3, 3) about c."""
    C = skew(com)
    I = np.zeros((6, 6))
    I[:3, :3] = I_c + mass * C @ C.T
    I[:3, 3:] = mass * C
    I[3:, :3] = mass * C.T
    I[3:, 3:] = mass * np.eye(3)
    return I


@njit
def inertia_parts(I):
    """(mass, centre of mass c (3,), I_c (3, 3) about c) of a spatial inertia; inverse of `inertia`."""
    m = I[3, 3]
    c = np.array([I[2, 4], I[0, 5], I[1, 3]]) / m
    C = skew(c)
    return m, c, I[:3, :3] - m * C @ C.T


@njit
def quat_to_rot(q) -> np.ndarray:
    """Unit quaternion [w, x, y, z] -> rotation matrix R (3, 3) (normalised first)."""
    n = np.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    w, x, y, z = q[0] / n, q[1] / n, q[2] / n, q[3] / n
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


@njit
def rotvec_to_quat(r) -> np.ndarray:
    """Rotation vector (3,) -> unit quaternion [w, x, y, z]."""
    s = np.sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2])
    if s < 1e-12:
        return np.array([1.0, 0.5 * r[0], 0.5 * r[1], 0.5 * r[2]]) / np.sqrt(1 + 0.25 * s * s)
    k = np.sin(s / 2) / s
    return np.array([np.cos(s / 2), k * r[0], k * r[1], k * r[2]])


@njit
def quat_rate(q, w) -> np.ndarray:
    """dq/dt (4,) for quaternion q = [w, x, y, z] and angular velocity w (3,) in the rotated (body) frame."""
    qw, qx, qy, qz = q[0], q[1], q[2], q[3]
    wx, wy, wz = w[0], w[1], w[2]
    return 0.5 * np.array([-qx * wx - qy * wy - qz * wz,
                           qw * wx + qy * wz - qz * wy,
                           qw * wy - qx * wz + qz * wx,
                           qw * wz + qx * wy - qy * wx])


def rotation_rpy(rpy) -> np.ndarray:
    """Rotation matrix R = Rz(yaw) Ry(pitch) Rx(roll), (3, 3): maps triad axes to parent axes."""
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    Rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    Ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    Rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx
