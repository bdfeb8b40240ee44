"""`fe-linear`: the full-order linear transient of the beam or solid mesh, every DOF kept.

    M u'' + C u' + K u = f(t),   u(0) = 0, u'(0) = 0

on the same mesh, element and mass matrix as the reduced body, with the root node clamped (the
fixed joint) and nothing truncated. Three time-stepping schemes (setting `scheme`):

  exact    (default on a damped beam) the first-order system y' = A y + b(t), y = [u; u'],
           advanced by the matrix exponential: y_{k+1} = e^{A h} y_k + A^{-1} (e^{A h} - 1)
           b(t_k + h/2). Exact for constant and step loads switched on at a step boundary; second
           order for smooth loads.
  newmark  average-acceleration Newmark (trapezoidal: unconditionally stable, no numerical
           damping, period error (w h)^2 / 12 — 8e-4 at 314 Hz with h = 5e-5 s, a visible phase
           drift of the higher modes over a 2 s run, which is why it is not the default).
  modal    (default on an undamped beam) every mode of the full model (K phi = w^2 M phi, dense:
           at most MODAL_DOFS DOFs), each modal coordinate advanced exactly over a step under the
           step's midpoint load: the same discrete solution as `exact`, to the round-off of the
           two factorizations (1.4e-10 of the peak on a 6-element cantilever; on the 600 DOFs of
           cantilever_step the exponential's own, 1.2e-5, against the modal scheme's 1.9e-7:
           docs/fe.md), at O(n) a step instead of a dense (2n, 2n) product, and an n x n
           eigenproblem instead of a 2n x 2n exponential (cantilever_step: 0.5 s against 3.3 s);
           undamped only.

Modal damping ratio zeta, when non-zero, enters as C = M Phi diag(2 zeta w) Phi^T M over all
modes of the full model. A point mass fixed to the beam (or a frame) adds its mass to the three
translations of its node (`with_point_masses`), so its inertia and its weight are in M and M g.

A solid (`run_solid`) keeps every DOF of its mesh with the frame interface's nodes held, its
loads spread over their interfaces' nodes by the same averaging interface as the reduced body's
(`fe.solid.averaging`). Its interfaces' reference points move as the rigid fit of their nodes; its
stresses are those at the centres of the channels' elements. It steps by one of

  newmark  (default) as above, on the sparse matrices (banded Cholesky or SuperLU);
  modal    as above, on the dense matrices of the mesh's size: no period error in any mode, so
           that what differs from a reduced body is its truncation alone.

Modal damping of a solid is not modelled (all of its modes for C, or a dense exponential).

A frame (a solid whose mesh is of bar elements, `fe.frame`; `run`, `frame_trajectory`) keeps
every DOF of its nodes, six each, with the frame interface's node held; its loads act on their
interfaces' nodes, gravity on its lumped node masses; its stresses are `fe.frame.fibre_rows`'. It
steps by the schemes of a beam (default modal, undamped; exact with damping).

A planar mechanism's natural frequencies (`system_frequencies`): every beam of the case in one
full-order frame at the assembled pose, its joints as ties between nodes (`planar_frame`), an
independent check of flexmbd's linearization about the same state (docs/formulation.md §10).
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np
import scipy.linalg
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from flexmbd import cases
from flexmbd.cases import closure
from flexmbd.core.errors import InputError
from flexmbd.harness import channels, cost
from flexmbd.fe import flexbody
from flexmbd.mbd import profiles
from flexmbd.solvers import common
from flexmbd.fe import frame, solid, stress
from flexmbd.harness.progress import Progress, Ticking

SETTINGS = {
    "scheme": (("exact", "newmark", "modal"), None),   # default: exact on a beam, newmark on a solid
    "dt": ("float+", None),             # s; default: output_dt (exact), 5e-5 s (newmark)
}


def version() -> str:
    return "1"


SOLIDS = True                           # a clamped solid: its whole mesh (`run_solid`)
MODAL_DOFS = 12_000                     # the modal scheme's largest model: K, M, Phi dense, 1.2 GB each
EIGH_S = 1e-9                           # s per n^3 of the dense generalized eigh (6,813 DOFs: 320 s on
                                        # 2 busy cores, 2.4 GB resident)
STYLE = {"color": "#7f7f7f", "marker": "s"}     # on the figures (report.figures.looks), solid lines


def applies(case) -> str:
    name, why = common.clamped_beam(case, solids=True, masses=True)
    body = case.bodies[name] if name else None
    if body and body.type == "solid" and not body.is_frame and len(case.bodies) > 1:
        return (f"a point mass on solid {name!r} sits at an interface's reference point, which the full mesh does not "
                f"hold as a node")
    if body and body.type == "solid" and not body.is_frame and body.damping_ratio > 0:
        return ("modal damping of a solid's full model needs all of its modes (a dense eigenproblem of the mesh's "
                "size)")
    return why


def stages(case, t_end, settings) -> list:
    """The costly stages of a run (`cost.stages`). Full-order FE: the exact scheme exponentiates the
    dense 2n x 2n system matrix and steps by dense products; the modal scheme solves the dense n x n
    eigenproblem and steps every mode; newmark factorizes once and steps by sparse solves; damping
    takes a dense eigensolution of all n DOFs."""
    name, body = next((n, b) for n, b in case.bodies.items() if b.type != "point_mass")   # point masses: node masses
    n = cost.solid_dofs(body) if body.type == "solid" else 6 * body.elements
    damped = body.damping_ratio > 0 or body.stiffness_damping > 0
    mesh = body.type == "solid" and not body.is_frame   # a 3-D mesh; a frame steps as a beam
    scheme = settings["scheme"] or ("newmark" if mesh else "exact" if damped else "modal")
    dt = settings["dt"] or (5e-5 if scheme == "newmark" else case.integrator.output_dt)
    out_dt = case.integrator.output_dt
    stride = max(round(out_dt / dt), 1)
    steps = (cost.samples(case, t_end) - 1) * stride
    if scheme == "exact":
        setup_s, setup_b, per_step = 3e-10 * (2 * n) ** 3, 48.0 * (2 * n) ** 2, 1e-9 * (2 * n) ** 2
    elif scheme == "modal":                     # eigh of the dense pair (its bar: elapsed against this
        # estimate), then per step O(n) and u = Phi q at every sample (2 n^2 flops each)
        setup_s, setup_b = EIGH_S * n ** 3, 48.0 * n ** 2
        per_step = 1e-8 * n + 2e-5 + 4e-10 * n * n / stride
    elif mesh:                                  # a 3-D mesh's factor fills in more: 2.1 ms a step at 5,463 DOFs
        setup_s, setup_b, per_step = 1e-4 * n, cost.SOLID_BYTES * n, 4e-7 * n + 2e-5
    else:
        setup_s, setup_b, per_step = 1e-5 * n, 8.0 * 200 * n, 1e-8 * 12 * n + 2e-5
    if damped:
        setup_s, setup_b = setup_s + 5e-10 * n ** 3, setup_b + 40.0 * n ** 2
    matrix = f"bodies.{name}.mesh" if body.type == "solid" else f"bodies.{name}.elements"
    steps_key = "solvers.fe-linear.dt" if settings["dt"] and settings["dt"] < out_dt else \
        ("duration" if t_end == case.duration else "--t-end")
    return [cost.Stage(f"setting up the {scheme} scheme for {n} DOFs", matrix, memory=setup_b, seconds=setup_s,
                       progress=scheme == "modal"),
            cost.Stage(f"stepping {n} DOFs through {steps:.3g} {scheme} steps of {out_dt / stride:.3g} s",
                       steps_key if steps * per_step > setup_s else matrix,
                       memory=32.0 * cost.samples(case, t_end) * n, seconds=steps * per_step,
                       progress=mesh)]


def load_vectors(case, n_dof: int, node=None) -> list:
    """(f (n_dof,), profile) per point load on its node, in the body frame; `node` maps a frame's
    interface to its mesh node (a beam's load knows its node)."""
    out = []
    for ld in case.loads.values():
        f = np.zeros(n_dof)
        p = node(ld.point.x) if node else ld.point.node
        f[6 * p: 6 * p + 3] = common.body_force(case, ld)
        out.append((f, ld.profile))
    return out


def with_point_masses(case, M, node=None):
    """M (sparse, 6 DOFs a node) with each point mass's mass on its node's three translations
    (`node`: a frame's interface -> its mesh node; on a beam the joint knows its node)."""
    d = np.zeros(M.shape[0])
    for name, b in case.bodies.items():
        if b.type == "point_mass":
            j = case.joint_of(name)
            p = node(j.point.x) if node else j.point.node
            d[6 * p:6 * p + 3] += b.mass
    return (M + sp.diags(d)).tocsr() if d.any() else M


def run(case, t_end, settings):
    from flexmbd.harness.results import Result
    t_start = time.perf_counter()
    name, _ = common.clamped_beam(case, solids=True, masses=True)
    body = case.bodies[name]
    if body.type == "solid" and not body.is_frame:
        return run_solid(case, name, t_end, settings, t_start)
    if body.type == "solid":
        K, M = flexbody.frame_matrices(body)
        mesh = flexbody.solid_mesh(**dataclasses.asdict(body.mesh))
        held = flexbody.frame_node(body, mesh, body.frame)
        nodes = mesh.nodes - mesh.nodes[held]
    else:
        nodes, elements, sec, K, M, _ = flexbody.fe_model(body)
        held = 0
    n_dof = K.shape[0]
    free = np.setdiff1d(np.arange(n_dof), np.arange(6 * held, 6 * held + 6))   # clamped by the fixed joint
    node = (lambda k: flexbody.frame_node(body, mesh, k)) if body.type == "solid" else None
    M = with_point_masses(case, M, node)

    # external loads: point loads with their profiles, gravity as constant nodal forces
    loads = load_vectors(case, n_dof, node)
    g = common.gravity_body(case)
    fg = M @ np.tile(np.r_[g, 0.0, 0.0, 0.0], nodes.shape[0])

    Kf, Mf = K[free][:, free].tocsc(), M[free][:, free].tocsc()
    C = damping(Kf, Mf, body.damping_ratio)
    if body.stiffness_damping > 0:                      # a beam's material damping, C = beta K
        C = body.stiffness_damping * Kf if C is None else C + body.stiffness_damping * Kf

    scheme = settings.get("scheme") or ("modal" if C is None else "exact")
    out_dt = case.integrator.output_dt
    dt = settings.get("dt") or (5e-5 if scheme == "newmark" else out_dt)
    t_out = common.sample_times(case, t_end)
    stride = max(int(round(out_dt / dt)), 1)
    dt = out_dt / stride
    terms = [(fg[free], lambda t: 1.0)] + [(f[free], lambda t, p=p: profiles.load_factor(p, t)) for f, p in loads]
    force = lambda t: sum(f * g(t) for f, g in terms)
    if scheme == "modal" and C is not None:
        raise ValueError("the modal scheme models no damping (scheme = \"exact\" does)")
    setup_s = time.perf_counter() - t_start

    t_solve = time.perf_counter()
    if scheme == "modal":
        U, V = modal(Kf, Mf, terms, dt, stride, t_out.size)
    else:
        U, V = newmark(Kf, Mf, C, force, dt, stride, t_out.size) if scheme == "newmark" else \
            exact(Kf, Mf, C, terms, dt, stride, t_out.size)
    wall_s = time.perf_counter() - t_solve

    u_full = np.zeros((t_out.size, n_dof))
    u_full[:, free] = U
    v_full = np.zeros_like(u_full)
    v_full[:, free] = V
    if body.type == "solid":
        traj = frame_trajectory(case, name, t_out, u_full, mesh, nodes)
    else:
        traj = trajectory(case, name, t_out, u_full, nodes, elements, sec)
    if channels.wants_energy(case):
        traj.energy = {"total": energy(u_full, v_full, K, M, fg)}
    return Result(solver="fe-linear", case=case.name, t=t_out, wall_s=wall_s,
                  setup_s=setup_s, steps=(t_out.size - 1) * stride, rhs_evals=(t_out.size - 1) * stride,
                  settings={"dt": dt, "scheme": scheme, "dofs": int(free.size),
                            **({"mesh": mesh.source, "nodes": mesh.n_nodes} if body.type == "solid" else
                               {"elements": body.elements, "mass": body.mass})}, trajectory=traj)


def trajectory(case, name: str, t, U, nodes, elements, sec) -> channels.Trajectory:
    """The channels' view of the nodal displacements U (n, 6N) of the clamped beam `name`: node
    positions in the body frame (the root node is clamped: its frame is the body frame) and
    section strains from the element shape functions. A point x snaps to its node by the one
    rule (`flexbody.node_index`, the case's mesh)."""
    body = case.bodies[name]
    mat = body.material
    node = {x: flexbody.node_index(body.length, body.elements, x) for x in channels.points_needed(case, name)}
    rows = {float(c.at): stress.strain_rows(nodes, elements, mat.E, mat.G, sec, c.at, shear=body.shear)
            for c in case.channels.values() if c.kind in cases.STRESS_KINDS}
    beam = channels.Beam(length=body.length,
                         points={x: nodes[k] + U[:, 6 * k:6 * k + 3] for x, k in node.items()},
                         x0={x: nodes[k] for x, k in node.items()}, root=np.tile(np.eye(3), (len(t), 1, 1)),
                         strains={x: U @ r.T for x, r in rows.items()})
    return channels.Trajectory(t=t, beams={name: beam})


def frame_trajectory(case, name: str, t, U, mesh, nodes) -> channels.Trajectory:
    """The channels' view of the nodal displacements U (n, 6N) of the clamped frame `name`: its
    interfaces' nodes in the body frame (origin at the frame interface's node, `nodes` (N, 3)),
    and the stresses at its stress points (`fe.frame.fibre_rows`)."""
    body, mat = case.bodies[name], case.bodies[name].material
    keys = channels.points_needed(case, name)
    at = {k: flexbody.frame_node(body, mesh, k) for k in keys}
    origin = mesh.nodes[at[body.frame]]
    stresses = {}
    for p in case.stress_sections(name):
        S, d = frame.fibre_rows(mesh, mat.E, mat.nu, np.asarray(p) + origin)
        stresses[p] = U[:, d] @ S.T
    beam = channels.Beam(length=body.length, points={k: nodes[p] + U[:, 6 * p:6 * p + 3] for k, p in at.items()},
                         x0={k: nodes[p] for k, p in at.items()}, root=np.tile(np.eye(3), (len(t), 1, 1)),
                         origin=body.frame, stresses=stresses)
    return channels.Trajectory(t=t, beams={name: beam})


def run_solid(case, name: str, t_end, settings, t_start: float):
    """The full-order transient of a clamped solid (module docstring)."""
    from flexmbd.harness.results import Result
    scheme = settings.get("scheme") or "newmark"
    if scheme == "exact":
        raise ValueError("a solid steps by scheme = \"newmark\" or \"modal\" (the exact scheme's exponential of "
                         "the mesh's size is not formed)")
    body = case.bodies[name]
    mesh, mat = flexbody.solid_mesh(**dataclasses.asdict(body.mesh)), body.material
    K, Ms = flexbody.solid_matrices(body)             # the mesh's assembly, or its matrix files
    M = solid.vector_mass(Ms)
    n_dof = K.shape[0]
    face = {n: body.interfaces[n] for n in flexbody.solid_order(body)}
    ref = {n: flexbody.reference_point(mesh, f.set, f.point) for n, f in face.items()}
    fit = {n: solid.averaging(mesh.nodes[mesh.node_sets[f.set]], ref[n]) for n, f in face.items()}
    dofs = {n: solid.node_dofs(mesh.node_sets[f.set]) for n, f in face.items()}
    # the frame interface's nodes held (the fixed joint), a rigid interface's nodes moving with its
    # reference point: the whole mesh in the coordinates T maps to its DOFs (`fe.solid.constraint_basis`)
    T = solid.constraint_basis(mesh.n_nodes, mesh.nodes, mesh.node_sets[face[body.frame].set],
                               [(mesh.node_sets[f.set], ref[n]) for n, f in face.items()
                                if f.kind == "rigid" and n != body.frame])

    loads = []
    for ld in case.loads.values():                      # [m; f] at the interface, spread over its nodes
        f = np.zeros(n_dof)
        f[dofs[ld.point.x]] = fit[ld.point.x].T @ np.r_[0.0, 0.0, 0.0, common.body_force(case, ld)]
        loads.append((f, ld.profile))
    fg = M @ np.tile(common.gravity_body(case), mesh.n_nodes)
    Kf, Mf = (T.T @ K @ T).tocsr(), (T.T @ M @ T).tocsc()
    if scheme == "modal" and Kf.shape[0] > MODAL_DOFS:
        raise ValueError(f"the modal scheme forms dense matrices of the model's size: {Kf.shape[0]} DOFs, at most "
                         f"{MODAL_DOFS} (scheme = \"newmark\" steps a larger one)")
    out_dt = case.integrator.output_dt
    dt = settings.get("dt") or (out_dt if scheme == "modal" else 5e-5)
    t_out = common.sample_times(case, t_end)
    stride = max(int(round(out_dt / dt)), 1)
    dt = out_dt / stride
    terms = [(T.T @ fg, lambda t: 1.0)] + [(T.T @ f, lambda t, p=p: profiles.load_factor(p, t)) for f, p in loads]
    setup_s = time.perf_counter() - t_start
    t_solve = time.perf_counter()
    bar = Progress(float(t_out[-1]), f"{case.name} / fe-linear")
    if scheme == "modal":
        U, V = modal(Kf, Mf, terms, dt, stride, t_out.size, bar, velocities=channels.wants_energy(case))
    else:
        U, V = newmark(Kf, Mf, None, lambda t: sum(f * g(t) for f, g in terms), dt, stride, t_out.size, bar)
    bar.close()
    wall_s = time.perf_counter() - t_solve

    u = np.asarray((T @ U.T).T)
    origin = ref[body.frame]
    keys = channels.points_needed(case, name)
    points = {k: ref[k] - origin + (u[:, dofs[k]] @ fit[k].T)[:, 3:] for k in keys}
    stresses = {}
    for p in case.stress_sections(name):
        S, d = flexbody.point_stress_rows(mesh, mat.E, mat.nu, np.asarray(p) + origin)
        stresses[p] = u[:, d] @ S.T
    faces, owners = solid.boundary_faces(mesh)
    elements, inverse = np.unique(owners, return_inverse=True)
    rows = solid.centre_stress_rows(mesh, mat.E, mat.nu, elements)
    surface = lambda k: np.stack([u[k][:, d] @ S.T for S, d in rows], axis=1)[:, inverse]     # (k, nf, 6)
    beam = channels.Beam(length=body.length, points=points, x0={k: ref[k] - origin for k in keys},
                         root=np.tile(np.eye(3), (len(t_out), 1, 1)), origin=body.frame, stresses=stresses,
                         surface=surface)
    traj = channels.Trajectory(t=t_out, beams={name: beam})
    if channels.wants_energy(case):
        traj.energy = {"total": energy(u, np.asarray((T @ V.T).T), K, M, fg)}
    return Result(solver="fe-linear", case=case.name, t=t_out, wall_s=wall_s, setup_s=setup_s,
                  steps=(t_out.size - 1) * stride, rhs_evals=(t_out.size - 1) * stride,
                  settings={"dt": dt, "scheme": scheme, "dofs": int(T.shape[1]), "mesh": mesh.source,
                            "nodes": mesh.n_nodes}, trajectory=traj)


def damping(K, M, zeta: float):
    """C = M Phi diag(2 zeta w) Phi^T M over all modes of the full model (None when zeta = 0)."""
    if zeta == 0.0:
        return None
    w2, Phi = scipy.linalg.eigh(K.toarray(), M.toarray())
    MPhi = M @ Phi
    return sp.csc_matrix(MPhi @ np.diag(2.0 * zeta * np.sqrt(np.abs(w2))) @ MPhi.T)


def exact(K, M, C, terms: list, dt: float, stride: int, n_out: int):
    """Matrix-exponential stepping of y = [u; u'] from rest under the load f(t) = sum_j f_j g_j(t)
    (`terms` [(f_j (n,), g_j)], as `modal`'s), held at its value at each step's midpoint:

        y+ = Phi y + sum_j g_j(t + h/2) b_j,    Phi = e^{A h},  b_j = (int_0^h e^{A s} ds) [0; M^-1 f_j]

    the b_j formed once (one product with a dense (2n, 2n) matrix a step, not two). Returns
    displacements and velocities (n_out, n)."""
    n = K.shape[0]
    Minv = np.linalg.inv(M.toarray())
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -Minv @ K.toarray()
    if C is not None:
        A[n:, n:] = -Minv @ C.toarray()
    Phi = scipy.linalg.expm(A * dt)
    Gam = np.linalg.solve(A, Phi - np.eye(2 * n))         # int_0^h e^{A s} ds
    b = [(Gam[:, n:] @ (Minv @ f), g) for f, g in terms]
    y = np.zeros(2 * n)
    U, V = np.zeros((n_out, n)), np.zeros((n_out, n))
    t = 0.0
    for k in range(1, n_out):
        for _ in range(stride):
            y = Phi @ y + sum(bj * g(t + dt / 2) for bj, g in b)
            t += dt
        U[k], V[k] = y[:n], y[n:]
    return U, V


def newmark(K, M, C, force, dt: float, stride: int, n_out: int, bar: Progress | None = None):
    """Average-acceleration Newmark from rest; returns displacements and velocities (n_out, n);
    `bar` shows the simulated time."""
    n = K.shape[0]
    Ceff = C if C is not None else sp.csc_matrix((n, n))
    lu = factor((K + (2.0 / dt) * Ceff + (4.0 / dt ** 2) * M).tocsr())
    u, v = np.zeros(n), np.zeros(n)
    a = splu(M.tocsc()).solve(force(0.0) - K @ u - Ceff @ v)
    U, V = np.zeros((n_out, n)), np.zeros((n_out, n))
    t = 0.0
    for k in range(1, n_out):
        for _ in range(stride):
            t += dt
            rhs = force(t) + M @ ((4.0 / dt ** 2) * u + (4.0 / dt) * v + a) + Ceff @ ((2.0 / dt) * u + v)
            u_new = lu.solve(rhs)
            v_new = (2.0 / dt) * (u_new - u) - v
            a = (4.0 / dt ** 2) * (u_new - u) - (4.0 / dt) * v - a
            u, v = u_new, v_new
        U[k], V[k] = u, v
        if bar is not None:
            bar.update(t)
    return U, V


def modal(K, M, terms: list, dt: float, stride: int, n_out: int, bar: Progress | None = None,
          velocities: bool = True):
    """Every mode of the undamped model, u = Phi q with Phi^T M Phi = 1 and q_i'' + w_i^2 q_i =
    phi_i^T f, the load f(t) = sum_j f_j g_j(t) given as `terms` [(f_j (n,), g_j)], each q_i
    advanced exactly over a step h under the step's midpoint load p_i (constant over the step):

        q+ = c q + (s / w) q' + (1 - c) p / w^2,    q+' = -w s q + c q' + s p / w,   c, s = cos wh, sin wh

    From rest; displacements and velocities (n_out, n) as `newmark`'s (the velocities None unless
    `velocities`: each costs a product with the dense Phi); `bar` shows the simulated time."""
    with Ticking(EIGH_S * K.shape[0] ** 3, f"every mode of {K.shape[0]} DOFs"):
        w2, Phi = scipy.linalg.eigh(K.toarray(), M.toarray(), driver="gvd")
    if w2[0] <= 0.0:
        raise ValueError(f"the model is not held (its lowest eigenvalue w^2 = {w2[0]:.3g}): the modal scheme "
                         f"needs every mode elastic")
    w = np.sqrt(w2)
    c, s = np.cos(w * dt), np.sin(w * dt)
    q, qd = np.zeros(w.size), np.zeros(w.size)
    Q, Qd = np.zeros((n_out, w.size)), np.zeros((n_out, w.size))
    t = 0.0
    P = [(Phi.T @ f, g) for f, g in terms]               # the loads' modal forces, formed once
    for k in range(1, n_out):
        for _ in range(stride):
            p = sum(pj * g(t + dt / 2) for pj, g in P)
            q, qd = c * q + s / w * qd + (1.0 - c) * p / w2, -w * s * q + c * qd + s * p / w
            t += dt
        Q[k], Qd[k] = q, qd
        if bar is not None:
            bar.update(t)
    return Q @ Phi.T, (Qd @ Phi.T if velocities else None)


class Banded:
    """A symmetric positive definite sparse matrix factored as a banded Cholesky factor in the
    reverse Cuthill-McKee order of its graph: on a slender mesh (a beam's sections in a row) its
    solves are about half SuperLU's. `solve(b)` as SuperLU's."""

    def __init__(self, A, perm, bw):
        P = A[perm][:, perm].tocoo()
        upper = P.row <= P.col
        ab = np.zeros((bw + 1, A.shape[0]))
        ab[bw + P.row[upper] - P.col[upper], P.col[upper]] = P.data[upper]
        self.c, self.perm = scipy.linalg.cholesky_banded(ab), perm

    def solve(self, b):
        x = np.empty_like(b)
        x[self.perm] = scipy.linalg.cho_solve_banded((self.c, False), b[self.perm])
        return x


def factor(A):
    """A factorization of the symmetric positive definite Newmark matrix: `Banded` when its
    band (in reverse Cuthill-McKee order) holds at most a tenth as many entries as the dense
    matrix, else SuperLU (sparse LU)."""
    from scipy.sparse.csgraph import reverse_cuthill_mckee
    perm = reverse_cuthill_mckee(A, symmetric_mode=True)
    P = A[perm][:, perm].tocoo()
    bw = int(np.max(np.abs(P.row - P.col))) if P.nnz else 0
    if (bw + 1) * 10 <= A.shape[0]:
        return Banded(A, perm, bw)
    return splu(A.tocsc())


def energy(U, V, K, M, fg):
    """Kinetic + strain + gravitational potential (-fg . u), per output row."""
    kin = 0.5 * np.einsum("ti,ti->t", V, (M @ V.T).T)
    strain = 0.5 * np.einsum("ti,ti->t", U, (K @ U.T).T)
    return kin + strain - U @ fg


# ---------------------------------------------------------------------------------------------
# a planar mechanism's natural frequencies: all its beams as one full-order frame

PLANE = 1e-9            # how far |z| of a unit vector (a pin's axis, a beam's body z) may be from 1


def system_frequencies(case, count: int) -> np.ndarray:
    """(count,) the lowest natural frequencies of the case's mechanism, Hz, ascending: the planar
    frame of all its beams at the assembled pose (`planar_frame`), K phi = w^2 M phi on its free
    coordinates (dense `scipy.linalg.eigh`). A motion the joints leave free (a mechanism nothing
    holds) is a frequency of 0.

    Planar, not 3-D: a mechanism in the x-y plane with every pin about z and every beam bending in
    the plane about its section's z vibrates in the plane and out of it independently (the
    element's in-plane families are uncoupled from torsion and x-z bending, and a pin about z ties
    in-plane DOFs to in-plane DOFs only), so the in-plane frequencies of a 3-D frame are exactly
    this frame's, with 3 DOFs a node instead of 6. Those are the modes a planar case's bodies
    retain (`kinds = ["bending xy"]`); out of the plane a 3-D frame would add torsion and x-z
    bending modes that depend on how stiff a pin is taken to be about its normals. Anything else
    is refused (`planar_frame`, InputError).

    The model is linear about an unloaded state: elastic stiffness only (EA and E Iz), no geometric
    stiffness (the mechanism is at rest and nothing preloads it; gravity and the case's loads are
    not applied), no damping. Its frequencies converge from above as the elements' h^4 (Hermite
    cubics, consistent mass)."""
    K, M, T = planar_frame(case)
    Kr, Mr = (T.T @ K @ T).toarray(), (T.T @ M @ T).toarray()
    if not 1 <= count <= Kr.shape[0]:
        raise InputError(f"{case.path}: {count} frequencies asked of a frame of {Kr.shape[0]} free DOFs")
    w2 = scipy.linalg.eigh(Kr, Mr, eigvals_only=True, subset_by_index=[0, count - 1])
    return np.sqrt(np.clip(w2, 0.0, None)) / (2.0 * np.pi)


def planar_frame(case) -> tuple:
    """(K (3N, 3N), M (3N, 3N), T (3N, r)), sparse: the mechanism of the case as one planar frame
    (`fe.frame.planar_matrices`), DOFs 3 p + [ux, uy, rz] of node p in world axes (m, rad), and
    the joints' ties (`fe.frame.tied`): the model on its free coordinates is T^T K T, T^T M T.

    - Every beam (flexible or declared rigid: here each is elastic) meshed by its own `elements`
      along its body x, placed by the assembled pose (`cases.closure.body_poses` at the joints'
      q0, the loops' closed ones); the beams' nodes in file order. Consistent mass whatever the
      beam's `mass` (the reference converges as h^4, the lumped mass as h^2); Timoshenko stiffness
      where the beam says `shear`.
    - A point mass: its mass on the two translations of its parent's node (its fixed joint's).
    - A joint, tree or loop, between the parent's node (a beam's `at`) and the child's (its node 0,
      or a loop joint's `child_at`): a revolute ties the two translations and leaves the rotations
      independent (a pin); a fixed joint, or a revolute with a prescribed `motion` (held at its
      initial angle), ties all three. A joint to ground holds the child's node's DOFs instead.

    Refused, one line (InputError naming the case file): a body other than a beam or a point mass;
    a joint other than revolute or fixed; a revolute whose axis is not along z, a beam whose body
    z is not along z (its axis or its section leaving the x-y plane)."""
    poses = closure.body_poses(case, {name: j.q0 for name, j in case.joints.items()})
    joints = [*case.joints.values(), *case.loops.values()]
    beams = [name for name, b in case.bodies.items() if b.type == "beam"]
    _check_planar(case, poses, joints, beams)

    first = dict(zip(beams, np.cumsum([0] + [case.bodies[n].elements + 1 for n in beams]).tolist()))
    n_nodes = sum(case.bodies[n].elements + 1 for n in beams)
    cells, k, m = [], [], []
    for name in beams:
        b, (R, p) = case.bodies[name], poses[name]
        x = np.linspace(0.0, b.length, b.elements + 1)
        here = p + np.outer(x, R[:, 0])                     # along the body's x, world coordinates
        local = np.column_stack([np.arange(b.elements), np.arange(1, b.elements + 1)])
        mat = b.material
        ke, me = frame.planar_matrices(here, local, mat.E, mat.G, mat.rho, b.geometry, shear=b.shear)
        cells.append(local + first[name])
        k.append(ke)
        m.append(me)
    cells = np.concatenate(cells)
    K = frame.assemble(np.concatenate(k), cells, n_nodes)
    M = frame.assemble(np.concatenate(m), cells, n_nodes)

    lumped, pairs, held = np.zeros(3 * n_nodes), [], []
    for j in joints:
        parent = None if j.parent == "ground" else first[j.parent] + j.node
        if case.bodies[j.child].type == "point_mass":       # fixed to its parent: a mass on that node
            if parent is not None:
                lumped[3 * parent:3 * parent + 2] += case.bodies[j.child].mass
            continue
        child = first[j.child] + (j.child_point.node if j.loop else 0)
        dofs = [0, 1] if j.type == "revolute" and j.motion is None else [0, 1, 2]      # a pin keeps rz apart
        if parent is None:
            held += [3 * child + d for d in dofs]
        else:
            pairs += [(3 * parent + d, 3 * child + d) for d in dofs]
    T = frame.tied(3 * n_nodes, np.array(pairs, dtype=int), np.array(held, dtype=int))
    return K, (M + sp.diags(lumped)).tocsr(), T


def _check_planar(case, poses: dict, joints: list, beams: list) -> None:
    """Refuse (InputError, one line naming the case file) what `planar_frame` does not model."""
    where = str(case.path)
    for name, b in case.bodies.items():
        if b.type not in ("beam", "point_mass"):
            raise InputError(f"{where}: bodies.{name}: a {b.type} body; the full-order frame of a mechanism takes "
                             f"beams and point masses")
    for name in beams:
        z = poses[name][0][:, 2]
        if abs(abs(z[2]) - 1.0) > PLANE:
            raise InputError(f"{where}: bodies.{name}: not planar: its body z axis is ({z[0]:.3g}, {z[1]:.3g}, "
                             f"{z[2]:.3g}) in the world, so it leaves the x-y plane or bends out of it; the planar "
                             f"frame takes beams in the x-y plane with z normal to it")
    for j in joints:
        if j.type not in ("revolute", "fixed"):
            raise InputError(f"{where}: joints.{j.name}: a {j.type} joint; the planar frame takes revolute joints "
                             f"about z and fixed joints")
        a = poses[j.parent][0] @ np.array(j.triad) @ np.asarray(j.axis, dtype=float)
        if j.type == "revolute" and abs(abs(a[2]) - 1.0) > PLANE:
            raise InputError(f"{where}: joints.{j.name}: not planar: its axis is ({a[0]:.3g}, {a[1]:.3g}, "
                             f"{a[2]:.3g}) in the world, not along z; the planar frame takes pins about z")
