"""`mujoco`: the rigid limit of a case, as MJCF text run by MuJoCo.

The MJCF text is written from the case itself, as a user of MuJoCo would write it, never from
flexmbd's Model (`build.from_case`), so that it checks flexmbd rather than repeating it: the same
rigid limit as `pinocchio` (`common.rigid_bodies`): every beam a rigid prism of mass rho A L,
centre of mass [L/2, 0, 0] and inertia about it diag(rho L (Iy + Iz), m L^2/12 + rho L Iy,
m L^2/12 + rho L Iz) (setting `beam_mass = "lumped"`: the case mesh's lumped node masses,
m L^2/12 (1 + 2/n^2) across the beam); a rigid body as the case gives it. One nested <body> per
case body, named as in the case, at its joint's input triad (`pos`: `at` in the parent frame, on
a beam parent the snapped node [x, 0, 0], `case.joints[name].x`, the node flexmbd
uses; `quat`: the triad's rotation from `rpy`), with its joint (named as in the case; `hinge` /
`slide` about the unit axis in the body frame, `ball`, `freejoint`; a fixed joint welds the body)
and an explicit <inertial> (mass, centre of mass, full inertia; a point mass's diaginertia 0 0 0);
no geoms, contacts disabled, constraints too unless the case has loops, MuJoCo's RK4 integrator
with a small step. Point loads enter through `xfrc_applied` (world frame, at the body's centre
of mass), set before each step from the state at the start of the step. Prescribed joint motion
has no exact counterpart in MuJoCo's own integrators, so such cases are not applicable here (the
`pinocchio` adapter runs them).

Closed loops: each cut joint (`case.loops`) becomes MuJoCo equality constraints between sites on
its two bodies (`cut_equalities`): a revolute one two `connect`s at the points AXIS_REACH either
side of the joint point along its axis (the points coincide and the axis is shared), a spherical
one a `connect` at the joint point, a fixed one a `weld` of the two frames; a prismatic one has
no MuJoCo equality (connect holds a point, weld a frame, none leaves a slide free): not
applicable. The tree joints' initial values are a starting guess: the closure fixes the
dependent coordinates, chosen as flexmbd chooses them, and their rates (`close_loops`, Newton on
MuJoCo's own constraint rows).

MuJoCo's constraints are soft: its solver gives a constraint row the acceleration
aref = -b v - k r (r, v its violation and rate; solref (tc, 1): b = 2 / tc, k = 1 / tc^2) only
up to the regularization R = (1 - d) / d diagApprox, the impedance d at most 0.9999 (mjMAXIMP).
The closure then errs like a stiff spring (by (1 - d) tc^2) and RK4 on its fast mode (by
(dt / tc)^4, the reactions first). The loops take d = 0.9999, tc = TIMECONST dt, a constraint
solver run to 1e-15, and diagApprox, which MuJoCo computes from `body_invweight0`, scaled by
REGULARIZATION after compiling (`compile_model`: an impedance of 1 - 1e-8, past the clamp).
four_bar_swing_rigid over 1 s at dt = 1e-4 s is then within 3e-9 rad of a tight ODE solution, its
energy conserved to 5e-10 of its largest kinetic energy, its pin force within 4e-8 of its
largest: efc_force = -(J qacc - aref) / R keeps about 8 digits with R that small. MJCF settings
alone (no scaling; solref, solimp, negative solref's direct stiffness and damping, o_solref and
o_solimp, the refsafe flag, RK4 or the implicit integrators) reach 3e-7 rad at best (tc = 4 dt,
the force within 1.4e-4; 2e-8 rad at dt = 2.5e-5 s; the first-order integrators 5e-3 rad at
dt = 1e-5 s).

Channels: joint angles from qpos (`mj_name2id` of the case's joint), energy from MuJoCo's own
mj_energyPos / mj_energyVel, the reactions of cut joints from the constraint forces efc_force
(`cut_reactions`); deflections and stresses of the rigid beams are identically zero (the
trajectory holds no Beam).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

import mujoco
from flexmbd import cases
from flexmbd.harness import channels, cost, results
from flexmbd.mbd import profiles
from flexmbd.cases.closure import pick
from flexmbd.solvers import common
from flexmbd.solvers.mujoco_common import fmt, quat_to_rot, rot_to_quat

RIGID = True                        # every beam rigid: deformation channels are zero, not compared
LOOPS = True                        # cut joints closed by equality constraints (`cut_equalities`)
SETTINGS = {
    "dt": ("float+", 1e-4),                         # s, RK4 step (rounded so that it divides output_dt)
    "beam_mass": (common.BEAM_MASS, "prism"),       # a beam's inertia: the prism, or its lumped mesh
}
STYLE = {"color": "#e377c2", "marker": "P"}     # on the figures (report.figures.looks), solid lines
UNCLOSED = {"prismatic": "MuJoCo's equality constraints hold a point (connect) or a frame (weld), none leaves a "
                         "slide free",
            "free": "it constrains nothing"}
AXIS_REACH = 0.5                    # m: a revolute cut's two connects sit this far either side of its point
IMPEDANCE = 0.9999                  # solimp d of the loops: MuJoCo's largest (mjMAXIMP)
REGULARIZATION = 1e-4               # scale of body_invweight0, thus of the loops' regularization R
TIMECONST = 32                      # steps: solref time constant of the loops (MuJoCo's floor: 2)
CLOSURE_TOL = 1e-12                 # m: the largest residual of the loops' closure at the start


def version() -> str:
    return mujoco.__version__


def applies(case) -> str:
    if cases.is_fixed_base(case):
        return "every joint is fixed: nothing moves in the rigid limit"
    for name, j in case.joints.items():
        if j.motion is not None:
            return f"joint {name!r} has prescribed motion (MuJoCo's integrators have no exact counterpart)"
        if j.type == "free" and j.parent != "ground":
            return f"joint {name!r}: MuJoCo allows free joints only on children of the world body"
    for name, j in case.loops.items():
        if j.type in UNCLOSED:
            return f"loop joint {name!r} is {j.type}: {UNCLOSED[j.type]}"
    return ""


def stages(case, t_end, settings) -> list:
    """The costly stages of a run (`cost.stages`): the meshes of its beams (their rigid limit) and
    the RK4 steps."""
    return cost.modes(case, rigid=True) + cost.fixed_step(case, t_end, settings["dt"], "solvers.mujoco.dt", 6e-6)


def rigid_case(case):
    """The case with every beam declared rigid (validated like any case): what flexmbd runs to
    compare with this peer (the peer itself makes every beam rigid when it reads the case)."""
    extra = [f"bodies.{n}.rigid=true" for n, b in case.bodies.items() if b.type == "beam"]
    return cases.load(str(case.path), list(case.overrides) + extra)


# ---------------------------------------------------------------------------------------------
# model text and initial state


@dataclass(frozen=True)
class Site:
    """A frame on a body for an equality constraint: origin r (3,) and axes R (3, 3) (columns, R
    maps site to body coordinates) in the frame of body `body` ("ground": the world)."""

    name: str
    body: str
    r: np.ndarray
    R: np.ndarray


@dataclass(frozen=True)
class Equality:
    """One MuJoCo equality constraint closing cut joint `joint`: `kind` connect (the two sites'
    origins coincide) or weld (their frames coincide), from the parent-side to the child-side site."""

    joint: str
    kind: str
    parent: Site
    child: Site


def cut_equalities(case) -> list:
    """The equality constraints that close the case's loops (`case.loops`), in the rigid limit.
    A cut joint's parent side is its input triad at `offset` on its parent (axes R = triad, as for
    `common.RigidBody`), its child side the child's frame moved to `child_offset`:
      revolute   two connects, at the points AXIS_REACH either side of the joint point along the
                 axis a (R a on the parent, a on the child): the points coincide, the axis is shared
      spherical  one connect at the joint point
      fixed      one weld of the two frames
    """
    out = []
    for name, j in case.loops.items():
        R, a = np.array(j.triad, dtype=float), np.array(j.axis, dtype=float)
        r, rc = np.array(j.offset, dtype=float), np.array(j.child_offset, dtype=float)
        points = {"revolute": [("+", AXIS_REACH), ("-", -AXIS_REACH)]}.get(j.type, [("", 0.0)])
        for tag, s in points:
            out.append(Equality(name, "weld" if j.type == "fixed" else "connect",
                                Site(f"{name}{tag}/parent", j.parent, r + s * (R @ a), R),
                                Site(f"{name}{tag}/child", j.child, rc + s * a, np.eye(3))))
    return out


def mjcf(bodies, gravity, dt: float, cuts=()) -> str:
    """MJCF text of a case's rigid limit (`common.rigid_bodies`, tree order) under gravity (3,):
    bodies and joints named as in the case; the loops closed by the equality constraints `cuts`
    (`cut_equalities`, in that order: equality i is cuts[i]), with their sites."""
    children = {"ground": []}
    for b in bodies:
        children.setdefault(b.parent, []).append(b)
        children.setdefault(b.name, [])
    sites = {}
    for e in cuts:
        for st in (e.parent, e.child):
            line = f'<site name="{st.name}" pos="{fmt(st.r)}" quat="{fmt(rot_to_quat(st.R))}"/>'
            sites.setdefault(st.body, []).append(line)

    def body(b, indent: str) -> list:
        I = b.inertia
        # a point mass has no rotational inertia: MuJoCo refuses a `fullinertia` without positive
        # eigenvalues, but takes diaginertia="0 0 0" on a welded body (a point mass is welded:
        # schema.POINT_MASS_JOINTS), whose mass joins its parent's composite inertia
        inertia = (f'fullinertia="{fmt(I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2])}"' if I.any()
                   else 'diaginertia="0 0 0"')
        lines = [f'{indent}<body name="{b.name}" pos="{fmt(b.r)}" quat="{fmt(rot_to_quat(b.R))}">',
                 f'{indent}  <inertial pos="{fmt(b.com)}" mass="{fmt(b.mass)}" {inertia}/>']
        if b.type == "revolute":
            lines.append(f'{indent}  <joint name="{b.joint}" type="hinge" axis="{fmt(b.axis)}"/>')
        elif b.type == "prismatic":
            lines.append(f'{indent}  <joint name="{b.joint}" type="slide" axis="{fmt(b.axis)}"/>')
        elif b.type == "spherical":
            lines.append(f'{indent}  <joint name="{b.joint}" type="ball"/>')
        elif b.type == "free":
            lines.append(f'{indent}  <freejoint name="{b.joint}"/>')
        lines += [f"{indent}  {line}" for line in sites.get(b.name, [])]
        for c in children[b.name]:
            lines += body(c, indent + "  ")
        return lines + [f"{indent}</body>"]

    tree = [f"    {line}" for line in sites.get("ground", [])]
    tree += [line for b in children["ground"] for line in body(b, "    ")]
    soft = f'solref="{fmt(TIMECONST * dt, 1.0)}" solimp="{fmt(IMPEDANCE, IMPEDANCE, 0.001, 0.5, 2.0)}"'
    equality = ['  <equality>', *(f'    <{e.kind} site1="{e.parent.name}" site2="{e.child.name}" {soft}/>'
                                   for e in cuts), '  </equality>'] if cuts else []
    solver = ' jacobian="dense" tolerance="1e-15"' if cuts else ""   # rows (nefc, nv), read by `closure`
    constraint = "" if cuts else ' constraint="disable"'
    return "\n".join([
        '<mujoco model="flexmbd rigid limit">',
        '  <compiler angle="radian" autolimits="true" boundmass="0" boundinertia="0"/>',
        f'  <option timestep="{fmt(dt)}" integrator="RK4" gravity="{fmt(gravity)}"{solver}>',
        f'    <flag contact="disable"{constraint} energy="enable"/>',
        '  </option>',
        '  <worldbody>', *tree, '  </worldbody>', *equality,
        '</mujoco>', ""])


def compile_model(bodies, gravity, dt: float, cuts=()):
    """MuJoCo's model of `mjcf`; with loops, its bodies' body_invweight0 (the mean inverse inertia
    at qpos0 that only the constraints' regularization diagApprox uses here) scaled by
    REGULARIZATION, the loops' R with it: a stiffer closure than MJCF's largest impedance allows."""
    m = mujoco.MjModel.from_xml_string(mjcf(bodies, gravity, dt, cuts))
    if cuts:
        m.body_invweight0[:] *= REGULARIZATION
    return m


def initial_state(bodies, m) -> tuple[np.ndarray, np.ndarray]:
    """(qpos, qvel) from the case's initial values. Revolute, prismatic: the coordinate and its
    rate. Ball: the quaternion [w, x, y, z] of the rotation vector (`mju_axisAngle2Quat`), the
    angular velocity in the body frame. Free joint (a child of the world): the body's position
    r + R p and rotation R R(quat) in the world (triad origin r, rotation R; the case's rotation
    vector and p in the triad), and [v (world); w (body)] from the case's [w; v] (body frame)."""
    qpos, qvel = m.qpos0.copy(), np.zeros(m.nv)
    for b in bodies:
        if b.type == "fixed":
            continue
        jid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, b.joint)
        a, k = m.jnt_qposadr[jid], m.jnt_dofadr[jid]
        if b.type in ("revolute", "prismatic"):
            qpos[a], qvel[k] = b.q0[0], b.qd0[0]
        elif b.type == "spherical":
            qpos[a:a + 4], qvel[k:k + 3] = quaternion(b.q0), b.qd0
        else:
            Rb = b.R @ quat_to_rot(quaternion(b.q0[:3]))
            qpos[a:a + 3] = b.r + b.R @ np.asarray(b.q0[3:])
            qpos[a + 3:a + 7] = rot_to_quat(Rb)
            qvel[k:k + 3], qvel[k + 3:k + 6] = Rb @ np.asarray(b.qd0[3:]), b.qd0[:3]
    return qpos, qvel


