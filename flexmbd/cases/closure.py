"""Whether a case's loops can close at its initial values: the tree's rigid kinematics in the case's
own terms (every beam straight, every joint at its `q0`), and Newton on the dependent joint
coordinates (one-coordinate tree joints from the last backwards, as the solvers choose them;
docs/formulation.md §11). A case whose loop cannot close is refused when it is loaded, one line
naming the joint and the residual; the values that close it (`assemble`) become the dependent
joints' `q0`, so every solver starts in the same assembly, closing it with its own model from
there.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from flexmbd.mbd.constraints import pick      # the rank rule of the dependent coordinates, the solver's own
from flexmbd.core.errors import InputError

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


def assemble(case, where: str) -> dict:
    """The values (joint name -> float, rad or m) of the dependent joints that close the case's
    loops with every beam straight, nearest the case's `q0` (the guesses): Gauss-Newton from the
    guesses, and from the guesses with each dependent revolute turned by a quarter, a half and
    three quarters of a turn and with all of them turned by half a turn; of the closures found,
    the one nearest the guesses (the sum of the squared differences, angles wrapped), each angle
    within half a turn of its guess. A loop closes in several ways (a four-bar's two branches):
    the guesses name the one meant. Every solver starts from these values (`cases.load` puts
    them in the case's `q0`), so all start in one assembly. Refuses (InputError) a case whose
    loops close from none of the starts. {} without loops."""
    if not case.loops:
        return {}
    guess = {name: np.array(j.q0, dtype=float) for name, j in case.joints.items()}
    names = dependent(case)
    dep = pick(_jacobian(case, guess, names), names)
    size = max([1.0] + [float(np.linalg.norm(j.offset)) for j in case.joints.values()])
    turned = [n for n in dep if case.joints[n].type == "revolute"]
    starts = [guess] + [_turned(guess, [n], k * np.pi / 2) for n in turned for k in (1, 2, 3)]
    starts += [_turned(guess, turned, np.pi)] if len(turned) > 1 else []
    ends = [_descend(case, q, dep, size) for q in starts]
    found = [{n: guess[n][0] + _apart(case.joints[n].type, q[n][0], guess[n][0]) for n in dep}
             for q in ends if _closes(case, q, size)]
    if not found:
        poses = body_poses(case, ends[0])
        misfit = {j.name: float(np.nanmax(np.abs(residual(case, poses, j)))) for j in case.loops.values()}
        worst = max(misfit, key=lambda n: misfit[n] if np.isfinite(misfit[n]) else np.inf)
        raise InputError(f"{where}: joints.{worst}: the loop cannot close from the initial values: the closest "
                         f"the tree joints {', '.join(dep) or '(none free)'} reach leaves a residual of "
                         f"{misfit[worst]:.3g} (m, or rad of the axes)")
    return min(found, key=lambda x: sum((x[n] - guess[n][0]) ** 2 for n in dep))


def _turned(q: dict, names: list, angle: float) -> dict:
    """A copy of q with the joints `names` turned by `angle` (rad)."""
    out = {n: v.copy() for n, v in q.items()}
    for n in names:
        out[n][0] += angle
    return out


def _apart(kind: str, x: float, y: float) -> float:
    """x - y, an angle's wrapped to (-pi, pi]."""
    d = x - y
    return float(np.pi - (np.pi - d) % (2 * np.pi)) if kind == "revolute" else d


def _misfit(case, q: dict) -> np.ndarray:
    poses = body_poses(case, q)
    return np.concatenate([residual(case, poses, j) for j in case.loops.values()])


def _closes(case, q: dict, size: float) -> bool:
    r = _misfit(case, q)
    return bool(np.all(np.isfinite(r)) and np.abs(r).max() < CLOSES * size)


def _jacobian(case, q: dict, names: list) -> np.ndarray:
    """d misfit / d q[name] (rows, len(names)) by central differences."""
    J = np.empty((_misfit(case, q).size, len(names)))
    for c, name in enumerate(names):
        x = q[name][0]
        q[name][0] = x + STEP
        up = _misfit(case, q)
        q[name][0] = x - STEP
        J[:, c] = (up - _misfit(case, q)) / (2 * STEP)
        q[name][0] = x
    return J


def _descend(case, start: dict, dep: list, size: float) -> dict:
    """Gauss-Newton on the `dep` joints from `start` (joint -> array; copied), each step halved
    until the misfit drops, until the loops close to CLOSES x size or the misfit drops no more."""
    q = {n: v.copy() for n, v in start.items()}
    for _ in range(50):
        r0 = _misfit(case, q)
        if np.abs(r0).max() < CLOSES * size or not dep:
            break
        step = np.linalg.lstsq(_jacobian(case, q, dep), r0, rcond=1e-10)[0]
        x0 = [q[name][0] for name in dep]
        for scale in 0.5 ** np.arange(20):
            for c, name in enumerate(dep):
                q[name][0] = x0[c] - scale * step[c]
            if np.linalg.norm(_misfit(case, q)) < np.linalg.norm(r0):
                break
        else:
            for c, name in enumerate(dep):
                q[name][0] = x0[c]
            break
    return q
