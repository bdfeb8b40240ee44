"""`mujoco`: the rigid limit of a case, as MJCF text run by MuJoCo.

The same rigid tree as `pinocchio` (every beam rigid, mass properties from its reduced body's
undeformed invariants): one nested <body> per flexmbd body at its input triad, explicit
<inertial> (mass, centre of mass, full inertia), no geoms, contacts and constraints disabled,
MuJoCo's RK4 integrator with a small step. Point loads enter through `xfrc_applied` (world frame,
at the body's centre of mass), set before each step from the state at the start of the step.
Prescribed joint motion has no exact counterpart in MuJoCo's own integrators, so such cases are
not applicable here (the `pinocchio` adapter runs them).

Channels: joint angles from qpos, energy from MuJoCo's own mj_energyPos / mj_energyVel;
deflections and stresses of the rigid beams are identically zero.
"""

from __future__ import annotations

import time

import numpy as np

import mujoco
from flexmbd import cases, channels, profiles, results
from flexmbd.adapters import common
from flexmbd.adapters.mujoco_common import fmt, quat_to_rot, rot_to_quat
from flexmbd.spatial import inertia_parts, plux_parts
from flexmbd.build import from_case
from flexmbd.joints import FIXED, FREE, PRISMATIC, REVOLUTE, SPHERICAL

RIGID = True                        # every beam rigid: deformation channels are zero, not compared
SETTINGS = {"dt": ("float+", 1e-4)}         # s, RK4 step (rounded so that it divides output_dt)


def version() -> str:
    return mujoco.__version__


def applies(case) -> str:
    if cases.is_fixed_base(case):
        return "every joint is fixed: nothing moves in the rigid limit"
    for name, j in case["joints"].items():
        if j["motion"] is not None:
            return f"joint {name!r} has prescribed motion (MuJoCo's integrators have no exact counterpart)"
        if j["type"] == "free" and j["parent"] != "ground":
            return f"joint {name!r}: MuJoCo allows free joints only on children of the world body"
    return ""


def rigid_case(case):
    """The case with every beam declared rigid (validated like any case)."""
    extra = [f"bodies.{n}.rigid=true" for n, b in case["bodies"].items() if b["type"] == "beam"]
    return cases.load(str(case.path), list(case.overrides) + extra)


# ---------------------------------------------------------------------------------------------
# model text and state conversion


def mjcf(model, dt: float) -> str:
    """MJCF text of a rigid flexmbd Model: body k is named b<k>, its joint j<k>."""
    children = {i: [k for k in range(1, model.nb + 1) if model.parent[k] == i] for i in range(model.nb + 1)}

    def body(i: int, indent: str) -> list:
        r, R = plux_parts(model.jnt_Xtriad[i])                  # input triad in the parent frame
        m, c, Ic = inertia_parts(model.body_inertia[i])
        lines = [f'{indent}<body name="b{i}" pos="{fmt(r)}" quat="{fmt(rot_to_quat(R))}">',
                 f'{indent}  <inertial pos="{fmt(c)}" mass="{fmt(m)}" '
                 f'fullinertia="{fmt(Ic[0, 0], Ic[1, 1], Ic[2, 2], Ic[0, 1], Ic[0, 2], Ic[1, 2])}"/>']
        t, a = model.jnt_type[i], model.jnt_axis[i]
        if t == REVOLUTE:
            lines.append(f'{indent}  <joint name="j{i}" type="hinge" axis="{fmt(a)}"/>')
        elif t == PRISMATIC:
            lines.append(f'{indent}  <joint name="j{i}" type="slide" axis="{fmt(a)}"/>')
        elif t == SPHERICAL:
            lines.append(f'{indent}  <joint name="j{i}" type="ball"/>')
        elif t == FREE:
            lines.append(f'{indent}  <freejoint name="j{i}"/>')
        for k in children[i]:
            lines += body(k, indent + "  ")
        return lines + [f"{indent}</body>"]

    tree = [line for k in children[0] for line in body(k, "    ")]
    return "\n".join([
        '<mujoco model="flexmbd rigid limit">',
        '  <compiler angle="radian" autolimits="true" boundmass="0" boundinertia="0"/>',
        f'  <option timestep="{fmt(dt)}" integrator="RK4" gravity="{fmt(model.gravity)}">',
        '    <flag contact="disable" constraint="disable" energy="enable"/>',
        '  </option>',
        '  <worldbody>', *tree, '  </worldbody>',
        '</mujoco>', ""])


