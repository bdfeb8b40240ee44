"""`exudyn-beam`: the beams of a planar case as chains of Exudyn's geometrically exact 2-D beam
elements (`ObjectBeamGeometricallyExact2D`, Simo-Reissner: axial, shear and bending strains of
the large-rotation kinematics), full nonlinear FE in the role LS-Dyna plays in the paper.

Every flexible beam: `elements` equal elements (setting, default 64) on `NodeRigidBody2D` nodes
(x, y, rotation), E A, k G A (k = 5/6 rectangle, 9/10 circle), E I of the bending plane x-y,
rho A per length, rho I cross-section rotary inertia. A rigid body, and a beam declared rigid, is
one `ObjectRigidBody2D` on a `NodeRigidBody2D` at its centre of mass: mass, com and the inertia
Izz about the com as the case gives them (a rigid body) or as `common.beam_inertia` computes them
(a beam declared rigid; setting `beam_mass`: "lumped", the default, is flexmbd's beam declared
rigid, "prism" the rigid peers' default). A point mass is Exudyn's `ObjectMassPoint2D` on a
`NodePoint2D` (x, y: no rotation, so nothing to hold but its position). Every body frame starts
where the case's tree puts it, undeformed, moving rigidly with the joint rates.

Joints (planar only), each between the two points it joins: on ground or a rigid body the point
where the joint sits (a `MarkerBodyPosition`), on a flexible beam the node of this mesh nearest
to it (`mesh_node`; a child's root node). A revolute joint about z is `ObjectJointRevolute2D` (a
pin: the two positions coincide); a fixed joint adds a `CoordinateConstraint` that holds the
child's rotation coordinate equal to the rotation where it sits (`rotation_marker`: zero on
ground, a beam node's, a rigid body's), so a rigid body fixed to a beam's node (a tip mass)
turns with the node's cross-section; a point mass's fixed joint is the pin alone; a prismatic
joint in the plane is `ObjectJointPrismatic2D` (rotations equal, the child's origin on the axis
line). A revolute joint to ground with
prescribed motion (the hub of a spin-up or slewing beam, a driven crank) is the same pin plus a
`CoordinateConstraint` that holds the child node's rotation on the profile: its offset user
functions are `profiles.motion` (angle and rate), so the child turns exactly as flexmbd's joint
does; written as Exudyn symbolic user functions (`exudyn_common.motion_expr`), Exudyn evaluates
them in C++ (a table profile stays a Python function). Point loads are `LoadForceVector` on their
node of this mesh, or at their point of a rigid body (a body-frame load turns with the root node
or the rigid body); gravity is `LoadMassProportional` on every element and m g at every rigid
body's com.

Closed loops (`LOOPS`): a cut joint (revolute) is one more `ObjectJointRevolute2D` between its
two points (on a beam, its node, following the node's elastic motion). The mechanism starts
closed: the tree joints' coordinates are the case's (a driven joint's from its profile), except
two per loop (`dependent`: the loop's last two joints in file order that are neither driven nor
fixed), which Newton's method on the closure of the undeformed bodies fixes, and their rates,
which the closure's velocity equations fix (`close_loops`); every body starts undeformed, moving
with that rigid-body velocity field.

The trajectory (`flexmbd.harness.channels`) from Exudyn's nodes and elements (docs/formulation.md §7):
  deflection   clamped-root body: node displacement in the root node's frame (the cross-section
               frame: it differs from the tangent by the shear angle, ~1e-6 rad here) minus the
               undeformed offset; hinged-hinged body: signed distance from the chord through the
               end nodes, in the chord frame; zero on a rigid body;
  joint_angle  revolute: child body frame angle (root node rotation, or chord angle for a
               hinged-hinged body, or the rigid body's rotation) minus the input triad's (ground:
               0; a beam: the rotation of its node; a rigid body: its rotation); prismatic: the
               child's origin along the axis from the joint's point, m;
  stress_vm    from eps and kappa taken at the element centres (where the constant-strain
               element is most accurate) and interpolated linearly to the stress section;
  energy       Exudyn's kinetic and strain energies of the elements plus -g . (rho A l (r1 + r2) / 2);
               a rigid body's m v^2 / 2 + J w^2 / 2 - m g . r_com, a point mass's m v^2 / 2 - m g . r;
  reaction_*   of a revolute or fixed joint: the force its pin exerts on the child (minus
               Exudyn's joint force, which acts on the parent's marker) in the child's body frame
               (a cut joint's: the frame at its child point, the node's on a beam; a point mass's:
               its parent's triad); the moment about z, minus the force of the rotation constraint of
               a fixed or driven joint (the drive torque), else 0 (a pin, a point mass's joint). A
               prismatic joint's are not reported (Exudyn's reports none).
The largest closure mismatch of the cut joints over the run is `extra["loop_closure_m"]`.
Time integration: Exudyn's implicit solver, fixed steps of exactly dt up to the last output
instant (`exudyn_common.reach`).

The system's natural frequencies (`system_frequencies`): this model at its initial state, every
prescribed joint held, by Exudyn's own eigenvalue solver on the constrained system
(`exudyn_common.system_frequencies`).
"""

from __future__ import annotations

import time

import numpy as np

from flexmbd import cases
from flexmbd.harness import channels, cost, results
from flexmbd.fe import flexbody
from flexmbd.mbd import profiles
from flexmbd.solvers import common
from flexmbd.solvers import exudyn_common as xc
from flexmbd.solvers.exudyn_common import eii, exu

SETTINGS = {
    "elements": ("int+", 64),                # per flexible beam
    "dt": ("float+", 1e-4),                  # s, fixed step (rounded to divide output_dt)
    "solver": (tuple(xc.IMPLICIT), "generalized-alpha"),
    "spectral_radius": ("float0+", 0.9),
    "newton_rtol": ("float+", 1e-5),
    "newton_atol": ("float+", None),         # N, absolute residual tolerance; None: `newton_atol`
    "adaptive": ("bool", False),
    "beam_mass": (common.BEAM_MASS, "lumped"),   # a beam declared rigid (`common.beam_inertia`)
}

