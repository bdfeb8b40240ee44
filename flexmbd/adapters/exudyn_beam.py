"""`exudyn-beam`: the beams of a planar case as chains of Exudyn's geometrically exact 2-D beam
elements (`ObjectBeamGeometricallyExact2D`, Simo-Reissner: axial, shear and bending strains of
the large-rotation kinematics), full nonlinear FE in the role LS-Dyna plays in the paper.

Every beam: `elements` equal elements (setting, default 64) on `NodeRigidBody2D` nodes
(x, y, rotation), E A, k G A (k = 5/6 rectangle, 9/10 circle), E I of the bending plane x-y,
rho A per length, rho I cross-section rotary inertia. Its body frame starts where the case's
tree puts it (joint q0 included), undeformed and at rest.

Joints (planar only): a revolute joint about z is `ObjectJointRevolute2D` (a pin: the two node
positions coincide) between ground and the root node or between a node of the parent beam (the
node of this mesh nearest to `at`, `mesh_node`) and the child's root node; a fixed joint to
ground clamps the root node's three coordinates. A revolute joint to ground with prescribed
motion (the hub of a spin-up or slewing beam) is the same pin plus a `CoordinateConstraint` that
holds the root node's rotation on the profile: its offset user functions are `profiles.motion`
(angle and rate), so the root is clamped to a hub turning exactly as flexmbd's joint does; written
as Exudyn symbolic user functions (`exudyn_common.motion_expr`), Exudyn evaluates them in C++
(a table profile stays a Python function). The
beam starts undeformed on the profile's q(0), every node moving with the rigid rotation at its
rate qd(0). Point loads are `LoadForceVector` on their node of this mesh (a body-frame load
turns with the root node); gravity is `LoadMassProportional` on every element.

The trajectory (`flexmbd.channels`) from Exudyn's nodes and elements (docs/formulation.md §7):
  deflection   clamped-root body: node displacement in the root node's frame (the cross-section
               frame: it differs from the tangent by the shear angle, ~1e-6 rad here) minus the
               undeformed offset; hinged-hinged body: signed distance from the chord through the
               end nodes, in the chord frame;
  joint_angle  child body frame angle (root node rotation, or chord angle for a hinged-hinged
               body) minus the input triad's (ground: 0; a beam: the rotation of its node);
  stress_vm    from eps and kappa taken at the element centres (where the constant-strain
               element is most accurate) and interpolated linearly to the stress section;
  energy       Exudyn's kinetic and strain energies of the elements plus -g . (rho A l (r1 + r2) / 2).
Time integration: Exudyn's implicit solver, fixed step.
"""

from __future__ import annotations

import time

import numpy as np

from flexmbd import cases, channels, flexbody, profiles
from flexmbd.adapters import exudyn_common as xc
from flexmbd.adapters.exudyn_common import eii, exu

SETTINGS = {
    "elements": ("int+", 64),                # per beam
    "dt": ("float+", 1e-4),                  # s, fixed step (rounded to divide output_dt)
    "solver": (tuple(xc.IMPLICIT), "generalized-alpha"),
    "spectral_radius": ("float0+", 0.9),
    "newton_rtol": ("float+", 1e-5),
    "newton_atol": ("float+", None),         # absolute residual tolerance; None: newton_rtol / 100
    "adaptive": ("bool", False),
}

OV = exu.OutputVariableType


def version() -> str:
    return xc.version()


def applies(case) -> str:
    why = xc.is_planar(case)
    if why:
        return f"planar beam model only (3-D beams are not built yet): {why}"
    for name, b in case.bodies.items():
        if b.type != "beam" or b.rigid:
            return f"body {name!r}: only flexible beams are modelled (no rigid bodies)"
        if b.damping_ratio > 0:
            return f"body {name!r}: modal damping has no counterpart in the beam elements"
    for jn, j in case.joints.items():
        if j.type not in ("revolute", "fixed"):
            return f"joint {jn!r}: only revolute (pin) and fixed joints"
        if j.type == "fixed" and j.parent != "ground":
            return f"joint {jn!r}: fixed joints only to ground"
        if j.motion is not None and (j.type != "revolute" or j.parent != "ground"):
            return f"joint {jn!r}: prescribed motion only on a revolute joint to ground"
        if j.motion is None and any(abs(x) > 0 for x in j.qd0):
            return f"joint {jn!r}: the beams start at rest"
    for cname, c in case.channels.items():
        if c.component == "z":
            return f"channel {cname!r}: out-of-plane component in a planar model"
    return ""


