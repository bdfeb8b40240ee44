"""Model (constants of a tree of rigid and flexible bodies) and Data (the workspace of one state).

Bodies are numbered 1..nb with parent[i] < i; index 0 is ground. Body i and the joint to its
parent share the number. Arrays are indexed by body number (row 0 unused unless stated).
A flexible body is a body with extra (modal) coordinates: its modes sit in q and v right after
its joint's coordinates, at `body_madr[i]`, `body_nm[i]` of them. Per-body modal arrays are
zero-padded to nm = max(body_nm).

Frames: every body-level quantity is in the body frame (the joint's output triad). The input
triad of joint i sits on its parent: on a rigid parent (or ground) at the constant transform
`jnt_Xtriad[i]` from the parent frame; on a flexible parent at node `jnt_node[i]`, and then
`jnt_Xtriad[i]` is the constant transform from the deformed node frame, whose undeformed
position is `jnt_x0[i]` and mode block `jnt_Phi[i]`.

The arrays live in `Model.arrays` (a NamedTuple); the Model shell adds what only Python needs
(names, motion profiles, the reduced bodies for the trajectory). `build.from_case` makes a Model from a
case; the algorithms (`dynamics`) read the arrays and a Data by field name, whether they are these
NamedTuples or the kernel's structrefs with the same fields (`compiled.bound`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from flexmbd.mbd.invariants import Invariants


class Arrays(NamedTuple):
    parent: np.ndarray        # (nb+1,) parent body, parent[0] = -1
    jnt_type: np.ndarray      # (nb+1,) joints.FIXED, joints.REVOLUTE, ...
    jnt_axis: np.ndarray      # (nb+1, 3) unit axis in the input triad
    jnt_Xtriad: np.ndarray    # (nb+1, 6, 6) parent (or node) frame -> input triad
    jnt_node: np.ndarray      # (nb+1,) node on a flexible parent, -1 otherwise
    jnt_x0: np.ndarray        # (nb+1, 3) undeformed position of that node, parent frame
    jnt_Phi: np.ndarray       # (nb+1, 6, nm) mode block of that node [rot; trans]
    jnt_D: np.ndarray         # (nb+1, nm, nm) its foreshortening matrix D_p (zero without stiffening)
    jnt_qadr: np.ndarray      # (nb+1,) first joint coordinate in q
    jnt_vadr: np.ndarray      # (nb+1,) first joint velocity in v
    jnt_nv: np.ndarray        # (nb+1,) joint velocity count
    jnt_prescribed: np.ndarray  # (nb+1,) True: motion given by a profile
    jnt_motion_kind: np.ndarray  # (nb+1,) motion profile code (profiles.MOTION_KINDS), -1: none
    jnt_motion_par: np.ndarray  # (nb+1, 4) its parameters (profiles.motion_at)
    jnt_motion_n: np.ndarray  # (nb+1,) breakpoints of a table profile (0 otherwise)
    jnt_motion_x: np.ndarray  # (nb+1, nt) a table profile's breakpoints, s
    jnt_motion_c: np.ndarray  # (nb+1, 4, nt) its cubic pieces' coefficients
    jnt_q0: np.ndarray        # (nb+1,) start value of a 1-DOF joint's coordinate
    body_inertia: np.ndarray  # (nb+1, 6, 6) spatial inertia of rigid bodies at the body origin
    body_madr: np.ndarray     # (nb+1,) first modal coordinate in q (equal to its index in v)
    body_nm: np.ndarray       # (nb+1,) number of modes (0: rigid)
    body_mass: np.ndarray     # (nb+1,) total mass
    flex_K: np.ndarray        # (nb+1, nm, nm) modal stiffness
    flex_C: np.ndarray        # (nb+1, nm, nm) modal damping
    inv: Invariants  # stacked over bodies (nb+1, ...), zero for rigid ones
    load_body: np.ndarray     # (nl,) body a point load acts on
    load_point: np.ndarray    # (nl, 3) undeformed point of application, body frame
    load_Phi: np.ndarray      # (nl, 6, nm) mode block of the loaded node (zeros on rigid bodies)
    load_D: np.ndarray        # (nl, nm, nm) its foreshortening matrix D_p (zero without stiffening)
    load_force: np.ndarray    # (nl, 3) force at unit scale
    load_global: np.ndarray   # (nl,) True: force given in the global frame
    load_kind: np.ndarray     # (nl,) load profile code (profiles.LOAD_KINDS)
    load_par: np.ndarray      # (nl, 4) its parameters (profiles.load_at)
    gravity: np.ndarray       # (3,) global frame, m/s^2


@dataclass(frozen=True)
class Model:
    nb: int
    nq: int
    nv: int
    arrays: Arrays
    names: tuple              # (nb+1,) body names, names[0] = 'ground'
    jnt_names: tuple          # (nb+1,) joint names
    jnt_motion: tuple         # (nb+1,) prescribed-motion profile or None
    load_profiles: tuple      # (nl,) load time profiles
    bodies: dict              # reduced FlexBody per flexible body name (trajectory, adapters)
    q0: np.ndarray            # (nq,)
    v0: np.ndarray            # (nv,)

    def __getattr__(self, name):
        if name == "arrays":
            raise AttributeError(name)
        return getattr(self.arrays, name)

    def index(self, body: str) -> int:
        return self.names.index(body)


class Data(NamedTuple):
    """Workspace of one evaluation, grouped by the pass that fills it. Frames: body frame."""

    qdd_p: np.ndarray   # (nv,)         accelerations of the prescribed joints        profiles
    scale: np.ndarray   # (nl,)         profile factors of the point loads
    XJ: np.ndarray      # (nb+1, 6, 6)  joint transform, input triad -> body frame     pass 1
    S: np.ndarray       # (nb+1, 6, 6)  joint motion subspace (first jnt_nv columns)
    vJ: np.ndarray      # (nb+1, 6)     joint velocity S qd
    Xup: np.ndarray     # (nb+1, 6, 6)  parent frame -> body frame
    X0: np.ndarray      # (nb+1, 6, 6)  global -> body frame
    U: np.ndarray       # (nb+1, 6, nm) parent's modal velocities -> body velocity
    v: np.ndarray       # (nb+1, 6)     spatial velocity
    c: np.ndarray       # (nb+1, 6)     velocity-product acceleration
    Iv: np.ndarray      # (nb+1, 6)     rigid body's momentum I v
    F: np.ndarray       # (nb+1, 6+nm)  generalized external forces of the point loads
    MA: np.ndarray      # (nb+1, 6+nm, 6+nm) articulated inertia over (a_i, eta_dd_i)   pass 2
    pA: np.ndarray      # (nb+1, 6+nm)  articulated bias force
    Lm: np.ndarray      # (nb+1, nm, nm) Cholesky factor L of the modal block D = L L^T
    W: np.ndarray       # (nb+1, nm, 6) L^-1 B^T (B: reference-modal block)
    y: np.ndarray       # (nb+1, nm)    L^-1 p_m
    Ia: np.ndarray      # (nb+1, 6, 6)  articulated inertia after the modes and the joint
    pa: np.ndarray      # (nb+1, 6)     its bias force
    Uj: np.ndarray      # (nb+1, 6, 6)  IA S
    dinv: np.ndarray    # (nb+1, 6, 6)  (S^T IA S)^-1
    u: np.ndarray       # (nb+1, 6)     tau - S^T pA
    IG: np.ndarray      # (6, 6+nm)     IA G, projecting onto the parent (one body at a time)
    a: np.ndarray       # (nb+1, 6)     spatial acceleration, gravity as base acceleration    pass 3
    f: np.ndarray       # (nb+1, 6)     force the joint transmits from the parent onto the body
    qdd: np.ndarray     # (nv,)         joint and modal accelerations


def make_data(model: Model) -> Data:
    """A zeroed workspace for `model`."""
    return empty_data(model.nb, model.jnt_Phi.shape[2], model.nv, model.load_kind.size)


def empty_data(nb: int, nm: int, nv: int, nl: int) -> Data:
    n = nb + 1
    X0 = np.zeros((n, 6, 6))
    X0[0] = np.eye(6)
    z6, z66 = np.zeros((n, 6)), np.zeros((n, 6, 6))
    return Data(qdd_p=np.zeros(nv), scale=np.ones(nl), XJ=z66.copy(), S=z66.copy(), vJ=z6.copy(), Xup=z66.copy(),
                X0=X0, U=np.zeros((n, 6, nm)), v=z6.copy(), c=z6.copy(), Iv=z6.copy(), F=np.zeros((n, 6 + nm)),
                MA=np.zeros((n, 6 + nm, 6 + nm)), pA=np.zeros((n, 6 + nm)), Lm=np.zeros((n, nm, nm)),
                W=np.zeros((n, nm, 6)), y=np.zeros((n, nm)), Ia=z66.copy(), pa=z6.copy(), Uj=z66.copy(),
                dinv=z66.copy(), u=z6.copy(), IG=np.zeros((6, 6 + nm)), a=z6.copy(), f=z6.copy(), qdd=np.zeros(nv))


def empty_arrays(nb: int, nm: int, nt: int = 2) -> dict:
    """The per-body Model arrays (see Arrays) for nb bodies and nm modes, zeroed (identity triads)."""
    n = nb + 1
    return dict(parent=np.full(n, -1), jnt_type=np.zeros(n, dtype=np.int64),
                jnt_axis=np.zeros((n, 3)), jnt_Xtriad=np.tile(np.eye(6), (n, 1, 1)),
                jnt_node=np.full(n, -1), jnt_x0=np.zeros((n, 3)), jnt_Phi=np.zeros((n, 6, nm)),
                jnt_D=np.zeros((n, nm, nm)),
                jnt_qadr=np.zeros(n, dtype=np.int64), jnt_vadr=np.zeros(n, dtype=np.int64),
                jnt_nv=np.zeros(n, dtype=np.int64), jnt_prescribed=np.zeros(n, dtype=bool),
                jnt_motion_kind=np.full(n, -1), jnt_motion_par=np.zeros((n, 4)),
                jnt_motion_n=np.zeros(n, dtype=np.int64), jnt_motion_x=np.zeros((n, nt)),
                jnt_motion_c=np.zeros((n, 4, nt)), jnt_q0=np.zeros(n),
                body_inertia=np.zeros((n, 6, 6)), body_madr=np.zeros(n, dtype=np.int64),
                body_nm=np.zeros(n, dtype=np.int64), body_mass=np.zeros(n),
                flex_K=np.zeros((n, nm, nm)), flex_C=np.zeros((n, nm, nm)))


def empty_loads(nl: int, nm: int) -> dict:
    """The point-load Model arrays (see Arrays.load_*), zeroed."""
    return dict(load_body=np.zeros(nl, dtype=np.int64), load_point=np.zeros((nl, 3)),
                load_Phi=np.zeros((nl, 6, nm)), load_D=np.zeros((nl, nm, nm)), load_force=np.zeros((nl, 3)),
                load_global=np.zeros(nl, dtype=bool), load_kind=np.zeros(nl, dtype=np.int64),
                load_par=np.zeros((nl, 4)))