DRIVEN_NEWTON_ATOL = 1e-5                    # N: the rotating beams' absolute Newton tolerance (cases/spinup_beam.toml)


def newton_atol(case, opt: dict) -> float:
    """The absolute Newton tolerance (N): the case's, else DRIVEN_NEWTON_ATOL on a case with a
    driven joint (below it a beam on a spun hub stops in step reduction at once: the residual of
    its stiff axial coordinates does not fall below newton_rtol / 100), else newton_rtol / 100."""
    if opt["newton_atol"] is not None:
        return opt["newton_atol"]
    driven = any(j.motion is not None for j in case.joints.values())
    return DRIVEN_NEWTON_ATOL if driven else opt["newton_rtol"] * 1e-2


LOOPS = True                                 # closes kinematic loops (cut joints: `close_loops`)
STYLE = {"color": "#2ca02c", "marker": "v"}     # on the figures (report.figures.looks), solid lines

OV = exu.OutputVariableType
CLOSURE_TOL = 1e-12                          # m: the initial loop closure's Newton tolerance


def version() -> str:
    return xc.version()


def applies(case) -> str:
    why = xc.is_planar(case)
    if why:
        return f"planar beam model only (3-D beams are not built yet): {why}"
    for name, b in case.bodies.items():
        if flexible(b) and b.damping_ratio > 0:
            return (f"body {name!r}: modal damping has no counterpart in the beam elements (material damping, "
                    f"stiffness_damping, has)")
    for jn, j in case.joints.items():
        if j.type not in ("revolute", "fixed", "prismatic"):
            return f"joint {jn!r}: only revolute (pin), prismatic and fixed joints"
        if j.motion is not None and (j.type != "revolute" or j.parent != "ground"):
            return f"joint {jn!r}: prescribed motion only on a revolute joint to ground"
    for jn, j in case.loops.items():
        if j.type != "revolute":
            return f"loop joint {jn!r}: only revolute (pin) loop joints"
        if any(abs(x) > 0 for x in (*j.axis[:2], *j.rpy, j.offset[2], j.child_offset[2])):
            return f"loop joint {jn!r}: not a pin about z in the x-y plane"
        if len(free_joints(case, j)) < 2:
            return f"loop joint {jn!r}: its loop has fewer than two joints that are not driven or fixed"
    for cname, c in case.channels.items():
        if out_of_plane(c):
            return f"channel {cname!r}: out-of-plane component in a planar model"
    return ""


def stages(case, t_end, settings) -> list:
    """The costly stages of a run (`cost.stages`): Exudyn's beam elements, steps x elements
    (sparse Newton iterations), with progress shown."""
    n_beams = sum(1 for b in case.bodies.values() if b.type == "beam")
    el, out_dt, dt = settings["elements"] * n_beams, case.integrator.output_dt, settings["dt"]
    dt = out_dt / max(round(out_dt / dt), 1) if dt <= out_dt else dt
    steps = t_end / dt
    key = "solvers.exudyn-beam.elements" if el > 10000 else cost.time_key(case, t_end, "solvers.exudyn-beam.dt",
                                                                            settings["dt"], 1e-4)
    return [cost.Stage(f"stepping {el} beam elements through {steps:.3g} steps", key,
                       memory=8.0 * 6 * (el + n_beams) * 300, seconds=steps * (2e-5 + 2e-6 * el), progress=True)]


def out_of_plane(c: cases.Channel) -> bool:
    """A channel component the planar model has not: a moment about x or y, any other z."""
    return c.component != "z" if c.kind == "reaction_moment" else c.component == "z"


def flexible(body) -> bool:
    """A beam not declared rigid: a chain of beam elements here (else one rigid body)."""
    return body.type == "beam" and not body.rigid


def section_constants(body: cases.Beam) -> dict:
    """Element constants of a case beam (bending in x-y: I = Iz of the FE section)."""
    sec, mat = body.geometry, body.material
    E, G, rho = mat.E, mat.G, mat.rho
    k = 0.9 if body.section.shape == "circle" else 5.0 / 6.0
    beta = body.stiffness_damping                       # material damping: each section force beta times its rate's stiffness
    return {"massPerLength": rho * sec.A, "crossSectionInertia": rho * sec.Iz,
            "bendingStiffness": E * sec.Iz, "axialStiffness": E * sec.A, "shearStiffness": k * G * sec.A,
            "bendingDamping": beta * E * sec.Iz, "axialDamping": beta * E * sec.A, "shearDamping": beta * k * G * sec.A,
            "E": E, "cy": sec.cy, "Iz": sec.Iz, "A": sec.A}


# ---------------------------------------------------------------------------------------------
# the initial state: the tree at the case's coordinates, its loops closed


def start(j: cases.Joint) -> tuple:
    """(q, qd) of a tree joint at t = 0 as the case gives it: its profile's for prescribed motion,
    else (q0, qd0); (0, 0) for a fixed joint."""
    if j.type == "fixed":
        return 0.0, 0.0
    q0 = float(j.q0[0])
    if j.motion is None:
        return q0, float(j.qd0[0])
    q, qd, _ = profiles.motion(j.motion, 0.0, q0)
    return q, qd


def site(case, n_el: dict, body: str, point, offset) -> tuple[int, np.ndarray]:
    """(node, local (2,)): where a joint sits on `body` in this model. On a flexible beam the
    node of this mesh nearest to point.x (the root node when point is None) and its undeformed
    position (x_k, 0) in the body frame, m; on ground or a rigid body -1 and offset[:2]."""
    b = case.bodies.get(body)
    if b is None or not flexible(b):
        return -1, np.asarray(offset[:2], dtype=float)
    k = mesh_node(b, n_el[body], point.x) if point is not None else 0
    return k, np.array([k * b.length / n_el[body], 0.0])


def parent_site(case, n_el: dict, j: cases.Joint) -> tuple[int, np.ndarray]:
    return site(case, n_el, j.parent, j.point, j.offset)


def child_site(case, n_el: dict, j: cases.Joint) -> tuple[int, np.ndarray]:
    """A tree joint's child side is the child frame's origin; a cut joint's `child_at`."""
    return site(case, n_el, j.child, j.child_point, j.child_offset)