def quaternion(rotvec) -> np.ndarray:
    """MuJoCo's quaternion [w, x, y, z] of a rotation vector (3,)."""
    rotvec = np.asarray(rotvec, dtype=float)
    angle = float(np.linalg.norm(rotvec))
    q = np.array([1.0, 0.0, 0.0, 0.0])
    if angle > 0.0:
        mujoco.mju_axisAngle2Quat(q, rotvec / angle, angle)
    return q


def closure(m, d) -> tuple[np.ndarray, np.ndarray]:
    """(r (ne,), J (ne, nv)): MuJoCo's equality rows at d.qpos, the loops' residuals (a connect's
    p_parent - p_child, world, m; a weld's also its rotation error) and their Jacobian in qvel."""
    mujoco.mj_forward(m, d)
    return d.efc_pos[:d.ne].copy(), d.efc_J[:d.ne * m.nv].reshape(d.ne, m.nv).copy()


def close_loops(case, m, d, iterations: int = 20) -> float:
    """Close the loops from the tree's initial state in d, in place, as flexmbd chooses the
    coordinates (docs/formulation.md, section 11): the dependent ones are one-coordinate tree
    joints without motion, from the last in the tree back (`cases.closure.pick`), the others kept.
    Newton on them (least squares on their columns of `closure`, steps by mj_integratePos), then
    their velocities such that J qvel = 0. Returns the largest residual left (m)."""
    joints = [case.joints[link.joint] for link in case.tree]
    order = [m.jnt_dofadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, j.name)] for j in joints
             if j.type in ("revolute", "prismatic") and j.motion is None]
    r, J = closure(m, d)
    dep = pick(J[:, order[::-1]], order[::-1])
    for _ in range(iterations):
        step = np.zeros(m.nv)
        step[dep] = -np.linalg.lstsq(J[:, dep], r, rcond=None)[0]
        mujoco.mj_integratePos(m, d.qpos, step, 1.0)
        r, J = closure(m, d)
        if np.abs(step).max() < 1e-15:
            break
    kept = [k for k in range(m.nv) if k not in dep]
    d.qvel[dep] = -np.linalg.lstsq(J[:, dep], J[:, kept] @ d.qvel[kept], rcond=None)[0]
    return float(np.abs(r).max())


