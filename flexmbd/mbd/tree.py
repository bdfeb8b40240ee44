"""A Model from plain descriptions of bodies and joints, no case file: the tree in body order
(every joint's parent before its child), each body rigid or flexible.

    Body(name, inertia=I6, mass=m)              rigid: spatial inertia (6, 6) at its origin, body frame
    Body(name, flex=fb, stiffening=True)        flexible: its reduced arrays, by name (below)
    Joint(name, parent, "revolute", axis=..., Xtriad=..., node=..., q0=..., qd0=..., motion=...)
    model([...bodies], [...joints], gravity=(0, -9.81, 0))

A flexible body's `flex` holds what the invariants and the joints read, as `flexbody.FlexBody`
does: node positions x0 (N, 3) and masses m (N,), rotary inertias J (N, 3, 3), mode blocks Phi
(N, 6, nm) [rot; trans] orthonormal in the node masses, modal stiffness Km and damping Cm
(nm, nm), the foreshortening D (N, nm, nm) (zeros without stiffening), a solid's consistent-mass
sums Mx0 (0 or N, 3) and MPt, and n_modes. A joint on a flexible parent sits on its node `node`
and follows it; on a rigid parent or ground at the constant transform `Xtriad` (6, 6, parent
frame -> input triad; on a node: node frame -> input triad).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from flexmbd.mbd import invariants, profiles
from flexmbd.mbd.joints import JOINT_CODES, NQ, NV, initial_q
from flexmbd.mbd.model import Arrays, Model, empty_arrays, empty_loads


class Body(NamedTuple):
    name: str
    inertia: np.ndarray | None = None   # (6, 6) spatial inertia at the body origin (rigid)
    mass: float = 0.0                   # kg (rigid; a flexible body's is its node masses' sum)
    flex: object = None                 # the reduced arrays of a flexible body (module docstring)
    stiffening: bool = False            # the foreshortening terms of a flexible body (docs/formulation.md §4b)


class Joint(NamedTuple):
    name: str
    parent: int                         # body number (0: ground), below the child's
    type: str                           # fixed, revolute, prismatic, spherical, free
    axis: tuple = (0.0, 0.0, 1.0)       # unit axis in the input triad (revolute, prismatic)
    Xtriad: np.ndarray | None = None    # (6, 6) parent (or node) frame -> input triad; None: identity
    node: int = -1                      # the node of a flexible parent the joint sits on
    q0: tuple = ()                      # initial values (a rotation vector for spherical and free)
    qd0: tuple = ()                     # initial rates
    motion: object = None               # a prescribed-motion profile (`profiles.encode_motion`), or None


def model(bodies: list, joints: list, gravity=(0.0, 0.0, 0.0), loads: tuple | None = None) -> Model:
    """The Model of bodies 1..nb (`bodies[k]` is body k + 1, `joints[k]` its joint to its
    parent), with gravity (3,) m/s^2 in the global frame and the point loads `loads`
    ((the load arrays of `model.empty_loads`, filled; their profiles), none when None)."""
    nb = len(bodies)
    nm = max([b.flex.n_modes for b in bodies if b.flex is not None] + [0])
    A = {k: x for k, x in empty_arrays(nb, nm).items() if not k.startswith("jnt_motion") and k != "jnt_q0"}
    invs, q0, v0 = [None] * (nb + 1), [], []
    nq = nv = 0
    for i, (b, j) in enumerate(zip(bodies, joints), start=1):
        t = JOINT_CODES[j.type]
        A["parent"][i], A["jnt_type"][i], A["jnt_nv"][i] = j.parent, t, NV[t]
        A["jnt_axis"][i], A["jnt_prescribed"][i] = j.axis, j.motion is not None
        if j.Xtriad is not None:
            A["jnt_Xtriad"][i] = j.Xtriad
        on = bodies[j.parent - 1] if j.parent > 0 else None
        if on is not None and on.flex is not None:      # the triad follows the parent's node
            fb, k = on.flex, on.flex.n_modes
            A["jnt_node"][i], A["jnt_x0"][i], A["jnt_Phi"][i, :, :k] = j.node, fb.x0[j.node], fb.Phi[j.node]
            if on.stiffening:
                A["jnt_D"][i, :k, :k] = fb.D[j.node]
        A["jnt_qadr"][i], A["jnt_vadr"][i] = nq, nv
        q0.extend(initial_q(t, list(j.q0) or [0.0] * (3 if t == JOINT_CODES["spherical"] else NV[t])))
        v0.extend(list(j.qd0) or [0.0] * NV[t])
        nq, nv = nq + NQ[t], nv + NV[t]
        if b.flex is None:
            A["body_inertia"][i], A["body_mass"][i] = b.inertia, b.mass
            continue
        fb, k = b.flex, b.flex.n_modes
        invs[i] = invariants.invariants(fb, b.stiffening)
        A["body_mass"][i] = fb.m.sum()
        A["body_madr"][i], A["body_nm"][i] = nq, k
        A["flex_K"][i, :k, :k], A["flex_C"][i, :k, :k] = fb.Km, fb.Cm
        q0.extend([0.0] * k)
        v0.extend([0.0] * k)
        nq, nv = nq + k, nv + k
    motion = [None] + [j.motion for j in joints]
    A.update(motion_arrays(motion, A["jnt_qadr"], A["jnt_nv"], q0))
    load_arrays, load_profiles = loads if loads is not None else (empty_loads(0, nm), ())
    arrays = Arrays(**A, inv=invariants.stack(invs, nm), **load_arrays, gravity=np.asarray(gravity, dtype=float))
    return Model(nb=nb, nq=nq, nv=nv, arrays=arrays, names=("ground",) + tuple(b.name for b in bodies),
                 jnt_names=("",) + tuple(j.name for j in joints), jnt_motion=tuple(motion),
                 load_profiles=tuple(load_profiles), bodies={b.name: b.flex for b in bodies if b.flex is not None},
                 q0=np.array(q0, dtype=float), v0=np.array(v0, dtype=float))


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
