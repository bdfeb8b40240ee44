"""`example-pendulum`: a minimal flexmbd solver plug-in (docs/plugins.md).

The rigid limit of a hinged slender beam: one beam on a revolute joint to ground about z, the beam
along x at zero angle, no prescribed motion. Its angle obeys

    theta'' = (3 / 2L) (g_y cos(theta) - g_x sin(theta))

(uniform slender rod, I_O = m L^2 / 3; the section's own inertia is left out), integrated by
scipy's DOP853. It reports its trajectory, the joint's angle; flexmbd forms the case's channels
from it: the joint_angle channels, and zero deflections and stresses of its rigid beam, which
the report does not compare (RIGID).

A solver is a module with SETTINGS, version(), applies(case) and run(case, t_end, settings); it
reads the case's typed values (`case.bodies`, `case.joints`, `case.integrator`, ...) and returns a
Result carrying its `channels.Trajectory`. The entry point (group "flexmbd.solvers") names the module.
"""

import time

import numpy as np
from scipy.integrate import solve_ivp

RIGID = True                           # a rigid model: deformation channels are not compared
SETTINGS = {"rtol": ("float+", 1e-10), "atol": ("float+", 1e-12)}


def version() -> str:
    return "0.1.0"


def applies(case) -> str:
    """'' for one beam hinged to ground about z, released free; else why not."""
    if len(case.bodies) != 1 or len(case.joints) != 1:
        return "a single hinged beam only"
    (body,), (joint,) = case.bodies.values(), case.joints.values()
    if body.type != "beam" or joint.type != "revolute" or joint.parent != "ground":
        return "a single beam on a revolute joint to ground only"
    if joint.axis != (0.0, 0.0, 1.0) or joint.motion is not None:
        return "a free joint about z only"
    return ""


def run(case, t_end, settings):
    from flexmbd.harness.channels import Trajectory
    from flexmbd.harness.results import Result, Status, failed
    (body,), (joint,) = case.bodies.values(), case.joints.values()
    L, (gx, gy, _) = body.length, case.gravity
    dt = case.integrator.output_dt                      # the case's output instants 0, dt, ...
    t = np.linspace(0.0, round(t_end / dt) * dt, int(round(t_end / dt)) + 1)
    start = time.perf_counter()
    sol = solve_ivp(lambda _, y: [y[1], 1.5 / L * (gy * np.cos(y[0]) - gx * np.sin(y[0]))],
                    (0.0, t[-1]), [joint.q0[0], joint.qd0[0]], method="DOP853", t_eval=t,
                    rtol=settings["rtol"], atol=settings["atol"])
    wall = time.perf_counter() - start
    return Result(solver="example-pendulum", case=case.name, t=sol.t,
                  trajectory=Trajectory(t=sol.t, joints={joint.name: sol.y[0]}),
                  status=Status() if sol.success else failed(sol.message, float(sol.t[-1])),
                  wall_s=wall, steps=int(sol.nfev // 12), rhs_evals=int(sol.nfev),
                  settings={"rtol": settings["rtol"], "atol": settings["atol"], "model": "rigid slender rod"})
