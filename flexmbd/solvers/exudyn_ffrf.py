"""`exudyn-ffrf`: every flexible beam or solid as an Exudyn `ObjectFFRFreducedOrder` fed the identical
reduced body flexmbd reads; rigid bodies as `ObjectRigidBody`, point masses as `ObjectMassPoint`;
Exudyn's implicit solver.

The reduced body goes in through Exudyn's own `ObjectFFRFreducedOrderInterface`, built from a
small FEM stand-in that hands it the FlexBody's node positions x0 (N, 3), the lumped node masses
m (N,) as a diagonal translational mass matrix (3N, 3N), and the translational mode rows Phi_t
as the mode basis (3N, nm); the interface computes Exudyn's FFRF invariants from them. Modal
stiffness and damping are the FlexBody's Km, Cm. Exudyn's object has no rotary node inertia;
with `rotary_inertia = true` (default) the FlexBody's J_p are added where the object's data
allows: sum J_p to the reference inertia, sum Phi_r^T J_p Phi_r to the modal mass (so the modal
mass is the identity the modes were normalised to) and sum J_p Phi_r to the rotation-mode
coupling. What stays out is the gyroscopic term w x (sum J_p Phi_r) eta_d, zero in planar motion.

A flexible solid (`SOLIDS`; docs/exudyn.md, Solids) goes in as the same FlexBody (its interfaces'
reference points, node 0 the frame's, then the mesh's nodes; the same modes, Km and Cm) with the
mesh's consistent mass Ms (x) I3 in place of the lumped one (`solid_mass`: zero rows for the
interface nodes, Ms the mesh's: `flexbody.solid_matrices`), so Exudyn's invariants are flexmbd's
(`invariants.mass_sums`); one massless node at the centre of mass is appended (`mass_centre`) to
carry gravity. Joints at the frame interface are joints at the reference node; at another
interface a spherical joint or a load acts on that interface's reference node (its mode rows are
the rigid fit of its node set, exact for a rigid one), any other joint there is not applicable, as is a
cut joint on a solid in a planar case (it holds x and y only; a solid's modes leave the plane). Channels:
the interfaces' positions from Exudyn's nodes, the stresses from the modal coordinates and the
FlexBody's modal stresses (`channels.modal_solid`), the kinetic energy with Ms.

Joints (body frame = the FFRF reference node, which is the beam's root node):
  parent ground / rigid body / the reference node of a beam: `ObjectJointGeneric` between rigid
    markers, all six axes or the joint's free ones (revolute: rotation about the axis,
    prismatic: translation along it, spherical: the three rotations, free: no joint);
  parent a flexible node: `MarkerSuperElementPosition` on that node; the joint can only hold its
    position (Exudyn's rigid super-element marker needs non-collinear nodes, a beam's are
    collinear), so spherical joints are exact, and revolute joints about z are exact in a planar
    case (the moments about x and y they would carry are zero there);
  a fixed joint on a flexible node (a tip mass): an `ObjectJointGeneric` with all six axes held
    from a `MarkerSuperElementRigid` on four massless nodes appended around the node (`anchors`,
    `anchor_rows`: they move with it rigidly, theta x d for its elastic rotation theta = Phi_r
    eta), whose position is the node's and whose rotation is exactly the node's elastic rotation,
    as flexmbd's joint on the node takes it; other joints: not applicable;
  a point mass's fixed joint (`add_point_joint`): an `ObjectJointSpherical` from the point where
    it sits (a position marker: on a flexible node `MarkerSuperElementPosition`, exact, as the
    mass point has no rotation to hold) to its `NodePoint`.
Prescribed joint motion: the generic joint's offset user function, a symbolic one that Exudyn
evaluates in C++ (a table profile: a Python function). Loads: `LoadForceVector` on
the node's super-element marker; gravity: M g on the centre node (`add_loads`).

Closed loops (`case.loops`): each cut joint is an `ObjectJointSpherical` between position
markers at its two points (on a flexible beam `MarkerSuperElementPosition` on the node, which
follows the node's elastic translation), holding the points together in the components that are
not the tree's already (`held_axes`): in a planar case x and y (z and the rotations out of the
plane are held by the tree's joints; a cut revolute about z transmits nothing else, so it is
exact there, and the node's elastic rotation, about z, is the joint's free one), in a spatial case
x, y and z (a spherical cut joint only). The start closes the loops (`assembled`): the tree
joints that `closing_joints` names take the positions (Newton on the gap between the two points)
and rates (the gap's rate zero) of the undeformed mechanism, a prescribed joint its profile's
rate, every other joint the case's values. The reaction is the joint's `Force` (global, on marker
0, the parent side) turned round and taken into the child's body frame; its moment is zero. A
loop needs numerical damping or index-2 constraints: the default scheme, the trapezoidal rule
with index-3 constraints, is refused there (`refused`).

The trajectory (`flexmbd.harness.channels`) is measured from Exudyn's sensors: node positions of the
super element (global, taken into the body frame with the reference node's pose; formed after the
run from the frame's and the modal coordinates' sensors by Exudyn's own mesh-node kinematics,
`node_kinematics`, as are the node velocities and accelerations), the modal coordinates (the root node's rotation and the section strains, through the FlexBody's modes and
modal strains); the triad of a joint on a flexible node turns with the node's elastic
rotation Phi_r eta (Exudyn's modal coordinates). A beam with a stress channel and no axial
mode gets flexmbd's quasi-static axial strain N(x) / (E A) (docs/formulation.md §7) from
Exudyn's results: every node's global acceleration a_p (`node_kinematics`), taken with
gravity g into the body frame, -m_p R^T (a_p - g); the point loads on the beam at their nodes
with their profiles; the force each child joint exerts on its node (a spherical joint's
`Force`, global; a generic joint's `ForceLocal`, in its marker 0's frame; both on marker 0,
the parent side), and a cut joint's on its node on either side. Accelerations and joint forces
are read as means over the steps around each output instant (`step_mean`): sampled raw they
carry a part alternating from step to step.
Exudyn stores every sensor at those steps (`write_around_outputs`), so no Python runs per step:
the means are formed after the run.

The system's natural frequencies (`system_frequencies`): this model at its initial state, every
prescribed joint held, by Exudyn's own eigenvalue solver on the constrained system
(`exudyn_common.system_frequencies`).
"""

from __future__ import annotations

import time
from dataclasses import replace
from types import MappingProxyType

import numpy as np
import scipy.sparse as sp

from flexmbd import cases
from flexmbd.harness import channels, cost, results
from flexmbd.fe import flexbody
from flexmbd.mbd import invariants, profiles
from flexmbd.solvers import exudyn_common as xc
from flexmbd.solvers.exudyn_common import eii, exu
from flexmbd.cases import closure

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

LOOPS = True                             # closed loops: cut joints as Exudyn joints (module docstring)
SOLIDS = True                            # flexible solids: the FlexBody with the mesh's consistent mass (docstring)
STYLE = {"color": "#ff7f0e", "marker": "^"}     # on the figures (report.figures.looks), solid lines
INDEX2 = ("fox-goodwin", "trapezoidal-index2")   # the schemes with velocity-level (index-2) constraints
NODE_TYPE = exu.NodeType.RotationEulerParameters
CONSTRAINED = {"fixed": [1, 1, 1, 1, 1, 1], "revolute": [1, 1, 1, 1, 1, 0],
               "prismatic": [1, 1, 0, 1, 1, 1], "spherical": [1, 1, 1, 0, 0, 0]}


def version() -> str:
    return xc.version()


def applies(case) -> str:
    frames = [b.name for b in case.bodies.values() if b.type == "solid" and b.is_frame]
    if frames:
        return (f"body {frames[0]!r} is a frame (bar elements): Exudyn's ObjectFFRFreducedOrder holds three position "
                f"coordinates a mesh node, and a frame's nodes also rotate")
    none = [b.name for b in case.bodies.values() if b.type in ("beam", "solid") and not b.rigid and b.modes.count == 0]
    if none:
        return (f"body {none[0]!r} retains no modes (modes.count = 0): an FFRF body needs at least one; "
                f"its rigid limit is what flexmbd, pinocchio and mujoco model")
    if case.segments:
        name = next(iter(case.segments))
        return (f"body {name!r} is split into segments: exudyn-ffrf models unsplit beams only (a split beam's "
                f"channels are measured on the whole beam, which it does not assemble from the segments)")
    planar = xc.is_planar(case)
    for jn, j in case.joints.items():
        parent = case.bodies.get(j.parent)
        if parent is None or parent.type == "rigid" or parent.rigid or j.type == "free":
            continue
        if j.node == 0 and (parent.type == "solid" or parent.modes.boundary == "clamped-free"):
            continue                         # the root node (a solid's: its frame interface) is the frame
        if j.motion is not None:
            return f"joint {jn!r}: prescribed motion on a flexible node"
        if parent.type == "solid" and j.type != "spherical":
            return (f"joint {jn!r}: a {j.type} joint at interface {j.point.x!r} of solid {j.parent!r} (not its "
                    f"frame's) needs the interface's rotation, which Exudyn's super-element marker on its reference "
                    f"node does not give (its position only: spherical joints)")
        if j.type == "spherical" or (j.type == "revolute" and not planar) or j.type == "fixed":
            continue
        if j.type == "revolute":
            return (f"joint {jn!r}: a revolute joint on a flexible node holds only the node's position "
                    f"in Exudyn (a beam's nodes are collinear: no rigid super-element marker), exact "
                    f"only in planar cases, and this one is not ({planar})")
        return (f"joint {jn!r}: a {j.type} joint on a flexible node is not modelled (a fixed one is, from the "
                f"node's rigid anchor marker; a spherical one, and a revolute one about z in a planar case, "
                f"hold the node's position)")
    return cuts_apply(case, planar)


