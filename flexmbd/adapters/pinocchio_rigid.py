"""`pinocchio`: the rigid limit of a case, in Pinocchio.

The model is built from the case itself, as a user of Pinocchio would build it, never from
flexmbd's Model (`build.from_case`), so that it checks flexmbd rather than repeating it:
`common.rigid_bodies` reads the case's bodies, materials and joints, and
`pinocchio_model.rigid_model` builds the tree through Pinocchio's model API (`addJoint`,
`appendBodyToJoint`, `pin.Inertia`, `pin.SE3`; no URDF: it has no spherical joint and one
floating base only).

- Every beam, flexible or declared rigid, is a rigid prism (`common.beam_inertia`): mass
  m = rho A L, centre of mass [L/2, 0, 0] on its axis, inertia about the centre of mass
  I_c = diag(rho L (Iy + Iz), m L^2/12 + rho L Iy, m L^2/12 + rho L Iz), with A, Iy = int z^2 dA,
  Iz = int y^2 dA of the section in closed form (docs/formulation.md, "rigid limit of a beam for
  the rigid peers"). Setting `beam_mass = "lumped"` models the case's mesh of n elements with
  lumped node masses instead, the rigid body flexmbd integrates for a beam declared rigid: the
  terms across the beam become m L^2/12 (1 + 2/n^2), the rest is the same.
- A rigid body takes its mass, centre of mass and inertia (about the centre of mass) as the case
  gives them.
- A joint's input triad sits at `at` in the parent frame (ground, rigid body) or, on a beam, at
  the node `at` snaps to, [x, 0, 0] on the parent's axis (`case.joints[name].x`, the
  same node flexmbd uses), turned by the rotation of its `rpy`; the child's body frame is the
  joint's output frame (Pinocchio's joint frame), the joint axis a unit vector in it.
- Point loads act at `at` on a rigid body, at the snapped node [x, 0, 0] on a beam, in the body
  or the global frame, scaled by their time profile.

A difference from `flexmbd` on a case whose beams are declared rigid is then an error in one of
the two models (with `beam_mass = "prism"` also flexmbd's lumping, 2/n^2 of the inertia across
each beam about its centre of mass); on a flexible case it is elasticity. Forward dynamics by
`aba` (by `crba` + `rnea` when some joints are prescribed), integrated by scipy's DOP853 at tight
tolerance.

State y = [q; v] in Pinocchio's layout (quaternions [x, y, z, w], free flyer [p; quat] and
[v; w] in the joint frame), set from the case's initial values (`pinocchio_model.initial_state`).
Channels: joint angles and energy (kinetic + gravitational, Pinocchio's own energy functions)
from the engine's state; deflections and stresses of the rigid beams are identically zero (the
trajectory holds no Beam).
"""

from __future__ import annotations

import time

import numpy as np
import pinocchio as pin
from scipy.integrate import DOP853, RK45, Radau

from flexmbd import cases, channels, profiles, results
from flexmbd.adapters import common, pinocchio_model

RIGID = True                        # every beam rigid: deformation channels are zero, not compared
SETTINGS = {
    "method": (("DOP853", "RK45", "Radau"), "DOP853"),
    "rtol": ("float+", 1e-12),
    "atol": ("float+", 1e-12),
    "beam_mass": (common.BEAM_MASS, "prism"),     # a beam's inertia: the prism, or its lumped mesh
}
METHODS = {"DOP853": DOP853, "RK45": RK45, "Radau": Radau}
QUAT_JOINTS = ("JointModelSpherical", "JointModelFreeFlyer")


def version() -> str:
    return pin.__version__


def applies(case) -> str:
    if cases.is_fixed_base(case):
        return "every joint is fixed: nothing moves in the rigid limit"
    return ""


def rigid_case(case):
    """The case with every beam declared rigid (validated like any case): what flexmbd runs to
    compare with this peer (the peer itself makes every beam rigid when it reads the case)."""
    extra = [f"bodies.{n}.rigid=true" for n, b in case.bodies.items() if b.type == "beam"]
    return cases.load(str(case.path), list(case.overrides) + extra)


