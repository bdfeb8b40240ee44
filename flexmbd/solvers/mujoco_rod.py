"""`mujoco-rod`: each beam as a MuJoCo 1D `flexcomp` elastic rod (discrete elastic rod, DER).

MuJoCo 4 removed the `cable` plugin and the `composite` element; a rod is now a flexcomp with
`dim="1"` and `<elasticity young=...>` (changelog 4.0.0, Deformables, items 9-12). The traps,
and how they are handled here (docs/peers.md has the evidence):

- the clamp: `<pin id="0 1"/>` clamps the first edge's material frame to the parent body, and the
  first bending hinge sits at vertex 1, whose Voronoi segment starts at the middle of edge 0. The
  effective clamp is therefore at the middle of the first edge, so edge 0 straddles the
  attachment point: vertices at x_k = (k - 1/2) l, k = 0..ne, with l = L / (ne - 1/2), so
  vertex 0 sits at -l/2 (inside the support), vertex 1 at +l/2 and the tip vertex at L;
- stretching: DER has no axial stiffness, so every edge carries an equality constraint, made
  stiff (solref timeconst `edge_timeconst`, maximal impedance); a soft one lets the rod stretch;
- mass: flexcomp gives every vertex body `mass / npoints` and drops pinned vertices; the vertex
  bodies get the rod's own lumped distribution instead (rho A l inside, rho A l / 2 at the tip),
  and the segment [0, l] that the pinned vertex 1 stands for becomes the inertia of the parent
  body (a uniform bar of mass rho A l, centred at l/2), so the total is rho A L;
- integration: rod elasticity needs the `discrete` integrator (implicit in position; backward-
  Euler dissipation, damping ratio ~ w h / 2 per mode) or an explicit one with a tiny step.

The parent body is the world (fixed joint) or a body with a hinge at the joint (revolute joint
to ground). A rigid body joined to the rod (a tip mass) is not modelled: it would have to turn
with the rod's material frame at a vertex, and a flexcomp rod's vertex bodies carry three slides
and a twist hinge about the rod's x axis, so their frames do not turn as the rod bends. A point
mass on the rod is modelled, as it needs no turning: its mass joins the vertex body nearest to where
the case puts it (`point_masses`; on the support, vertices 0 and 1, a welded body of its mass and
no inertia at the vertex, in the parent body). A box
section of half-sizes (extent along y, extent along z) / 2 gives the rod the beam's two bending
stiffnesses (checked: 23.29 mm / 52.4 mm static tip deflections).

The trajectory (`flexmbd.harness.channels`), from the rod's own vertex positions in the root frame (the
parent body's frame, which holds the clamped first edge, i.e. the frame attached to the root and
tangent to the beam there):
  deflection   position of the rod point at `at` (linear between vertices) minus its undeformed one;
  stress_vm    curvatures (kappa_y, kappa_z) = (kb_y, kb_z) (no axial strain: the edges are
               inextensible), with the discrete curvature binormal kb_k = 2 e_{k-1} x e_k / (|e_{k-1}||e_k| +
               e_{k-1}.e_k) divided by the Voronoi length (l_{k-1} + l_k)/2 at vertex k, linearly
               interpolated between the two vertices that bracket `at`;
  joint_angle  the hinge coordinate (angle of the clamped first edge from +x);
  energy       MuJoCo's kinetic and gravitational energy (mj_energyVel / mj_energyPos) plus the
               rod's bending energy, sum_k k1 kb_1^2 + k2 kb_2^2 with k = E I / (l_{k-1} + l_k)
               (MuJoCo's DER energy; torsion is not excited in the planar cases).
"""

from __future__ import annotations

import time

import numpy as np

import mujoco
from flexmbd import cases
from flexmbd.harness import channels, cost, results
from flexmbd.mbd import profiles
from flexmbd.solvers import common
from flexmbd.solvers.mujoco_common import fmt, rot_to_quat
from flexmbd.harness.progress import Progress