def stages(case, t_end, settings) -> list:
    """The costly stages of a run (`cost.stages`): the FE modes of its bodies, and Exudyn's reduced
    bodies stepped, steps x the dense modal blocks (modes^2), with progress shown."""
    m2 = sum((m + 7) ** 2 for _, _, m, _ in cost.beams(case))
    out_dt, dt = case.integrator.output_dt, settings["dt"]
    dt = out_dt / max(round(out_dt / dt), 1) if dt <= out_dt else dt
    steps = t_end / dt
    return cost.modes(case) + [cost.Stage(f"stepping the reduced bodies through {steps:.3g} steps",
                                          cost.time_key(case, t_end, "solvers.exudyn-ffrf.dt", settings["dt"], 2.5e-5),
                                          memory=0.0, seconds=steps * (5e-5 + 4e-7 * m2), progress=True)]


def cuts_apply(case, planar: str) -> str:
    """'' when every cut joint can be modelled (module docstring), else why not: a spherical one
    (in the plane in a planar case), a revolute one about z in a planar case; the tree's joints
    must be able to close the loops (`closing_joints`, here with each beam's joints at their
    node's undeformed place, `offset`)."""
    for jn, j in case.loops.items():
        on = [b for b in (j.parent, j.child) if b in case.bodies and case.bodies[b].type == "solid"]
        if on and not planar:
            return (f"loop joint {jn!r}: in a planar case a cut joint holds its points in x and y only (the tree "
                    f"holds the rest), but the modes of solid {on[0]!r} can move its point out of the plane")
        out = cut_off_plane(j)
        if j.type == "revolute" and (planar or out):
            return (f"loop joint {jn!r}: a cut revolute joint is Exudyn's spherical joint between its two "
                    f"points (a beam's nodes are collinear: no rigid super-element marker), exact only in "
                    f"planar cases with its axis along z, and this one is not ({planar or out})")
        if j.type == "spherical" and out and not planar:
            return f"loop joint {jn!r}: a planar case's cut spherical joint must lie in its plane ({out})"
        if j.type not in ("revolute", "spherical"):
            return (f"loop joint {jn!r}: a cut {j.type} joint is not modelled: loops are closed by Exudyn's "
                    f"spherical joint between two points (a beam's nodes are collinear: no rigid super-element "
                    f"marker gives a node's rotation), which makes spherical and planar revolute cut joints only")
    held = len(held_axes(case)) * len(case.loops)
    names = closing_joints(case, {}) if held else []
    if len(names) < held:
        return (f"loop joint {next(iter(case.loops))!r}: the tree joints without prescribed motion move the "
                f"loops' gaps in {len(names)} of their {held} held components: they cannot close them")
    return ""


def cut_off_plane(j: cases.Joint) -> str:
    """'' when cut joint j lies in the x-y plane (its points, and a revolute's axis along z),
    else why not."""
    if any(abs(a) > 0 for a in j.rpy):
        return "it has a tilted triad (rpy)"
    if abs(j.offset[2]) > 0 or abs(j.child_offset[2]) > 0:
        return "it sits out of the x-y plane"
    if j.type == "revolute" and (abs(j.axis[0]) > 0 or abs(j.axis[1]) > 0):
        return "its axis is not along z"
    return ""


# ---------------------------------------------------------------------------------------------
# the reduced body as Exudyn's FFRF data


class _FEM:
    """The FlexBody seen through the few FEMinterface calls ObjectFFRFreducedOrderInterface makes;
    `mass` (3N, 3N) its mass matrix (default: the lumped node masses, a beam's). One node is
    appended, after the FlexBody's N: its centre of mass (`mass_centre`), no mass. Then, per node of
    `anchors`, the four massless nodes of its rigid marker (`anchor_rows`). The massless nodes add
    exact zeros to the invariants Exudyn's interface forms."""

    def __init__(self, fb: flexbody.FlexBody, mass: sp.spmatrix | None = None, anchors=()):
        self.x0 = np.asarray(fb.x0, dtype=float)
        self.modeBasis = {"matrix": translational_modes(fb)}
        self.postProcessingModes = {}
        self.mass = sp.diags(np.repeat(fb.m, 3)).tocsr() if mass is None else sp.csr_matrix(mass)
        c, Pc = mass_centre(fb)
        self.x0 = np.vstack([self.x0, c])
        self.modeBasis["matrix"] = np.vstack([self.modeBasis["matrix"], Pc])
        self.mass = sp.block_diag([self.mass, sp.csr_matrix((3, 3))], format="csr")
        for k in anchors:
            x, P = anchor_rows(fb, k)
            self.x0 = np.vstack([self.x0, x])
            self.modeBasis["matrix"] = np.vstack([self.modeBasis["matrix"], P])
            self.mass = sp.block_diag([self.mass, sp.csr_matrix((3 * len(x), 3 * len(x)))], format="csr")

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


def mass_centre(fb: flexbody.FlexBody) -> tuple:
    """(x0_c (3,), Phi_c (3, nm)) the body's centre of mass as a node of the super element: the
    m-weighted mean of its nodes, sum m_p x0_p / M and sum m_p Phi_t,p / M (m_p = sum_q Ms_pq for a
    solid, some negative at a quadratic mesh's corners). A force on it is the same as m_p / M of the
    force on every node: gravity (`add_loads`) through one node instead of all of a beam's or a
    solid's (the solve evaluates a load's marker at every Newton iteration)."""
    w = np.asarray(fb.m, dtype=float) / fb.m.sum()
    return w @ fb.x0, np.einsum("p,pik->ik", w, fb.Phi[:, 3:, :])


