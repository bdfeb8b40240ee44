"""Model (constants of a tree of rigid and flexible bodies) and Data (the workspace of one state).

Bodies are numbered 1..nb with parent[i] < i; index 0 is ground. Body i and the joint to its
parent share the number. Arrays are indexed by body number (row 0 unused unless stated).
A flexible body is a body with extra (modal) coordinates: its modes sit in q and v right after
its joint's coordinates, at `body_madr[i]`, `body_nm[i]` of them.

Frames: every body-level quantity is in the body frame (the joint's output triad). The input
triad of joint i sits on its parent: on a rigid parent (or ground) at a constant transform
`jnt_Xtriad[i]` from the parent frame; on a flexible parent at node `jnt_node[i]`, and then
`jnt_Xtriad[i]` is the constant transform from the deformed node frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flexmbd import flexbody, spatial

FIXED, REVOLUTE, PRISMATIC, SPHERICAL, FREE = range(5)
JOINT_CODES = {"fixed": FIXED, "revolute": REVOLUTE, "prismatic": PRISMATIC,
               "spherical": SPHERICAL, "free": FREE}
NQ = {FIXED: 0, REVOLUTE: 1, PRISMATIC: 1, SPHERICAL: 4, FREE: 7}   # quaternion [w,x,y,z]; free: quat, pos
NV = {FIXED: 0, REVOLUTE: 1, PRISMATIC: 1, SPHERICAL: 3, FREE: 6}   # free: [w; v] in the body frame


@dataclass(frozen=True)
class Flex:
    """A flexible body's data used at run time: invariants and what its node attachments need."""

    inv: flexbody.Invariants
    Km: np.ndarray          # (nm, nm)
    Cm: np.ndarray          # (nm, nm)
    x0: np.ndarray          # (N, 3) node positions, body frame
    Phi: np.ndarray         # (N, 6, nm) mode blocks [rot; trans]
    m: np.ndarray           # (N,) node masses
    J: np.ndarray           # (N, 3, 3) node rotary inertias, body axes


@dataclass(frozen=True)
class Model:
    nb: int                           # number of bodies
    names: tuple                      # (nb+1,) body names, names[0] = 'ground'
    parent: np.ndarray                # (nb+1,) parent body, parent[0] = -1
    jnt_type: np.ndarray              # (nb+1,) FIXED, REVOLUTE, ...
    jnt_axis: np.ndarray              # (nb+1, 3) unit axis in the input triad
    jnt_Xtriad: np.ndarray            # (nb+1, 6, 6) parent (or node) frame -> input triad
    jnt_node: np.ndarray              # (nb+1,) node on a flexible parent, -1 otherwise
    jnt_qadr: np.ndarray              # (nb+1,) first joint coordinate in q
    jnt_vadr: np.ndarray              # (nb+1,) first joint velocity in v
    jnt_motion: tuple                 # (nb+1,) prescribed-motion profile dict or None
    jnt_names: tuple                  # (nb+1,) joint names
    body_inertia: np.ndarray          # (nb+1, 6, 6) spatial inertia of rigid bodies at the body origin
    body_flex: tuple                  # (nb+1,) Flex or None
    body_madr: np.ndarray             # (nb+1,) first modal coordinate in q (== in v)
    body_nm: np.ndarray               # (nb+1,) number of modes (0: rigid)
    body_mass: np.ndarray             # (nb+1,) total mass
    gravity: np.ndarray               # (3,) global frame, m/s^2
    nq: int
    nv: int
    q0: np.ndarray                    # (nq,)
    v0: np.ndarray                    # (nv,)

    def __post_init__(self):
        for name, val in vars(self).items():
            if isinstance(val, np.ndarray):
                val.flags.writeable = False

    @property
    def children(self):
        return [[j for j in range(1, self.nb + 1) if self.parent[j] == i] for i in range(self.nb + 1)]


class Data:
    """Workspace for one evaluation; created from a Model, reused between calls."""

    def __init__(self, model: Model):
        n = model.nb + 1
        self.Xup = np.zeros((n, 6, 6))      # parent frame -> body frame
        self.X0 = np.zeros((n, 6, 6))       # global -> body frame
        self.X0[0] = np.eye(6)
        self.S = [None] * n                 # (6, nv_i) joint motion subspace, body frame
        self.U = [None] * n                 # (6, nm_parent) parent's modal velocity -> body velocity
        self.v = np.zeros((n, 6))           # spatial velocity, body frame
        self.c = np.zeros((n, 6))           # velocity-product acceleration, body frame
        self.a = np.zeros((n, 6))           # spatial acceleration, body frame (gravity included)
        self.f = np.zeros((n, 6))           # joint force transmitted from parent to body, body frame
        self.MA = [None] * n                # articulated inertia over (a_i, eta_dd_i)
        self.pA = [None] * n                # articulated bias force
        self.qdd = np.zeros(model.nv)       # generalized accelerations (joint and modal)


# ---------------------------------------------------------------------------------------------
# building from a case


def triad_transform(at, rpy, on_beam: bool) -> np.ndarray:
    """X from the parent (or node) frame to the input triad: rotation rpy, origin at `at` (vec3)."""
    from flexmbd.adapters.common import rotation_rpy
    R = rotation_rpy(rpy)
    r = np.zeros(3) if on_beam else np.asarray(at, dtype=float)
    return spatial.plux(R.T, r)