# ---------------------------------------------------------------------------------------------
# the solver


def model_loads(case, m) -> list:
    """The case's point loads as (MuJoCo body id, RigidLoad), without those on bodies welded to
    the world (no effect)."""
    loads = [(mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, ld.body), ld) for ld in common.rigid_loads(case)]
    return [(b, ld) for b, ld in loads if m.body_weldid[b] != 0]


def apply_loads(loads, m, d) -> None:
    """xfrc_applied (nbody, 6) = [force; torque about the body's centre of mass], world frame,
    from the point loads (`model_loads`) at time d.time and the current pose."""
    if not loads:
        return
    mujoco.mj_kinematics(m, d)
    d.xfrc_applied[:] = 0.0
    for b, ld in loads:
        R = d.xmat[b].reshape(3, 3)
        f = ld.force * float(profiles.load_factor(ld.profile, d.time))
        f = f if ld.glob else R @ f
        p = d.xpos[b] + R @ ld.point
        d.xfrc_applied[b, :3] += f
        d.xfrc_applied[b, 3:] += np.cross(p - d.xipos[b], f)


def cut_reactions(case, cuts, m, d) -> dict:
    """{cut joint: (6,) [moment; force]} at the state in d (after mj_forward): the force each cut
    joint transmits from its parent side onto its child side and the moment about the child-side
    joint point, components in the child's body frame, from MuJoCo's constraint forces efc_force
    of its equality rows (equality i is cuts[i], `cut_equalities`, site 1 on the parent side):
    a connect's three rows are the force f (world) on site 1, -f on site 2; a weld's next three
    rows a torque (`weld_torque`) on site 1's body, minus it on site 2's."""
    equality = d.efc_type[:d.nefc] == mujoco.mjtConstraint.mjCNSTR_EQUALITY
    out = {}
    for name, j in case.loops.items():
        c = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, j.child)
        Rc = d.xmat[c].reshape(3, 3)
        p = d.xpos[c] + Rc @ np.asarray(j.child_offset)
        moment, force = np.zeros(3), np.zeros(3)                # on the child, world
        for i in (i for i, e in enumerate(cuts) if e.joint == name):
            f = d.efc_force[:d.nefc][equality & (d.efc_id[:d.nefc] == i)]
            if f.size:                                          # none when no dof moves its sites
                force -= f[:3]
                moment -= np.cross(d.site_xpos[m.eq_obj2id[i]] - p, f[:3])
                if cuts[i].kind == "weld":
                    moment -= weld_torque(m, d, i, f[3:])
        out[name] = np.concatenate([Rc.T @ moment, Rc.T @ force])
    return out