def section_constants(body: cases.Beam) -> dict:
    """Element constants of a case beam (bending in x-y: I = Iz of the FE section)."""
    sec, mat = body.geometry, body.material
    E, G, rho = mat.E, mat.G, mat.rho
    k = 0.9 if body.section.shape == "circle" else 5.0 / 6.0
    return {"massPerLength": rho * sec.A, "crossSectionInertia": rho * sec.Iz,
            "bendingStiffness": E * sec.Iz, "axialStiffness": E * sec.A, "shearStiffness": k * G * sec.A,
            "E": E, "cy": sec.cy, "Iz": sec.Iz, "A": sec.A}


# ---------------------------------------------------------------------------------------------
# building


def initial_frames(case, n_el: dict) -> dict:
    """Planar (angle, origin (2,)) of every body frame at t = 0; a child sits on the parent's
    node nearest to the joint (`mesh_node`, on this adapter's mesh of n_el elements)."""
    out = {"ground": (0.0, np.zeros(2))}
    for name in case.order:
        j = case.joint_of(name)
        a, p = out[j.parent]
        if j.point is None:                               # on ground
            off = np.asarray(j.offset[:2], dtype=float)
        else:
            pb, n = case.bodies[j.parent], n_el[j.parent]
            off = np.array([mesh_node(pb, n, j.point.x) * pb.length / n, 0.0])
        c, s = np.cos(a), np.sin(a)
        out[name] = (a + j.rpy[2] + start(j)[0], p + np.array([c * off[0] - s * off[1], s * off[0] + c * off[1]]))
    return out


def start(j: cases.Joint) -> tuple:
    """(q, qd) of a joint at t = 0: its profile's for prescribed motion, else (q0, 0); (0, 0) fixed."""
    if j.type != "revolute":
        return 0.0, 0.0
    q0 = float(j.q0[0])
    if j.motion is None:
        return q0, 0.0
    q, qd, _ = profiles.motion(j.motion, 0.0, q0)
    return q, qd


def initial_rates(case, frames: dict) -> dict:
    """Planar (angular rate, origin velocity (2,)) of every body frame at t = 0: the bodies move
    rigidly with the prescribed joint rates qd(0) (zero on a joint that is not driven)."""
    out = {"ground": (0.0, np.zeros(2))}
    for name in case.order:
        j = case.joint_of(name)
        w, v = out[j.parent]
        r = frames[name][1] - frames[j.parent][1]
        out[name] = (w + start(j)[1], v + w * np.array([-r[1], r[0]]))
    return out


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
        axialStiffness=k["axialStiffness"], shearStiffness=k["shearStiffness"],
        visualization=eii.VObjectBeamGeometricallyExact2D(show=False))) for i in range(n)]
    return {"nodes": nodes, "elems": elems, "l": l, "k": k}


def add_joint(mbs, case, beams: dict, ground, j: cases.Joint) -> None:
    """Pin (revolute about z) or clamp (fixed to ground) at the child's root node; a driven
    revolute joint to ground clamps the root rotation to its profile."""
    child = beams[j.child]
    m1 = mbs.AddMarker(eii.MarkerNodePosition(nodeNumber=child["nodes"][0]))
    if j.parent == "ground":
        m0 = mbs.AddMarker(eii.MarkerBodyPosition(bodyNumber=ground, localPosition=list(j.offset)))
    else:
        par = beams[j.parent]
        node = mesh_node(case.bodies[j.parent], len(par["elems"]), j.point.x)
        m0 = mbs.AddMarker(eii.MarkerNodePosition(nodeNumber=par["nodes"][node]))
    mbs.AddObject(eii.ObjectJointRevolute2D(markerNumbers=[m0, m1],
                                            visualization=eii.VObjectJointRevolute2D(show=False)))
    if j.type == "fixed" or j.motion is not None:     # lock (or drive) the root rotation
        ng = mbs.AddNode(eii.NodePointGround(visualization=eii.VNodePointGround(show=False)))
        mg = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=ng, coordinate=0))
        mr = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=child["nodes"][0], coordinate=2))
        kw = hub_offset(mbs, j) if j.motion is not None else {}
        mbs.AddObject(eii.CoordinateConstraint(markerNumbers=[mg, mr], **kw,
                                               visualization=eii.VCoordinateConstraint(show=False)))


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


def add_loads(mbs, case, beams: dict) -> None:
    """Point loads on their nodes of this mesh (`mesh_node`; body frame: turning with the root
    node), gravity."""
    for ld in case.loads.values():
        b = beams[ld.body]
        node = b["nodes"][mesh_node(case.bodies[ld.body], len(b["elems"]), ld.point.x)]
        m = mbs.AddMarker(eii.MarkerNodePosition(nodeNumber=node))
        f = np.asarray(ld.force, dtype=float)
        prof, body_frame, root = ld.profile, ld.frame == "body", b["nodes"][0]
        steady = prof["type"] == "constant" or (prof["type"] == "step" and prof["t0"] <= 0.0)
        clamped = case.joint_of(ld.body).type == "fixed"
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
    if np.any(g):
        for b in beams.values():
            for e in b["elems"]:
                mm = mbs.AddMarker(eii.MarkerBodyMass(bodyNumber=e))
                mbs.AddLoad(eii.LoadMassProportional(markerNumber=mm, loadVector=list(g)))