# a node's rigid marker: four massless nodes around it at +-ANCHOR_ARM of the beam's length along
# the body frame's y and z axes (`anchor_rows`)
ANCHOR_ARM = 0.05
ANCHOR_DIRECTIONS = np.array([[0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])


def anchor_rows(fb: flexbody.FlexBody, k: int) -> tuple:
    """(x0 (4, 3), Phi (12, nm)) four nodes rigidly attached to node k (the `ANCHOR_DIRECTIONS`
    arms d of length ANCHOR_ARM L): x0_k + d and the rigid fit of the node's motion, Phi_t,k -
    skew(d) Phi_r,k (a small rotation theta moves the point by theta x d). A beam's nodes lie on
    a line, so Exudyn's rigid super-element marker (which takes the position and rotation of a
    node set) cannot use them; on these four, centred on node k, its position is node k's and its
    linearised rotation (the weighted sum of d x u over the nodes, W^-1 times it) is exactly
    Phi_r,k eta, the node's elastic rotation, as flexmbd's joints on a node take it."""
    d = ANCHOR_ARM * fb.length * ANCHOR_DIRECTIONS
    Pt, Pr = fb.Phi[k, 3:, :], fb.Phi[k, :3, :]
    rows = [Pt - np.cross(a, Pr, axisa=0, axisb=0, axisc=0) for a in d]
    return fb.x0[k] + d, np.vstack(rows)


def anchor_nodes(fb: flexbody.FlexBody, centre: bool, anchors) -> dict:
    """Node k of `anchors` -> the super element's node numbers of its four `anchor_rows` nodes
    (after the FlexBody's N nodes and, with `centre`, its centre node (`_FEM`), in the order of
    `anchors`)."""
    first = fb.n_nodes + int(centre)
    return {k: list(range(first + 4 * i, first + 4 * i + 4)) for i, k in enumerate(anchors)}


def anchors(case, name: str, fbs: dict) -> list:
    """The nodes of flexible body `name` that need a rigid marker: where a fixed joint sits on it
    other than its root (the reference node is the frame's own rigid marker), but for a point mass
    (its joint holds a position only, `add_point_joint`)."""
    return sorted({j.node for j in case.joints.values() if j.parent == name and j.type == "fixed"
                   and not on_root(j, fbs) and case.bodies[j.child].type != "point_mass"})


def ffrf_interface(fb: flexbody.FlexBody, rotary: bool, mass: sp.spmatrix | None = None,
                   anchored=()) -> ObjectFFRFreducedOrderInterface:
    """Exudyn's FFRF invariants of the body; modal stiffness Km; rotary inertia added when asked.
    `mass`: a solid's consistent mass matrix (`solid_mass`), from which Exudyn's interface forms
    every invariant itself (a solid has no rotary inertia: `rotary` is not used). `anchored`: the
    nodes that get a rigid marker's four massless nodes (`anchor_rows`)."""
    cms = ObjectFFRFreducedOrderInterface(_FEM(fb, mass, anchored), rigidBodyNodeType=NODE_TYPE,
                                          roundMassMatrix=0.0, roundStiffnessMatrix=0.0)
    cms.stiffnessMatrixReduced = np.array(fb.Km, dtype=float)
    if rotary and mass is None:
        inv = invariants.invariants(fb)
        cms.massMatrixReduced = np.array(inv.I9[0])                     # sum Phi_r'J Phi_r + m Phi_t'Phi_t
        cms.inertiaLocal = cms.inertiaLocal + fb.J.sum(axis=0)          # sum J_p
        cms.mXRefTildePsi = cms.mXRefTildePsi - inv.I10[0]              # Mrf = G'(I6 + I10)
    return cms


def solid_mass(body, fb: flexbody.FlexBody) -> sp.csr_matrix:
    """(3N, 3N) the consistent mass M = Ms (x) I3 of solid `body` (`cases.Solid`) over the N nodes of
    its FlexBody fb: zero rows and columns for its interfaces' reference points (nodes 0..k-1, no
    mass), then the mesh's nodes, Ms the mesh's scalar consistent mass (`flexbody.solid_matrices`)."""
    return sp.kron(padded_scalar_mass(body, fb), sp.identity(3), format="csr")


def padded_scalar_mass(body, fb: flexbody.FlexBody) -> sp.csr_matrix:
    """(N, N) the scalar consistent mass of solid `body` over its FlexBody's N nodes (`solid_mass`)."""
    Ms = flexbody.solid_matrices(body)[1]
    k = fb.n_nodes - Ms.shape[0]
    return sp.block_diag([sp.csr_matrix((k, k)), Ms], format="csr")


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


def add_rigid(mbs, body: cases.Rigid, R, p, v, w) -> dict:
    """An ObjectRigidBody whose node sits at the body frame origin (COM offset in the object)."""
    com = np.asarray(body.com, dtype=float)
    xx, yy, zz, xy, xz, yz = body.inertia
    Ic = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    Io = Ic + body.mass * (com @ com * np.eye(3) - np.outer(com, com))   # about the origin
    node = GetRigidBodyNode(nodeType=NODE_TYPE, position=list(p), velocity=list(v),
                            rotationMatrix=R, angularVelocity=list(w))
    n = mbs.AddNode(node)
    obj = mbs.AddObject(eii.ObjectRigidBody(
        nodeNumber=n, mass=body.mass, centerOfMass=list(com),
        inertia=[Io[0, 0], Io[1, 1], Io[2, 2], Io[1, 2], Io[0, 2], Io[0, 1]],
        visualization=eii.VObjectRigidBody(show=False)))
    return {"node": n, "obj": obj}


def add_point(mbs, body: cases.PointMass, p, v) -> dict:
    """A point mass at p (3,) moving with velocity v (3,), global: Exudyn's mass point."""
    n = mbs.AddNode(eii.NodePoint(referenceCoordinates=list(p), initialVelocities=list(v),
                                  visualization=eii.VNodePoint(show=False)))
    obj = mbs.AddObject(eii.ObjectMassPoint(nodeNumber=n, mass=body.mass,
                                            visualization=eii.VObjectMassPoint(show=False)))
    return {"node": n, "obj": obj}


# ---------------------------------------------------------------------------------------------
# the tree: initial poses, joints, loads


def joint_offset(j: cases.Joint):
    """(rotation (3, 3), translation (3,)) of the child frame in the input triad at q0."""
    A = xc.axis_frame(j.axis)
    q0 = list(j.q0)
    if j.type == "revolute":
        return xc.rotvec(A[:, 2] * q0[0]), np.zeros(3)
    if j.type == "prismatic":
        return np.eye(3), A[:, 2] * q0[0]
    if j.type == "spherical":
        return xc.rotvec(q0[:3]), np.zeros(3)
    if j.type == "free":
        return xc.rotvec(q0[:3]), np.asarray(q0[3:6], dtype=float)
    return np.eye(3), np.zeros(3)


def joint_rate(j: cases.Joint):
    """(angular (3,), linear (3,)) velocity of the child relative to the triad at t = 0, triad axes."""
    A = xc.axis_frame(j.axis)
    qd = list(j.qd0)
    if j.type == "revolute":
        return A[:, 2] * qd[0], np.zeros(3)
    if j.type == "prismatic":
        return np.zeros(3), A[:, 2] * qd[0]
    if j.type == "spherical":
        return np.asarray(qd[:3], dtype=float), np.zeros(3)
    if j.type == "free":
        return np.asarray(qd[:3], dtype=float), np.asarray(qd[3:6], dtype=float)
    return np.zeros(3), np.zeros(3)


def triad_point(j: cases.Joint, fbs: dict) -> np.ndarray:
    """Undeformed input-triad position (3,) in the parent frame (a beam: its snapped node, a
    flexible one's from the FlexBody's node positions)."""
    if j.parent in fbs:
        return fbs[j.parent].x0[j.node].copy()
    return np.array(j.offset, dtype=float)


def initial_states(case, order: list, fbs: dict) -> dict:
    """Global (R, p, v, w) of every body frame at t = 0 (undeformed, elastic velocities zero)."""
    out = {"ground": (np.eye(3), np.zeros(3), np.zeros(3), np.zeros(3))}
    for name in order:
        j = case.joint_of(name)
        Rp, pp, vp, wp = out[j.parent]
        Rt = Rp @ np.array(j.triad)
        pt = pp + Rp @ triad_point(j, fbs)
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


def on_root(j: cases.Joint, fbs) -> bool:
    """True when joint j's input triad is the reference node of a clamped-root beam."""
    fb = fbs.get(j.parent)
    return fb is not None and j.node == 0 and not np.any(fb.Phi[0])


def add_joint(mbs, items, case, fbs, j: cases.Joint):
    """The joint to the parent (see the module docstring for how each kind is realised).

    Returns (object, frame) of the joint object that carries the force onto the parent: frame
    None for a spherical joint (Exudyn's `Force`: global), else the rotation (3, 3) of its
    marker 0 in the parent's body frame (Exudyn's `ForceLocal` is in that marker's frame); None
    for a free joint. Either is the force the joint exerts on marker 0, the parent side."""
    if j.type == "free":
        return None
    if case.bodies[j.child].type == "point_mass":
        return add_point_joint(mbs, items, fbs, j)
    child = j.child
    A = xc.axis_frame(j.axis)
    if j.parent in fbs and not on_root(j, fbs) and j.type != "fixed":     # on a flexible node
        m0 = mbs.AddMarker(eii.MarkerSuperElementPosition(bodyNumber=items[j.parent]["obj"],
                                                          meshNodeNumbers=[j.node], weightingFactors=[1.0]))
        it = items[child]
        m1 = (mbs.AddMarker(eii.MarkerNodePosition(nodeNumber=it["node"])) if child in fbs
              else mbs.AddMarker(eii.MarkerBodyPosition(bodyNumber=it["obj"], localPosition=[0, 0, 0])))
        sph = mbs.AddObject(eii.ObjectJointSpherical(markerNumbers=[m0, m1],
                                                     visualization=eii.VObjectJointSpherical(show=False)))
        if j.type == "revolute":
            # planar case: the node's triad keeps its z axis along global z, so the child's does too
            mg = mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=items["ground"], localPosition=[0, 0, 0]))
            mc = (mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=it["node"])) if child in fbs
                  else mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=it["obj"], localPosition=[0, 0, 0])))
            mbs.AddObject(eii.ObjectJointGeneric(markerNumbers=[mg, mc], constrainedAxes=[0, 0, 0, 1, 1, 0],
                                                 visualization=eii.VObjectJointGeneric(show=False)))
        return sph, None
    # parent side: the input triad turned onto the axis (z of the joint frame is the axis)
    R0 = np.array(j.triad) @ A
    if j.parent in fbs and not on_root(j, fbs):          # a fixed joint on a flexible node: its anchor
        m0 = mbs.AddMarker(eii.MarkerSuperElementRigid(
            bodyNumber=items[j.parent]["obj"], meshNodeNumbers=items[j.parent]["anchors"][j.node],
            weightingFactors=[0.25] * 4, localHT=exu.HT(rotation=R0, translation=np.zeros(3)),
            visualization=eii.VMarkerSuperElementRigid(show=False)))
    else:
        m0 = body_marker_rigid(mbs, items, j.parent, case, fbs, triad_point(j, fbs), R0)

    # child side: the same joint frame at q0, in the child frame (coincident when driven)
    Rq, tq = joint_offset(j)
    driven = j.motion is not None
    m1 = body_marker_rigid(mbs, items, child, case, fbs, -Rq.T @ tq if driven else np.zeros(3), Rq.T @ A)
    kw = motion_offset(mbs, j) if driven else {}
    axes = [1] * 6 if driven else CONSTRAINED[j.type]
    obj = mbs.AddObject(eii.ObjectJointGeneric(markerNumbers=[m0, m1], constrainedAxes=axes,
                                               visualization=eii.VObjectJointGeneric(show=False), **kw))
    return obj, R0


def add_point_joint(mbs, items, fbs, j: cases.Joint):
    """A point mass's fixed joint: Exudyn's spherical joint from the point where it sits on its
    parent (`cut_marker`: on a flexible beam its node, following the node's elastic translation)
    to the mass point, which has no rotation to hold. Returns (joint, None): its `Force` is global."""
    m0 = cut_marker(mbs, items, fbs, j.parent, j.node, triad_point(j, fbs))
    m1 = mbs.AddMarker(eii.MarkerNodePosition(nodeNumber=items[j.child]["node"]))
    return mbs.AddObject(eii.ObjectJointSpherical(markerNumbers=[m0, m1],
                                                  visualization=eii.VObjectJointSpherical(show=False))), None