SETTINGS = {
    "edges": ("int+", 40),                  # rod edges per beam
    "dt": ("float+", 5e-5),                 # s, discrete-integrator step (divides output_dt)
    "edge_timeconst": ("float+", 1e-6),     # s, solref time constant of the edge equalities
    "integrator": (("discrete", "RK4", "Euler"), "discrete"),
}
STYLE = {"color": "#d62728", "marker": "<"}     # on the figures (report.figures.looks), solid lines


def version() -> str:
    return mujoco.__version__


def applies(case) -> str:
    masses = point_masses(case)
    bodies = {n: b for n, b in case.bodies.items() if n not in masses}
    joints = {n: j for n, j in case.joints.items() if j.child not in masses}
    for n in masses:
        j = case.joint_of(n)
        if j.parent not in bodies or bodies[j.parent].type != "beam" or bodies[j.parent].rigid:
            return f"point mass {n!r}: only on the rod (its joint {j.name!r} is not on a flexible beam)"
    rigid = next((n for n, b in bodies.items() if b.type == "rigid" or b.rigid), None)
    if rigid is not None and any(b.type == "beam" and not b.rigid for b in bodies.values()):
        return (f"body {rigid!r}: a rigid body joined to a rod needs the rod's material frame at a vertex, which "
                f"the flexcomp rod's vertex bodies (three slides and a twist hinge) do not turn with")
    if len(bodies) != 1 or len(joints) != 1:
        return "one beam on one joint only (a hinge on a rod vertex has no material frame to follow)"
    (name, body), (jname, j) = next(iter(bodies.items())), next(iter(joints.items()))
    if body.type != "beam" or body.rigid:
        return f"body {name!r} is not a flexible beam"
    if j.parent != "ground" or j.type not in ("fixed", "revolute"):
        return f"joint {jname!r}: only a fixed or revolute joint to ground"
    if j.motion is not None:
        return f"joint {jname!r}: prescribed motion is not modelled"
    if body.section.shape != "rectangle":
        return "rectangular sections only (box section of the rod)"
    if body.damping_ratio > 0:
        return "modal damping has no counterpart in the rod"
    if body.stiffness_damping > 0:
        return "material damping (stiffness_damping) is not modelled in the rod"
    return ""


def stages(case, t_end, settings) -> list:
    """The costly stages of a run (`cost.stages`): MuJoCo's rod, steps x edges, with progress shown."""
    edges = settings["edges"]
    st = cost.fixed_step(case, t_end, settings["dt"], "solvers.mujoco-rod.dt", 1e-5 + 4e-6 * edges)[0]
    key = "solvers.mujoco-rod.edges" if edges > 1000 else st.key
    return [cost.Stage(f"{st.what} with a rod of {edges} edges", key, memory=8.0 * 2000 * edges, seconds=st.seconds,
                       progress=True)]


def point_masses(case) -> dict:
    """The case's point masses: name -> (mass, position along the beam as the case gives it, m)."""
    return {n: (b.mass, case.joint_of(n).point.x if case.joint_of(n).point else None)
            for n, b in case.bodies.items() if b.type == "point_mass"}


def rod_of(case) -> tuple:
    """(name, body, joint) of the case's one beam (its other bodies are point masses on it)."""
    name = next(n for n, b in case.bodies.items() if b.type == "beam")
    return name, case.bodies[name], case.joint_of(name)


def vertex_masses(case, s: np.ndarray) -> dict:
    """Vertex k -> the point masses at it (kg): each at the vertex of positions s nearest to where
    the case puts it (the vertices are not the case's FE nodes, as for a load, `apply_loads`)."""
    out = {}
    for m, x in point_masses(case).values():
        k = int(np.argmin(np.abs(s - x)))
        out[k] = out.get(k, 0.0) + m
    return out


# ---------------------------------------------------------------------------------------------
# the rod: geometry, section, model text