def pose(case, n_el: dict, q: dict) -> dict:
    """Planar (angle, origin (2,)) of every body frame, undeformed, at the tree joints'
    coordinates q (joint name -> rad or m)."""
    out = {"ground": (0.0, np.zeros(2))}
    for name in case.order:
        j = case.joint_of(name)
        a, p = out[j.parent]
        R = rot2(a)[:2, :2]
        origin, angle = p + R @ parent_site(case, n_el, j)[1], a + j.rpy[2]
        if j.type == "prismatic":
            origin = origin + q[j.name] * (R @ np.asarray(j.axis[:2]))
        elif j.type == "revolute":
            angle = angle + q[j.name]
        out[name] = (angle, origin)
    return out


def twist(case, frames: dict, qd: dict) -> dict:
    """Planar (angular rate, origin velocity (2,)) of every body frame moving rigidly with the
    tree joints' rates qd (joint name -> rad/s or m/s) at the poses `frames`."""
    out = {"ground": (0.0, np.zeros(2))}
    for name in case.order:
        j = case.joint_of(name)
        w, v = out[j.parent]
        v = v + w * perp(frames[name][1] - frames[j.parent][1])
        if j.type == "prismatic":
            v = v + qd[j.name] * (rot2(frames[j.parent][0])[:2, :2] @ np.asarray(j.axis[:2]))
        elif j.type == "revolute":
            w = w + qd[j.name]
        out[name] = (w, v)
    return out


def perp(r) -> np.ndarray:
    """z x r of planar vectors r (..., 2)."""
    r = np.asarray(r, dtype=float)
    return np.stack([-r[..., 1], r[..., 0]], axis=-1)


def mismatch(case, n_el: dict, frames: dict, rates: dict | None = None) -> np.ndarray:
    """(2 m,) parent side minus child side of the m cut joints' points, global, m (undeformed
    bodies at `frames`); with `rates`, of their velocities, m/s."""
    out = []
    for j in case.loops.values():
        ends = []
        for body, local in ((j.parent, parent_site(case, n_el, j)[1]), (j.child, child_site(case, n_el, j)[1])):
            a, p = frames[body]
            r = rot2(a)[:2, :2] @ local
            ends.append(p + r if rates is None else rates[body][1] + rates[body][0] * perp(r))
        out.append(ends[0] - ends[1])
    return np.concatenate(out) if out else np.zeros(0)


def path(case, body: str) -> list:
    """The tree joints from `body` down to ground."""
    out = []
    while body != "ground":
        j = case.joint_of(body)
        out.append(j.name)
        body = j.parent
    return out


def free_joints(case, cut: cases.Joint) -> list:
    """The joints of the loop a cut joint closes (the tree path from its parent to its child)
    that are neither driven nor fixed, in file order."""
    loop = set(path(case, cut.parent)) ^ set(path(case, cut.child))
    return [jn for jn, j in case.joints.items() if jn in loop and j.motion is None and j.type != "fixed"]


def dependent(case) -> list:
    """The tree joints whose coordinates the loops' closure fixes: per cut joint (two closure
    equations in the plane) the last two of its loop's free joints (`free_joints`) that an
    earlier loop has not taken. The others, the first joints of each loop and the driven ones,
    keep the case's values."""
    out = []
    for cut in case.loops.values():
        out += [jn for jn in free_joints(case, cut) if jn not in out][-2:]
    return out


def close_loops(case, n_el: dict) -> tuple[dict, dict]:
    """(q, qd): the tree joints' coordinates and rates at t = 0 (joint name -> value) with every
    loop closed: the case's (`start`), the `dependent` ones from Newton's method on the position
    closure (`mismatch` within CLOSURE_TOL) and from its velocity equations. Its Jacobian is
    exact: the closure's velocity per unit rate of each dependent joint. ValueError when the loops
    do not close from the case's starting guess."""
    q = {jn: start(j)[0] for jn, j in case.joints.items()}
    qd = {jn: start(j)[1] for jn, j in case.joints.items()}
    dep = dependent(case)
    if not dep:
        return q, qd
    unit = {jn: {k: float(k == jn) for k in case.joints} for jn in dep}     # a unit rate of one joint

    def jacobian(frames):
        return np.column_stack([mismatch(case, n_el, frames, twist(case, frames, unit[jn])) for jn in dep])
    for _ in range(50):
        frames = pose(case, n_el, q)
        r = mismatch(case, n_el, frames)
        if np.abs(r).max() <= CLOSURE_TOL:
            break
        for jn, d in zip(dep, np.linalg.lstsq(jacobian(frames), -r, rcond=None)[0]):
            q[jn] += d
    else:
        raise ValueError(f"the loops do not close from the case's q0 (Newton on the closure of joints {dep}: "
                         f"mismatch {np.abs(r).max():.3g} m)")
    qd.update({jn: 0.0 for jn in dep})
    r = mismatch(case, n_el, frames, twist(case, frames, qd))
    qd.update(zip(dep, np.linalg.lstsq(jacobian(frames), -r, rcond=None)[0]))
    return q, qd


# ---------------------------------------------------------------------------------------------
# building


def mesh_node(body: cases.Beam, n: int, x: float) -> int:
    """The node of this adapter's n-element mesh of a beam nearest to position x (m) as the case
    gives it, by the one snapping rule (`flexbody.node_index`). The mesh is the `elements`
    setting's (64 by default), not the case's, so the case's resolved node (`Point.node`) is in
    general not a node of it."""
    return flexbody.node_index(body.length, n, x)