def motion_offset(mbs, j: cases.Joint) -> dict:
    """Offset user function of a generic joint driving a 1-DOF joint along its profile.

    The child marker carries the q0 offset, so the joint offset is q(t) - q0 about (along) z. It
    is a symbolic user function, evaluated by Exudyn itself (`xc.motion_expr`), except for a table
    profile, which stays a Python function."""
    q0 = j.q0[0]
    k = 5 if j.type == "revolute" else 2
    prof = j.motion
    motion = xc.motion_expr if prof["type"] in xc.SYMBOLIC else profiles.motion

    def offset(mbs, t, itemNumber, params):
        o = [0.0] * 6
        o[k] = motion(prof, t, q0)[0] - q0
        return o
    if motion is profiles.motion:
        return {"offsetUserFunction": offset}
    return {"offsetUserFunction": xc.symbolic(mbs, offset, "offsetUserFunction", "ObjectJointGeneric")}


def add_loads(mbs, items, case, fbs, states, gravity_mode: str = "nodal") -> None:
    """Point loads (with their time profiles) and gravity.

    Gravity on a flexible body: `nodal` (default) puts m_p g on every node as M g on its centre
    node (`mass_centre`), the mass-weighted mean of the nodes (its Jacobian is the mass-weighted sum
    of the node Jacobians, so this is exact; on a solid m_p = sum_q Ms_pq, its consistent gravity
    load): one node for the solve to evaluate at every Newton iteration, not N (pendulum: 0.6 of its
    solve time less). `mass-proportional` uses Exudyn's LoadMassProportional, which on an
    ObjectFFRFreducedOrder takes the moment of gravity about the reference frame from the
    undeformed centre of mass only (the deflection's lever arm is lost)."""
    for ld in case.loads.values():
        name = ld.body
        it = items[name]
        if name in fbs:
            m = mbs.AddMarker(eii.MarkerSuperElementPosition(bodyNumber=it["obj"], meshNodeNumbers=[ld.point.node],
                                                             weightingFactors=[1.0]))
        elif case.bodies[name].type == "rigid":
            m = mbs.AddMarker(eii.MarkerBodyPosition(bodyNumber=it["obj"], localPosition=list(ld.offset)))
        else:
            raise ValueError(f"load on beam {name!r} declared rigid: not supported by exudyn-ffrf")
        f = np.asarray(ld.force, dtype=float)
        prof, body_frame, node = ld.profile, ld.frame == "body", it["node"]
        steady = prof["type"] == "constant" or (prof["type"] == "step" and prof["t0"] <= 0.0)
        fixed_frame = xc.fixed_to_ground(case, name)
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
    g = np.asarray(case.gravity, dtype=float)
    if np.any(g):
        for name, it in items.items():
            if name == "ground":
                continue
            if name in fbs and gravity_mode == "nodal":
                # M g at the mass-weighted mean of the deformed nodes, the centre node (`mass_centre`)
                # = m_p g at every node (a solid: its consistent load, sum_q Ms_pq g)
                fb = fbs[name]
                m = mbs.AddMarker(eii.MarkerSuperElementPosition(bodyNumber=it["obj"], meshNodeNumbers=[fb.n_nodes],
                                                                 weightingFactors=[1.0]))
                mbs.AddLoad(eii.LoadForceVector(markerNumber=m, loadVector=list(fb.m.sum() * g)))
                continue
            m = mbs.AddMarker(eii.MarkerBodyMass(bodyNumber=it["obj"]))
            mbs.AddLoad(eii.LoadMassProportional(markerNumber=m, loadVector=list(g)))


# ---------------------------------------------------------------------------------------------
# closed loops: the start that closes them, the cut joints

CLOSED = 1e-13                           # m: the gap Newton leaves at the start (`assembled`)


def held_axes(case) -> list:
    """The global components of the gap between a cut joint's two points that the joint holds:
    x, y in a planar case (the tree holds the rest), x, y, z otherwise."""
    return [0, 1] if not xc.is_planar(case) else [0, 1, 2]


def closing_joints(case, fbs: dict) -> list:
    """Names of the tree joints whose coordinates the loops fix at the start (`assembled`), as
    every solver chooses them (`flexmbd.cases.closure`, docs/formulation.md §11): of the
    one-coordinate tree joints without prescribed motion, from the last in the tree backwards,
    each that adds to the rank of the gaps' Jacobian (`gap_jacobian`) at the case's values."""
    names = closure.dependent(case)
    return closure.pick(gap_jacobian(case, fbs, names), names)


def cut_point(j: cases.Joint, fbs: dict) -> np.ndarray:
    """Undeformed position (3,) of cut joint j's point on its child, child frame (a flexible
    beam: its node's, from the FlexBody)."""
    if j.child in fbs:
        return fbs[j.child].x0[j.child_point.node].copy()
    return np.array(j.child_offset, dtype=float)


def gaps_at_start(case, fbs: dict) -> tuple:
    """(gap (m,), its rate (m,)) of every cut joint at the start (`initial_states`, undeformed):
    the child point's position and velocity less the parent point's, global, the `held_axes`
    components, loop after loop."""
    states, axes = initial_states(case, case.order, fbs), held_axes(case)

    def point(body, x):
        R, p, v, w = states[body]
        r = R @ x
        return p + r, v + np.cross(w, r)
    gap, rate = [], []
    for j in case.loops.values():
        (pa, va), (pc, vc) = point(j.parent, triad_point(j, fbs)), point(j.child, cut_point(j, fbs))
        gap.append((pc - pa)[axes])
        rate.append((vc - va)[axes])
    return np.concatenate(gap), np.concatenate(rate)


def gap_jacobian(case, fbs: dict, names: list) -> np.ndarray:
    """(m, k) derivative of the gaps (`gaps_at_start`) by the coordinates of the one-coordinate
    joints `names`: exact, as the gaps' rate is linear in the joint rates, column k the rate a
    unit rate of joint k adds."""
    def rate_with(jn):
        j = case.joints[jn]
        return gaps_at_start(with_values(case, {jn: (j.q0[0], j.qd0[0] + 1.0)}), fbs)[1]
    rate = gaps_at_start(case, fbs)[1]
    return np.array([rate_with(jn) - rate for jn in names]).reshape(len(names), rate.size).T


def with_values(case, values: dict):
    """The resolved case with the (q0, qd0) of the one-coordinate joints in `values` (name ->
    (q, qd)) replaced."""
    base = getattr(case, "resolved", case)
    joints = {jn: replace(j, q0=(float(values[jn][0]),), qd0=(float(values[jn][1]),)) if jn in values else j
              for jn, j in base.joints.items()}
    return replace(base, joints=MappingProxyType(joints))


def assembled(case, fbs: dict):
    """The resolved case with the q0, qd0 of its tree joints closing every loop (the case itself
    when it has none): a prescribed joint starts at its profile's rate, the joints of
    `closing_joints` at the positions (Newton on the gaps, to CLOSED) and rates (the gaps' rate
    zero) that close the loops of the undeformed bodies, every other joint at the case's values.
    ValueError when Newton does not close them."""
    if not case.loops:
        return case
    start = with_values(case, {jn: (j.q0[0], profiles.motion(j.motion, 0.0, j.q0[0])[1])
                               for jn, j in case.joints.items() if j.motion is not None})
    names = closing_joints(start, fbs)
    q = np.array([start.joints[jn].q0[0] for jn in names])
    for _ in range(50):
        model = with_values(start, {jn: (x, 0.0) for jn, x in zip(names, q)})
        (gap, rate), J = gaps_at_start(model, fbs), gap_jacobian(model, fbs, names)
        if np.abs(gap).max() <= CLOSED:
            return with_values(model, {jn: (x, v) for jn, x, v in zip(names, q, np.linalg.lstsq(J, -rate)[0])})
        q = q - np.linalg.lstsq(J, gap)[0]
    raise ValueError(f"the loops do not close from the case's q0 (gap {np.abs(gap).max():.3g} m after 50 "
                     f"Newton steps on {', '.join(names)})")


def cut_marker(mbs, items: dict, fbs: dict, body: str, node: int, point) -> int:
    """A position marker on `body` (or ground) at `point` (3,), body frame; on a flexible beam on
    its node `node`, following the node's elastic translation."""
    if body in fbs:
        return mbs.AddMarker(eii.MarkerSuperElementPosition(bodyNumber=items[body]["obj"], meshNodeNumbers=[node],
                                                            weightingFactors=[1.0]))
    obj = items["ground"] if body == "ground" else items[body]["obj"]
    return mbs.AddMarker(eii.MarkerBodyPosition(bodyNumber=obj, localPosition=list(point)))


def add_cut(mbs, items: dict, case, fbs: dict, j: cases.Joint) -> dict:
    """Cut joint j: Exudyn's spherical joint from its parent point (marker 0) to its child point
    (marker 1), holding the `held_axes` components of their gap. Returns its sensors: "f" the
    joint's `Force` (global, on marker 0), "r" the positions (global) of its two points."""
    m0 = cut_marker(mbs, items, fbs, j.parent, j.node, triad_point(j, fbs))
    m1 = cut_marker(mbs, items, fbs, j.child, j.child_point.node if j.child_point else -1, cut_point(j, fbs))
    held = [int(k in held_axes(case)) for k in range(3)]
    obj = mbs.AddObject(eii.ObjectJointSpherical(markerNumbers=[m0, m1], constrainedAxes=held,
                                                 visualization=eii.VObjectJointSpherical(show=False)))
    sens = lambda **kw: mbs.AddSensor(eii.SensorMarker(writeToFile=False, storeInternal=True,
                                                       visualization=eii.VSensorMarker(show=False), **kw))
    OV = exu.OutputVariableType
    return {"f": mbs.AddSensor(eii.SensorObject(objectNumber=obj, outputVariableType=OV.Force, writeToFile=False,
                                                storeInternal=True, visualization=eii.VSensorObject(show=False))),
            "r": {0: sens(markerNumber=m0, outputVariableType=OV.Position),
                  1: sens(markerNumber=m1, outputVariableType=OV.Position)}}


