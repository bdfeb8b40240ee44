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
(names, motion profiles, the reduced bodies for outputs). The compiled entry points get the arrays
and a Data as one `Bound` (end of this file), in which both are structrefs with the same fields.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numba
import numpy as np
from numba.core import cgutils, types
from numba.experimental import structref
from numba.extending import intrinsic

from flexmbd import flexbody, profiles, spatial
from flexmbd.jit import PURE_PYTHON, njit

FIXED, REVOLUTE, PRISMATIC, SPHERICAL, FREE = range(5)
JOINT_CODES = {"fixed": FIXED, "revolute": REVOLUTE, "prismatic": PRISMATIC,
               "spherical": SPHERICAL, "free": FREE}
NQ = {FIXED: 0, REVOLUTE: 1, PRISMATIC: 1, SPHERICAL: 4, FREE: 7}   # quaternion [w,x,y,z]; free: quat, pos
NV = {FIXED: 0, REVOLUTE: 1, PRISMATIC: 1, SPHERICAL: 3, FREE: 6}   # free: [w; v] in the body frame


class Arrays(NamedTuple):
    parent: np.ndarray        # (nb+1,) parent body, parent[0] = -1
    jnt_type: np.ndarray      # (nb+1,) FIXED, REVOLUTE, ...
    jnt_axis: np.ndarray      # (nb+1, 3) unit axis in the input triad
    jnt_Xtriad: np.ndarray    # (nb+1, 6, 6) parent (or node) frame -> input triad
    jnt_node: np.ndarray      # (nb+1,) node on a flexible parent, -1 otherwise
    jnt_x0: np.ndarray        # (nb+1, 3) undeformed position of that node, parent frame
    jnt_Phi: np.ndarray       # (nb+1, 6, nm) mode block of that node [rot; trans]
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
    inv: flexbody.Invariants  # stacked over bodies (nb+1, ...), zero for rigid ones
    load_body: np.ndarray     # (nl,) body a point load acts on
    load_point: np.ndarray    # (nl, 3) undeformed point of application, body frame
    load_Phi: np.ndarray      # (nl, 6, nm) mode block of the loaded node (zeros on rigid bodies)
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
    bodies: dict              # reduced FlexBody per flexible body name (outputs, adapters)
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


# ---------------------------------------------------------------------------------------------
# building from a case


def from_case(case, bodies: dict | None = None) -> Model:
    """Build the Model of a case; `bodies`: reduced flexible bodies by name (built when None)."""
    if bodies is None:
        bodies = flexbody.for_case(case)
    order = topological_order(case)
    index = {name: k + 1 for k, name in enumerate(order)}
    by_child = {j["child"]: (jn, j) for jn, j in case["joints"].items()}
    nb = len(order)
    nm = max([fb.n_modes for fb in bodies.values()] + [0])

    A = {k: x for k, x in empty_arrays(nb, nm).items() if not k.startswith("jnt_motion") and k != "jnt_q0"}
    invs = [None] * (nb + 1)
    motion, jnames, q0, v0 = [None] * (nb + 1), [""] * (nb + 1), [], []
    nq = nv = 0
    for name in order:
        i = index[name]
        jname, j = by_child[name]
        jnames[i], motion[i] = jname, j["motion"]
        A["jnt_prescribed"][i] = j["motion"] is not None
        A["parent"][i] = 0 if j["parent"] == "ground" else index[j["parent"]]
        t = JOINT_CODES[j["type"]]
        A["jnt_type"][i], A["jnt_nv"][i] = t, NV[t]
        A["jnt_axis"][i] = np.asarray(j["axis"]) / np.linalg.norm(j["axis"])
        attach(A, i, j, case["bodies"].get(j["parent"]), bodies.get(j["parent"]))
        A["jnt_qadr"][i], A["jnt_vadr"][i] = nq, nv
        q0.extend(initial_q(t, j["q0"]))
        v0.extend(j["qd0"])
        nq, nv = nq + NQ[t], nv + NV[t]

        body = case["bodies"][name]
        if body["type"] == "rigid":
            A["body_inertia"][i] = spatial.inertia(body["mass"], np.asarray(body["com"], dtype=float),
                                                   inertia_matrix(body["inertia"]))
            A["body_mass"][i] = body["mass"]
        elif body["rigid"]:
            fb = flexbody.undeformed(name, body,
                                case["materials"][body["material"]])
            A["body_inertia"][i] = rigid_inertia_of_beam(fb)
            A["body_mass"][i] = fb.m.sum()
        else:
            fb = bodies[name]
            k = fb.n_modes
            invs[i] = flexbody.invariants(fb)
            A["body_mass"][i] = fb.m.sum()
            A["body_madr"][i], A["body_nm"][i] = nq, k
            A["flex_K"][i, :k, :k], A["flex_C"][i, :k, :k] = fb.Km, fb.Cm
            q0.extend([0.0] * k)
            v0.extend([0.0] * k)
            nq, nv = nq + k, nv + k

    A.update(motion_arrays(motion, A["jnt_qadr"], A["jnt_nv"], q0))
    loads = point_loads(case, index, bodies, nm)
    arrays = Arrays(**A, inv=flexbody.stack(invs, nm), **loads[0],
                    gravity=np.asarray(case["gravity"], dtype=float))
    return Model(nb=nb, nq=nq, nv=nv, arrays=arrays, names=("ground",) + tuple(order),
                 jnt_names=tuple(jnames), jnt_motion=tuple(motion), load_profiles=loads[1],
                 bodies=dict(bodies), q0=np.array(q0, dtype=float), v0=np.array(v0, dtype=float))