def rot2(a: float) -> np.ndarray:
    """Rotation (3, 3) about z by a."""
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def add_sensors(mbs, case, beams: dict) -> dict:
    """Node positions and rotations of every beam; element curvature and strain near stress
    points; element energies when the case asks for energy."""
    node = lambda n, ov: mbs.AddSensor(eii.SensorNode(nodeNumber=n, outputVariableType=ov, writeToFile=False,
                                                      storeInternal=True, visualization=eii.VSensorNode(show=False)))
    elem = lambda e, ov: mbs.AddSensor(eii.SensorBody(bodyNumber=e, localPosition=[0, 0, 0], outputVariableType=ov,
                                                      writeToFile=False, storeInternal=True,
                                                      visualization=eii.VSensorBody(show=False)))
    energy = channels.wants_energy(case)
    S = {}
    for name, b in beams.items():
        S[name] = {"r": {k: node(n, OV.Position) for k, n in enumerate(b["nodes"])},
                   "rot": {k: node(n, OV.Rotation) for k, n in enumerate(b["nodes"])},
                   "kappa": {}, "eps": {}}
        for c in case.channels.values():
            if c.kind == "stress_vm" and c.body == name:
                for e in stress_elements(b, c.at):
                    S[name]["kappa"][e] = elem(b["elems"][e], OV.CurvatureLocal)
                    S[name]["eps"][e] = elem(b["elems"][e], OV.StrainLocal)
        if energy:
            S[name]["T"] = {e: elem(eo, OV.KineticEnergy) for e, eo in enumerate(b["elems"])}
            S[name]["U"] = {e: elem(eo, OV.PotentialEnergy) for e, eo in enumerate(b["elems"])}
    return S


def stress_elements(b: dict, x: float) -> tuple:
    """The two elements whose centres bracket x (clipped to the beam)."""
    n, l = len(b["elems"]), b["l"]
    e0 = int(np.clip(np.floor(x / l - 0.5), 0, n - 2))
    return e0, e0 + 1


# ---------------------------------------------------------------------------------------------
# channels


def trajectory(case, beams: dict, X: dict, t: np.ndarray) -> channels.Trajectory:
    """The channels' view of the sensor data X: global node positions with the root node's
    rotation (or the chord, hinged-hinged), strains interpolated to the stress sections."""
    traj = channels.Trajectory(t=t)
    for jname in channels.joints_needed(case):
        traj.joints[jname] = joint_angle(case, beams, X, case.joints[jname])
    if channels.wants_energy(case):
        traj.energy = energy(case, beams, X)
    for name, b in beams.items():
        body, Xb = case.bodies[name], X[name]
        nodes = {x: mesh_node(body, len(b["elems"]), x) for x in channels.points_needed(case, name)}
        hinged = body.modes.boundary == "hinged-hinged"
        traj.beams[name] = channels.Beam(
            length=body.length, points={x: Xb["r"][k] for x, k in nodes.items()},
            x0={x: np.array([k * b["l"], 0.0, 0.0]) for x, k in nodes.items()},
            root=None if hinged else rot_z(node_angle(Xb, 0)),
            strains={float(c.at): strains(c.at, b, Xb) for c in case.channels.values()
                     if c.kind == "stress_vm" and c.body == name})
    return traj


def rot_z(a) -> np.ndarray:
    """(n, 3, 3) rotations about z by angles a (n,)."""
    c, s = np.cos(a), np.sin(a)
    R = np.zeros((a.size, 3, 3))
    R[:, 0, 0], R[:, 0, 1], R[:, 1, 0], R[:, 1, 1], R[:, 2, 2] = c, -s, s, c, 1.0
    return R


def frame_angle(body: cases.Beam, Xb: dict) -> np.ndarray:
    """Body frame angle (n,): chord angle (hinged-hinged modes) or root node rotation."""
    if body.modes.boundary == "hinged-hinged":
        last = max(Xb["r"])
        e = Xb["r"][last] - Xb["r"][0]
        return np.unwrap(np.arctan2(e[:, 1], e[:, 0]))
    return node_angle(Xb, 0)


def node_angle(Xb: dict, k: int) -> np.ndarray:
    return Xb["rot"][k][:, -1]