# ---------------------------------------------------------------------------------------------
# sensors and channels


def axial_rules(case, fbs) -> dict:
    """Beam name -> where its quasi-static axial force enters (`channels.axial_rule`): this model
    has no geometric stiffening, so the axial load is always one of its validity measures. A
    solid: nowhere (its stresses are the modes' own, flexmbd's `inhouse.trajectory` likewise)."""
    return {n: (False, False) if case.bodies[n].type == "solid" else
            channels.axial_rule(False, bool(case.stress_sections(n)), fb) for n, fb in fbs.items()}


def summed_bodies(case, fbs) -> list:
    """Names of the flexible beams whose stress comes by force summation (`stress = "forces"` and a
    stress section: docs/formulation.md §7c)."""
    return [n for n in fbs if case.bodies[n].type == "beam" and case.bodies[n].stress == "forces"
            and case.stress_sections(n)]


def axial_bodies(case, fbs) -> list:
    """Names of the flexible beams whose node forces are needed (`axial_rules`, `summed_bodies`)."""
    summed = summed_bodies(case, fbs)
    return [n for n, rule in axial_rules(case, fbs).items() if any(rule) or n in summed]


def add_sensors(mbs, items, case, fbs, joints: dict) -> dict:
    """Sensors kept in memory: poses of every body (velocities too for the energy), modal
    coordinates (and their rates); for the beams of `axial_bodies` what their nodes' accelerations
    are formed from ("a": the frame's acceleration, global angular velocity and acceleration, the
    modal accelerations) and the force of each child joint (`joints`: add_joint's (object, frame) by
    joint name). The nodes' positions, velocities and accelerations are formed from these after the
    run (`node_kinematics`): a few sensors a body instead of three for each of its nodes."""
    S = {}
    sens = lambda **kw: mbs.AddSensor(eii.SensorNode(writeToFile=False, storeInternal=True,
                                                     visualization=eii.VSensorNode(show=False), **kw))
    obj = lambda **kw: mbs.AddSensor(eii.SensorObject(writeToFile=False, storeInternal=True,
                                                      visualization=eii.VSensorObject(show=False), **kw))
    axial = axial_bodies(case, fbs)
    energy = channels.wants_energy(case)
    OV = exu.OutputVariableType
    for name, it in items.items():
        if name == "ground":
            continue
        n = it["node"]
        if case.bodies[name].type == "point_mass":           # a mass point: no rotation
            S[name] = {"p": sens(nodeNumber=n, outputVariableType=OV.Position),
                       **({"v": sens(nodeNumber=n, outputVariableType=OV.Velocity)} if energy else {})}
            continue
        S[name] = {"p": sens(nodeNumber=n, outputVariableType=OV.Position),
                   "R": sens(nodeNumber=n, outputVariableType=OV.RotationMatrix)}
        if energy:
            S[name]["v"] = sens(nodeNumber=n, outputVariableType=OV.Velocity)
            S[name]["w"] = sens(nodeNumber=n, outputVariableType=OV.AngularVelocityLocal)
        if name in fbs:
            fb = fbs[name]
            S[name]["eta"] = sens(nodeNumber=it["modal"], outputVariableType=OV.Coordinates)
            if energy or name in axial:
                S[name]["eta_d"] = sens(nodeNumber=it["modal"], outputVariableType=OV.Coordinates_t)
            if name in axial:
                S[name]["a"] = {"a": sens(nodeNumber=n, outputVariableType=OV.Acceleration),
                                "omega": sens(nodeNumber=n, outputVariableType=OV.AngularVelocity),
                                "alpha": sens(nodeNumber=n, outputVariableType=OV.AngularAcceleration),
                                "eta_dd": sens(nodeNumber=it["modal"], outputVariableType=OV.Coordinates_tt)}
                S[name]["f"] = {jn: obj(objectNumber=jo[0], outputVariableType=OV.Force if jo[1] is None
                                        else OV.ForceLocal)
                                for jn, jo in joints.items() if jo is not None and case.joints[jn].parent == name}
                if name in summed_bodies(case, fbs):                # a generic joint's moment too (a spherical one has none)
                    S[name]["m"] = {jn: obj(objectNumber=jo[0], outputVariableType=OV.TorqueLocal)
                                    for jn, jo in joints.items()
                                    if jo is not None and jo[1] is not None and case.joints[jn].parent == name}
    return S


def tracked_nodes(case, name: str, fb: flexbody.FlexBody) -> list:
    """The nodes of body `name` whose positions the channels read (`channels.points_needed`): a
    beam's nearest to each position, a solid's interfaces' reference points."""
    body = case.bodies[name]
    node = body.node if body.type == "solid" else fb.node_at
    return sorted({node(x) for x in channels.points_needed(case, name)})


def step_sensors(S: dict) -> list:
    """The sensors of S whose stored rows give step means (`step_mean`): those the node
    accelerations are formed from, and the joint forces, the cut joints' too."""
    return ([x for Sb in S.values() for key in ("a", "f", "m") for x in Sb.get(key, {}).values()]
            + [c["f"] for Sb in S.values() for c in Sb.get("cut", {}).values()])


def write_around_outputs(mbs, sim, dt: float, out_dt: float) -> bool:
    """Have Exudyn store the sensors at the steps next to each output step as well as at it, for
    the step means (`step_mean`); False (nothing changed) when the step does not divide output_dt.

    Why step means: with index-3 constraints and no numerical damping, Exudyn's accelerations and
    joint forces of a constrained body carry a part that alternates in sign from step to step (it
    leaves the positions alone: the update uses a_n + a_n+1); sampled every output_dt / dt steps,
    always at the same parity, it would not average out (docs/exudyn.md).

    How: Exudyn writes all sensors on one schedule (`sim.solution.sensors.writePeriod`; the solver
    keeps the time of its next write as `output.lastSensorsWritten`). Up to output_dt = 3 dt every
    step is written. Beyond, a sensor user function moves that next write to the next step of the
    pattern k e - 1, k e, k e + 1 (`next_write`, e = output_dt / dt, k >= 1); Exudyn calls it only
    when it writes the sensors, three times per output step: no Python runs at the steps between.
    It reaches the solver as `SolveDynamic` stores it (mbs.sys["dynamicSolver"]). The system must
    be assembled after this call."""
    if dt > out_dt:
        return False
    every = int(round(out_dt / dt))
    if every <= 3:
        sim.solution.sensors.writePeriod = dt
        return True

    def schedule(mbs_, t, sensor_numbers, factors, configuration):
        n = next_write(int(round(t / dt)), every)
        mbs_.sys["dynamicSolver"].output.lastSensorsWritten = n * dt
        return [n * dt]                                   # its value (not stored): the next write's time
    mbs.AddSensor(eii.SensorUserFunction(sensorUserFunction=schedule, writeToFile=False, storeInternal=False))
    return True


def watch_divergence(mbs, S: dict, fbs: dict, case) -> None:
    """The divergence watch (`xc.watch`) on the flexible bodies with a deflection channel, from
    their modal coordinates alone (one sensor each): the points of the deflection channels in the
    body frame, x0_p + Phi_t,p eta, and the root rotation (`channels.modal_shape`), which are
    `trajectory`'s body-frame points to rounding (those come from Exudyn's global node positions
    and frame pose, p + R (x0_p + Phi_t,p eta)). A body whose points cannot reach its channels'
    bounds at a sample (`channels.modal_reach` below the smallest) is not judged there: most
    samples of most runs cost a few products, not the Beam the rule reads."""
    bound = channels.bounds(case)
    bodies = list(dict.fromkeys(c.body for n, c in case.channels.items() if n in bound and c.body in fbs))
    nodes = {b: watched_nodes(case, b, fbs[b]) for b in bodies}
    origin = {b: case.bodies[b].frame if case.bodies[b].type == "solid" else 0.0 for b in bodies}
    limit = {b: min(bound[n] for n, c in case.channels.items() if n in bound and c.body == b) for b in bodies}
    reach = {b: channels.modal_reach(fbs[b], nodes[b], origin[b]) for b in bodies}
    for b in bodies:                 # once before the solve's clock: numba loads the rotation's exponential
        channels.modal_shape(fbs[b], list(nodes[b]), np.zeros((1, fbs[b].n_modes)), nodes[b], origin[b])

    def beams(mbs_) -> dict:
        eta = {b: xc.values(mbs_, S[b]["eta"]) for b in bodies}
        return {b: channels.modal_shape(fbs[b], list(nodes[b]), eta[b], nodes[b], origin[b])
                for b in bodies if not reach[b](eta[b]) < limit[b]}
    if bodies:
        xc.watch(mbs, case, beams)


def watched_nodes(case, name: str, fb: flexbody.FlexBody) -> dict:
    """{x: node} of the points the deflection channels of body `name` read (`channels.deflection_points`):
    a beam's nearest nodes, a solid's interfaces' reference points (as `tracked_nodes`)."""
    body = case.bodies[name]
    node = body.node if body.type == "solid" else fb.node_at
    return {x: node(x) for x in channels.deflection_points(case, name)}