def empty_arrays(nb: int, nm: int, nt: int = 2) -> dict:
    """The per-body Model arrays (see Arrays) for nb bodies and nm modes, zeroed (identity triads)."""
    n = nb + 1
    return dict(parent=np.full(n, -1), jnt_type=np.zeros(n, dtype=np.int64),
                jnt_axis=np.zeros((n, 3)), jnt_Xtriad=np.tile(np.eye(6), (n, 1, 1)),
                jnt_node=np.full(n, -1), jnt_x0=np.zeros((n, 3)), jnt_Phi=np.zeros((n, 6, nm)),
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
                load_Phi=np.zeros((nl, 6, nm)), load_force=np.zeros((nl, 3)),
                load_global=np.zeros(nl, dtype=bool), load_kind=np.zeros(nl, dtype=np.int64),
                load_par=np.zeros((nl, 4)))


def attach(A: dict, i: int, j: dict, pbody: dict | None, fb: flexbody.FlexBody | None) -> None:
    """Input triad of joint i: on ground or a rigid body at a point; on a beam at its snapped node."""
    R = spatial.rotation_rpy(j["rpy"])
    if pbody is None or pbody["type"] == "rigid":
        A["jnt_Xtriad"][i] = spatial.plux(R.T, np.asarray(j["at"], dtype=float))
    elif pbody["rigid"]:          # a beam declared rigid: the snapped node's undeformed position
        x = flexbody.snapped(pbody["length"], pbody["elements"], j["at"])
        A["jnt_Xtriad"][i] = spatial.plux(R.T, np.array([x, 0.0, 0.0]))
    else:
        p = fb.node_at(j["at"])
        A["jnt_Xtriad"][i] = spatial.plux(R.T, np.zeros(3))
        A["jnt_node"][i], A["jnt_x0"][i] = p, fb.x0[p]
        A["jnt_Phi"][i, :, :fb.n_modes] = fb.Phi[p]


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


def point_loads(case, index: dict, bodies: dict, nm: int):
    """Load arrays (see Arrays.load_*) and their time profiles."""
    loads = list(case["loads"].values())
    nl = len(loads)
    L = empty_loads(nl, nm)
    for k, ld in enumerate(loads):
        L["load_body"][k] = index[ld["body"]]
        L["load_force"][k] = ld["force"]
        L["load_global"][k] = ld["frame"] == "global"
        L["load_kind"][k], L["load_par"][k] = profiles.encode_load(ld["profile"])
        body = case["bodies"][ld["body"]]
        if body["type"] == "rigid":
            L["load_point"][k] = ld["at"]
        elif body["rigid"]:
            L["load_point"][k] = [flexbody.snapped(body["length"], body["elements"], ld["at"]), 0.0, 0.0]
        else:
            fb = bodies[ld["body"]]
            p = fb.node_at(ld["at"])
            L["load_point"][k] = fb.x0[p]
            L["load_Phi"][k, :, :fb.n_modes] = fb.Phi[p]
    return L, tuple(ld["profile"] for ld in loads)


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


def rigid_inertia_of_beam(fb: flexbody.FlexBody) -> np.ndarray:
    """Spatial inertia (6, 6) at the body origin of a beam declared rigid: the undeformed invariants."""
    inv = flexbody.invariants(fb)
    I = np.zeros((6, 6))
    I[:3, :3] = inv.I1[0]
    I[:3, 3:] = spatial.skew(inv.I4[0])
    I[3:, :3] = spatial.skew(inv.I4[0]).T
    I[3:, 3:] = inv.I8[0] * np.eye(3)
    return I