def rod_points(L: float, ne: int) -> tuple[np.ndarray, float]:
    """Vertex positions along the beam x_k = (k - 1/2) l (ne + 1,) and the edge length l. But for
    the tip they are not the case's FE nodes (x = i L / elements): the first edge straddles the
    clamp (vertex 0 at -l/2) and there are `edges` of them, not `elements`."""
    l = L / (ne - 0.5)
    return (np.arange(ne + 1) - 0.5) * l, l


def section(body: cases.Beam) -> tuple[float, float]:
    """Extents of the rectangle along the body's y and z axes, m."""
    s = body.section
    return (s.h, s.b) if s.h_axis == "y" else (s.b, s.h)


def mjcf(case, ne: int, dt: float, tc: float, integrator: str) -> str:
    """MJCF text of the case's beam as a rod named `rod` in a parent body `root`."""
    _, body, j = rod_of(case)
    mat = body.material
    L, (ey, ez) = body.length, section(body)
    x, l = rod_points(L, ne)
    A = ey * ez
    m_seg = mat.rho * A * l                                 # the segment [0, l] held by the root
    r = np.asarray(j.offset, dtype=float)                   # the joint on ground
    R = np.array(j.triad)
    axis = np.asarray(j.axis, dtype=float)
    hinge = f'<joint name="pivot" type="hinge" axis="{fmt(axis)}"/>' if j.type == "revolute" else ""
    pts = " ".join(fmt(xk, 0.0, 0.0) for xk in x)
    support = "".join(f'<body pos="{fmt(x[k], 0.0, 0.0)}"><inertial pos="0 0 0" mass="{fmt(m)}" '
                      f'diaginertia="0 0 0"/></body>' for k, m in vertex_masses(case, x).items() if k < 2)
    elements = " ".join(f"{k} {k + 1}" for k in range(ne))
    q0 = float(j.q0[0]) if j.q0 else 0.0
    return f'''<mujoco model="flexmbd rod">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="{fmt(dt)}" integrator="{integrator}" solver="Newton" gravity="{fmt(case.gravity)}"
          tolerance="1e-12" iterations="200">
    <flag contact="disable" energy="enable" refsafe="disable"/>
  </option>
  <worldbody>
    <body name="root" pos="{fmt(r)}" quat="{fmt(rot_to_quat(R))}">
      <inertial pos="{fmt(l / 2, 0, 0)}" mass="{fmt(m_seg)}"
                diaginertia="{fmt(m_seg * (ey ** 2 + ez ** 2) / 12, m_seg * (l ** 2 + ez ** 2) / 12, m_seg * (l ** 2 + ey ** 2) / 12)}"/>
      {hinge}
      {support}
      <flexcomp name="rod" type="direct" dim="1" point="{pts}" element="{elements}"
                mass="{fmt(m_seg * (ne + 1))}" radius="{fmt(min(ey, ez) / 2)}">
        <pin id="0 1"/>
        <edge equality="true" solref="{fmt(tc)} 1" solimp="0.9999 0.9999 0.001 0.5 2"/>
        <elasticity young="{fmt(mat.E)}" poisson="{fmt(mat.nu)}" section="box" sectionsize="{fmt(ey / 2, ez / 2)}"/>
        <contact contype="0" conaffinity="0"/>
      </flexcomp>
    </body>
  </worldbody>
</mujoco>
''', q0


def compile_rod(case, ne: int, dt: float, tc: float, integrator: str):
    """MjModel of the rod with the beam's lumped vertex masses (rho A l inside, rho A l / 2 at the tip)
    and the point masses at their vertices (`vertex_masses`)."""
    _, body, _ = rod_of(case)
    rho = body.material.rho
    ey, ez = section(body)
    x, l = rod_points(body.length, ne)
    text, q0 = mjcf(case, ne, dt, tc, integrator)
    spec = mujoco.MjSpec.from_string(text)
    point = vertex_masses(case, x)
    for k in range(2, ne + 1):
        spec.body(f"rod_{k}").mass = rho * ey * ez * l * (0.5 if k == ne else 1.0) + point.get(k, 0.0)
    m = spec.compile()
    return m, q0


