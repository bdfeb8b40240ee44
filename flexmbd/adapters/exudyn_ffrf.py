"""`exudyn-ffrf`: every flexible beam as an Exudyn `ObjectFFRFreducedOrder` fed the identical
reduced body flexmbd reads; rigid bodies as `ObjectRigidBody`; Exudyn's implicit solver.

The reduced body goes in through Exudyn's own `ObjectFFRFreducedOrderInterface`, built from a
small FEM stand-in that hands it the FlexBody's node positions x0 (N, 3), the lumped node masses
m (N,) as a diagonal translational mass matrix (3N, 3N), and the translational mode rows Phi_t
as the mode basis (3N, nm); the interface computes Exudyn's FFRF invariants from them. Modal
stiffness and damping are the FlexBody's Km, Cm. Exudyn's object has no rotary node inertia;
with `rotary_inertia = true` (default) the FlexBody's J_p are added where the object's data
allows: sum J_p to the reference inertia, sum Phi_r^T J_p Phi_r to the modal mass (so the modal
mass is the identity the modes were normalised to) and sum J_p Phi_r to the rotation-mode
coupling. What stays out is the gyroscopic term w x (sum J_p Phi_r) eta_d, zero in planar motion.

Joints (body frame = the FFRF reference node, which is the beam's root node):
  parent ground / rigid body / the reference node of a beam: `ObjectJointGeneric` between rigid
    markers, all six axes or the joint's free ones (revolute: rotation about the axis,
    prismatic: translation along it, spherical: the three rotations, free: no joint);
  parent a flexible node: `MarkerSuperElementPosition` on that node; the joint can only hold its
    position (Exudyn's rigid super-element marker needs non-collinear nodes, a beam's are
    collinear), so spherical joints are exact, and revolute joints about z are exact in a planar
    case (the moments about x and y they would carry are zero there); other joints: not applicable.
Prescribed joint motion: the generic joint's offset user function. Loads: `LoadForceVector` on
the node's super-element marker; gravity: `LoadMassProportional`.

Channels are measured from Exudyn's sensors: node positions of the super element (global),
the reference node's pose, the modal coordinates. Deflections are formed from the node positions
in the root-node (or chord) frame; stresses apply the FlexBody's modal stress coefficients to
Exudyn's modal coordinates; the triad of a joint on a flexible node turns with the node's elastic
rotation Phi_r eta (Exudyn's modal coordinates).
"""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp

from flexmbd import flexbody, invariants, profiles
from flexmbd.adapters import common
from flexmbd.adapters import exudyn_common as xc
from flexmbd.adapters.exudyn_common import eii, exu
from flexmbd.fe.stress import von_mises
from flexmbd.spatial import rotation_rpy

from exudyn.FEM import ObjectFFRFreducedOrderInterface
from exudyn.rigidBodyUtilities import GetRigidBodyNode

SETTINGS = {
    "dt": ("float+", 2.5e-5),                # s, fixed step (rounded to divide output_dt); see docs/exudyn.md
    "solver": (tuple(xc.IMPLICIT), "generalized-alpha"),
    "spectral_radius": ("float0+", 1.0),     # 1: no numerical damping (trapezoidal rule)
    "newton_rtol": ("float+", 1e-8),         # 1e-10 stalls the double pendulum at t = 1.49 s
    "adaptive": ("bool", False),             # Exudyn's step reduction on Newton failure
    "rotary_inertia": ("bool", True),        # add the FlexBody's J_p (see the module docstring)
    "gravity": (("nodal", "mass-proportional"), "nodal"),   # see add_loads
}

NODE_TYPE = exu.NodeType.RotationEulerParameters
CONSTRAINED = {"fixed": [1, 1, 1, 1, 1, 1], "revolute": [1, 1, 1, 1, 1, 0],
               "prismatic": [1, 1, 0, 1, 1, 1], "spherical": [1, 1, 1, 0, 0, 0]}


def version() -> str:
    return xc.version()