def add_beam(mbs, body: cases.Beam, n: int, angle: float, origin, w: float = 0.0, v=(0.0, 0.0)) -> dict:
    """Nodes (n+1) and elements (n) of one beam along its frame's x axis, moving rigidly with
    the frame: angular rate w (rad/s), origin velocity v (2,) (m/s)."""
    k = section_constants(body)
    l = body.length / n
    ex = np.array([np.cos(angle), np.sin(angle)])
    ey = np.array([-ex[1], ex[0]])
    nodes = [mbs.AddNode(eii.NodeRigidBody2D(referenceCoordinates=[*(origin + i * l * ex), angle],
                                             initialVelocities=[*(np.asarray(v) + w * i * l * ey), w],
                                             visualization=eii.VNodeRigidBody2D(show=False)))
             for i in range(n + 1)]
    elems = [mbs.AddObject(eii.ObjectBeamGeometricallyExact2D(
        nodeNumbers=[nodes[i], nodes[i + 1]], length=l, massPerLength=k["massPerLength"],
        crossSectionInertia=k["crossSectionInertia"], bendingStiffness=k["bendingStiffness"],
        axialStiffness=k["axialStiffness"], shearStiffness=k["shearStiffness"], bendingDamping=k["bendingDamping"],
        axialDamping=k["axialDamping"], shearDamping=k["shearDamping"],
        visualization=eii.VObjectBeamGeometricallyExact2D(show=False))) for i in range(n)]
    return {"kind": "beam", "nodes": nodes, "elems": elems, "l": l, "k": k, "angle0": angle}


def add_point(mbs, body: cases.PointMass, angle: float, origin, v=(0.0, 0.0)) -> dict:
    """A point mass at `origin` (2,) moving with velocity v (2,): Exudyn's mass point (no rotation;
    `angle` is its frame's, which its parent's fixed joint turns)."""
    node = mbs.AddNode(eii.NodePoint2D(referenceCoordinates=list(origin), initialVelocities=list(v),
                                       visualization=eii.VNodePoint2D(show=False)))
    obj = mbs.AddObject(eii.ObjectMassPoint2D(nodeNumber=node, mass=body.mass,
                                              visualization=eii.VObjectMassPoint2D(show=False)))
    return {"kind": "point", "node": node, "obj": obj, "mass": body.mass, "com": np.zeros(2), "angle0": angle}


def add_rigid(mbs, body, beam_mass: str, angle: float, origin, w: float = 0.0, v=(0.0, 0.0)) -> dict:
    """A rigid body (or a beam declared rigid, `common.beam_inertia`) whose frame is at (angle,
    origin (2,)) moving with angular rate w and origin velocity v (2,): its node at the com
    (mass, com (2,) body frame, inertia J about the com)."""
    m, com, Ic = common.beam_inertia(body, beam_mass) if body.type == "beam" else common.rigid_body_inertia(body)
    c = rot2(angle)[:2, :2] @ com[:2]
    node = mbs.AddNode(eii.NodeRigidBody2D(referenceCoordinates=[*(origin + c), angle],
                                           initialVelocities=[*(np.asarray(v) + w * perp(c)), w],
                                           visualization=eii.VNodeRigidBody2D(show=False)))
    obj = mbs.AddObject(eii.ObjectRigidBody2D(nodeNumber=node, mass=m, inertia=Ic[2, 2],
                                              visualization=eii.VObjectRigidBody2D(show=False)))
    return {"kind": "rigid", "node": node, "obj": obj, "mass": m, "com": com[:2], "J": Ic[2, 2], "angle0": angle}


def beams(parts: dict) -> dict:
    """The flexible beams of the model's parts."""
    return {name: p for name, p in parts.items() if p["kind"] == "beam"}


def mesh(parts: dict) -> dict:
    """Elements per flexible beam."""
    return {name: len(p["elems"]) for name, p in beams(parts).items()}


def root_node(part: dict):
    """The node whose rotation is the body frame's: a beam's root node, a rigid body's node."""
    return part["nodes"][0] if part["kind"] == "beam" else part["node"]


def marker(mbs, parts: dict, body: str, where: tuple, rigid: bool = False):
    """A position (or, `rigid`, position and orientation) marker where a joint sits on `body`
    (`site`: node, local (2,)): a beam's node, else the point on ground or the rigid body."""
    p, (node, local) = parts[body], where
    if p["kind"] == "beam":
        kind = eii.MarkerNodeRigid if rigid else eii.MarkerNodePosition
        return mbs.AddMarker(kind(nodeNumber=p["nodes"][node]))
    if p["kind"] == "point":                    # a point mass: its position (its joint is a pin)
        return mbs.AddMarker(eii.MarkerNodePosition(nodeNumber=p["node"]))
    kind = eii.MarkerBodyRigid if rigid else eii.MarkerBodyPosition
    return mbs.AddMarker(kind(bodyNumber=p["obj"], localPosition=[*(local - p["com"]), 0.0]))


def add_joint(mbs, case, parts: dict, j: cases.Joint) -> tuple:
    """The joint between its parent's and its child's sites (`parent_site`, `child_site`): a pin
    (revolute about z; a fixed joint also holds the child's rotation to its parent's where it sits,
    `rotation_marker`: ground's, a beam node's or a rigid body's; a driven one holds it on its
    profile) or a prismatic joint along the axis. Returns its Exudyn objects
    (pin or prismatic joint, rotation constraint or None)."""
    n_el = mesh(parts)
    sites = (j.parent, parent_site(case, n_el, j)), (j.child, child_site(case, n_el, j))
    if j.type == "prismatic":
        ax, ay = j.axis[:2]
        return mbs.AddObject(eii.ObjectJointPrismatic2D(
            markerNumbers=[marker(mbs, parts, b, s, rigid=True) for b, s in sites], axisMarker0=[ax, ay, 0.0],
            normalMarker1=[-ay, ax, 0.0], visualization=eii.VObjectJointPrismatic2D(show=False))), None
    pin = mbs.AddObject(eii.ObjectJointRevolute2D(markerNumbers=[marker(mbs, parts, b, s) for b, s in sites],
                                                  visualization=eii.VObjectJointRevolute2D(show=False)))
    if (j.type != "fixed" or parts[j.child]["kind"] == "point") and j.motion is None:
        return pin, None
    mp = rotation_marker(mbs, parts, *sites[0])
    mr = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=root_node(parts[j.child]), coordinate=2))
    kw = hub_offset(mbs, j) if j.motion is not None else {}     # lock (or drive) the child's rotation
    return pin, mbs.AddObject(eii.CoordinateConstraint(markerNumbers=[mp, mr], **kw,
                                                       visualization=eii.VCoordinateConstraint(show=False)))