def rigid_inertia_of_beam(fb: flexbody.FlexBody) -> np.ndarray:
    """Spatial inertia (6, 6) at the body origin of a beam declared rigid: the undeformed invariants."""
    inv = flexbody.invariants(fb)
    I = np.zeros((6, 6))
    I[:3, :3] = inv.I1
    I[:3, 3:] = spatial.skew(inv.I4)
    I[3:, :3] = spatial.skew(inv.I4).T
    I[3:, 3:] = inv.I8 * np.eye(3)
    return I


def from_case(case, bodies: dict | None = None) -> Model:
    """Build the Model of a case; `bodies`: reduced flexible bodies by name (built when None)."""
    if bodies is None:
        bodies = flexbody.for_case(case)
    order = topological_order(case)
    index = {name: k + 1 for k, name in enumerate(order)}
    by_child = {j["child"]: (jn, j) for jn, j in case["joints"].items()}
    nb = len(order)

    parent = np.full(nb + 1, -1)
    jtype = np.zeros(nb + 1, dtype=int)
    axis = np.zeros((nb + 1, 3))
    Xtriad = np.tile(np.eye(6), (nb + 1, 1, 1))
    node = np.full(nb + 1, -1)
    qadr, vadr = np.zeros(nb + 1, dtype=int), np.zeros(nb + 1, dtype=int)
    madr, nm = np.zeros(nb + 1, dtype=int), np.zeros(nb + 1, dtype=int)
    inertia = np.zeros((nb + 1, 6, 6))
    mass = np.zeros(nb + 1)
    flex, motion, jnames = [None] * (nb + 1), [None] * (nb + 1), [""] * (nb + 1)
    q0, v0 = [], []
    nq = nv = 0
    for name in order:
        i = index[name]
        jname, j = by_child[name]
        jnames[i], motion[i] = jname, j["motion"]
        parent[i] = 0 if j["parent"] == "ground" else index[j["parent"]]
        jtype[i] = JOINT_CODES[j["type"]]
        axis[i] = np.asarray(j["axis"]) / np.linalg.norm(j["axis"])
        pbody = case["bodies"].get(j["parent"])
        p_flex = pbody is not None and pbody["type"] == "beam" and not pbody["rigid"]
        on_beam = pbody is not None and pbody["type"] == "beam"
        Xtriad[i] = triad_transform(j["at"], j["rpy"], on_beam)
        if on_beam:
            fbp = bodies[j["parent"]] if p_flex else None
            if p_flex:
                node[i] = fbp.node_at(j["at"])
            else:   # rigid-declared beam: the triad sits at the snapped node's position
                x = snapped_position(case["bodies"][j["parent"]], j["at"])
                Xtriad[i] = spatial.plux(Xtriad[i][:3, :3], np.array([x, 0.0, 0.0]))
        qadr[i], vadr[i] = nq, nv
        t = jtype[i]
        q0.extend(initial_q(t, j["q0"]))
        v0.extend(j["qd0"])
        nq, nv = nq + NQ[t], nv + NV[t]

        body = case["bodies"][name]
        if body["type"] == "rigid":
            inertia[i] = spatial.inertia(body["mass"], body["com"], inertia_matrix(body["inertia"]))
            mass[i] = body["mass"]
        elif body["rigid"]:
            fb = bodies.get(name) or flexbody.build(name, {**body, "modes": {**body["modes"], "count": 0}},
                                                    case["materials"][body["material"]])
            inertia[i] = rigid_inertia_of_beam(fb)
            mass[i] = fb.m.sum()
        else:
            fb = bodies[name]
            flex[i] = Flex(inv=flexbody.invariants(fb), Km=fb.Km, Cm=fb.Cm, x0=fb.x0, Phi=fb.Phi, m=fb.m, J=fb.J)
            mass[i] = fb.m.sum()
            madr[i], nm[i] = nq, fb.n_modes
            q0.extend([0.0] * fb.n_modes)
            v0.extend([0.0] * fb.n_modes)
            nq, nv = nq + fb.n_modes, nv + fb.n_modes
    names = ("ground",) + tuple(order)
    return Model(nb=nb, names=names, parent=parent, jnt_type=jtype, jnt_axis=axis, jnt_Xtriad=Xtriad,
                 jnt_node=node, jnt_qadr=qadr, jnt_vadr=vadr, jnt_motion=tuple(motion),
                 jnt_names=tuple(jnames), body_inertia=inertia, body_flex=tuple(flex), body_madr=madr,
                 body_nm=nm, body_mass=mass, gravity=np.asarray(case["gravity"], dtype=float),
                 nq=nq, nv=nv, q0=np.array(q0, dtype=float), v0=np.array(v0, dtype=float))


def topological_order(case) -> list:
    """Body names so that every parent comes before its children (case order kept otherwise)."""
    parent_of = {j["child"]: j["parent"] for j in case["joints"].values()}
    order, placed = [], {"ground"}
    while len(order) < len(parent_of):
        for name in case["bodies"]:
            if name not in placed and parent_of[name] in placed:
                order.append(name)
                placed.add(name)
    return order


def snapped_position(body: dict, x: float) -> float:
    """A position along a beam snapped to its nearest node."""
    h = body["length"] / body["elements"]
    return round(x / h) * h


def inertia_matrix(six) -> np.ndarray:
    """[Ixx, Iyy, Izz, Ixy, Ixz, Iyz] -> symmetric (3, 3)."""
    xx, yy, zz, xy, xz, yz = six
    return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])


def initial_q(jtype: int, values) -> list:
    """Case initial values -> q entries (rotation vectors become quaternions)."""
    if jtype == SPHERICAL:
        return list(spatial.rotvec_to_quat(values))
    if jtype == FREE:
        return list(spatial.rotvec_to_quat(values[:3])) + list(values[3:])
    return list(values)