def applies(case) -> str:
    planar = xc.is_planar(case)
    for jn, j in case["joints"].items():
        parent = case["bodies"].get(j["parent"])
        if parent is None or parent["type"] == "rigid" or parent["rigid"] or j["type"] == "free":
            continue
        at = j["at"] if not isinstance(j["at"], list) else j["at"][0]
        if flexbody.node_index(parent["length"], parent["elements"], at) == 0 \
                and parent["modes"]["boundary"] == "clamped-free":
            continue                         # the root node is the reference frame: any joint
        if j["motion"] is not None:
            return f"joint {jn!r}: prescribed motion on a flexible node"
        if j["type"] == "spherical" or (j["type"] == "revolute" and not planar):
            continue
        if j["type"] == "revolute":
            return (f"joint {jn!r}: a revolute joint on a flexible node holds only the node's position "
                    f"in Exudyn (a beam's nodes are collinear: no rigid super-element marker), exact "
                    f"only in planar cases, and this one is not ({planar})")
        return (f"joint {jn!r}: a {j['type']} joint on a flexible node needs the node's rotation, "
                f"which Exudyn's super-element markers cannot give for a beam's collinear nodes")
    return ""


# ---------------------------------------------------------------------------------------------
# the reduced body as Exudyn's FFRF data


class _FEM:
    """The FlexBody seen through the few FEMinterface calls ObjectFFRFreducedOrderInterface makes."""

    def __init__(self, fb: flexbody.FlexBody):
        self.x0 = np.asarray(fb.x0, dtype=float)
        self.modeBasis = {"matrix": translational_modes(fb)}
        self.postProcessingModes = {}
        self.mass = sp.diags(np.repeat(fb.m, 3)).tocsr()

    def GetNodePositionsAsArray(self):
        return self.x0

    def GetSurfaceTriangles6(self):
        return []

    def GetSurfaceTriangles(self):
        return []

    def GetMassMatrix(self, sparse=True):
        return self.mass

    def GetStiffnessMatrix(self, sparse=True):
        return sp.csr_matrix(self.mass.shape)


def translational_modes(fb: flexbody.FlexBody) -> np.ndarray:
    """Mode basis (3N, nm): rows [ux, uy, uz] of node 0, node 1, ... (Exudyn's ordering)."""
    return np.ascontiguousarray(fb.Phi[:, 3:, :].reshape(-1, fb.n_modes))


def ffrf_interface(fb: flexbody.FlexBody, rotary: bool) -> ObjectFFRFreducedOrderInterface:
    """Exudyn's FFRF invariants of the body; modal stiffness Km; rotary inertia added when asked."""
    cms = ObjectFFRFreducedOrderInterface(_FEM(fb), rigidBodyNodeType=NODE_TYPE,
                                          roundMassMatrix=0.0, roundStiffnessMatrix=0.0)
    cms.stiffnessMatrixReduced = np.array(fb.Km, dtype=float)
    if rotary:
        inv = invariants.invariants(fb)
        cms.massMatrixReduced = np.array(inv.I9[0])                     # sum Phi_r'J Phi_r + m Phi_t'Phi_t
        cms.inertiaLocal = cms.inertiaLocal + fb.J.sum(axis=0)          # sum J_p
        cms.mXRefTildePsi = cms.mXRefTildePsi - inv.I10[0]              # Mrf = G'(I6 + I10)
    return cms