# ---------------------------------------------------------------------------------------------
# the engine side: equations of motion in Pinocchio's layout


class Rigid:
    """Pinocchio model and data of a case's rigid limit, with its prescribed joints and point
    loads, built from the case (`common.rigid_bodies`, `pinocchio_model.rigid_model`)."""

    def __init__(self, case, beam_mass: str = "prism"):
        self.bodies = common.rigid_bodies(case, beam_mass)
        self.pm, self.frame = pinocchio_model.rigid_model(self.bodies, case.gravity)
        self.pd = self.pm.createData()
        self.nq, self.nv = self.pm.nq, self.pm.nv
        self.q0, self.v0 = pinocchio_model.initial_state(self.pm, self.bodies, self.frame)
        # the Pinocchio joint of each case joint that has one (fixed joints have none)
        self.joint = {b.joint: self.pm.joints[self.frame[b.name][0]] for b in self.bodies if b.type != "fixed"}
        # prescribed 1-DOF joints: (pin q index, pin v index, profile, the case's q0)
        self.prescribed = [(self.joint[b.joint].idx_q, self.joint[b.joint].idx_v, b.motion, b.q0[0])
                           for b in self.bodies if b.motion is not None]
        self.pv = np.array([k[1] for k in self.prescribed], dtype=int)
        self.fv = np.setdiff1d(np.arange(self.nv), self.pv)
        # point loads: (pin joint id, body placement in it, point (3,) and force (3,) body frame, global?, profile)
        self.loads = [(*self.frame[ld.body], ld.point, ld.force, ld.glob, ld.profile)
                      for ld in common.rigid_loads(case) if self.frame[ld.body][0] != 0]
        self.evals = 0

    def impose(self, t, q, v):
        """q, v with prescribed joints set from their profiles; their accelerations (np,)."""
        a = np.zeros(len(self.prescribed))
        for k, (iq, iv, p, q0) in enumerate(self.prescribed):
            q[iq], v[iv], a[k] = profiles.motion(p, t, q0)
        return q, v, a

    def fext(self, t, q):
        """External forces per Pinocchio joint, in the joint frame ([linear; angular] at its origin)."""
        f = [pin.Force.Zero() for _ in range(self.pm.njoints)]
        if any(ld[4] for ld in self.loads):
            pin.forwardKinematics(self.pm, self.pd, q)
        for jid, X, point, force, glob, prof in self.loads:
            fb = force * float(profiles.load_factor(prof, t))
            if glob:                                            # global direction -> body frame
                fb = (self.pd.oMi[jid].rotation @ X.rotation).T @ fb
            fj, pj = X.rotation @ fb, X.act(point)
            f[jid] = f[jid] + pin.Force(fj, np.cross(pj, fj))
        return f

    def qdd(self, t, q, v):
        """Accelerations (nv,) at time t; prescribed joints follow their profiles."""
        q, v, a_p = self.impose(t, q.copy(), v.copy())
        fext = self.fext(t, q)
        if not self.prescribed:
            return pin.aba(self.pm, self.pd, q, v, np.zeros(self.nv), fext), q, v
        # hybrid dynamics: M_ff a_f = -(b_f - f_ext,f) - M_fp a_p
        M = pin.crba(self.pm, self.pd, q)
        M = np.triu(M) + np.triu(M, 1).T
        b = pin.rnea(self.pm, self.pd, q, v, np.zeros(self.nv), fext)
        a = np.zeros(self.nv)
        a[self.pv] = a_p
        a[self.fv] = np.linalg.solve(M[np.ix_(self.fv, self.fv)], -b[self.fv] - M[np.ix_(self.fv, self.pv)] @ a_p)
        return a, q, v

    def rhs(self, t, y):
        """dy/dt for y = [q; v]."""
        self.evals += 1
        q, v = y[:self.nq], y[self.nq:]
        a, q, v = self.qdd(t, q, v)
        return np.concatenate([qdot(self.pm, q, v), a])

    def energy(self, q, v) -> float:
        """Kinetic + gravitational potential energy, J."""
        return pin.computeKineticEnergy(self.pm, self.pd, q, v) + pin.computePotentialEnergy(self.pm, self.pd, q)