def next_write(n: int, every: int) -> int:
    """The step after step n at which the sensors are written: the steps k every - 1, k every and
    k every + 1 around each output step k every (k >= 1)."""
    m = n + 1
    if m >= every - 1 and m % every in (every - 1, 0, 1):
        return m
    return (m // every + 1) * every - 1


def step_mean(v: np.ndarray, d: np.ndarray, t: np.ndarray, dt: float) -> np.ndarray:
    """(n, k) sensor values v (n, k) sampled at the output steps t (n,) replaced by their step
    means, from the sensor's stored rows d (m, 1 + k) (`write_around_outputs`): at an output step
    i, (v_i-1 + 2 v_i + v_i+1) / 4 (which cancels a part alternating from step to step); at the
    last one (v_i-1 + v_i) / 2; at t = 0, Exudyn's consistent initial value."""
    steps, rows = np.round(d[:, 0] / dt).astype(np.int64), d[:, 1:]
    i = np.round(t / dt).astype(np.int64)

    def row(s):
        j = np.clip(np.searchsorted(steps, s), 0, steps.size - 1)
        return j, steps[j] == s
    (jm, hm), (j0, h0), (jp, hp) = row(i - 1), row(i), row(i + 1)
    out = v.copy()
    mid, last = hm & h0 & hp, hm & h0 & ~hp
    out[mid] = 0.25 * rows[jm[mid]] + 0.5 * rows[j0[mid]] + 0.25 * rows[jp[mid]]
    out[last] = 0.5 * (rows[jm[last]] + rows[j0[last]])
    return out


def node_kinematics(D: dict, fb: flexbody.FlexBody, nodes: list, kind: str) -> np.ndarray:
    """(m, K, 3) the global positions (kind "r"), velocities ("u") or accelerations ("a") of the K
    `nodes` of flexible body fb at m instants, from D: its sensors' rows at those instants (key -> (m, k): "p", "R" (m, 9), "eta", and "v", "w", "eta_d" for the
    velocities, "a" (the frame's "a", "omega", "alpha", "eta_dd") for the accelerations; `add_sensors`).
    Exudyn's own kinematics of a mesh node of ObjectFFRFreducedOrder, x = x0 + Phi_t eta in the
    body frame: r = p + R x, u = v + R (w x x + Phi_t eta_d) (w body axes), a = a_0 + R Phi_t eta_dd
    + 2 omega x R Phi_t eta_d + alpha x R x + omega x (omega x R x) (omega, alpha global), so the
    results are those of its node sensors to rounding."""
    Phi = translational_modes(fb).reshape(fb.n_nodes, 3, fb.n_modes)[nodes]          # (K, 3, nm)
    R = D["R"].reshape(-1, 3, 3)
    x = fb.x0[nodes][None] + np.einsum("kin,mn->mki", Phi, D["eta"])                 # (m, K, 3)
    if kind == "u":
        xd = np.einsum("kin,mn->mki", Phi, D["eta_d"])
        return D["v"][:, None, :] + np.einsum("mij,mkj->mki", R, np.cross(D["w"][:, None, :], x) + xd)
    Rx = np.einsum("mij,mkj->mki", R, x)
    if kind == "r":
        return D["p"][:, None, :] + Rx
    A = D["a"]
    Rxd = np.einsum("mij,mkj->mki", R, np.einsum("kin,mn->mki", Phi, D["eta_d"]))
    Rxdd = np.einsum("mij,mkj->mki", R, np.einsum("kin,mn->mki", Phi, A["eta_dd"]))
    om, al = A["omega"][:, None, :], A["alpha"][:, None, :]
    return A["a"][:, None, :] + Rxdd + 2.0 * np.cross(om, Rxd) + np.cross(al, Rx) + np.cross(om, np.cross(om, Rx))


def read_nodes(mbs, Sb: dict, fb: flexbody.FlexBody, wanted: dict, t: np.ndarray, dt: float,
               means: bool) -> dict:
    """{"r": {node: (n, 3)}, "u": ..., "a": ...} of flexible body fb on the output grid t (n,),
    global, for the nodes `wanted` names ({"r": nodes, ...}), from the stored rows of its sensors
    Sb (`node_kinematics`); the accelerations as step means with `means` (`step_mean`)."""
    rows = lambda x: {k: rows(v) for k, v in x.items()} if isinstance(x, dict) else xc.stored(mbs, x)
    D = {k: rows(Sb[k]) for k in ("p", "R", "eta", "v", "w", "eta_d", "a") if k in Sb and (k != "a" or "a" in wanted)}
    time = D["p"][:, 0]
    strip = lambda x: {k: strip(v) for k, v in x.items()} if isinstance(x, dict) else x[:, 1:]
    out = {}
    for kind, nodes in wanted.items():
        v = node_kinematics(strip(D), fb, list(nodes), kind)                   # (m, K, 3)
        d = np.column_stack([time, v.reshape(time.size, -1)])
        s = xc.series(d, t)
        s = step_mean(s, d, t, dt) if kind == "a" and means else s
        out[kind] = dict(zip(nodes, s.reshape(t.size, len(nodes), 3).transpose(1, 0, 2)))
    return out


def wanted_nodes(case, name: str, fb: flexbody.FlexBody) -> dict:
    """The nodes of flexible body `name` whose positions "r", velocities "u" and accelerations "a"
    the channels read: every node's positions and velocities for the energy, else the `tracked_nodes`'
    positions; every node's accelerations on a beam of `axial_bodies`."""
    energy = channels.wants_energy(case)
    out = {"r": list(range(fb.n_nodes)) if energy else tracked_nodes(case, name, fb)}
    if energy:
        out["u"] = list(range(fb.n_nodes))
    if name in axial_bodies(case, {name: fb}):
        out["a"] = list(range(fb.n_nodes))
    return out


def read_sensors(mbs, S: dict, t: np.ndarray) -> dict:
    """Every sensor resampled on t (n,): the same nesting as S with arrays in place of sensors."""
    def rd(x):
        if isinstance(x, dict):
            return {k: rd(v) for k, v in x.items()}
        return xc.sensor_series(mbs, x, t)
    return rd(S)


def trajectory(case, fbs: dict, X: dict, t: np.ndarray, joints: dict) -> channels.Trajectory:
    """The channels' view of the sensor data X (see read_sensors): every body's pose (its node's,
    at the body frame's origin), node positions in the body frame, the root node's rotation from
    the modal coordinates, the modal beam
    (`channels.modal_beam`) with, on the beams of `axial_bodies`, the quasi-static axial force
    from `node_forces` (`joints`: add_joint's (object, frame) by joint name), and the cut joints'
    reactions (`cut_forces`). A solid: `channels.modal_solid` of the modal coordinates (its
    stresses and validity measure) with its interfaces' points from Exudyn's node positions."""
    traj = channels.Trajectory(t=t)
    for jname in channels.joints_needed(case):
        traj.joints[jname] = joint_coordinate(fbs, X, case.joints[jname])
    if channels.wants_energy(case):
        traj.energy = {"total": energy(case, fbs, X)}
    cuts = cut_forces(case, X)
    traj.reactions = {jn: reaction(f, X[case.loops[jn].child]["R"]) for jn, f in cuts.items()}
    traj.poses = {name: point_pose(case, fbs, X, name) if case.bodies[name].type == "point_mass" else
                  (X[name]["R"].reshape(-1, 3, 3), X[name]["p"]) for name in case.bodies}   # node: body frame
    rules, summed = axial_rules(case, fbs), summed_bodies(case, fbs)
    for name, fb in fbs.items():
        Xb, xs = X[name], channels.points_needed(case, name)
        body = case.bodies[name]
        if body.type == "solid":                 # flexmbd's modal solid, its points Exudyn's nodes
            beam = channels.modal_solid(fb, body, xs, case.stress_sections(name), Xb["eta"])
            beam.points = {x: body_positions(Xb, body.node(x)) for x in xs}
            traj.beams[name] = beam
            continue
        F = node_forces(case, fb, name, Xb, t, joints, cuts) if any(rules[name]) or name in summed else None
        traj.beams[name] = channels.modal_beam(
            fb, Xb["eta"], body.material, body.geometry,
            {x: body_positions(Xb, fb.node_at(x)) for x in xs}, {x: fb.x0[fb.node_at(x)] for x in xs},
            channels.modal_root(fb, Xb["eta"]), F, rules[name],
            summed_strains(case, fb, name, Xb, F, joints) if name in summed else None)
    return traj


def point_pose(case, fbs: dict, X: dict, name: str) -> tuple:
    """(R (n, 3, 3), p (n, 3)) of point mass `name`: its mass point's position, turned as the triad
    of its fixed joint on its parent (on a flexible node with the node's elastic rotation Phi_r eta)."""
    j, p = case.joint_of(name), X[name]["p"]
    R = np.broadcast_to(np.eye(3), (len(p), 3, 3)) if j.parent == "ground" else X[j.parent]["R"].reshape(-1, 3, 3)
    if j.parent in fbs:
        R = R @ np.array([xc.rotvec(w) for w in X[j.parent]["eta"] @ fbs[j.parent].Phi[j.node, :3, :].T])
    return R @ np.array(j.triad), p


def node_forces(case, fb, name: str, Xb: dict, t: np.ndarray, joints: dict, cuts: dict) -> np.ndarray:
    """(n, N, 3) net force on each node of beam `name`, body frame (`channels.node_forces`):
    from Exudyn's global node accelerations a_p (less gravity), the point loads on the beam, the
    forces its child joints exert on their nodes and those of the cut joints on either side
    (`cuts`: `cut_forces`)."""
    R = Xb["R"].reshape(-1, 3, 3)                                          # body frame -> global
    g = np.asarray(case.gravity, dtype=float)
    a = np.stack([Xb["a"][k] for k in range(fb.n_nodes)], axis=1) - g     # (n, N, 3) global
    loads = [(ld.point.node, load_force(ld, t, R)) for ld in case.loads.values() if ld.body == name]
    forces = [(case.joints[jn].node, joint_force(f, joints[jn][1], R)) for jn, f in Xb.get("f", {}).items()]
    for jn, f in cuts.items():
        j = case.loops[jn]
        forces += [(j.node, joint_force(-f, None, R))] if j.parent == name else []
        forces += [(j.child_point.node, joint_force(f, None, R))] if j.child == name else []
    return channels.node_forces(fb.m, np.einsum("nji,npj->npi", R, a), loads, forces)


def summed_strains(case, fb, name: str, Xb: dict, F: np.ndarray, joints: dict) -> dict:
    """{x: (n, 4)} section strains of beam `name` at its stress sections by force summation
    (docs/formulation.md §7c), from the node forces F (`node_forces`: Exudyn's node accelerations,
    loads, joint forces) and, as node moments, its generic joints' moments on their parent nodes:
    Exudyn's `TorqueLocal`, turned as the forces are, with the opposite sign to its `ForceLocal`
    (checked on a cantilever whose tip mass hangs 0.1 m beyond its mount: with it, force summation
    agrees with 30 modes' mode displacement to 1.2 % RMS, as flexmbd's does; with the other sign,
    9 %: tests/solvers/test_stress_recovery.py). The nodes' rotary inertia is left out
    (Exudyn's node sensors give no node angular acceleration): on a beam its moments are of order
    (h / L)^2 of the translational ones, 2.5e-5 on the paper's pendulum."""
    R = Xb["R"].reshape(-1, 3, 3)
    r = fb.x0 + flexbody.modal_field(fb.Phi[:, 3:, :], Xb["eta"])
    T = np.zeros_like(F)
    for jn, m in Xb.get("m", {}).items():
        T[:, case.joints[jn].node] -= joint_force(m, joints[jn][1], R)
    body = case.bodies[name]
    return channels.summed_strains(fb, r, F, T, body.material, body.geometry)


def cut_forces(case, X: dict) -> dict:
    """Cut joint name -> (n, 3) force it transmits from its parent point onto its child point,
    global: its spherical joint's `Force` (on marker 0, the parent point) turned round."""
    return {jn: -X[j.child]["cut"][jn]["f"] for jn, j in case.loops.items()}


def reaction(f: np.ndarray, R: np.ndarray) -> np.ndarray:
    """(n, 6) [moment; force] of a cut joint in its child's body frame (R (n, 9): body -> global)
    from its force f (n, 3), global; the moment about the joint point is zero (a spherical joint,
    and a planar revolute one's moments out of the plane are the tree's)."""
    return np.hstack([np.zeros_like(f), np.einsum("nji,nj->ni", R.reshape(-1, 3, 3), f)])


def gaps(case, X: dict) -> dict:
    """Cut joint name -> (n,) distance between its two points, m: the closure residual."""
    return {jn: np.linalg.norm(X[j.child]["cut"][jn]["r"][1] - X[j.child]["cut"][jn]["r"][0], axis=1)
            for jn, j in case.loops.items()}


def load_force(ld: cases.Load, t: np.ndarray, R: np.ndarray) -> np.ndarray:
    """(n, 3) point load `ld` at the instants t (n,), body frame (R (n, 3, 3): body -> global)."""
    f = profiles.load_factor(ld.profile, t)[:, None] * np.asarray(ld.force, dtype=float)
    return f if ld.frame == "body" else np.einsum("nji,nj->ni", R, f)


def joint_force(f: np.ndarray, R0, R: np.ndarray) -> np.ndarray:
    """(n, 3) force a joint exerts on its parent node, body frame, from Exudyn's joint force f
    (n, 3) on marker 0: global (R0 None, a spherical joint's `Force`) or in marker 0's frame (R0
    (3, 3) its rotation in the body frame, a generic joint's `ForceLocal`). R (n, 3, 3): body -> global."""
    return np.einsum("nji,nj->ni", R, f) if R0 is None else f @ np.asarray(R0).T


def body_positions(Xb: dict, k: int) -> np.ndarray:
    """Node k's position (n, 3) in the body frame, from Exudyn's global node position and frame pose."""
    R = Xb["R"].reshape(-1, 3, 3)
    return np.einsum("nji,nj->ni", R, Xb["r"][k] - Xb["p"])


def joint_coordinate(fbs, X, j: cases.Joint) -> np.ndarray:
    """The coordinate (n,) of a 1-DOF joint: a revolute one's angle (rad), a prismatic one's slide (m)."""
    return joint_slide(fbs, X, j) if j.type == "prismatic" else joint_angle(fbs, X, j)


def joint_slide(fbs, X, j: cases.Joint) -> np.ndarray:
    """Displacement (n,) of the child frame's origin from the input triad along the axis, m
    (the parent a rigid body, ground or a clamped beam's root: the triad does not deform)."""
    pc = X[j.child]["p"]
    if j.parent == "ground":
        Rp, pp = np.tile(np.eye(3), (pc.shape[0], 1, 1)), np.zeros_like(pc)
    else:
        Rp, pp = X[j.parent]["R"].reshape(-1, 3, 3), X[j.parent]["p"]
    axis = np.array(j.triad) @ xc.axis_frame(j.axis)[:, 2]                # parent frame
    return np.einsum("nji,nj->ni", Rp, pc - pp) @ axis - triad_point(j, fbs) @ axis


def joint_angle(fbs, X, j: cases.Joint) -> np.ndarray:
    """Angle of the child frame from the input triad about the joint axis (continuous), rad."""
    A = xc.axis_frame(j.axis)
    Rc = X[j.child]["R"].reshape(-1, 3, 3)
    n = Rc.shape[0]
    if j.parent == "ground":
        Rp = np.tile(np.eye(3), (n, 1, 1))
    else:
        Rp = X[j.parent]["R"].reshape(-1, 3, 3).copy()
        fb = fbs.get(j.parent)
        if fb is not None:                                   # the triad turns with the node
            rot = X[j.parent]["eta"] @ fb.Phi[j.node, :3, :].T
            Rp = np.array([R @ xc.rotvec(w) for R, w in zip(Rp, rot)])
    Rin = Rp @ np.array(j.triad) @ A
    Rrel = np.einsum("nji,njk->nik", Rin, Rc @ A)
    q = xc.angle_z(Rrel)
    q0 = j.q0[0]
    return q + 2.0 * np.pi * np.round((q0 - q[0]) / (2.0 * np.pi))


def energy(case, fbs, X) -> np.ndarray:
    """Kinetic + gravitational + strain energy from Exudyn's node positions and velocities.

    Flexible body: 1/2 sum m_p |v_p|^2 (+ 1/2 (w + Phi_r eta_d)' J_p (w + Phi_r eta_d), rotary
    inertia, body axes) - g . sum m_p r_p + 1/2 eta' Km eta; a solid's kinetic energy with its
    consistent mass, 1/2 sum_pq Ms_pq v_p . v_q (its m_p = sum_q Ms_pq make the gravity term exact).
    Rigid body: from its node's velocity, angular velocity and pose; a point mass: 1/2 m |v|^2 - m g . p."""
    g = np.asarray(case.gravity, dtype=float)
    E = 0.0
    for name, Xb in X.items():
        if name in fbs:
            fb = fbs[name]
            if case.bodies[name].type == "solid":           # 1/2 u' (Ms (x) I3) u, u (N, 3) every instant
                U = np.stack([Xb["u"][k] for k in range(fb.n_nodes)])                         # (N, n, 3)
                MU = (padded_scalar_mass(case.bodies[name], fb) @ U.reshape(fb.n_nodes, -1)).reshape(U.shape)
                E = E + 0.5 * np.einsum("kni,kni->n", U, MU)
                for k in range(fb.n_nodes):
                    E = E - fb.m[k] * Xb["r"][k] @ g
            else:
                for k in range(fb.n_nodes):
                    E = E + 0.5 * fb.m[k] * np.einsum("ni,ni->n", Xb["u"][k], Xb["u"][k]) - fb.m[k] * Xb["r"][k] @ g
            wr = Xb["w"][:, None, :] + np.einsum("kij,nj->nki", fb.Phi[:, :3, :], Xb["eta_d"])   # (n, N, 3)
            E = E + 0.5 * np.einsum("nki,kij,nkj->n", wr, fb.J, wr)
            E = E + 0.5 * np.einsum("ni,ij,nj->n", Xb["eta"], fb.Km, Xb["eta"])
        elif case.bodies[name].type == "point_mass":
            m = case.bodies[name].mass
            E = E + 0.5 * m * np.einsum("ni,ni->n", Xb["v"], Xb["v"]) - m * Xb["p"] @ g
        else:                                   # a rigid body, or a beam declared rigid (`rigid_beam`)
            b = case.bodies[name]
            b = rigid_beam(b) if b.type == "beam" else b
            R = Xb["R"].reshape(-1, 3, 3)
            com = np.asarray(b.com, dtype=float)
            xx, yy, zz, xy, xz, yz = b.inertia
            Ic = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
            w = Xb["w"]
            vc = Xb["v"] + np.cross(np.einsum("nij,nj->ni", R, w), R @ com)
            E = E + 0.5 * b.mass * np.einsum("ni,ni->n", vc, vc) + 0.5 * np.einsum("ni,ij,nj->n", w, Ic, w)
            E = E - b.mass * (Xb["p"] + R @ com) @ g
    return E


# ---------------------------------------------------------------------------------------------
# the solver


def build(case, fbs: dict, rotary: bool, gravity_mode: str = "nodal"):
    """(SystemContainer, mbs, items by body name, sensors, joints) of the case, not yet assembled;
    the sensors of a cut joint (`add_cut`) under "cut" of its child's. The tree starts at the
    case's q0, qd0: `assembled` first when the case has loops."""
    SC, mbs = xc.system()
    order = case.order
    states = initial_states(case, order, fbs)
    items = {"ground": mbs.AddObject(eii.ObjectGround())}
    for name in order:
        body = case.bodies[name]
        R, p, v, w = states[name]
        if name in fbs:
            mass = solid_mass(body, fbs[name]) if body.type == "solid" else None
            nodes = anchors(case, name, fbs)
            items[name] = add_ffrf(mbs, fbs[name], ffrf_interface(fbs[name], rotary, mass, nodes), R, p, v, w,
                                   fbs[name].Cm)
            items[name]["anchors"] = anchor_nodes(fbs[name], True, nodes)
        elif body.type == "rigid":
            items[name] = add_rigid(mbs, body, R, p, v, w)
        elif body.type == "point_mass":
            items[name] = add_point(mbs, body, p, v)
        else:                                    # a beam declared rigid: its undeformed mass properties
            items[name] = add_rigid(mbs, rigid_beam(body), R, p, v, w)
    joints = {jn: add_joint(mbs, items, case, fbs, j) for jn, j in case.joints.items()}
    add_loads(mbs, items, case, fbs, states, gravity_mode)
    S = add_sensors(mbs, items, case, fbs, joints)
    for jn, j in case.loops.items():
        S[j.child].setdefault("cut", {})[jn] = add_cut(mbs, items, case, fbs, j)
    return SC, mbs, items, S, joints


def rigid_beam(body: cases.Beam) -> cases.Rigid:
    """A beam declared rigid as a rigid body: mass, COM and inertia about the COM of its lumped
    undeformed nodes."""
    fb = flexbody.undeformed(body.name, body)
    m = fb.m.sum()
    c = fb.m @ fb.x0 / m
    d = fb.x0 - c
    I = fb.J.sum(axis=0) + np.einsum("p,pk,pl->kl", fb.m, d, d) * -1 + np.eye(3) * np.einsum("p,pk,pk->", fb.m, d, d)
    return cases.Rigid(name=body.name, mass=m, com=tuple(c),
                       inertia=(I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]))