def add_ffrf(mbs, fb, cms, R, p, v, w, damping: np.ndarray) -> dict:
    """Add the rigid-body node, modal node and ObjectFFRFreducedOrder at pose (R (3, 3), p (3,)),
    velocity v (3,), angular velocity w (3,) global; returns Exudyn indices."""
    node = GetRigidBodyNode(nodeType=NODE_TYPE, position=list(p), velocity=list(v),
                            rotationMatrix=R, angularVelocity=list(w))
    n_rigid = mbs.AddNode(node)
    nm = fb.n_modes
    n_modal = mbs.AddNode(eii.NodeGenericODE2(numberOfODE2Coordinates=nm, referenceCoordinates=[0.0] * nm,
                                              initialCoordinates=[0.0] * nm,
                                              initialCoordinates_t=[0.0] * nm))
    K, M = exu.MatrixContainer(), exu.MatrixContainer()
    K.SetWithDenseMatrix(cms.stiffnessMatrixReduced, useDenseMatrix=True)
    M.SetWithDenseMatrix(cms.massMatrixReduced, useDenseMatrix=True)
    D = []
    if np.any(damping):
        D = exu.MatrixContainer()
        D.SetWithDenseMatrix(np.asarray(damping, dtype=float), useDenseMatrix=True)
    obj = mbs.AddObject(eii.ObjectFFRFreducedOrder(
        nodeNumbers=[n_rigid, n_modal], stiffnessMatrixReduced=K, massMatrixReduced=M,
        dampingMatrixReduced=D, modeBasis=cms.modeBasis, referencePositions=cms.xRef,
        mass=cms.totalMass, inertia=cms.inertiaLocal, centerOfMass=cms.chiU,
        mPsiTildePsi=cms.mPsiTildePsi, mPsiTildePsiTilde=cms.mPsiTildePsiTilde,
        mPhitTPsi=cms.mPhitTPsi, mPhitTPsiTilde=cms.mPhitTPsiTilde, mXRefTildePsi=cms.mXRefTildePsi,
        mXRefTildePsiTilde=cms.mXRefTildePsiTilde, computeFFRFterms=True,
        visualization=eii.VObjectFFRFreducedOrder(show=False)))
    return {"node": n_rigid, "modal": n_modal, "obj": obj}


def add_rigid(mbs, body: dict, R, p, v, w) -> dict:
    """An ObjectRigidBody whose node sits at the body frame origin (COM offset in the object)."""
    com = np.asarray(body["com"], dtype=float)
    xx, yy, zz, xy, xz, yz = body["inertia"]
    Ic = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    Io = Ic + body["mass"] * (com @ com * np.eye(3) - np.outer(com, com))   # about the origin
    node = GetRigidBodyNode(nodeType=NODE_TYPE, position=list(p), velocity=list(v),
                            rotationMatrix=R, angularVelocity=list(w))
    n = mbs.AddNode(node)
    obj = mbs.AddObject(eii.ObjectRigidBody(
        nodeNumber=n, mass=body["mass"], centerOfMass=list(com),
        inertia=[Io[0, 0], Io[1, 1], Io[2, 2], Io[1, 2], Io[0, 2], Io[0, 1]],
        visualization=eii.VObjectRigidBody(show=False)))
    return {"node": n, "obj": obj}


# ---------------------------------------------------------------------------------------------
# the tree: initial poses, joints, loads


def joint_offset(j: dict):
    """(rotation (3, 3), translation (3,)) of the child frame in the input triad at q0."""
    A = xc.axis_frame(j["axis"])
    q0 = list(j["q0"])
    if j["type"] == "revolute":
        return xc.rotvec(A[:, 2] * q0[0]), np.zeros(3)
    if j["type"] == "prismatic":
        return np.eye(3), A[:, 2] * q0[0]
    if j["type"] == "spherical":
        return xc.rotvec(q0[:3]), np.zeros(3)
    if j["type"] == "free":
        return xc.rotvec(q0[:3]), np.asarray(q0[3:6], dtype=float)
    return np.eye(3), np.zeros(3)


def joint_rate(j: dict):
    """(angular (3,), linear (3,)) velocity of the child relative to the triad at t = 0, triad axes."""
    A = xc.axis_frame(j["axis"])
    qd = list(j["qd0"])
    if j["type"] == "revolute":
        return A[:, 2] * qd[0], np.zeros(3)
    if j["type"] == "prismatic":
        return np.zeros(3), A[:, 2] * qd[0]
    if j["type"] == "spherical":
        return np.asarray(qd[:3], dtype=float), np.zeros(3)
    if j["type"] == "free":
        return np.asarray(qd[:3], dtype=float), np.asarray(qd[3:6], dtype=float)
    return np.zeros(3), np.zeros(3)