def weld_torque(m, d, i: int, f) -> np.ndarray:
    """(3,) world: the torque of weld i's rotational rows with forces f (3,) on its first site's
    body, G^T f, with G its rows' Jacobian in the bodies' relative angular velocity w (world):
    0.5 torquescale Im(conj(q2) (0, w) q1), q1, q2 the sites' orientations xquat site_quat (MuJoCo's
    weld, site semantic)."""
    q = []
    for site in (m.eq_obj1id[i], m.eq_obj2id[i]):
        qs = np.zeros(4)
        mujoco.mju_mulQuat(qs, d.xquat[m.site_bodyid[site]], m.site_quat[site])
        q.append(qs)
    conj, G = np.zeros(4), np.zeros((3, 3))
    mujoco.mju_negQuat(conj, q[1])
    for k in range(3):
        left, full = np.zeros(4), np.zeros(4)
        mujoco.mju_mulQuatAxis(left, conj, np.eye(3)[k])
        mujoco.mju_mulQuat(full, left, q[0])
        G[:, k] = 0.5 * m.eq_data[i, 10] * full[1:]
    return G.T @ f


def trajectory(case, m, t, P, E, F) -> channels.Trajectory:
    """The trajectory from qpos samples P (n, nq), energies E (n,) and cut-joint reactions F
    ({cut joint: (n, 6)}, `cut_reactions`), with the bodies' poses (`poses`)."""
    def coordinate(jname):
        return P[:, m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, jname)]].copy()
    traj = common.rigid_trajectory(case, t, coordinate, lambda: E.copy())
    traj.reactions = F
    traj.poses = poses(case, m, P)
    return traj