def rotation_marker(mbs, parts: dict, body: str, where: tuple):
    """A coordinate marker on the rotation where a joint sits on `body` (`site`: node, local): a
    beam's node's, a rigid body's; on ground a ground coordinate (zero). Each counts from its
    undeformed start, so a fixed joint holds the child's rotation coordinate equal to it."""
    p = parts[body]
    if p["kind"] == "ground":
        node = mbs.AddNode(eii.NodePointGround(visualization=eii.VNodePointGround(show=False)))
        return mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=node, coordinate=0))
    node = p["nodes"][where[0]] if p["kind"] == "beam" else p["node"]
    return mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=node, coordinate=2))


def hub_offset(mbs, j: cases.Joint) -> dict:
    """Offset user functions of the root rotation's coordinate constraint on a driven joint.

    The constraint holds the rotation coordinate, which Exudyn counts from the node's reference
    angle (the profile's q(0)), so the offset is q(t) - q(0); its rate qd(t) serves the
    velocity-level (index-2) solvers. Both are symbolic user functions, evaluated by Exudyn
    itself (`xc.motion_expr`), except for a table profile, which stays a Python function."""
    prof, q0 = j.motion, float(j.q0[0])
    q_start = profiles.motion(prof, 0.0, q0)[0]
    motion = xc.motion_expr if prof["type"] in xc.SYMBOLIC else profiles.motion

    def offset(mbs, t, itemNumber, lOffset):
        return motion(prof, t, q0)[0] - q_start

    def offset_t(mbs, t, itemNumber, lOffset):
        return motion(prof, t, q0)[1]
    if motion is profiles.motion:
        return {"offsetUserFunction": offset, "offsetUserFunction_t": offset_t}
    return {name: xc.symbolic(mbs, f, name, "ObjectConnectorCoordinate")
            for name, f in (("offsetUserFunction", offset), ("offsetUserFunction_t", offset_t))}


def add_loads(mbs, case, parts: dict) -> None:
    """Point loads on a flexible beam at their node of this mesh (`mesh_node`), on a rigid body
    at their point (body frame: turning with the beam's root node or the rigid body), gravity on
    every element and at every rigid body's com."""
    for ld in case.loads.values():
        b = parts[ld.body]
        if b["kind"] == "beam":
            node = b["nodes"][mesh_node(case.bodies[ld.body], len(b["elems"]), ld.point.x)]
            m = mbs.AddMarker(eii.MarkerNodePosition(nodeNumber=node))
        else:
            m = marker(mbs, parts, ld.body, (-1, np.asarray(ld.offset[:2], dtype=float)))
        f = np.asarray(ld.force, dtype=float)
        prof, body_frame, root = ld.profile, ld.frame == "body", root_node(b)
        steady = prof["type"] == "constant" or (prof["type"] == "step" and prof["t0"] <= 0.0)
        clamped = xc.fixed_to_ground(case, ld.body)
        if steady and (not body_frame or clamped):
            a0 = b["angle0"] if body_frame else 0.0
            mbs.AddLoad(eii.LoadForceVector(markerNumber=m, loadVector=list(rot2(a0) @ f)))
            continue

        def force(mbs_, t, load, f=f, prof=prof, body_frame=body_frame, root=root):
            s = float(profiles.load_factor(prof, t))
            a = float(np.ravel(mbs_.GetNodeOutput(root, OV.Rotation))[-1])
            return list(s * (rot2(a) @ f if body_frame else f))
        mbs.AddLoad(eii.LoadForceVector(markerNumber=m, loadVector=list(f), loadVectorUserFunction=force))
    g = np.asarray(case.gravity, dtype=float)
    if not np.any(g):
        return
    for p in parts.values():
        if p["kind"] == "beam":
            for e in p["elems"]:
                mm = mbs.AddMarker(eii.MarkerBodyMass(bodyNumber=e))
                mbs.AddLoad(eii.LoadMassProportional(markerNumber=mm, loadVector=list(g)))
        elif p["kind"] in ("rigid", "point"):
            mc = mbs.AddMarker(eii.MarkerBodyPosition(bodyNumber=p["obj"], localPosition=[0.0, 0.0, 0.0]))
            mbs.AddLoad(eii.LoadForceVector(markerNumber=mc, loadVector=list(p["mass"] * g)))


def rot2(a: float) -> np.ndarray:
    """Rotation (3, 3) about z by a."""
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def add_sensors(mbs, case, parts: dict, joints: dict) -> dict:
    """{"bodies": ..., "joints": ...}: node positions and rotations of every beam, element
    curvature and strain near stress points, element energies when the case asks for energy; a
    rigid body's node (com) position "p" and rotation "rot" (and velocities "v", "w" for the
    energy); the pin's force "F" and the rotation constraint's torque "M" of every joint whose
    reactions the channels use (`reactions_needed`; `joints`: name -> add_joint's objects)."""
    node = lambda n, ov: mbs.AddSensor(eii.SensorNode(nodeNumber=n, outputVariableType=ov, writeToFile=False,
                                                      storeInternal=True, visualization=eii.VSensorNode(show=False)))
    elem = lambda e, ov: mbs.AddSensor(eii.SensorBody(bodyNumber=e, localPosition=[0, 0, 0], outputVariableType=ov,
                                                      writeToFile=False, storeInternal=True,
                                                      visualization=eii.VSensorBody(show=False)))
    energy = channels.wants_energy(case)
    S = {}
    for name, b in parts.items():
        if b["kind"] == "rigid":
            S[name] = {"p": node(b["node"], OV.Position), "rot": node(b["node"], OV.Rotation)}
            if energy:
                S[name].update(v=node(b["node"], OV.Velocity), w=node(b["node"], OV.AngularVelocity))
            continue
        if b["kind"] == "point":
            S[name] = {"p": node(b["node"], OV.Position), **({"v": node(b["node"], OV.Velocity)} if energy else {})}
            continue
        if b["kind"] != "beam":
            continue
        S[name] = {"r": {k: node(n, OV.Position) for k, n in enumerate(b["nodes"])},
                   "rot": {k: node(n, OV.Rotation) for k, n in enumerate(b["nodes"])},
                   "kappa": {}, "eps": {}}
        for c in case.channels.values():
            if c.kind in cases.STRESS_KINDS and c.body == name:
                for e in stress_elements(b, c.at):
                    S[name]["kappa"][e] = elem(b["elems"][e], OV.CurvatureLocal)
                    S[name]["eps"][e] = elem(b["elems"][e], OV.StrainLocal)
        if energy:
            S[name]["T"] = {e: elem(eo, OV.KineticEnergy) for e, eo in enumerate(b["elems"])}
            S[name]["U"] = {e: elem(eo, OV.PotentialEnergy) for e, eo in enumerate(b["elems"])}
    force = lambda obj: mbs.AddSensor(eii.SensorObject(objectNumber=obj, outputVariableType=OV.Force, writeToFile=False,
                                                       storeInternal=True, visualization=eii.VSensorObject(show=False)))
    J = {}
    for jn in reactions_needed(case):
        pin, lock = joints[jn]
        J[jn] = {"F": force(pin), **({"M": force(lock)} if lock is not None else {})}
    watch_divergence(mbs, case, parts, S)
    return {"bodies": S, "joints": J}