def triad_point(case, j: dict, fbs: dict) -> np.ndarray:
    """Undeformed input-triad position (3,) in the parent frame (a beam: its snapped node)."""
    parent = case["bodies"].get(j["parent"])
    at = j["at"]
    if parent is None or parent["type"] == "rigid":
        return np.asarray(at, dtype=float)
    if j["parent"] in fbs:
        fb = fbs[j["parent"]]
        return fb.x0[fb.node_at(at if not isinstance(at, list) else at[0])].copy()
    return np.array([flexbody.snapped(parent["length"], parent["elements"], at if not isinstance(at, list) else at[0]),
                     0.0, 0.0])


def initial_states(case, order: list, fbs: dict) -> dict:
    """Global (R, p, v, w) of every body frame at t = 0 (undeformed, elastic velocities zero)."""
    by_child = {j["child"]: j for j in case["joints"].values()}
    out = {"ground": (np.eye(3), np.zeros(3), np.zeros(3), np.zeros(3))}
    for name in order:
        j = by_child[name]
        Rp, pp, vp, wp = out[j["parent"]]
        Rt = Rp @ rotation_rpy(j["rpy"])
        pt = pp + Rp @ triad_point(case, j, fbs)
        vt = vp + np.cross(wp, pt - pp)
        Rq, tq = joint_offset(j)
        wq, vq = joint_rate(j)
        R, p = Rt @ Rq, pt + Rt @ tq
        w = wp + Rt @ wq
        v = vt + np.cross(wp, Rt @ tq) + Rt @ vq
        out[name] = (R, p, v, w)
    return out


def body_marker_rigid(mbs, items: dict, name: str, case, fbs, point, R_local):
    """A rigid marker on body `name` (or ground) at `point` (3,) with rotation R_local, body frame."""
    ht = exu.HT(rotation=np.asarray(R_local, dtype=float), translation=np.asarray(point, dtype=float))
    if name == "ground":
        return mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=items["ground"], localHT=ht))
    it = items[name]
    if name in fbs:                          # the reference node: the beam's root node frame
        return mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=it["node"], localHT=ht))
    return mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=it["obj"], localHT=ht))


def on_root(case, j, fbs) -> bool:
    """True when joint j's input triad is the reference node of a clamped-root beam."""
    fb = fbs.get(j["parent"])
    if fb is None:
        return False
    p = fb.node_at(j["at"] if not isinstance(j["at"], list) else j["at"][0])
    return p == 0 and not np.any(fb.Phi[0])


def add_joint(mbs, items, case, fbs, jname: str, j: dict) -> None:
    """The joint to the parent (see the module docstring for how each kind is realised)."""
    if j["type"] == "free":
        return
    child = j["child"]
    A = xc.axis_frame(j["axis"])
    flexible_parent = j["parent"] in fbs and not on_root(case, j, fbs)
    if flexible_parent:
        fb = fbs[j["parent"]]
        p = fb.node_at(j["at"] if not isinstance(j["at"], list) else j["at"][0])
        m0 = mbs.AddMarker(eii.MarkerSuperElementPosition(bodyNumber=items[j["parent"]]["obj"],
                                                          meshNodeNumbers=[p], weightingFactors=[1.0]))
        it = items[child]
        m1 = (mbs.AddMarker(eii.MarkerNodePosition(nodeNumber=it["node"])) if child in fbs
              else mbs.AddMarker(eii.MarkerBodyPosition(bodyNumber=it["obj"], localPosition=[0, 0, 0])))
        mbs.AddObject(eii.ObjectJointSpherical(markerNumbers=[m0, m1],
                                               visualization=eii.VObjectJointSpherical(show=False)))
        if j["type"] == "revolute":
            # planar case: the node's triad keeps its z axis along global z, so the child's does too
            mg = mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=items["ground"], localPosition=[0, 0, 0]))
            mc = (mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=it["node"])) if child in fbs
                  else mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=it["obj"], localPosition=[0, 0, 0])))
            mbs.AddObject(eii.ObjectJointGeneric(markerNumbers=[mg, mc], constrainedAxes=[0, 0, 0, 1, 1, 0],
                                                 visualization=eii.VObjectJointGeneric(show=False)))
        return
    # parent side: the input triad turned onto the axis (z of the joint frame is the axis)
    Rt = rotation_rpy(j["rpy"])
    m0 = body_marker_rigid(mbs, items, j["parent"], case, fbs, triad_point(case, j, fbs), Rt @ A)

    # child side: the same joint frame at q0, in the child frame (coincident when driven)
    Rq, tq = joint_offset(j)
    driven = j["motion"] is not None
    m1 = body_marker_rigid(mbs, items, child, case, fbs, -Rq.T @ tq if driven else np.zeros(3), Rq.T @ A)
    kw = motion_offset(j) if driven else {}
    axes = [1] * 6 if driven else CONSTRAINED[j["type"]]
    mbs.AddObject(eii.ObjectJointGeneric(markerNumbers=[m0, m1], constrainedAxes=axes,
                                         visualization=eii.VObjectJointGeneric(show=False), **kw))