def poses(case, m, P) -> dict:
    """Body name -> (R (n, 3, 3) body -> world, p (n, 3)) of every body at the positions P (n, nq)
    (`channels.Trajectory.poses`): MuJoCo's forward kinematics, each body's xmat and xpos (its
    frame is the case's: the joint's input triad at rest, moved by the joint)."""
    d, ids = mujoco.MjData(m), {b: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, b) for b in case.bodies}
    out = {b: (np.zeros((len(P), 3, 3)), np.zeros((len(P), 3))) for b in ids}
    for k, q in enumerate(P):
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        for b, i in ids.items():
            out[b][0][k], out[b][1][k] = d.xmat[i].reshape(3, 3), d.xpos[i]
    return out


def samples(case, cuts, loads, m, d, S: dict) -> tuple:
    """From the states S kept at the output instants ({qpos (n, nq), qvel (n, nv), qacc_warmstart
    (n, nv), time (n,)}): the positions P (n, nq), the energy E (n,) J and the cut joints' reactions
    {name: (n, 6)} (`cut_reactions`), each by `mj_forward` at that state under its loads."""
    n = S["time"].size
    P, E = S["qpos"].copy(), np.zeros(n)
    F = {name: np.zeros((n, 6)) for name in case.loops}
    for k in range(n):
        d.qpos[:], d.qvel[:], d.qacc_warmstart[:], d.time = S["qpos"][k], S["qvel"][k], S["qacc_warmstart"][k], S["time"][k]
        apply_loads(loads, m, d)
        mujoco.mj_forward(m, d)
        E[k] = d.energy.sum()
        for name, f in cut_reactions(case, cuts, m, d).items():
            F[name][k] = f
    return P, E, F