def joint_angle(case, beams, X, j: cases.Joint) -> np.ndarray:
    """Child frame angle minus the input triad's angle (a beam's triad turns with its node)."""
    child = frame_angle(case.bodies[j.child], X[j.child])
    if j.parent == "ground":
        return child - j.rpy[2]
    p = mesh_node(case.bodies[j.parent], len(beams[j.parent]["elems"]), j.point.x)
    return child - node_angle(X[j.parent], p) - j.rpy[2]


def strains(x: float, b: dict, Xb: dict) -> np.ndarray:
    """(n, 4) section strains [eps, 0, kappa_z, 0] at x, interpolated between element centres."""
    e0, e1 = stress_elements(b, x)
    w = (x - (e0 + 0.5) * b["l"]) / b["l"]
    kap = (1 - w) * Xb["kappa"][e0][:, 2] + w * Xb["kappa"][e1][:, 2]
    eps = (1 - w) * Xb["eps"][e0][:, 0] + w * Xb["eps"][e1][:, 0]
    zero = np.zeros_like(eps)
    return np.column_stack([eps, zero, kap, zero])


def energy(case, beams, X) -> dict:
    """The energy parts (n,) J: the elements' kinetic and strain energies, and gravity's
    -g . (rho A l (r1 + r2) / 2) over the elements."""
    g = np.asarray(case.gravity, dtype=float)[:2]
    T = U = V = 0.0
    for name, b in beams.items():
        Xb = X[name]
        mass = b["k"]["massPerLength"] * b["l"]
        for e in range(len(b["elems"])):
            T = T + Xb["T"][e][:, 0]
            U = U + Xb["U"][e][:, 0]
            V = V - mass * 0.5 * (Xb["r"][e][:, :2] + Xb["r"][e + 1][:, :2]) @ g
    return {"kinetic": T, "strain": U, "gravity": V}


# ---------------------------------------------------------------------------------------------
# the solver


def build(case, n: int):
    SC, mbs = xc.system()
    ground = mbs.AddObject(eii.ObjectGround())
    frames = initial_frames(case, {name: n for name in case.bodies})
    rates = initial_rates(case, frames)
    beams = {}
    for name, body in case.bodies.items():
        a, p = frames[name]
        beams[name] = add_beam(mbs, body, n, a, p, *rates[name])
        beams[name]["angle0"] = a
    for j in case.joints.values():
        add_joint(mbs, case, beams, ground, j)
    add_loads(mbs, case, beams)
    S = add_sensors(mbs, case, beams)
    mbs.Assemble()
    return SC, mbs, beams, S


def run(case, t_end, settings):
    from flexmbd.results import Result
    opt = {k: settings.get(k, d) for k, (_, d) in SETTINGS.items()}
    t_start = time.perf_counter()
    out_dt = case.integrator.output_dt
    dt = out_dt / max(int(round(out_dt / opt["dt"])), 1) if opt["dt"] <= out_dt else opt["dt"]
    with xc.quiet():
        SC, mbs, beams, S = build(case, opt["elements"])
    sim = xc.simulation_settings(case, t_end, dt, opt)
    if opt["newton_atol"] is not None:
        sim.timeIntegration.newton.absoluteTolerance = opt["newton_atol"]
    setup_s = time.perf_counter() - t_start

    status, wall_s, steps, newton = xc.solve(mbs, sim, opt["solver"], f"{case.name} / exudyn-beam")
    t = xc.output_grid(case, t_end)
    recorded = {"dt": dt, **opt, "element": "ObjectBeamGeometricallyExact2D", "node": "NodeRigidBody2D",
                "shear_correction": "5/6 rectangle, 9/10 circle", "linear_solver": "EigenSparse"}
    r = Result(solver="exudyn-beam", case=case.name, status=status, wall_s=wall_s, setup_s=setup_s,
               steps=steps, rhs_evals=newton, settings=recorded, solver_version=version(),
               extra={"newton_iterations": newton,
                      "dofs": int(sum(3 * len(b["nodes"]) for b in beams.values()))})
    first = S[next(iter(S))]["r"][0]
    n = xc.reached(r, t, xc.completed(mbs, first, t), t_end)
    if n == 0:
        return r
    X = {name: {k: ({i: xc.sensor_series(mbs, s, t[:n]) for i, s in v.items()}) for k, v in Sb.items()}
         for name, Sb in S.items()}
    traj = trajectory(case, beams, X, t[:n])
    r.t, r.trajectory = t[:n], traj
    if "kinetic" in traj.energy:                   # what an energy channel's differences are measured against
        r.extra["kinetic_max_J"] = float(np.max(traj.energy["kinetic"]))
    return r