def motion_offset(j: dict) -> dict:
    """Offset user function of a generic joint driving a 1-DOF joint along its profile.

    The child marker carries the q0 offset, so the joint offset is q(t) - q0 about (along) z."""
    q0 = list(j["q0"])[0]
    k = 5 if j["type"] == "revolute" else 2
    prof = j["motion"]

    def offset(mbs, t, itemNumber, params):
        o = [0.0] * 6
        o[k] = profiles.motion(prof, t, q0)[0] - q0
        return o
    return {"offsetUserFunction": offset}


def add_loads(mbs, items, case, fbs, states, gravity_mode: str = "nodal") -> None:
    """Point loads (with their time profiles) and gravity.

    Gravity on a flexible body: `nodal` (default) puts m_p g on every node through one
    super-element marker at the mass-weighted mean of the nodes (its Jacobian is the
    mass-weighted sum of the node Jacobians, so this is exact); `mass-proportional` uses Exudyn's
    LoadMassProportional, which on an ObjectFFRFreducedOrder takes the moment of gravity about the
    reference frame from the undeformed centre of mass only (the deflection's lever arm is lost)."""
    for ld in case["loads"].values():
        name = ld["body"]
        it = items[name]
        if name in fbs:
            fb = fbs[name]
            p = fb.node_at(ld["at"] if not isinstance(ld["at"], list) else ld["at"][0])
            m = mbs.AddMarker(eii.MarkerSuperElementPosition(bodyNumber=it["obj"], meshNodeNumbers=[p],
                                                             weightingFactors=[1.0]))
        elif case["bodies"][name]["type"] == "rigid":
            m = mbs.AddMarker(eii.MarkerBodyPosition(bodyNumber=it["obj"], localPosition=list(ld["at"])))
        else:
            raise ValueError(f"load on beam {name!r} declared rigid: not supported by exudyn-ffrf")
        f = np.asarray(ld["force"], dtype=float)
        prof, body_frame, node = ld["profile"], ld["frame"] == "body", it["node"]
        steady = prof["type"] == "constant" or (prof["type"] == "step" and prof["t0"] <= 0.0)
        fixed_frame = fixed_to_ground(case, name)
        if steady and (not body_frame or fixed_frame):
            R0 = states[name][0] if body_frame else np.eye(3)
            mbs.AddLoad(eii.LoadForceVector(markerNumber=m, loadVector=list(R0 @ f)))
            continue

        def force(mbs_, t, load, f=f, prof=prof, body_frame=body_frame, node=node):
            s = float(profiles.load_factor(prof, t))
            if body_frame:
                R = np.asarray(mbs_.GetNodeOutput(node, exu.OutputVariableType.RotationMatrix)).reshape(3, 3)
                return list(s * (R @ f))
            return list(s * f)
        mbs.AddLoad(eii.LoadForceVector(markerNumber=m, loadVector=list(f), loadVectorUserFunction=force))
    g = np.asarray(case["gravity"], dtype=float)
    if np.any(g):
        for name, it in items.items():
            if name == "ground":
                continue
            if name in fbs and gravity_mode == "nodal":
                # M g at the mass-weighted mean of the deformed nodes = m_p g at every node
                fb = fbs[name]
                m = mbs.AddMarker(eii.MarkerSuperElementPosition(
                    bodyNumber=it["obj"], meshNodeNumbers=list(range(fb.n_nodes)),
                    weightingFactors=list(fb.m / fb.m.sum())))
                mbs.AddLoad(eii.LoadForceVector(markerNumber=m, loadVector=list(fb.m.sum() * g)))
                continue
            m = mbs.AddMarker(eii.MarkerBodyMass(bodyNumber=it["obj"]))
            mbs.AddLoad(eii.LoadMassProportional(markerNumber=m, loadVector=list(g)))