def watch_divergence(mbs, case, parts: dict, S: dict) -> None:
    """The divergence watch (`xc.watch`) on the flexible beams with a deflection channel: their
    nodes' positions and the root node's rotation (`beam_shape`). S: the bodies' sensors."""
    bound = channels.bounds(case)
    bodies = list(dict.fromkeys(c.body for n, c in case.channels.items() if n in bound and c.body in beams(parts)))

    xs = {b: channels.deflection_points(case, b) for b in bodies}

    def sensors(b):                                  # the nodes of those points and the root's rotation
        nodes = {mesh_node(case.bodies[b], len(parts[b]["elems"]), x) for x in xs[b]}
        return {"r": {k: S[b]["r"][k] for k in sorted(nodes)}, "rot": {0: S[b]["rot"][0]}}
    read = {b: sensors(b) for b in bodies}
    if bodies:
        xc.watch(mbs, case, lambda mbs_: {b: beam_shape(case, parts[b], b, xc.values(mbs_, read[b]), xs[b])
                                         for b in bodies})


def stress_elements(b: dict, x: float) -> tuple:
    """The two elements whose centres bracket x (clipped to the beam)."""
    n, l = len(b["elems"]), b["l"]
    e0 = int(np.clip(np.floor(x / l - 0.5), 0, n - 2))
    return e0, e0 + 1


# ---------------------------------------------------------------------------------------------
# channels


def trajectory(case, parts: dict, X: dict, t: np.ndarray) -> channels.Trajectory:
    """The channels' view of the sensor data X (`read`): the bodies' poses (`frames`), global
    node positions with the root node's rotation (or the chord, hinged-hinged), strains
    interpolated to the stress sections, the joints' coordinates, the cut joints' reactions."""
    traj = channels.Trajectory(t=t)
    XB = X["bodies"]
    for jname in channels.joints_needed(case):
        traj.joints[jname] = joint_coordinate(case, parts, XB, case.joints[jname], t.size)
    if channels.wants_energy(case):
        traj.energy = energy(case, parts, XB, t.size)
    for jname, XJ in X["joints"].items():
        traj.reactions[jname] = reaction(case, parts, XB, jname, XJ)
    traj.poses = frames(case, parts, XB, t.size)
    for name, b in beams(parts).items():
        Xb = XB[name]
        traj.beams[name] = beam_shape(case, b, name, Xb, channels.points_needed(case, name))
        traj.beams[name].strains = {float(c.at): strains(c.at, b, Xb) for c in case.channels.values()
                                    if c.kind in cases.STRESS_KINDS and c.body == name}
    return traj


def frames(case, parts: dict, XB: dict, n: int) -> dict:
    """Body name -> (R (n, 3, 3), p (n, 3)) of the frame each body's points are given in
    (`channels.Trajectory.poses`): a rigid body's body frame, turned by its node's rotation about
    z, its origin the node (at the com) less the turned com; a point mass's at its node, turned as
    its parent's triad; a flexible beam's points are global (the identity)."""
    out = {}
    for name in case.bodies:
        kind, Xb = parts[name]["kind"], XB.get(name)
        if kind == "beam":
            out[name] = (np.broadcast_to(np.eye(3), (n, 3, 3)), np.zeros((n, 3)))
            continue
        if kind == "point":
            j = case.joint_of(name)
            a = site_angle(parts, XB, j.parent, parent_site(case, mesh(parts), j), n) + j.rpy[2]
        else:
            a = Xb["rot"][:, -1]
        out[name] = (rot_z(a), np.column_stack([Xb["p"][:, :2] - turn(a, parts[name]["com"]), np.zeros(n)]))
    return out


def beam_shape(case, b: dict, name: str, Xb: dict, xs: list) -> channels.Beam:
    """The Beam of beam `name` (b: its Exudyn items) without strains: the global positions of its
    nodes at the positions xs and the root node's rotation (or the chord, hinged-hinged), from
    its sensor data Xb."""
    body = case.bodies[name]
    nodes = {x: mesh_node(body, len(b["elems"]), x) for x in xs}
    hinged = body.modes.boundary == "hinged-hinged"
    return channels.Beam(length=body.length, points={x: Xb["r"][k] for x, k in nodes.items()},
                         x0={x: np.array([k * b["l"], 0.0, 0.0]) for x, k in nodes.items()},
                         root=None if hinged else rot_z(node_angle(Xb, 0)))


def reactions_needed(case) -> list:
    """The joints (tree or cut) whose reactions the channels use, but for a prismatic joint's
    (Exudyn's prismatic joint reports none): not reported."""
    every = {**case.joints, **case.loops}
    return list(dict.fromkeys(c.joint for c in case.channels.values()
                              if c.kind in ("reaction_force", "reaction_moment") and every[c.joint].type != "prismatic"))


def rot_z(a) -> np.ndarray:
    """(n, 3, 3) rotations about z by angles a (n,)."""
    c, s = np.cos(a), np.sin(a)
    R = np.zeros((a.size, 3, 3))
    R[:, 0, 0], R[:, 0, 1], R[:, 1, 0], R[:, 1, 1], R[:, 2, 2] = c, -s, s, c, 1.0
    return R