def vertex_positions(m, d, ne: int) -> np.ndarray:
    """Rod vertices (ne + 1, 3) in the world: 0 and 1 pinned to `root`, the rest vertex bodies."""
    root = m.body("root").id
    R, p = d.xmat[root].reshape(3, 3), d.xpos[root]
    x = np.zeros((ne + 1, 3))
    for k in range(2):
        x[k] = p + R @ m.flex_vert[m.flex_vertadr[0] + k]
    for k in range(2, ne + 1):
        x[k] = d.xpos[m.body(f"rod_{k}").id]
    return x


# ---------------------------------------------------------------------------------------------
# channels from the rod's vertices


def root_frame(m, d) -> tuple[np.ndarray, np.ndarray]:
    """(R (3, 3) root frame -> world, origin (3,)): the frame holding the clamped first edge."""
    root = m.body("root").id
    return d.xmat[root].reshape(3, 3).copy(), d.xpos[root].copy()


def curvatures(X) -> np.ndarray:
    """Discrete curvature vectors (ne + 1, 3) at the vertices of a polyline X (ne + 1, 3), 1/m:
    2 e0 x e1 / (|e0||e1| + e0.e1) / ((|e0| + |e1|)/2); zero at the two end vertices."""
    e = np.diff(X, axis=0)
    n = np.linalg.norm(e, axis=1)
    kb = 2.0 * np.cross(e[:-1], e[1:]) / (n[:-1] * n[1:] + np.einsum("ij,ij->i", e[:-1], e[1:]))[:, None]
    out = np.zeros_like(X)
    out[1:-1] = kb / (0.5 * (n[:-1] + n[1:]))[:, None]
    return out


def bending_energy(X, E: float, Iz: float, Iy: float, l0: float) -> float:
    """MuJoCo's DER bending energy sum_k k |kb|^2, k = E I / (2 l0), per bending plane (root frame)."""
    kappa = curvatures(X)[1:-1] * l0                        # kb = kappa * Voronoi length (= l0 at rest)
    return float(np.sum(E * Iz / (2 * l0) * kappa[:, 2] ** 2 + E * Iy / (2 * l0) * kappa[:, 1] ** 2))


def sample(case, m, d, ne: int, l: float) -> dict:
    """What the trajectory needs of the current state: vertex positions X (ne + 1, 3) in the
    root frame and that frame's pose R, p (`root_frame`), the hinge coordinate q, and the energy
    E (MuJoCo's plus the rod's bending energy)."""
    _, body, _ = rod_of(case)
    R, p = root_frame(m, d)
    X = (vertex_positions(m, d, ne) - p) @ R
    out = {"X": X, "R": R, "p": p, "q": d.qpos[m.jnt_qposadr[m.joint("pivot").id]] if "pivot" in names(m) else 0.0}
    if channels.wants_energy(case):
        ey, ez = section(body)
        mujoco.mj_energyPos(m, d)
        mujoco.mj_energyVel(m, d)
        out["E"] = d.energy.sum() + bending_energy(X, body.material.E, ez * ey ** 3 / 12, ey * ez ** 3 / 12, l)
    return out


def trajectory(case, rows: list, t: np.ndarray, s: np.ndarray) -> channels.Trajectory:
    """The channels' view of the samples `rows` (see `sample`) at vertex positions s: points
    interpolated linearly between vertices, in the root frame (its pose the beam's); curvatures
    at the vertices."""
    traj = channels.Trajectory(t=t)
    for jname in channels.joints_needed(case):
        traj.joints[jname] = np.array([r["q"] for r in rows])
    if channels.wants_energy(case):
        traj.energy = {"total": np.array([r["E"] for r in rows])}
    name, body, _ = rod_of(case)
    X = np.array([r["X"] for r in rows])                                   # (n, ne + 1, 3)
    at = lambda x, F, grid: np.array([[np.interp(x, grid, f[:, k]) for k in range(F.shape[2])] for f in F])
    xs = channels.points_needed(case, name)
    K = np.array([curvatures(x) for x in X])                               # (n, ne + 1, 3)
    strain = lambda x: np.column_stack([np.zeros(len(t)), at(x, K[:, 1:-1, 1:], s[1:-1]), np.zeros(len(t))])
    traj.beams[name] = channels.Beam(
        length=body.length, points={x: at(x, X, s) for x in xs}, x0={x: np.array([x, 0.0, 0.0]) for x in xs},
        root=np.tile(np.eye(3), (len(t), 1, 1)),
        strains={float(c.at): strain(c.at) for c in case.channels.values() if c.kind in cases.STRESS_KINDS})
    traj.poses = {name: (np.array([r["R"] for r in rows]).reshape(-1, 3, 3),
                         np.array([r["p"] for r in rows]).reshape(-1, 3))}
    return traj