def to_mj_state(model, m, q, v) -> tuple[np.ndarray, np.ndarray]:
    """flexmbd (q, v) -> MuJoCo (qpos, qvel). Free joints: [quat; p] -> [p; quat] in the world,
    [w; v] (body) -> [v (world); w (body)]."""
    qpos, qvel = np.zeros(m.nq), np.zeros(m.nv)
    for i in range(1, model.nb + 1):
        t = model.jnt_type[i]
        if t == FIXED:
            continue
        jid = m.joint(f"j{i}").id
        a, b, k, kv = m.jnt_qposadr[jid], m.jnt_dofadr[jid], model.jnt_qadr[i], model.jnt_vadr[i]
        if t in (REVOLUTE, PRISMATIC):
            qpos[a], qvel[b] = q[k], v[kv]
        elif t == SPHERICAL:
            qpos[a:a + 4], qvel[b:b + 3] = q[k:k + 4], v[kv:kv + 3]
        else:
            r, R = plux_parts(model.jnt_Xtriad[i])              # triad in the world
            Rb = R @ quat_to_rot(q[k:k + 4])
            qpos[a:a + 3] = r + R @ q[k + 4:k + 7]
            qpos[a + 3:a + 7] = rot_to_quat(Rb)
            qvel[b:b + 3], qvel[b + 3:b + 6] = Rb @ v[kv + 3:kv + 6], v[kv:kv + 3]
    return qpos, qvel


def from_mj_state(model, m, qpos, qvel) -> tuple[np.ndarray, np.ndarray]:
    """MuJoCo (qpos, qvel) -> flexmbd (q, v); the inverse of `to_mj_state`."""
    q, v = np.zeros(model.nq), np.zeros(model.nv)
    for i in range(1, model.nb + 1):
        t = model.jnt_type[i]
        if t == FIXED:
            continue
        jid = m.joint(f"j{i}").id
        a, b, k, kv = m.jnt_qposadr[jid], m.jnt_dofadr[jid], model.jnt_qadr[i], model.jnt_vadr[i]
        if t in (REVOLUTE, PRISMATIC):
            q[k], v[kv] = qpos[a], qvel[b]
        elif t == SPHERICAL:
            q[k:k + 4], v[kv:kv + 3] = qpos[a:a + 4], qvel[b:b + 3]
        else:
            r, R = plux_parts(model.jnt_Xtriad[i])
            Rb = quat_to_rot(qpos[a + 3:a + 7])
            q[k:k + 4] = rot_to_quat(R.T @ Rb)
            q[k + 4:k + 7] = R.T @ (qpos[a:a + 3] - r)
            v[kv:kv + 3], v[kv + 3:kv + 6] = qvel[b + 3:b + 6], Rb.T @ qvel[b:b + 3]
    return q, v


# ---------------------------------------------------------------------------------------------
# the solver


def apply_loads(model, m, d) -> None:
    """xfrc_applied (nbody, 6) = [force; torque about the body's centre of mass], world frame,
    from the point loads at time d.time and the current pose."""
    loads = [(k, m.body(f"b{i}").id) for k, i in enumerate(model.load_body)]
    loads = [(k, b) for k, b in loads if m.body_weldid[b] != 0]    # welded to the world: no effect
    if not loads:
        return
    mujoco.mj_kinematics(m, d)
    d.xfrc_applied[:] = 0.0
    for k, b in loads:
        R = d.xmat[b].reshape(3, 3)
        f = model.load_force[k] * float(profiles.load_factor(model.load_profiles[k], d.time))
        f = f if model.load_global[k] else R @ f
        p = d.xpos[b] + R @ model.load_point[k]
        d.xfrc_applied[b, :3] += f
        d.xfrc_applied[b, 3:] += np.cross(p - d.xipos[b], f)


def trajectory(case, model, m, t, P, E) -> channels.Trajectory:
    """The trajectory from qpos samples P (n, nq) and energies E (n,)."""
    return common.rigid_trajectory(case, model, t, lambda i: P[:, m.jnt_qposadr[m.joint(f"j{i}").id]].copy(),
                                   lambda: E.copy())


def run(case, t_end, settings):
    from flexmbd.results import Result
    t0 = time.perf_counter()
    model = from_case(rigid_case(case))
    out_dt = case["integrator"]["output_dt"]
    stride = max(int(np.ceil(out_dt / settings.get("dt", SETTINGS["dt"][1]) - 1e-9)), 1)
    dt = out_dt / stride
    m = mujoco.MjModel.from_xml_string(mjcf(model, dt))
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = to_mj_state(model, m, model.q0, model.v0)
    setup_s = time.perf_counter() - t0

    t_out = common.sample_times(case, t_end)
    P, E = np.zeros((t_out.size, m.nq)), np.zeros(t_out.size)
    status, k = results.Status(), 0
    t1 = time.perf_counter()
    mujoco.mj_forward(m, d)
    P[0], E[0] = d.qpos, d.energy.sum()
    for k in range(1, t_out.size):
        for _ in range(stride):
            apply_loads(model, m, d)
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
    return Result(solver="mujoco", case=case.name, t=t_out[:n], channels=channels.channels(
                      case, trajectory(case, model, m, t_out[:n], P[:n], E[:n])),
                  status=status, wall_s=wall_s, setup_s=setup_s, steps=(n - 1) * stride,
                  rhs_evals=4 * (n - 1) * stride,
                  settings={"integrator": "RK4", "dt": dt, "contacts": "disabled",
                            "model": "rigid limit: every beam rigid, undeformed reduced-body inertia"})