def inertia_matrix(six) -> np.ndarray:
    """[Ixx, Iyy, Izz, Ixy, Ixz, Iyz] -> symmetric (3, 3)."""
    xx, yy, zz, xy, xz, yz = six
    return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])


def initial_q(jtype: int, values) -> list:
    """Case initial values -> q entries (rotation vectors become quaternions)."""
    if jtype == SPHERICAL:
        return list(spatial.rotvec_to_quat(np.asarray(values, dtype=float)))
    if jtype == FREE:
        return list(spatial.rotvec_to_quat(np.asarray(values[:3], dtype=float))) + list(values[3:])
    return list(values)


# ---------------------------------------------------------------------------------------------
# Model arrays and a Data as one object for compiled code


@structref.register
class ArraysType(types.StructRef):
    """numba type of `ArraysRef`."""


@structref.register
class DataType(types.StructRef):
    """numba type of `DataRef`."""


@structref.register
class BoundType(types.StructRef):
    """numba type of `Bound`."""


class ArraysRef(structref.StructRefProxy):
    """The fields of `Arrays` behind one pointer. Reading one field in compiled code touches that
    array only, where a NamedTuple read out of a structref takes a reference to every member."""


class DataRef(structref.StructRefProxy):
    """The fields of `Data` behind one pointer (see ArraysRef)."""


class Bound(structref.StructRefProxy):
    """A Model's arrays (field M, an ArraysRef) and one Data (field D, a DataRef) as a single
    object for compiled code: numba passes it in about 1.7 us, where the two NamedTuples (some 70
    arrays) take about 17 us. Made by `bind`; the arrays are shared, not copied.

    `address` (int) is where its data lives. numba's dispatcher types an int in C but a structref
    in Python (about 0.8 us more), so the cheap call from Python (`dynamics.forward`) passes the
    address, and the compiled code takes the Bound back with `bound_at`, while the Python object
    keeps it alive for the call."""

    @classmethod
    def _numba_box_(cls, ty, mi):
        b = super()._numba_box_(ty, mi)
        b.address = _address(b)
        return b


structref.define_proxy(ArraysRef, ArraysType, Arrays._fields)
structref.define_proxy(DataRef, DataType, Data._fields)
structref.define_boxing(BoundType, Bound)


def _bound_type() -> BoundType:
    A = Arrays(**empty_arrays(0, 0), inv=flexbody.stack([None], 0), **empty_loads(0, 0), gravity=np.zeros(3))
    D = empty_data(0, 0, 0, 0)
    return BoundType([("M", ArraysType(list(zip(Arrays._fields, numba.typeof(A).types)))),
                      ("D", DataType(list(zip(Data._fields, numba.typeof(D).types))))])


BOUND_T = _bound_type()


@intrinsic
def address_of(typingctx, b):
    """The address (intp) of a Bound's data (its meminfo)."""
    def codegen(context, builder, sig, args):
        st = cgutils.create_struct_proxy(BOUND_T)(context, builder, value=args[0])
        return builder.ptrtoint(st.meminfo, context.get_value_type(types.intp))
    return types.intp(BOUND_T), codegen


@intrinsic
def bound_at(typingctx, address):
    """The Bound at `address` (`Bound.address`), as a new reference. The caller guarantees that
    a Bound there is alive for the call."""
    def codegen(context, builder, sig, args):
        st = cgutils.create_struct_proxy(BOUND_T)(context, builder)
        st.meminfo = builder.inttoptr(args[0], st.meminfo.type)
        context.nrt.incref(builder, BOUND_T, st._getvalue())
        return st._getvalue()
    return BOUND_T(types.intp), codegen


@njit
def _address(b):
    return address_of(b)


@njit
def _bind(M, D):
    b = structref.new(BOUND_T)
    b.M = ArraysRef(*M)
    b.D = DataRef(*D)
    return b


class PlainBound(NamedTuple):
    """The uncompiled stand-in for a Bound (numba's JIT disabled, `jit.PURE_PYTHON`): the same
    fields M and D, the NamedTuples themselves."""

    M: Arrays
    D: Data


def bind(model: Model, data: Data) -> Bound:
    """The Model's arrays and `data` as one `Bound` (see `dynamics.forward`); a PlainBound when
    numba's JIT is disabled."""
    if PURE_PYTHON:
        return PlainBound(model.arrays, data)
    return _bind(model.arrays, data)