def fixed_to_ground(case, name: str) -> bool:
    """True when a chain of fixed joints ties the body frame to ground."""
    by_child = {j["child"]: j for j in case["joints"].values()}
    while name != "ground":
        j = by_child[name]
        if j["type"] != "fixed" or j["motion"] is not None:
            return False
        name = j["parent"]
    return True


# ---------------------------------------------------------------------------------------------
# sensors and channels


def add_sensors(mbs, items, case, fbs) -> dict:
    """Sensors kept in memory: poses of every body, modal coordinates, node positions and velocities."""
    S = {}
    sens = lambda **kw: mbs.AddSensor(eii.SensorNode(writeToFile=False, storeInternal=True,
                                                     visualization=eii.VSensorNode(show=False), **kw))
    sup = lambda **kw: mbs.AddSensor(eii.SensorSuperElement(writeToFile=False, storeInternal=True,
                                                            visualization=eii.VSensorSuperElement(show=False), **kw))
    energy = any(c["kind"] == "energy" for c in case["channels"].values())
    OV = exu.OutputVariableType
    for name, it in items.items():
        if name == "ground":
            continue
        n = it["node"]
        S[name] = {"p": sens(nodeNumber=n, outputVariableType=OV.Position),
                   "R": sens(nodeNumber=n, outputVariableType=OV.RotationMatrix)}
        if energy:
            S[name]["v"] = sens(nodeNumber=n, outputVariableType=OV.Velocity)
            S[name]["w"] = sens(nodeNumber=n, outputVariableType=OV.AngularVelocityLocal)
        if name in fbs:
            fb = fbs[name]
            S[name]["eta"] = sens(nodeNumber=it["modal"], outputVariableType=OV.Coordinates)
            nodes = range(fb.n_nodes) if energy else sorted({0, fb.n_nodes - 1} | channel_nodes(case, name, fb))
            S[name]["r"] = {k: sup(bodyNumber=it["obj"], meshNodeNumber=k, outputVariableType=OV.Position)
                            for k in nodes}
            if energy:
                S[name]["eta_d"] = sens(nodeNumber=it["modal"], outputVariableType=OV.Coordinates_t)
                S[name]["u"] = {k: sup(bodyNumber=it["obj"], meshNodeNumber=k, outputVariableType=OV.Velocity)
                                for k in nodes}
    return S


def channel_nodes(case, name: str, fb) -> set:
    return {fb.node_at(c["at"]) for c in case["channels"].values()
            if c["kind"] == "deflection" and c["body"] == name}


def read_sensors(mbs, S: dict, t: np.ndarray) -> dict:
    """Every sensor resampled on t (n,): the same nesting as S with arrays in place of sensors."""
    def rd(x):
        if isinstance(x, dict):
            return {k: rd(v) for k, v in x.items()}
        return xc.sensor_series(mbs, x, t)
    return rd(S)


def channels(case, fbs: dict, X: dict, t: np.ndarray) -> dict:
    """The case's channels from the sensor data X (see read_sensors)."""
    out, row = {}, {}
    for cname, c in case["channels"].items():
        kind = c["kind"]
        if kind == "joint_angle":
            j = case["joints"][c["joint"]]
            out[cname] = joint_angle(case, fbs, X, j)
        elif kind == "energy":
            out[cname] = energy(case, fbs, X)
        elif c["body"] not in fbs:
            out[cname] = np.zeros(t.size)                  # a rigid body does not deform
        elif kind == "deflection":
            fb = fbs[c["body"]]
            out[cname] = deflection(fb, X[c["body"]], fb.node_at(c["at"]), "xyz".index(c["component"]))
        else:
            fb = fbs[c["body"]]
            k = row[c["body"]] = row.get(c["body"], -1) + 1
            eta = X[c["body"]]["eta"]
            out[cname] = von_mises(eta @ fb.S_sigma[k], eta @ fb.S_tau[k])
    return out