def qdot(pm, q, v) -> np.ndarray:
    """dq/dt (nq,): v for 1-DOF joints; for quaternions [x, y, z, w] 1/2 q (x) [w_local; 0];
    for the free flyer's position R v_local."""
    dq = np.zeros(pm.nq)
    for j in pm.joints[1:]:
        iq, iv, name = j.idx_q, j.idx_v, j.shortname()
        if name not in QUAT_JOINTS:
            dq[iq:iq + j.nq] = v[iv:iv + j.nv]
            continue
        k, w = iq, v[iv:iv + 3]
        if name == "JointModelFreeFlyer":
            quat = q[iq + 3:iq + 7]
            dq[iq:iq + 3] = pin.Quaternion(quat[3], *quat[:3]).toRotationMatrix() @ v[iv:iv + 3]
            k, w = iq + 3, v[iv + 3:iv + 6]
        x, s = q[k:k + 3], q[k + 3]
        dq[k:k + 3] = 0.5 * (s * w + np.cross(x, w))
        dq[k + 3] = -0.5 * x @ w
    return dq


# ---------------------------------------------------------------------------------------------
# the solver


def integrate(eng: Rigid, y0, t_out, method: str, rtol: float, atol: float):
    """States Y (n, nq + nv) at t_out, steps, status."""
    Y = np.full((t_out.size, y0.size), np.nan)
    Y[0] = y0
    if y0.size == 0 or eng.nv == 0:                             # nothing moves (all joints fixed)
        return np.tile(y0, (t_out.size, 1)), 0, results.Status()
    sol = METHODS[method](eng.rhs, 0.0, y0, t_out[-1], rtol=rtol, atol=atol)
    k, steps = 1, 0
    while sol.status == "running":
        msg = sol.step()
        if sol.status == "failed":
            return Y[:k], steps, results.failed(f"{method}: {msg}", sol.t)
        steps += 1
        dense = sol.dense_output()
        while k < t_out.size and t_out[k] <= sol.t + 1e-12:
            Y[k] = dense(t_out[k])
            k += 1
        if not np.all(np.isfinite(sol.y)):
            return Y[:k], steps, results.failed("non-finite state", sol.t)
    return Y, steps, results.Status()


def trajectory(case, eng: Rigid, t, Q, V) -> channels.Trajectory:
    """The trajectory from Pinocchio states Q (n, nq), V (n, nv)."""
    return common.rigid_trajectory(case, t, lambda jname: Q[:, eng.joint[jname].idx_q].copy(),
                                   lambda: np.array([eng.energy(q, v) for q, v in zip(Q, V)]))


def run(case, t_end, settings):
    from flexmbd.results import Result
    t0 = time.perf_counter()
    beam_mass = settings.get("beam_mass", SETTINGS["beam_mass"][1])
    eng = Rigid(case, beam_mass)
    setup_s = time.perf_counter() - t0

    method = settings.get("method", SETTINGS["method"][1])
    rtol = settings.get("rtol", SETTINGS["rtol"][1])
    atol = settings.get("atol", SETTINGS["atol"][1])
    t_out = common.sample_times(case, t_end)
    q0, v0, _ = eng.impose(0.0, eng.q0.copy(), eng.v0.copy())

    t1 = time.perf_counter()
    Y, steps, status = integrate(eng, np.concatenate([q0, v0]), t_out, method, rtol, atol)
    wall_s = time.perf_counter() - t1

    # prescribed joints exactly on their profiles at the samples
    t_out = t_out[:len(Y)]
    Q, V = Y[:, :eng.nq].copy(), Y[:, eng.nq:].copy()
    for k, t in enumerate(t_out):
        Q[k], V[k], _ = eng.impose(t, Q[k], V[k])
    traj = trajectory(case, eng, t_out, Q, V)
    return Result(solver="pinocchio", case=case.name, t=t_out,
                  trajectory=traj, status=status, wall_s=wall_s, setup_s=setup_s, steps=steps,
                  rhs_evals=eng.evals,
                  settings={"method": method, "rtol": rtol, "atol": atol, "beam_mass": beam_mass,
                            "model": common.rigid_limit_text(beam_mass)})