def step_size(case, settings) -> float:
    """The fixed step (s), rounded so that it divides output_dt."""
    out_dt = case.integrator.output_dt
    dt = settings.get("dt", SETTINGS["dt"][1])
    return out_dt / max(int(round(out_dt / dt)), 1) if dt <= out_dt else dt


def options(settings) -> dict:
    return {k: settings.get(k, d) for k, (_, d) in SETTINGS.items()}


def refused(case, opt: dict) -> str:
    """'' when the scheme of `opt` can run the case, else why not: an index-2 scheme cannot drive
    a joint, and the trapezoidal rule with index-3 constraints (generalized-alpha at spectral
    radius 1) is unstable on a closed loop: the part of the constraint forces that alternates
    from step to step grows (four_bar_swing_rigid: to 1.6 kN by t = 0.4 s, Newton fails at 0.90 s;
    at spectral radius 0.99 it stays below 0.8 N, at 0.9 below 0.08 N, the force up to 72 N)."""
    driven = [jn for jn, j in case.joints.items() if j.motion is not None]
    if opt["solver"] in INDEX2 and driven:
        return (f"{opt['solver']} holds its constraints at velocity level, where Exudyn's generic joint takes "
                f"no prescribed rate (its offsetUserFunction_t is not implemented there): joint {driven[0]!r} "
                f"would stand still; use generalized-alpha")
    if case.loops and opt["solver"] == "generalized-alpha" and opt["spectral_radius"] >= 1.0:
        return (f"generalized-alpha at spectral radius 1 (the trapezoidal rule, index-3 constraints) is unstable "
                f"on the loop closed by joint {next(iter(case.loops))!r}: the step-to-step alternating part of "
                f"its constraint forces grows without bound; use spectral_radius < 1 (0.9) or, without a "
                f"driven joint, fox-goodwin")
    return ""