def body_positions(Xb: dict, k: int) -> np.ndarray:
    """Node k's position (n, 3) in the body frame, from Exudyn's global node position and frame pose."""
    R = Xb["R"].reshape(-1, 3, 3)
    return np.einsum("nji,nj->ni", R, Xb["r"][k] - Xb["p"])


def deflection(fb, Xb: dict, p: int, axis: int) -> np.ndarray:
    """DESIGN §2: in the chord frame (hinged-hinged modes) or the root-node frame, minus undeformed."""
    r0, rp = body_positions(Xb, 0), body_positions(Xb, p)
    if fb.boundary == "hinged-hinged":
        e = body_positions(Xb, fb.n_nodes - 1) - r0
        Rs = [xc.chord_frame(x / np.linalg.norm(x)) for x in e]
    else:
        rot = Xb["eta"] @ fb.Phi[0, :3, :].T                 # root node's elastic rotation (n, 3)
        Rs = [xc.rotvec(w) for w in rot]
    d = np.array([(R.T @ (b - a))[axis] for R, a, b in zip(Rs, r0, rp)])
    return d - (fb.x0[p] - fb.x0[0])[axis]


def joint_angle(case, fbs, X, j: dict) -> np.ndarray:
    """Angle of the child frame from the input triad about the joint axis (continuous), rad."""
    A = xc.axis_frame(j["axis"])
    Rc = X[j["child"]]["R"].reshape(-1, 3, 3)
    n = Rc.shape[0]
    if j["parent"] == "ground":
        Rp = np.tile(np.eye(3), (n, 1, 1))
    else:
        Rp = X[j["parent"]]["R"].reshape(-1, 3, 3).copy()
        fb = fbs.get(j["parent"])
        if fb is not None:                                   # the triad turns with the node
            p = fb.node_at(j["at"] if not isinstance(j["at"], list) else j["at"][0])
            rot = X[j["parent"]]["eta"] @ fb.Phi[p, :3, :].T
            Rp = np.array([R @ xc.rotvec(w) for R, w in zip(Rp, rot)])
    Rin = Rp @ rotation_rpy(j["rpy"]) @ A
    Rrel = np.einsum("nji,njk->nik", Rin, Rc @ A)
    q = xc.angle_z(Rrel)
    q0 = list(j["q0"])[0]
    return q + 2.0 * np.pi * np.round((q0 - q[0]) / (2.0 * np.pi))


def energy(case, fbs, X) -> np.ndarray:
    """Kinetic + gravitational + strain energy from Exudyn's node positions and velocities.

    Flexible body: 1/2 sum m_p |v_p|^2 (+ 1/2 (w + Phi_r eta_d)' J_p (w + Phi_r eta_d), rotary
    inertia, body axes) - g . sum m_p r_p + 1/2 eta' Km eta. Rigid body: from its node's velocity,
    angular velocity and pose."""
    g = np.asarray(case["gravity"], dtype=float)
    E = 0.0
    for name, Xb in X.items():
        if name in fbs:
            fb = fbs[name]
            for k in range(fb.n_nodes):
                E = E + 0.5 * fb.m[k] * np.einsum("ni,ni->n", Xb["u"][k], Xb["u"][k]) - fb.m[k] * Xb["r"][k] @ g
            wr = Xb["w"][:, None, :] + np.einsum("kij,nj->nki", fb.Phi[:, :3, :], Xb["eta_d"])   # (n, N, 3)
            E = E + 0.5 * np.einsum("nki,kij,nkj->n", wr, fb.J, wr)
            E = E + 0.5 * np.einsum("ni,ij,nj->n", Xb["eta"], fb.Km, Xb["eta"])
        else:
            b = case["bodies"][name]
            R = Xb["R"].reshape(-1, 3, 3)
            com = np.asarray(b["com"], dtype=float)
            xx, yy, zz, xy, xz, yz = b["inertia"]
            Ic = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
            w = Xb["w"]
            vc = Xb["v"] + np.cross(np.einsum("nij,nj->ni", R, w), R @ com)
            E = E + 0.5 * b["mass"] * np.einsum("ni,ni->n", vc, vc) + 0.5 * np.einsum("ni,ij,nj->n", w, Ic, w)
            E = E - b["mass"] * (Xb["p"] + R @ com) @ g
    return E