def frame_angle(body, Xb: dict) -> np.ndarray:
    """Body frame angle (n,): a rigid body's rotation, a flexible beam's chord angle
    (hinged-hinged modes) or root node rotation."""
    if not flexible(body):
        return Xb["rot"][:, -1]
    if body.modes.boundary == "hinged-hinged":
        last = max(Xb["r"])
        e = Xb["r"][last] - Xb["r"][0]
        return np.unwrap(np.arctan2(e[:, 1], e[:, 0]))
    return node_angle(Xb, 0)


def node_angle(Xb: dict, k: int) -> np.ndarray:
    return Xb["rot"][k][:, -1]


def turn(a: np.ndarray, v) -> np.ndarray:
    """(n, 2) planar vectors v ((2,) or (n, 2)) turned by angles a (n,)."""
    v = np.broadcast_to(np.asarray(v, dtype=float), (a.size, 2))
    c, s = np.cos(a), np.sin(a)
    return np.column_stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1]])


def site_angle(parts: dict, XB: dict, body: str, where: tuple, n: int) -> np.ndarray:
    """(n,) rotation of the frame where a joint sits (`site`: node, local): 0 on ground, a beam's
    node rotation, a rigid body's rotation."""
    kind = parts[body]["kind"]
    if kind == "ground":
        return np.zeros(n)
    return XB[body]["rot"][where[0]][:, -1] if kind == "beam" else XB[body]["rot"][:, -1]


def site_position(parts: dict, XB: dict, body: str, where: tuple, n: int) -> np.ndarray:
    """(n, 2) global position of where a joint sits on `body` (`site`: node, local (2,)), m."""
    p, (node, local) = parts[body], where
    if p["kind"] == "ground":
        return np.tile(local, (n, 1))
    if p["kind"] == "beam":
        return XB[body]["r"][node][:, :2]
    return XB[body]["p"][:, :2] + turn(XB[body]["rot"][:, -1], local - p["com"])


def joint_coordinate(case, parts: dict, XB: dict, j: cases.Joint, n: int) -> np.ndarray:
    """(n,) a tree joint's coordinate: revolute, the child frame angle minus the input triad's
    (rad); prismatic, the child origin's travel along the axis from the joint's point (m)."""
    n_el = mesh(parts)
    ps = parent_site(case, n_el, j)
    a = site_angle(parts, XB, j.parent, ps, n)
    if j.type == "prismatic":
        d = site_position(parts, XB, j.child, child_site(case, n_el, j), n) - site_position(parts, XB, j.parent, ps, n)
        return np.sum(d * turn(a, j.axis[:2]), axis=1)
    return frame_angle(case.bodies[j.child], XB[j.child]) - a - j.rpy[2]


def reaction(case, parts: dict, XB: dict, jname: str, XJ: dict) -> np.ndarray:
    """(n, 6) [moment; force] a revolute or fixed joint exerts on its child, about the joint
    point: minus Exudyn's pin force XJ["F"] (n, 3) (global; Exudyn's acts on the parent's
    marker), in the child's body frame (a cut joint's: the frame at its child point, the node's
    on a beam); the moment about z minus the rotation constraint's force XJ["M"] (n, 1) of a
    fixed or driven joint, else 0 (a pin)."""
    F = XJ["F"]
    if jname in case.loops:
        j = case.loops[jname]
        a = site_angle(parts, XB, j.child, child_site(case, mesh(parts), j), len(F))
    elif parts[case.joints[jname].child]["kind"] == "point":    # its frame: the triad, fixed on the parent
        j = case.joints[jname]
        a = site_angle(parts, XB, j.parent, parent_site(case, mesh(parts), j), len(F)) + j.rpy[2]
    else:
        j = case.joints[jname]
        a = frame_angle(case.bodies[j.child], XB[j.child])
    out = np.zeros((len(F), 6))
    out[:, 3:5] = -turn(-a, F[:, :2])
    if "M" in XJ:
        out[:, 2] = -XJ["M"][:, 0]
    return out


def loop_closure(case, parts: dict, XB: dict, n: int) -> float:
    """The largest distance between the two sides of a cut joint over the run, m (0 without loops)."""
    n_el = mesh(parts)
    gaps = [site_position(parts, XB, j.parent, parent_site(case, n_el, j), n)
            - site_position(parts, XB, j.child, child_site(case, n_el, j), n) for j in case.loops.values()]
    return max((float(np.linalg.norm(g, axis=1).max()) for g in gaps), default=0.0)


def strains(x: float, b: dict, Xb: dict) -> np.ndarray:
    """(n, 4) section strains [eps, 0, kappa_z, 0] at x, interpolated between element centres."""
    e0, e1 = stress_elements(b, x)
    w = (x - (e0 + 0.5) * b["l"]) / b["l"]
    kap = (1 - w) * Xb["kappa"][e0][:, 2] + w * Xb["kappa"][e1][:, 2]
    eps = (1 - w) * Xb["eps"][e0][:, 0] + w * Xb["eps"][e1][:, 0]
    zero = np.zeros_like(eps)
    return np.column_stack([eps, zero, kap, zero])


def energy(case, parts: dict, XB: dict, n: int) -> dict:
    """The energy parts (n,) J: the elements' kinetic and strain energies and gravity's
    -g . (rho A l (r1 + r2) / 2) over the elements; a rigid body's m v^2 / 2 + J w^2 / 2 and
    -m g . r_com (a point mass: no J w^2 / 2)."""
    g = np.asarray(case.gravity, dtype=float)[:2]
    T, U, V = np.zeros(n), np.zeros(n), np.zeros(n)
    for name, b in parts.items():
        if b["kind"] in ("rigid", "point"):
            Xb = XB[name]
            T = T + 0.5 * b["mass"] * np.sum(Xb["v"][:, :2] ** 2, axis=1)
            T = T + (0.5 * b["J"] * Xb["w"][:, -1] ** 2 if b["kind"] == "rigid" else 0.0)
            V = V - b["mass"] * Xb["p"][:, :2] @ g
    for name, b in beams(parts).items():
        Xb = XB[name]
        mass = b["k"]["massPerLength"] * b["l"]
        for e in range(len(b["elems"])):
            T = T + Xb["T"][e][:, 0]
            U = U + Xb["U"][e][:, 0]
            V = V - mass * 0.5 * (Xb["r"][e][:, :2] + Xb["r"][e + 1][:, :2]) @ g
    return {"kinetic": T, "strain": U, "gravity": V}


