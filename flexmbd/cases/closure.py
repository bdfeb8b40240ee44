"""Whether a case's loops can close at its initial values: the tree's rigid kinematics in the case's
own terms (every beam straight, every joint at its `q0`), and Newton on the dependent joint
coordinates (one-coordinate tree joints from the last backwards, as the solvers choose them;
docs/formulation.md §11). A case whose loop cannot close is refused when it is loaded, one line
naming the joint and the residual; the solvers assemble their own start (with their own models)
from the same values.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from flexmbd.errors import InputError

CLOSES = 1e-9       # m (rad): the largest residual a closed loop may keep, relative to the mechanism's size
STEP = 1e-7         # rad (m): the central differences' step on a joint coordinate


def body_poses(case, q: dict) -> dict:
    """{body: (R (3, 3) body -> world, p (3,) origin)} of the rigid tree at joint values q
    (joint name -> tuple, as the case's q0)."""
    poses = {"ground": (np.eye(3), np.zeros(3))}
    for link in case.tree:
        j = case.joints[link.joint]
        Rp, pp = poses[j.parent]
        R = Rp @ np.array(j.triad)
        p = pp + Rp @ np.asarray(j.offset, dtype=float)
        a, x = np.asarray(j.axis, dtype=float), q[j.name]
        if j.type == "revolute":
            R = R @ Rotation.from_rotvec(a * x[0]).as_matrix()
        elif j.type == "prismatic":
            p = p + R @ (a * x[0])
        elif j.type == "spherical":
            R = R @ Rotation.from_rotvec(x[:3]).as_matrix()
        elif j.type == "free":
            p, R = p + R @ np.asarray(x[3:6]), R @ Rotation.from_rotvec(x[:3]).as_matrix()
        poses[link.name] = (R, p)
    return poses


def residual(case, poses: dict, j) -> np.ndarray:
    """The loop joint j's misfit at poses: the two points' distance (across the axis of a
    prismatic) and the misalignment of the axis (revolute) or of the frames (fixed, prismatic)."""
    (Rp, pp), (Rc, pc) = poses[j.parent], poses[j.child]
    T = Rp @ np.array(j.triad)
    d = T.T @ (pc + Rc @ np.asarray(j.child_offset, dtype=float) - pp - Rp @ np.asarray(j.offset, dtype=float))
    a = np.asarray(j.axis, dtype=float)
    Q = T.T @ Rc
    if j.type == "prismatic":
        d = d - a * (a @ d)
    if j.type == "revolute":
        return np.concatenate([d, np.cross(a, Q @ a)])
    if j.type in ("fixed", "prismatic"):
        return np.concatenate([d, Rotation.from_matrix(Q).as_rotvec()])
    return d


def dependent(case) -> list:
    """The joints whose coordinates the loops' closure may change: one-coordinate tree joints
    without motion, from the last in the tree backwards."""
    return [case.joints[link.joint].name for link in reversed(case.tree)
            if case.joints[link.joint].type in ("revolute", "prismatic") and case.joints[link.joint].motion is None]


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


def check(case, where: str) -> None:
    """Refuse (InputError) a case whose loops cannot close from its initial values."""
    if not case.loops:
        return
    q = {name: np.array(j.q0, dtype=float) for name, j in case.joints.items()}

    def r():
        poses = body_poses(case, q)
        return np.concatenate([residual(case, poses, j) for j in case.loops.values()])

    def jacobian(names):
        J = np.empty((r().size, len(names)))
        for c, name in enumerate(names):
            x = q[name][0]
            q[name][0] = x + STEP
            up = r()
            q[name][0] = x - STEP
            J[:, c] = (up - r()) / (2 * STEP)
            q[name][0] = x
        return J

    dep = pick(jacobian(dependent(case)), dependent(case))
    size = max([1.0] + [float(np.linalg.norm(j.offset)) for j in case.joints.values()])
    for _ in range(50):
        r0 = r()
        if np.abs(r0).max() < CLOSES * size or not dep:
            break
        step = np.linalg.lstsq(jacobian(dep), r0, rcond=1e-10)[0]
        x0 = [q[name][0] for name in dep]
        for scale in 0.5 ** np.arange(20):              # Gauss-Newton, halved until the misfit drops
            for c, name in enumerate(dep):
                q[name][0] = x0[c] - scale * step[c]
            if np.linalg.norm(r()) < np.linalg.norm(r0):
                break
        else:
            for c, name in enumerate(dep):
                q[name][0] = x0[c]
            break
    r0 = r()
    if np.all(np.isfinite(r0)) and np.abs(r0).max() < CLOSES * size:
        return
    poses = body_poses(case, q)
    misfit = {j.name: float(np.nanmax(np.abs(residual(case, poses, j)))) for j in case.loops.values()}
    worst = max(misfit, key=lambda n: misfit[n] if np.isfinite(misfit[n]) else np.inf)
    raise InputError(f"{where}: joints.{worst}: the loop cannot close from the initial values: the closest the "
                     f"tree joints {', '.join(dep) or '(none free)'} reach leaves a residual of {misfit[worst]:.3g} "
                     f"(m, or rad of the axes)")