# ---------------------------------------------------------------------------------------------
# the solver


def build(case, fbs: dict, rotary: bool, gravity_mode: str = "nodal"):
    """(SystemContainer, mbs, items by body name, sensors) of the case."""
    from flexmbd.build import topological_order
    SC, mbs = xc.system()
    order = topological_order(case)
    states = initial_states(case, order, fbs)
    items = {"ground": mbs.AddObject(eii.ObjectGround())}
    for name in order:
        body = case["bodies"][name]
        R, p, v, w = states[name]
        if name in fbs:
            items[name] = add_ffrf(mbs, fbs[name], ffrf_interface(fbs[name], rotary), R, p, v, w, fbs[name].Cm)
        elif body["type"] == "rigid":
            items[name] = add_rigid(mbs, body, R, p, v, w)
        else:                                    # a beam declared rigid: its undeformed mass properties
            rb = rigid_beam(name, body, case)
            items[name] = add_rigid(mbs, rb, R, p, v, w)
    for jn, j in case["joints"].items():
        add_joint(mbs, items, case, fbs, jn, j)
    add_loads(mbs, items, case, fbs, states, gravity_mode)
    S = add_sensors(mbs, items, case, fbs)
    mbs.Assemble()
    return SC, mbs, items, S


def rigid_beam(name: str, body: dict, case) -> dict:
    """Mass, COM and inertia about the COM of a beam declared rigid (its lumped undeformed nodes)."""
    fb = flexbody.undeformed(name, body,
                        case["materials"][body["material"]])
    m = fb.m.sum()
    c = fb.m @ fb.x0 / m
    d = fb.x0 - c
    I = fb.J.sum(axis=0) + np.einsum("p,pk,pl->kl", fb.m, d, d) * -1 + np.eye(3) * np.einsum("p,pk,pk->", fb.m, d, d)
    return {"mass": m, "com": list(c), "inertia": [I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]}


def step_size(case, settings) -> float:
    """The fixed step (s), rounded so that it divides output_dt."""
    out_dt = case["integrator"]["output_dt"]
    dt = settings.get("dt", SETTINGS["dt"][1])
    return out_dt / max(int(round(out_dt / dt)), 1) if dt <= out_dt else dt


def options(settings) -> dict:
    return {k: settings.get(k, d) for k, (_, d) in SETTINGS.items()}


def run(case, t_end, settings):
    from flexmbd.results import Result
    opt = options(settings)
    t_start = time.perf_counter()
    fbs = flexbody.for_case(case)
    dt = step_size(case, opt)
    with xc.quiet():
        SC, mbs, items, S = build(case, fbs, opt["rotary_inertia"], opt["gravity"])
    sim = xc.simulation_settings(case, t_end, dt, opt)
    setup_s = time.perf_counter() - t_start

    status, wall_s, steps, newton = xc.solve(mbs, sim, opt["solver"])
    t = xc.output_grid(case, t_end)
    recorded = {"dt": dt, **{k: opt[k] for k in ("solver", "spectral_radius", "newton_rtol", "adaptive",
                                                 "rotary_inertia", "gravity")},
                "node_type": str(NODE_TYPE), "linear_solver": "EigenSparse",
                "modes": {n: {"count": fb.n_modes, "boundary": fb.boundary} for n, fb in fbs.items()}}
    r = Result(solver="exudyn-ffrf", case=case.name, status=status, wall_s=wall_s, setup_s=setup_s,
               steps=steps, rhs_evals=newton, settings=recorded, solver_version=version(),
               extra={"newton_iterations": newton})
    first = next(iter(S.values()))["p"]
    n = xc.reached(r, t, xc.completed(mbs, first, t), t_end)
    if n == 0:
        return r
    X = read_sensors(mbs, S, t[:n])
    r.t, r.channels = t[:n], channels(case, fbs, X, t[:n])
    return r
