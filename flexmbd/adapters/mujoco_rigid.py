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
and an explicit <inertial> (mass, centre of mass, full inertia); no geoms, contacts and
constraints disabled, MuJoCo's RK4 integrator with a small step. Point loads enter through
`xfrc_applied` (world frame, at the body's centre of mass), set before each step from the state
at the start of the step. Prescribed joint motion has no exact counterpart in MuJoCo's own
integrators, so such cases are not applicable here (the `pinocchio` adapter runs them).

Channels: joint angles from qpos (`mj_name2id` of the case's joint), energy from MuJoCo's own
mj_energyPos / mj_energyVel; deflections and stresses of the rigid beams are identically zero
(the trajectory holds no Beam).
"""

from __future__ import annotations

import time

import numpy as np

import mujoco
from flexmbd import cases, channels, profiles, results
from flexmbd.adapters import common
from flexmbd.adapters.mujoco_common import fmt, quat_to_rot, rot_to_quat

RIGID = True                        # every beam rigid: deformation channels are zero, not compared
SETTINGS = {
    "dt": ("float+", 1e-4),                         # s, RK4 step (rounded so that it divides output_dt)
    "beam_mass": (common.BEAM_MASS, "prism"),       # a beam's inertia: the prism, or its lumped mesh
}


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
    return ""


def rigid_case(case):
    """The case with every beam declared rigid (validated like any case): what flexmbd runs to
    compare with this peer (the peer itself makes every beam rigid when it reads the case)."""
    extra = [f"bodies.{n}.rigid=true" for n, b in case.bodies.items() if b.type == "beam"]
    return cases.load(str(case.path), list(case.overrides) + extra)


# ---------------------------------------------------------------------------------------------
# model text and initial state


def mjcf(bodies, gravity, dt: float) -> str:
    """MJCF text of a case's rigid limit (`common.rigid_bodies`, tree order) under gravity (3,):
    bodies and joints named as in the case."""
    children = {"ground": []}
    for b in bodies:
        children.setdefault(b.parent, []).append(b)
        children.setdefault(b.name, [])

    def body(b, indent: str) -> list:
        I = b.inertia
        lines = [f'{indent}<body name="{b.name}" pos="{fmt(b.r)}" quat="{fmt(rot_to_quat(b.R))}">',
                 f'{indent}  <inertial pos="{fmt(b.com)}" mass="{fmt(b.mass)}" '
                 f'fullinertia="{fmt(I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2])}"/>']
        if b.type == "revolute":
            lines.append(f'{indent}  <joint name="{b.joint}" type="hinge" axis="{fmt(b.axis)}"/>')
        elif b.type == "prismatic":
            lines.append(f'{indent}  <joint name="{b.joint}" type="slide" axis="{fmt(b.axis)}"/>')
        elif b.type == "spherical":
            lines.append(f'{indent}  <joint name="{b.joint}" type="ball"/>')
        elif b.type == "free":
            lines.append(f'{indent}  <freejoint name="{b.joint}"/>')
        for c in children[b.name]:
            lines += body(c, indent + "  ")
        return lines + [f"{indent}</body>"]

    tree = [line for b in children["ground"] for line in body(b, "    ")]
    return "\n".join([
        '<mujoco model="flexmbd rigid limit">',
        '  <compiler angle="radian" autolimits="true" boundmass="0" boundinertia="0"/>',
        f'  <option timestep="{fmt(dt)}" integrator="RK4" gravity="{fmt(gravity)}">',
        '    <flag contact="disable" constraint="disable" energy="enable"/>',
        '  </option>',
        '  <worldbody>', *tree, '  </worldbody>',
        '</mujoco>', ""])


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


def trajectory(case, m, t, P, E) -> channels.Trajectory:
    """The trajectory from qpos samples P (n, nq) and energies E (n,)."""
    def coordinate(jname):
        return P[:, m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, jname)]].copy()
    return common.rigid_trajectory(case, t, coordinate, lambda: E.copy())


def run(case, t_end, settings):
    from flexmbd.results import Result
    t0 = time.perf_counter()
    beam_mass = settings.get("beam_mass", SETTINGS["beam_mass"][1])
    bodies = common.rigid_bodies(case, beam_mass)
    out_dt = case.integrator.output_dt
    stride = max(int(np.ceil(out_dt / settings.get("dt", SETTINGS["dt"][1]) - 1e-9)), 1)
    dt = out_dt / stride
    m = mujoco.MjModel.from_xml_string(mjcf(bodies, case.gravity, dt))
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = initial_state(bodies, m)
    loads = model_loads(case, m)
    setup_s = time.perf_counter() - t0

    t_out = common.sample_times(case, t_end)
    P, E = np.zeros((t_out.size, m.nq)), np.zeros(t_out.size)
    status, k = results.Status(), 0
    t1 = time.perf_counter()
    mujoco.mj_forward(m, d)
    P[0], E[0] = d.qpos, d.energy.sum()
    for k in range(1, t_out.size):
        for _ in range(stride):
            apply_loads(loads, m, d)
            mujoco.mj_step(m, d)
        if not np.all(np.isfinite(d.qpos)):
            status = results.failed("non-finite state", d.time)
            break
        mujoco.mj_forward(m, d)                                 # energy of the current state
        P[k], E[k] = d.qpos, d.energy.sum()
    else:
        k = t_out.size
    wall_s = time.perf_counter() - t1

    n = k
    traj = trajectory(case, m, t_out[:n], P[:n], E[:n])
    return Result(solver="mujoco", case=case.name, t=t_out[:n],
                  trajectory=traj, status=status, wall_s=wall_s, setup_s=setup_s, steps=(n - 1) * stride,
                  rhs_evals=4 * (n - 1) * stride,
                  settings={"integrator": "RK4", "dt": dt, "contacts": "disabled", "beam_mass": beam_mass,
                            "model": common.rigid_limit_text(beam_mass)})