# ---------------------------------------------------------------------------------------------
# the solver


def build(case, n: int, beam_mass: str = "lumped"):
    """(SC, mbs, parts, S): every flexible beam of n elements, every rigid body, the joints and
    loads, the sensors (`add_sensors`), assembled at the closed initial state (`close_loops`).
    parts: body name (and "ground") -> its Exudyn items. ValueError when the loops do not close."""
    SC, mbs = xc.system()
    parts = {"ground": {"kind": "ground", "obj": mbs.AddObject(eii.ObjectGround()), "com": np.zeros(2)}}
    n_el = {name: n for name, b in case.bodies.items() if flexible(b)}
    q, qd = close_loops(case, n_el)
    frames = pose(case, n_el, q)
    rates = twist(case, frames, qd)
    for name, body in case.bodies.items():
        (a, p), (w, v) = frames[name], rates[name]
        if flexible(body):
            parts[name] = add_beam(mbs, body, n, a, p, w, v)
        elif body.type == "point_mass":
            parts[name] = add_point(mbs, body, a, p, v)
        else:
            parts[name] = add_rigid(mbs, body, beam_mass, a, p, w, v)
    joints = {jn: add_joint(mbs, case, parts, j) for jn, j in {**case.joints, **case.loops}.items()}
    add_loads(mbs, case, parts)
    S = add_sensors(mbs, case, parts, joints)
    mbs.Assemble()
    return SC, mbs, parts, S


def read(mbs, S, t: np.ndarray):
    """The sensors S (nested dicts of sensors) read on the output grid t: the same nesting of
    (n, k) arrays (`xc.sensor_series`)."""
    if isinstance(S, dict):
        return {k: read(mbs, s, t) for k, s in S.items()}
    return xc.sensor_series(mbs, S, t)


def clock(S: dict):
    """One sensor of the model, to tell how far a run went: the first body's position."""
    Sb = next(iter(S["bodies"].values()))
    return Sb["p"] if "p" in Sb else Sb["r"][0]


def run(case, t_end, settings):
    opt = {k: settings.get(k, d) for k, (_, d) in SETTINGS.items()}
    opt["newton_atol"] = newton_atol(case, opt)
    t_start = time.perf_counter()
    out_dt = case.integrator.output_dt
    dt = out_dt / max(int(round(out_dt / opt["dt"])), 1) if opt["dt"] <= out_dt else opt["dt"]
    recorded = {"dt": dt, **opt, "element": "ObjectBeamGeometricallyExact2D", "node": "NodeRigidBody2D",
                "shear_correction": "5/6 rectangle, 9/10 circle", "linear_solver": "EigenSparse"}
    try:
        with xc.quiet():
            SC, mbs, parts, S = build(case, opt["elements"], opt["beam_mass"])
    except ValueError as e:                          # the loops do not close
        return results.Result(solver="exudyn-beam", case=case.name, status=results.failed(str(e), 0.0),
                              settings=recorded, solver_version=version())
    t = xc.output_grid(case, t_end)
    sim = xc.simulation_settings(case, t_end, dt, opt)
    xc.reach(sim, t[-1], dt)
    sim.timeIntegration.newton.absoluteTolerance = opt["newton_atol"]
    setup_s = time.perf_counter() - t_start

    status, wall_s, steps, newton = xc.solve(mbs, sim, opt["solver"], f"{case.name} / exudyn-beam")
    dofs = sum(3 * len(p["nodes"]) if p["kind"] == "beam" else 2 if p["kind"] == "point" else 3
               for p in parts.values() if p["kind"] != "ground")
    r = results.Result(solver="exudyn-beam", case=case.name, status=status, wall_s=wall_s, setup_s=setup_s,
                       steps=steps, rhs_evals=newton, settings=recorded, solver_version=version(),
                       extra={"newton_iterations": newton, "dofs": int(dofs)})
    xc.stopped(r, mbs)
    n = xc.reached(r, t, xc.completed(mbs, clock(S), t), t_end)
    if n == 0:
        return r
    X = read(mbs, S, t[:n])
    traj = trajectory(case, parts, X, t[:n])
    r.t, r.trajectory = t[:n], traj
    if "kinetic" in traj.energy:                   # what an energy channel's differences are measured against
        r.extra["kinetic_max_J"] = float(np.max(traj.energy["kinetic"]))
    if case.loops:
        r.extra["loop_closure_m"] = loop_closure(case, parts, X["bodies"], n)
    return r


# ---------------------------------------------------------------------------------------------
# the system's natural frequencies


def system_frequencies(case, count: int) -> np.ndarray:
    """The lowest `count` nonzero natural frequencies (count,) of the case's mechanism, Hz,
    ascending: this model (`build`, the case's `elements` and `beam_mass` settings) at the initial
    state, the loops closed and every joint of prescribed motion held at its initial value (a
    lock of its coordinate: the driven joint's rotation constraint, its offset zero), linearized
    by Exudyn's own eigenvalue solver on the constrained system (`xc.frequencies`: undamped, the
    zero eigenvalues of rigid-body motion dropped, within `xc.ZERO` of the largest). The model is
    the full beam mesh: its frequencies converge from above as the elements are refined (the
    element's error falls as 1 / elements^2). InputError (one line, naming the case file) for a
    case this model cannot take (`applies`), one loaded at t = 0 (`xc.loaded`: Exudyn's
    eigenvalue solver sees no stiffness from loads), one whose initial state moves (`xc.at_rest`),
    or one Exudyn refuses."""
    opt = cases.check_table(dict(case.solvers.get("exudyn-beam", {})), SETTINGS, str(case.path), "solvers.exudyn-beam.")

    def model(fixed):
        SC, mbs, _, _ = build(fixed, opt["elements"], opt["beam_mass"])
        return SC, mbs
    return xc.system_frequencies(case, count, "exudyn-beam", applies, model)
