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
- A cut joint (`case.loops`) is a Pinocchio rigid constraint between its child side (the child's
  frame at `child_at`, on a beam the snapped node) and its parent side (the input triad, as a
  tree joint's) (`pinocchio_model.loop_constraints`): a fixed one holds the two frames together
  (CONTACT_6D), a spherical one their origins (CONTACT_3D). A revolute one is the same point
  constraint, which with the tree's hinges makes a hinge on a planar loop (every joint on it
  turning about the cut's axis or sliding across it, `planar_loop`): the rows of the point
  constraint along the axis, which no motion reaches, carry no force. A prismatic cut joint, or
  a revolute one on a loop that is not planar, is not applicable (Pinocchio 4.1's rigid
  constraints hold a point or a frame, not a slide or a hinge).

A difference from `flexmbd` on a case whose beams are declared rigid is then an error in one of
the two models (with `beam_mass = "prism"` also flexmbd's lumping, 2/n^2 of the inertia across
each beam about its centre of mass); on a flexible case it is elasticity. Forward dynamics by
`aba` (by `crba` + `rnea` when some joints are prescribed), integrated by scipy's DOP853 at tight
tolerance. With loops, by `constraintDynamics` (Pinocchio's proximal solver of the constrained
equations, which takes the rank-deficient rows of a planar loop; the closure's acceleration
error driven to -w^2 e - 2 w de/dt, Baumgarte's correction at the rate w = `baumgarte`, so that
the closure's drift stays at the integrator's error); a prescribed joint's drive is then the
generalized force that gives it its profile's acceleration (`Rigid.closed`).

State y = [q; v] in Pinocchio's layout (quaternions [x, y, z, w], free flyer [p; quat] and
[v; w] in the joint frame), set from the case's initial values (`pinocchio_model.initial_state`);
with loops, the coordinates the closure fixes (the last free ones in tree order) then follow from
it, by Gauss-Newton on the position closure and the velocity closure J v = 0 (`Rigid.assemble`).
Channels: joint angles and energy (kinetic + gravitational, Pinocchio's own energy functions)
from the engine's state; a joint's reaction (what its parent side exerts on its child side, child
body axes) for a cut joint from its constraint force (moment about the joint point), for a tree
joint from `rnea` with the constraint forces acting on both sides of each cut (moment about the
child's origin; a fixed tree joint has none) (`Rigid.reactions`); deflections and stresses of the
rigid beams are identically zero (the trajectory holds no Beam).
"""

from __future__ import annotations

import time

import numpy as np
import pinocchio as pin
from scipy.integrate import DOP853, RK45, Radau

from flexmbd import cases
from flexmbd.harness import channels, cost, results
from flexmbd.mbd import profiles
from flexmbd.cases import closure
from flexmbd.solvers import common, pinocchio_model

RIGID = True                        # every beam rigid: deformation channels are zero, not compared
LOOPS = True                        # cut joints closed by Pinocchio's rigid constraints
SETTINGS = {
    "method": (("DOP853", "RK45", "Radau"), "DOP853"),
    "rtol": ("float+", 1e-12),
    "atol": ("float+", 1e-12),
    "beam_mass": (common.BEAM_MASS, "prism"),     # a beam's inertia: the prism, or its lumped mesh
    "baumgarte": ("float0+", 10.0),               # 1/s, rate at which a loop's closure error decays (0: off)
}
STYLE = {"color": "#9467bd", "marker": ">"}     # on the figures (report.figures.looks), solid lines
METHODS = {"DOP853": DOP853, "RK45": RK45, "Radau": Radau}
QUAT_JOINTS = ("JointModelSpherical", "JointModelFreeFlyer")
PROX_ACCURACY, PROX_MU, PROX_ITER = 1e-12, 1e-10, 20    # constraintDynamics' proximal iterations
ASSEMBLY_TOL, ASSEMBLY_ITER = 1e-14, 50                 # closing the loops at the start: error / size, steps


def version() -> str:
    return pin.__version__


def applies(case) -> str:
    if cases.is_fixed_base(case):
        return "every joint is fixed: nothing moves in the rigid limit"
    for name, j in case.loops.items():
        if j.type == "prismatic":
            return (f"cut joint {name!r} is prismatic: Pinocchio's rigid constraints hold a point or a whole frame "
                    f"together, not a slide")
        if j.type == "revolute" and not planar_loop(case, j):
            return (f"cut joint {name!r} is revolute on a loop whose joints do not all turn about its axis: "
                    f"Pinocchio's point constraint closes a hinge only on a planar loop")
    return ""


def stages(case, t_end, settings) -> list:
    """The costly stages of a run (`cost.stages`): the meshes of its beams (their rigid limit); its
    integration is not estimated."""
    return cost.modes(case, rigid=True)


def loop_joints(case, cut) -> list:
    """The tree joints on the loop a cut joint (cases.Joint) closes: those from its parent and
    its child up to their nearest common ancestor."""
    def up(body):
        path = [body]
        while path[-1] != "ground":
            path.append(case.joint_of(path[-1]).parent)
        return path
    a, b = up(cut.parent), up(cut.child)
    top = next(x for x in a if x in b)
    return [case.joint_of(x).name for x in a[:a.index(top)] + b[:b.index(top)]]


def planar_loop(case, cut) -> bool:
    """Whether the loop a revolute cut joint (cases.Joint) closes moves in the plane normal to its
    axis: its two sides' axes and its tree joints' axes parallel (prismatic ones across them,
    fixed ones anyhow) at the case's initial values, which turns about that axis keep so. Then
    the point constraint (CONTACT_3D) and the tree's hinges make the cut a hinge."""
    eng = Rigid(case)
    pin.forwardKinematics(eng.pm, eng.pd, eng.q0)

    def world(body, a):                             # a direction (3,) in the body's frame, in world axes
        jid, X = eng.frame[body]
        return eng.pd.oMi[jid].rotation @ X.rotation @ np.asarray(a)

    n = world(cut.parent, np.array(cut.triad) @ cut.axis)
    hinges = [world(cut.child, cut.axis)]
    for name in loop_joints(case, cut):
        j = case.joints[name]
        a = world(j.parent, np.array(j.triad) @ j.axis)
        if j.type in ("spherical", "free") or (j.type == "prismatic" and abs(a @ n) > 1e-9):
            return False
        if j.type == "revolute":
            hinges.append(a)
    return all(np.linalg.norm(np.cross(a, n)) < 1e-9 for a in hinges)


def rigid_case(case):
    """The case with every beam declared rigid (validated like any case): what flexmbd runs to
    compare with this peer (the peer itself makes every beam rigid when it reads the case)."""
    extra = [f"bodies.{n}.rigid=true" for n, b in case.bodies.items() if b.type == "beam"]
    return cases.load(str(case.path), list(case.overrides) + extra)


# ---------------------------------------------------------------------------------------------
# the engine side: equations of motion in Pinocchio's layout


class Rigid:
    """Pinocchio model and data of a case's rigid limit, with its prescribed joints, point loads
    and cut joints, built from the case (`common.rigid_bodies`, `pinocchio_model.rigid_model`,
    `pinocchio_model.loop_constraints`); `baumgarte` (1/s) the rate at which a closure error
    decays."""

    def __init__(self, case, beam_mass: str = "prism", baumgarte: float = SETTINGS["baumgarte"][1]):
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
        # cut joints: their constraints and data, Baumgarte's correction a = -w^2 e - 2 w de/dt
        self.cuts = list(case.loops)
        self.cm, self.cd = pin.StdVec_RigidConstraintModel(), pin.StdVec_RigidConstraintData()
        for c in pinocchio_model.loop_constraints(self.pm, self.frame, case.loops):
            c.setBaumgarteCorrectorParameters(pin.BaumgarteCorrectorParameters(baumgarte ** 2, 2.0 * baumgarte))
            self.cm.append(c)
            self.cd.append(c.createData())
        if self.cuts:
            pin.initConstraintDynamics(self.pm, self.pd, self.cm, self.cd)
        self.prox = pin.ProximalSettings(PROX_ACCURACY, PROX_MU, PROX_ITER)
        self.tau0 = np.zeros(self.nv)
        self.quats = any(j.shortname() in QUAT_JOINTS for j in self.pm.joints[1:])
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
        if not (self.prescribed or self.cuts or self.loads):        # a free tree: one call of aba
            return pin.aba(self.pm, self.pd, q, v, self.tau0), q, v
        q, v, a_p = self.impose(t, q.copy(), v.copy())
        fext = self.fext(t, q)
        if self.cuts:
            return self.closed(q, v, fext, a_p)[0], q, v
        if not self.prescribed:
            return pin.aba(self.pm, self.pd, q, v, self.tau0, fext), q, v
        # hybrid dynamics: M_ff a_f = -(b_f - f_ext,f) - M_fp a_p
        M = pin.crba(self.pm, self.pd, q)
        M = np.triu(M) + np.triu(M, 1).T
        b = pin.rnea(self.pm, self.pd, q, v, np.zeros(self.nv), fext)
        a = np.zeros(self.nv)
        a[self.pv] = a_p
        a[self.fv] = np.linalg.solve(M[np.ix_(self.fv, self.fv)], -b[self.fv] - M[np.ix_(self.fv, self.pv)] @ a_p)
        return a, q, v

    def closed(self, q, v, fext, a_p):
        """Accelerations (nv,) of the closed mechanism and the generalized forces tau (nv,) that
        produce them (`constrained`): the loads' J^T f, and on the prescribed joints the drive that
        gives them their accelerations a_p (np,). The accelerations are affine in tau: one solve
        per prescribed joint gives its column."""
        tau = np.zeros(self.nv)
        if self.loads:
            tau = pin.computeGeneralizedGravity(self.pm, self.pd, q) - pin.rnea(
                self.pm, self.pd, q, np.zeros(self.nv), np.zeros(self.nv), fext)
        a = self.constrained(q, v, tau)
        if self.prescribed:
            A = np.column_stack([self.constrained(q, v, tau + np.eye(self.nv)[k]) - a for k in self.pv])
            drive = np.linalg.solve(A[self.pv], a_p - a[self.pv])
            a, tau[self.pv] = a + A @ drive, tau[self.pv] + drive
            a[self.pv] = a_p
        return a, tau

    def constrained(self, q, v, tau) -> np.ndarray:
        """Accelerations (nv,) under the generalized forces tau (nv,) with the cut joints closed:
        Pinocchio's `constraintDynamics` (proximal iterations, which also solve the rows of a
        planar loop's point constraints that no motion reaches); their forces left in self.cd."""
        return pin.constraintDynamics(self.pm, self.pd, q, v, tau, self.cm, self.cd, self.prox).copy()

    def reactions(self, t, q, v) -> dict:
        """Joint name -> [moment; force] (6,) at time t: what the joint transmits from its parent
        side onto its child side, in the child's body axes. A cut joint's is its constraint force
        (moment about the joint point); a tree joint's (but a fixed one's) the spatial force `rnea`
        finds across it (moment about the child's origin), the cut joints' forces acting on both
        their sides as external forces."""
        q, v, a_p = self.impose(t, q.copy(), v.copy())
        fext, out = self.fext(t, q), {}
        if self.cuts:
            a, tau = self.closed(q, v, fext, a_p)
            self.constrained(q, v, tau)
            for name, c, d in zip(self.cuts, self.cm, self.cd):
                f = d.contact_force                         # on side 1, at its origin, in its axes
                out[name] = np.r_[f.angular, f.linear]
                fext[c.joint1_id] = fext[c.joint1_id] + c.joint1_placement.act(f)
                fext[c.joint2_id] = fext[c.joint2_id] - self.pd.oMi[c.joint2_id].actInv(d.oMc1).act(f)
        else:
            a = self.qdd(t, q, v)[0]
        pin.rnea(self.pm, self.pd, q, v, a, fext)
        return out | {name: np.r_[self.pd.f[j.id].angular, self.pd.f[j.id].linear] for name, j in self.joint.items()}

    def closure(self, q) -> tuple[np.ndarray, np.ndarray]:
        """The cut joints' closure error e (nc,) and its Jacobian (nc, nv) at q: per cut, its child
        side's origin minus its parent side's (and for CONTACT_6D the rotation between them, log6),
        in the child side's axes."""
        pin.computeJointJacobians(self.pm, self.pd, q)
        e, J = [], []
        for c, d in zip(self.cm, self.cd):
            c.calc(self.pm, self.pd, d)
            e.append(-pin.log6(d.c1Mc2).vector if c.type == pin.ContactType.CONTACT_6D else -d.c1Mc2.translation)
            J.append(pin.getConstraintJacobian(self.pm, self.pd, c, d))
        return np.concatenate(e), np.vstack(J)

    def start(self) -> tuple[np.ndarray, np.ndarray]:
        """The initial state (q (nq,), v (nv,)): the case's values, prescribed joints on their
        profiles at t = 0, the loops closed (`assemble`)."""
        q, v, _ = self.impose(0.0, self.q0.copy(), self.v0.copy())
        return self.assemble(q, v) if self.cuts else (q, v)

    def assemble(self, q, v) -> tuple[np.ndarray, np.ndarray]:
        """The closed state (q (nq,), v (nv,)) from the guess q, v: the coordinates the closure
        fixes (`cases.closure.pick`) moved by Gauss-Newton until the cut joints close, their rates solved
        from the closure's velocity J v = 0; the others (the independent and the prescribed
        joints) kept. ValueError when the loops do not close."""
        e, J = self.closure(q)
        free = list(self.fv[::-1])
        dep = np.sort(np.array(closure.pick(J[:, free], free), dtype=int))   # the first declared stay independent
        tol = ASSEMBLY_TOL * (1.0 + max(np.linalg.norm(X.translation) for X in self.pm.jointPlacements))
        for _ in range(ASSEMBLY_ITER):
            if np.abs(e).max() <= tol:
                break
            dq = np.zeros(self.nv)
            dq[dep] = -np.linalg.lstsq(J[:, dep], e, rcond=None)[0]
            q = pin.integrate(self.pm, q, dq)
            e, J = self.closure(q)
        else:
            raise ValueError(f"the loops do not close from the case's initial values (error {np.abs(e).max():.3g})")
        ind = np.setdiff1d(np.arange(self.nv), dep)
        v = v.copy()
        v[dep] = -np.linalg.lstsq(J[:, dep], J[:, ind] @ v[ind], rcond=None)[0]
        return q, v

    def rhs(self, t, y):
        """dy/dt for y = [q; v]."""
        self.evals += 1
        q, v = y[:self.nq], y[self.nq:]
        a, q, v = self.qdd(t, q, v)
        return np.concatenate([qdot(self.pm, q, v) if self.quats else v, a])

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
            return Y[:k], steps, results.diverged(results.STATE_NOT_FINITE, sol.t)
    return Y, steps, results.Status()


def trajectory(case, eng: Rigid, t, Q, V) -> channels.Trajectory:
    """The trajectory from Pinocchio states Q (n, nq), V (n, nv), with the bodies' poses (`poses`)
    and the reactions (n, 6) [moment; force] of the joints the channels name (`Rigid.reactions`;
    a fixed tree joint has none)."""
    traj = common.rigid_trajectory(case, t, lambda jname: Q[:, eng.joint[jname].idx_q].copy(),
                                   lambda: np.array([eng.energy(q, v) for q, v in zip(Q, V)]))
    traj.poses = poses(eng, Q)
    wanted = {c.joint for c in case.channels.values() if c.kind.startswith("reaction")}
    if wanted:
        R = [eng.reactions(tk, q, v) for tk, q, v in zip(t, Q, V)]
        traj.reactions = {name: np.array([r[name] for r in R]) for name in wanted if name in R[0]}
    return traj


def poses(eng: Rigid, Q) -> dict:
    """Body name -> (R (n, 3, 3) body -> global, p (n, 3)) of every body at the states Q (n, nq)
    (`channels.Trajectory.poses`): Pinocchio's forward kinematics, its joint's placement oMi
    composed with the body frame's placement in the joint (`pinocchio_model.rigid_model`)."""
    out = {b.name: (np.zeros((len(Q), 3, 3)), np.zeros((len(Q), 3))) for b in eng.bodies}
    for k, q in enumerate(Q):
        pin.forwardKinematics(eng.pm, eng.pd, q)
        for name, (R, p) in out.items():
            jid, placement = eng.frame[name]
            M = eng.pd.oMi[jid] * placement
            R[k], p[k] = M.rotation, M.translation
    return out


def run(case, t_end, settings):
    from flexmbd.harness.results import Result
    t0 = time.perf_counter()
    opt = {k: settings.get(k, d) for k, (_, d) in SETTINGS.items()}
    eng = Rigid(case, opt["beam_mass"], opt["baumgarte"])
    t_out = common.sample_times(case, t_end)
    out = dict(solver="pinocchio", case=case.name, settings={**opt, "model": common.rigid_limit_text(opt["beam_mass"])})
    try:
        q0, v0 = eng.start()
    except ValueError as e:
        return Result(t=t_out[:0], status=results.failed(str(e), 0.0), **out)
    setup_s = time.perf_counter() - t0

    t1 = time.perf_counter()
    Y, steps, status = integrate(eng, np.concatenate([q0, v0]), t_out, opt["method"], opt["rtol"], opt["atol"])
    wall_s = time.perf_counter() - t1

    # prescribed joints exactly on their profiles at the samples
    t_out = t_out[:len(Y)]
    Q, V = Y[:, :eng.nq].copy(), Y[:, eng.nq:].copy()
    for k, t in enumerate(t_out):
        Q[k], V[k], _ = eng.impose(t, Q[k], V[k])
    traj = trajectory(case, eng, t_out, Q, V)
    return Result(t=t_out, trajectory=traj, status=status, wall_s=wall_s, setup_s=setup_s, steps=steps,
                  rhs_evals=eng.evals, **out)