def run(case, t_end, settings):
    opt = options(settings)
    why = refused(case, opt)
    if why:
        return results.Result(solver="exudyn-ffrf", case=case.name, solver_version=version(), settings=dict(opt),
                              status=results.failed(why, 0.0))
    t_start = time.perf_counter()
    fbs = flexbody.for_case(case)
    model = assembled(case, fbs)
    dt = step_size(case, opt)
    sim = xc.simulation_settings(case, t_end, dt, opt)
    xc.reach(sim, xc.output_grid(case, t_end)[-1], dt)
    with xc.quiet():
        SC, mbs, items, S, joints = build(model, fbs, opt["rotary_inertia"], opt["gravity"])
        means = bool(step_sensors(S)) and write_around_outputs(mbs, sim, dt, case.integrator.output_dt)
        watch_divergence(mbs, S, fbs, model)
        mbs.Assemble()
    setup_s = time.perf_counter() - t_start

    status, wall_s, steps, newton = xc.solve(mbs, sim, opt["solver"], f"{case.name} / exudyn-ffrf")
    t = xc.output_grid(case, t_end)
    recorded = {"dt": dt, **{k: opt[k] for k in ("solver", "spectral_radius", "newton_rtol", "adaptive",
                                                 "rotary_inertia", "gravity")},
                "node_type": str(NODE_TYPE), "linear_solver": "EigenSparse",
                "modes": {n: {"count": fb.n_modes, "boundary": fb.boundary} for n, fb in fbs.items()}}
    r = results.Result(solver="exudyn-ffrf", case=case.name, status=status, wall_s=wall_s, setup_s=setup_s,
               steps=steps, rhs_evals=newton, settings=recorded, solver_version=version(),
               extra={"newton_iterations": newton})
    xc.stopped(r, mbs)
    first = next(iter(S.values()))["p"]
    n = xc.reached(r, t, xc.completed(mbs, first, t), t_end)
    if n == 0:
        return r
    X = read_sensors(mbs, S, t[:n])
    for b, fb in fbs.items():
        X[b].update(read_nodes(mbs, S[b], fb, wanted_nodes(model, b, fb), t[:n], dt, means))
    if means:
        for Xb, Sb in ((X[b], S[b]) for b in axial_bodies(case, fbs)):
            for key in ("f", "m"):
                Xb[key] = {k: step_mean(Xb[key][k], xc.stored(mbs, x), t[:n], dt) for k, x in Sb.get(key, {}).items()}
        for Xb, Sb in ((X[b], S[b]) for b in S if "cut" in S[b]):
            for jn, c in Sb["cut"].items():
                Xb["cut"][jn]["f"] = step_mean(Xb["cut"][jn]["f"], xc.stored(mbs, c["f"]), t[:n], dt)
    r.t, r.trajectory = t[:n], trajectory(model, fbs, X, t[:n], joints)
    if case.loops:
        r.extra["loop_gap_m"] = {jn: float(g.max()) for jn, g in gaps(case, X).items()}
    return r


# ---------------------------------------------------------------------------------------------
# the system's natural frequencies


def system_frequencies(case, count: int) -> np.ndarray:
    """The lowest `count` nonzero natural frequencies (count,) of the case's mechanism, Hz,
    ascending: this model (`build`: the case's reduced bodies, flexmbd's FlexBody modes, with the
    `rotary_inertia` setting) at the initial state, the loops closed (`assembled`) and every joint
    of prescribed motion held at its initial value (a lock of its coordinate: the driven joint's
    generic joint, all six axes held, its offset zero), linearized by Exudyn's own eigenvalue
    solver on the constrained system (`xc.frequencies`: undamped, the zero eigenvalues of
    rigid-body motion dropped, within `xc.ZERO` of the largest; the planar mechanism's redundant
    out-of-plane constraints dropped from the null-space projection, `xc.SINGULAR`). Its
    frequencies are those of the retained modes. InputError (one line, naming the case file) for a
    case this model cannot take (`applies`), one loaded at t = 0 (`xc.loaded`: Exudyn's
    eigenvalue solver sees no stiffness from loads), one whose initial state moves (`xc.at_rest`),
    or one Exudyn refuses (the loops not closing among them)."""
    opt = options(cases.check_table(dict(case.solvers.get("exudyn-ffrf", {})), SETTINGS, str(case.path),
                                    "solvers.exudyn-ffrf."))
    fbs = flexbody.for_case(case)

    def model(fixed):
        SC, mbs, *_ = build(assembled(fixed, fbs), fbs, opt["rotary_inertia"], opt["gravity"])
        mbs.Assemble()
        return SC, mbs
    return xc.system_frequencies(case, count, "exudyn-ffrf", applies, model)