def run(case, t_end, settings):
    from flexmbd.harness.results import Result
    t0 = time.perf_counter()
    beam_mass = settings.get("beam_mass", SETTINGS["beam_mass"][1])
    bodies = common.rigid_bodies(case, beam_mass)
    out_dt = case.integrator.output_dt
    stride = max(int(np.ceil(out_dt / settings.get("dt", SETTINGS["dt"][1]) - 1e-9)), 1)
    dt = out_dt / stride
    cuts = cut_equalities(case)
    m = compile_model(bodies, case.gravity, dt, cuts)
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = initial_state(bodies, m)
    if case.loops and (residual := close_loops(case, m, d)) > CLOSURE_TOL:
        raise ValueError(f"the loops do not close from the tree joints' initial values (residual {residual:.1e} m)")
    loads = model_loads(case, m)
    setup_s = time.perf_counter() - t0

    t_out = common.sample_times(case, t_end)
    n_out = t_out.size
    S = {"qpos": np.zeros((n_out, m.nq)), "qvel": np.zeros((n_out, m.nv)),
         "qacc_warmstart": np.zeros((n_out, m.nv)), "time": np.zeros(n_out)}
    status, k = results.Status(), 0

    def keep(k: int) -> None:
        for name, arr in S.items():
            arr[k] = getattr(d, name)

    # the run as a MuJoCo user times it: the state kept at the output instants, everything else
    # (energy, constraint forces) computed from it after the run (`samples`). Without point loads
    # MuJoCo steps stride steps in one call (mj_step's nstep); a point load's time profile is set
    # before each step (`apply_loads`).
    t1 = time.perf_counter()
    keep(0)
    for k in range(1, n_out):
        if loads:
            for _ in range(stride):
                apply_loads(loads, m, d)
                mujoco.mj_step(m, d)
        else:
            mujoco.mj_step(m, d, stride)
        keep(k)
        if not np.all(np.isfinite(d.qpos)):
            status = results.diverged(results.STATE_NOT_FINITE, d.time)
            break
    else:
        k = n_out
    wall_s = time.perf_counter() - t1
    n = k                                       # a failed run keeps the instants before the failure
    P, E, F = samples(case, cuts, loads, m, d, {name: arr[:n] for name, arr in S.items()})
    n = k
    traj = trajectory(case, m, t_out[:n], P[:n], E[:n], {name: f[:n] for name, f in F.items()})
    loops = {"loops": f"equality constraints, solref ({TIMECONST} dt, 1), solimp d = {IMPEDANCE}, "
                      f"body_invweight0 x {REGULARIZATION:g}"} if case.loops else {}
    return Result(solver="mujoco", case=case.name, t=t_out[:n],
                  trajectory=traj, status=status, wall_s=wall_s, setup_s=setup_s, steps=(n - 1) * stride,
                  rhs_evals=4 * (n - 1) * stride,
                  settings={"integrator": "RK4", "dt": dt, "contacts": "disabled", "beam_mass": beam_mass,
                            "model": common.rigid_limit_text(beam_mass), **loops})