def names(m) -> set:
    return {m.joint(i).name for i in range(m.njnt)}


def apply_loads(case, m, d, ne: int, s: np.ndarray) -> None:
    """Point loads on the rod vertex nearest to where the case puts them (xfrc_applied, world
    frame), at time d.time. The vertices s are not the case's FE nodes (`rod_points`), so a load
    goes to its own nearest vertex, not to the case's node (`Load.point.node`)."""
    d.xfrc_applied[:] = 0.0
    R, _ = root_frame(m, d)
    for ld in case.loads.values():
        k = int(np.argmin(np.abs(s - ld.point.x)))
        if k < 2:                                           # on the support: carried by the root body
            continue
        f = np.asarray(ld.force, dtype=float) * float(profiles.load_factor(ld.profile, d.time))
        d.xfrc_applied[m.body(f"rod_{k}").id, :3] += f if ld.frame == "global" else R @ f


# ---------------------------------------------------------------------------------------------
# the solver


def run(case, t_end, settings):
    from flexmbd.harness.results import Result
    get = lambda k: settings.get(k, SETTINGS[k][1])
    ne, tc, integrator = get("edges"), get("edge_timeconst"), get("integrator")
    t0 = time.perf_counter()
    out_dt = case.integrator.output_dt
    stride = max(int(np.ceil(out_dt / get("dt") - 1e-9)), 1)
    dt = out_dt / stride
    m, q0 = compile_rod(case, ne, dt, tc, integrator)
    d = mujoco.MjData(m)
    if "pivot" in names(m):
        d.qpos[m.jnt_qposadr[m.joint("pivot").id]] = q0
    s, l = rod_points(rod_of(case)[1].length, ne)
    setup_s = time.perf_counter() - t0

    t_out = common.sample_times(case, t_end)
    rows, status = [], results.Status()
    bar = Progress(t_end, f"{case.name} / mujoco-rod")
    t1 = time.perf_counter()
    mujoco.mj_forward(m, d)
    rows.append(sample(case, m, d, ne, l))
    for k in range(1, t_out.size):
        for _ in range(stride):
            apply_loads(case, m, d, ne, s)
            mujoco.mj_step(m, d)
        if not np.all(np.isfinite(d.qpos)):
            status = results.diverged(results.STATE_NOT_FINITE, d.time)
            break
        mujoco.mj_fwdPosition(m, d)                             # kinematics and inertia of the new state
        rows.append(sample(case, m, d, ne, l))
        bar.update(t_out[k])
        hit = channels.failure(case, trajectory(case, rows[-1:], t_out[k:k + 1], s))
        if hit is not None:                                     # the divergence rule: stop at this sample
            status = hit[1]
            break
    wall_s = time.perf_counter() - t1
    bar.close()

    n = len(rows)
    traj = trajectory(case, rows, t_out[:n], s)
    return Result(solver="mujoco-rod", case=case.name, t=t_out[:n],
                  status=status, wall_s=wall_s, setup_s=setup_s, steps=(n - 1) * stride, rhs_evals=(n - 1) * stride,
                  settings={"edges": ne, "edge_length": l, "dt": dt, "integrator": integrator,
                            "solver": "Newton", "edge_timeconst": tc, "section": "box",
                            "mass": "lumped, rho A l per vertex, rho A l/2 at the tip"}, trajectory=traj)
