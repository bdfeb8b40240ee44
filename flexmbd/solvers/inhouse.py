"""`flexmbd`, the in-house solver, behind the same interface as every other solver (harness/registry.py):
the case's Model integrated in time, reported as a `channels.Trajectory` of its states. The Model
is that of the tree the modal solvers model (`case.modelled`: a beam with `segments` is several bodies);
the trajectory reports every beam of the case whole."""

from __future__ import annotations

import sys
import time
from typing import NamedTuple

import numpy as np

from flexmbd.solvers import build
from flexmbd.harness import channels, cost, results
from flexmbd.fe import flexbody
from flexmbd.solvers.build import from_case
from flexmbd.mbd import constraints, dynamics, integrate
from flexmbd.mbd.compiled import entry, jit
from flexmbd.mbd.model import Model, make_data
from flexmbd.harness.progress import Progress
from flexmbd.harness.results import Result
from flexmbd.version import __version__

SETTINGS = {}           # the case's [integrator] table holds this solver's settings
LOOPS = True            # cut joints: constraints.Loops
SOLIDS = True           # flexible solids: flexbody.solid_body
STYLE = {"color": "#1f77b4", "marker": "o"}     # on the figures (report.figures.looks), solid lines
# s, a cold compile of the kernel (its entry and a run's integrator, into an empty cache) on this
# project's reference machine: `bench.compile_seconds` 40.8 s in the full run of 2201fdb, a whole
# first `flexmbd run` 41.0-42.3 s (docs/performance.md, "cold compile"). The executor adds it to
# the first flexmbd job while the kernel is not cached; the notices say it (`compiling`).
COMPILE_S = 41.0


def version() -> str:
    return __version__


def applies(case) -> str:
    return ""


def compiling(why: str = "") -> str:
    """The notice that the kernel compiles now (`jit.is_cached` is False), what for (`why`, e.g.
    ', to linearize the case') and about how long (COMPILE_S)."""
    return (f"compiling the solver's kernel once for this source version{why} "
            f"(about {round(COMPILE_S, -1):.0f} s; cached afterwards)")


def stages(case, t_end, settings) -> list:
    """The costly stages of a run (`cost.stages`): the FE modes of its beams and solids, and the
    integration."""
    return cost.modes(case) + integration(case, t_end)


# h omega (step x the highest retained frequency, rad/s) of each adaptive method's steps at rtol
# 1e-8: accuracy, not stability, sets it. Measured on the pendulum (437 Hz, t_end 0.5 s): adams
# 0.092, dopri5 0.095, rk45 0.096, dop853 0.35. It grows about as rtol^0.15 (dopri5: 0.154 at rtol
# 1e-6, 0.039 at 1e-10) up to the method's stability bound (adams 0.102 at 1e-6).
REACH = {"adams": 0.09, "dopri5": 0.095, "rk45": 0.095, "dop853": 0.35}
STABLE = {"adams": 0.1, "dopri5": 3.3, "rk45": 2.8, "dop853": 4.0}
# right-hand sides per step (pendulum: adams 1.84, dopri5 6.3, rk45 6.0, dop853 12.0, fox-goodwin
# 2.0) and the Python around each one (s; pendulum, against 16 us for the right-hand side: adams
# 18.6 us, rk4 30 us, rk45 53 us, dop853 36 us; dopri5 and fox-goodwin are compiled whole)
# exp-adams: two a step and its linearizations, 2.6 a step on the pendulum at 1 ms (5.0 on the
# double pendulum, where every one is full), and its eigenbasis work around them, about 3 us each
EVALS = {"adams": 2, "dopri5": 7, "rk45": 7, "dop853": 13, "rk4": 4, "fox-goodwin": 2, "exp-adams": 2.6}
AROUND = {"adams": 3e-6, "rk4": 1.5e-5, "rk45": 4e-5, "dop853": 2e-5, "dopri5": 0.0, "fox-goodwin": 0.0,
          "exp-adams": 3e-6}
# a closed loop's right-hand side (`constraints.constrained_rates`, compiled): one evaluation and per
# constraint row one response of its factored inertias (`dynamics.response`, about a quarter of an
# evaluation), and around them the rows, the multipliers' solve and a share of the projection at
# each output instant: measured 19 us on slider_crank (tree 4 us, 5 rows), 38 us on four_bar (16 us)
LOOP_RESPONSE = 0.25
LOOP_AROUND = 1e-5


def integration(case, t_end: float) -> list:
    """The in-house integrator: evaluations x the cost of one (`cost.evaluation`). Adaptive methods
    take at least duration / max_step steps, and about duration x the highest retained frequency
    / REACH (at rtol 1e-8, scaled as rtol^0.15, at most STABLE); a run whose step size collapses
    (a singular moment) takes more, which no estimate knows. rk45 and dop853 show no progress."""
    ig = case.integrator
    method = ig.method
    if method in ("rk4", "fox-goodwin", "exp-adams"):
        steps = t_end / ig.dt
        evals = steps * EVALS[method] + case.modelled.nv + 2
        key, how = cost.time_key(case, t_end, "integrator.dt", ig.dt, 1e-4), "duration / dt"
    else:
        omega, beam = cost.highest_frequency(case)
        reach = min(REACH[method] * (ig.rtol / 1e-8) ** 0.15, STABLE[method])
        steps = max(t_end / ig.max_step, t_end * omega / reach)
        evals = steps * EVALS[method]
        key, how = cost.time_key(case, t_end, "integrator.max_step", ig.max_step, 1e-3), "at least duration / max_step"
        if t_end * omega / reach > t_end / ig.max_step:
            key = "duration" if t_end == case.duration else "--t-end"
            how = (f"duration x the highest retained frequency of beam {beam!r}, {omega / (2 * np.pi):.3g} Hz, "
                   f"over h omega = {reach:.2g}")
    per_eval = cost.evaluation(case) + AROUND[method]
    if case.loops:
        rows = sum(len(constraints.ROWS.get(j.type, ((), ()))[0]) + len(constraints.ROWS.get(j.type, ((), ()))[1])
                   for j in case.loops.values())
        per_eval = (1 + LOOP_RESPONSE * rows) * cost.evaluation(case) + LOOP_AROUND + AROUND[method]
    return [cost.Stage(f"integrating {steps:.3g} {method} steps ({how})", key, memory=0.0,
                       seconds=evals * per_eval, progress=method not in ("rk45", "dop853"))]


def run(case, t_end, settings, progress: bool = True) -> Result:
    t0 = time.perf_counter()
    model = from_case(case.modelled, flexbody.for_case(case.modelled))
    setup_s = time.perf_counter() - t0

    # compile (or load from the cache) before the clock starts
    if not jit.is_cached():
        print(f"flexmbd: {compiling()}", file=sys.stderr, flush=True)
    t0 = time.perf_counter()
    ig = case.integrator
    loops = build.loops(model, case.modelled)
    compiled = integrate.COMPILED_LOOPS if loops else ("dopri5", "fox-goodwin", "exp-adams")
    integrate.warm_up(model, ig.method if ig.method in compiled else "", loops)
    compile_s = time.perf_counter() - t0

    bar = Progress(t_end, f"{case.name} / flexmbd") if progress else None
    check = watch(case, model) if not loops else None
    if loops:
        sim = integrate.simulate_loops(loops, t_end, method=ig.method, rtol=ig.rtol, atol=ig.atol,
                                       max_step=ig.max_step, output_dt=ig.output_dt, progress=bar, dt=ig.dt)
    else:
        sim = integrate.simulate(model, t_end, method=ig.method, rtol=ig.rtol, atol=ig.atol,
                                 max_step=ig.max_step, dt=ig.dt, output_dt=ig.output_dt, refresh=ig.refresh,
                                 progress=bar, check=check)
    E = energies(model, sim.q, sim.v)
    traj = trajectory(case, model, sim.t, sim.q, sim.v, E, loops)
    status = status_of(sim.status, getattr(check, "found", ()))
    if not status.ok and status.why in integrate.NON_FINITE:
        status = stiffening_limit(case, model, sim, traj) or status
    modes = {n: {"count": fb.n_modes, "boundary": fb.boundary, "freq_hz": np.round(fb.freq_hz, 4).tolist()}
             for n, fb in model.bodies.items()}
    kinetic_max = float(E[:, 0].max()) if len(sim.t) else 0.0
    return Result(solver="flexmbd", case=case.name, t=sim.t, status=status,
                  wall_s=sim.wall_s, setup_s=setup_s, steps=sim.steps, rhs_evals=sim.rhs_evals,
                  settings={**sim.settings, "modes": modes},
                  extra={"compile_s": compile_s, "kinetic_max_J": kinetic_max}, trajectory=traj)


# the integrators' whys (`integrate.WHY`, `integrate.NON_FINITE`) of a run that broke the divergence rule:
# a state or an acceleration not finite, a velocity beyond `integrate.DIVERGED`
DIVERGES = (*integrate.NON_FINITE, integrate.WHY[integrate.DIVERGING])


def status_of(end: integrate.Ended, found=()) -> results.Status:
    """The run's results.Status of how the integrators ended (`integrate.Ended`): ok; the failure
    the divergence watch found (`found`: the Statuses `watch`'s check returned), as it found it;
    diverged for the divergence rule's whys of the integrators (DIVERGES); aborted for any other
    (a step size too small, Newton, a loop that does not close, scipy's or VODE's message)."""
    if end.ok:
        return results.Status()
    hit = next((s for s in found if (s.why, s.t) == (end.why, end.t)), None)
    if hit is not None:
        return hit
    return (results.diverged if end.why in DIVERGES else results.failed)(end.why, end.t)


def watch(case, model: Model):
    """The divergence rule checked while the run goes (`integrate.simulate`'s check): the
    deflection channels of new output samples (`channels.failure`) from the modal coordinates of
    the flexible bodies they name (`shape`); None when there is nothing to check. The failures it
    returns are kept in its `found` (`status_of` reads their cause). A beam split into segments is
    judged after the run only (`registry.run`)."""
    bound = channels.bounds(case)
    bodies = list(dict.fromkeys(c.body for n, c in case.channels.items() if n in bound and c.body in model.bodies))
    if not bodies:
        return None

    def check(t, Q, V):
        hit = channels.failure(case, channels.Trajectory(t=t, beams={b: shape(case, model, b, Q) for b in bodies}))
        if hit is not None:
            check.found.append(hit[1])
        return hit
    check.found = []
    return check


def shape(case, model: Model, name: str, Q) -> channels.Beam:
    """The Beam of flexible body `name` with the points of its deflection channels and its root
    rotation only (as `trajectory` forms them), from states Q (n, nq): what the divergence rule reads."""
    fb, i, body = model.bodies[name], model.index(name), case.modelled.bodies[name]
    eta = Q[:, model.body_madr[i]:model.body_madr[i] + model.body_nm[i]]
    xs = channels.deflection_points(case.modelled, name)
    if body.type == "solid":
        return channels.modal_shape(fb, xs, eta, {x: body.node(x) for x in xs}, body.frame)
    return channels.modal_shape(fb, xs, eta)


SINGULAR = 0.1     # smallest eigenvalue of M at the last sample, relative to the start: M is singular


def stiffening_limit(case, model: Model, sim, traj) -> results.Status | None:
    """Why a run with geometric stiffening that ended in non-finite values stopped, when it is the
    model's own limit: past moderate deflections of a strongly bent beam the second-order mass
    matrix stops being positive definite (docs/formulation.md §4b). Diagnosed from the system mass
    matrix over the free coordinates at the last finite sample: its smallest eigenvalue has fallen
    below SINGULAR times its value at the start. None when not (or no beam is stiffened)."""
    stiff = [n for n, b in traj.beams.items() if case.bodies[n].stiffening]
    finite = np.flatnonzero(np.all(np.isfinite(sim.q), axis=1) & np.all(np.isfinite(sim.v), axis=1))
    if not stiff or finite.size < 2:
        return None
    free, data = dynamics.free_velocities(model), make_data(model)
    lam = [np.linalg.eigvalsh(entry.mass_matrix_system(model, data, sim.q[k])[np.ix_(free, free)])[0]
           for k in (0, finite[-1])]
    if lam[1] >= SINGULAR * lam[0]:
        return None
    bent = {n: traj.beams[n].extent["deflection"][finite[-1]] for n in stiff}
    name = max(bent, key=bent.get)
    return results.failed(
        f"outside linear validity: the stiffened mass matrix stops being positive definite (beam {name!r} bent "
        f"{100 * bent[name]:.1f} % of its length, smallest eigenvalue {lam[1] / lam[0]:.2g} of its initial value at "
        f"t = {sim.t[finite[-1]]:.6g} s; docs/formulation.md §4b: split the beam with segments, or set stiffening "
        f"= false)", sim.status.t)


# ---------------------------------------------------------------------------------------------
# the trajectory of a run


def energies(model: Model, Q, V) -> np.ndarray:
    """(n, 2): kinetic and potential (gravity + strain) energy of every state, J."""
    data = make_data(model)
    return np.array([entry.energy(model, data, q, v) for q, v in zip(Q, V)]).reshape(-1, 2)


class Evaluated(NamedTuple):
    """Per state k of a run, what one forward-dynamics evaluation leaves in the Data (body frame)."""

    f: np.ndarray       # (n, nb+1, 6) joint force [moment; force] from parent onto body
    v: np.ndarray       # (n, nb+1, 6) spatial velocity [w; v]
    a: np.ndarray       # (n, nb+1, 6) spatial acceleration, gravity as base acceleration
    Xup: np.ndarray     # (n, nb+1, 6, 6) parent frame -> body frame
    X0: np.ndarray      # (n, nb+1, 6, 6) global -> body frame
    scale: np.ndarray   # (n, nl) point-load profile factors
    qdd: np.ndarray     # (n, nv) joint and modal accelerations


class Cut(NamedTuple):
    """The cut joints at state k of a run (`cut_forces`)."""

    tau: np.ndarray         # (nv,) the constraint forces G^T lam, generalized
    wrenches: list          # `constraints.Loops.wrenches`: per cut (name, f, n, x), world
    reactions: dict         # `constraints.Loops.reactions`: per cut (6,) [moment; force], child frame


def cut_forces(loops: constraints.Loops, t, Q, V) -> list:
    """[Cut] at every state: the multipliers of the constrained evaluation, as forces."""
    out = []
    for tk, q, v in zip(t, Q, V):
        _, lam, G, frames = loops.rates(float(tk), q, v)
        out.append(Cut(tau=G.T @ lam, wrenches=loops.wrenches(lam, frames), reactions=loops.reactions(lam, frames)))
    return out


def evaluate(model: Model, t, Q, V, loops: constraints.Loops | None = None, cuts: list | None = None) -> Evaluated:
    """One forward-dynamics evaluation at every state, keeping what the channels need. With cut
    joints (`loops`, and their `cut_forces` if known): evaluated under the constraint forces as
    generalized forces, which gives the constrained accelerations; the joint forces f then carry
    those forces as if the tree joints transmitted them, and are corrected to the physical ones
    (`cut_wrenches`)."""
    data, tau = make_data(model), np.zeros(model.nv)
    if loops and cuts is None:
        cuts = cut_forces(loops, t, Q, V)
    rows = []
    for k, (tk, q, v) in enumerate(zip(t, Q, V)):
        q, v = np.ascontiguousarray(q, dtype=float), np.ascontiguousarray(v, dtype=float)
        if loops:
            tau = np.ascontiguousarray(cuts[k].tau)
        entry.forward(model, data, float(tk), q, v, tau)
        rows.append([data.f.copy(), data.v.copy(), data.a.copy(), data.Xup.copy(), data.X0.copy(),
                     data.scale.copy(), data.qdd.copy()])
    ev = Evaluated(*(np.array([r[k] for r in rows]).reshape((len(t),) + x.shape)
                     for k, x in enumerate([data.f, data.v, data.a, data.Xup, data.X0, data.scale, data.qdd])))
    if loops:
        ev = ev._replace(f=ev.f - cut_wrenches(model, loops, ev, [c.wrenches for c in cuts]))
    return ev


def cut_wrenches(model: Model, loops: constraints.Loops, ev: Evaluated, cuts: list) -> np.ndarray:
    """(n, nb+1, 6): per body k, the cut joints' forces on the bodies of its subtree, as a spatial
    force [moment; force] in k's frame: what a tree joint's force computed with the constraint
    forces as generalized forces exceeds the physical one by (the subtree's momentum balance)."""
    n, nb = len(ev.f), model.nb
    out = np.zeros((n, nb + 1, 6))
    for k in range(n):
        Xf = np.swapaxes(np.linalg.inv(ev.X0[k]), 1, 2)                # world -> body, force vectors
        for c, (_, f, m, x) in zip(loops.cuts, cuts[k]):
            for body, sign in ((c.C.body, 1.0), (c.P.body, -1.0)):
                W = sign * np.concatenate([m + np.cross(x, f), f])     # about the world origin
                i = body
                while i > 0:
                    out[k, i] += Xf[i] @ W
                    i = model.parent[i]
    return out


def reactions(model: Model, t, Q, V) -> np.ndarray:
    """(n, nb+1, 6): joint forces [moment; force] from parent onto body, body frame, at every state."""
    return evaluate(model, t, Q, V).f


def node_forces(model: Model, ev: Evaluated, i: int, Q, V, cut_loads=()) -> np.ndarray:
    """(n, N, 3) net force on each node of flexible body i, body frame (`channels.node_forces`):
    from the node accelerations relative to free fall (ev.a carries gravity as a base
    acceleration), the point loads on the body and the forces its child joints exert on it.

    a_p = a_O + al x r_p + w x (w x r_p) + 2 w x r'_p + r''_p, with r_p = x0_p + Phi_t,p eta and
    the classical acceleration of the origin a_O = a_lin + w x v_O (a_lin the spatial one)."""
    fb = model.bodies[model.names[i]]
    s = slice(model.body_madr[i], model.body_madr[i] + model.body_nm[i])
    Pt = fb.Phi[:, 3:, :]                                                   # (N, 3, nm)
    r = fb.x0 + flexbody.modal_field(Pt, Q[:, s])
    rd = flexbody.modal_field(Pt, V[:, s])
    rdd = flexbody.modal_field(Pt, ev.qdd[:, s])
    w, vO, al = ev.v[:, i, None, :3], ev.v[:, i, 3:], ev.a[:, i, None, :3]
    aO = (ev.a[:, i, 3:] + np.cross(ev.v[:, i, :3], vO))[:, None, :]
    acc = aO + np.cross(al, r) + np.cross(w, np.cross(w, r)) + 2.0 * np.cross(w, rd) + rdd
    loads = []
    for k in np.flatnonzero(model.load_body == i):
        f = model.load_force[k] * ev.scale[:, k, None]                      # (n, 3)
        if model.load_global[k]:
            f = np.einsum("nij,nj->ni", ev.X0[:, i, :3, :3], f)
        loads.append((fb.node_at(model.load_point[k, 0]), f))
    loads.extend(cut_loads)
    joints = [(model.jnt_node[c], -np.einsum("nji,nj->ni", ev.Xup[:, c, :3, :3], ev.f[:, c, 3:]))  # parent -> child
              for c in np.flatnonzero(model.parent == i)]
    return channels.node_forces(fb.m, acc, loads, joints)


def node_moments(model: Model, ev: Evaluated, i: int, V, r, cut_wrenches=()) -> np.ndarray:
    """(n, N, 3) net moment on each node of flexible body i beside its net force (`node_forces`),
    body frame (docs/formulation.md §7c): its rotary inertia's (`channels.rotary_moments`) and the
    moments about the node of the joints on it, the child joints' and the cut joints' (their forces
    are node forces); r (n, N, 3) the deformed node positions. A joint's wrench about the body
    origin, W = [m; f], puts m - r_p x f at its node p."""
    fb = model.bodies[model.names[i]]
    s = slice(model.body_madr[i], model.body_madr[i] + model.body_nm[i])
    T = channels.rotary_moments(fb.J, fb.Phi[:, :3, :], ev.v[:, i, :3], ev.a[:, i, :3], V[:, s], ev.qdd[:, s])
    for c in np.flatnonzero(model.parent == i):
        W = -np.einsum("nji,nj->ni", ev.Xup[:, c], ev.f[:, c])             # onto body i, about its origin
        p = model.jnt_node[c]
        T[:, p] += W[:, :3] - np.cross(r[:, p], W[:, 3:])
    for p, W in cut_wrenches:
        T[:, p] += W[:, :3] - np.cross(r[:, p], W[:, 3:])
    return T


def cut_node_wrenches(loops: constraints.Loops | None, cuts: list | None, ev: Evaluated, i: int) -> list:
    """[(node, (n, 6) [moment; force] about body i's origin, body i's frame)]: the cut joints'
    wrenches (`cut_forces`) on the nodes of flexible body i, whole (`cut_loads` keeps the forces)."""
    if not loops:
        return []
    fb = loops.model.bodies[loops.model.names[i]]
    Xf = np.swapaxes(np.linalg.inv(ev.X0[:, i]), 1, 2)                    # world -> body i, force vectors
    out = []
    for k, c in enumerate(loops.cuts):
        for side, sign in ((c.C, 1.0), (c.P, -1.0)):
            if side.body == i and side.Phi is not None:
                W = np.array([np.concatenate([n + np.cross(x, f), f]) for _, f, n, x in
                              (cut.wrenches[k] for cut in cuts)])         # (n, 6) about the world origin
                out.append((fb.node_at(side.x0[0]), sign * np.einsum("nij,nj->ni", Xf, W)))
    return out


def summed_strains(case, model: Model, ev: Evaluated, i: int, Q, V, F, loops=None, cuts=None) -> dict:
    """{x: (n, 4)} section strains at flexible beam i's stress sections by force summation
    (docs/formulation.md §7c): the resultants of the part beyond each section (`channels.section_loads`)
    from its nodes' net forces F (`node_forces`) and moments (`node_moments`), read through the
    section's stiffness (`channels.resultant_strains`)."""
    name = model.names[i]
    fb, body = model.bodies[name], case.modelled.bodies[name]
    s = slice(model.body_madr[i], model.body_madr[i] + model.body_nm[i])
    r = fb.x0 + flexbody.modal_field(fb.Phi[:, 3:, :], Q[:, s])
    T = node_moments(model, ev, i, V, r, cut_node_wrenches(loops, cuts, ev, i))
    return channels.summed_strains(fb, r, F, T, body.material, body.geometry)


def trajectory(case, model: Model, t, Q, V, E=None, loops: constraints.Loops | None = None) -> channels.Trajectory:
    """The channels' view of states Q (n, nq), V (n, nv) at t (n,) of the Model of
    `case.modelled`; E: `energies` if known; loops: the case's cut joints on the model. A beam
    split into segments is reported whole (`joined`)."""
    seg = case.modelled
    traj = channels.Trajectory(t=t)
    for jname in channels.joints_needed(case):
        i = model.index(seg.joints[jname].child)
        traj.joints[jname] = Q[:, model.jnt_qadr[i]].copy()
    if channels.wants_energy(case):
        E = energies(model, Q, V) if E is None else E
        traj.energy = {"kinetic": E[:, 0], "potential": E[:, 1]}
    asked = [c.joint for c in case.channels.values() if c.kind in ("reaction_force", "reaction_moment")]
    rules = {name: (False, False) if seg.bodies[name].type == "solid" else
             channels.axial_rule(seg.bodies[name].stiffening, bool(seg.stress_sections(name)), fb)
             for name, fb in model.bodies.items()}
    summed = {name for name in model.bodies if seg.bodies[name].type == "beam" and seg.bodies[name].stress == "forces"
              and seg.stress_sections(name)}
    need = asked or any(map(any, rules.values())) or case.segments or summed
    cuts = cut_forces(loops, t, Q, V) if loops and need else None
    ev = evaluate(model, t, Q, V, loops, cuts) if need else None
    traj.reactions = {j: ev.f[:, model.index(seg.joints[j].child)] for j in asked if j in seg.joints}
    traj.reactions.update({j: np.array([c.reactions[j] for c in cuts]).reshape(len(t), 6)
                           for j in asked if j in case.loops})
    for name, fb in model.bodies.items():
        i = model.index(name)
        eta = Q[:, model.body_madr[i]:model.body_madr[i] + model.body_nm[i]]
        body = seg.bodies[name]
        if body.type == "solid":
            traj.beams[name] = channels.modal_solid(fb, body, channels.points_needed(seg, name),
                                                    seg.stress_sections(name), eta)
            continue
        points, x0 = channels.modal_points(fb, channels.points_needed(seg, name), eta)
        F = node_forces(model, ev, i, Q, V, cut_loads(loops, cuts, ev, i)) if any(rules[name]) or name in summed \
            else None
        strains = summed_strains(case, model, ev, i, Q, V, F, loops, cuts) if name in summed else None
        traj.beams[name] = channels.modal_beam(fb, eta, body.material, body.geometry,
                                               points, x0, channels.modal_root(fb, eta), F, rules[name], strains)
    for beam, parts in case.segments.items():
        traj.beams[beam] = joined(case, model, ev, Q, beam, [traj.beams.pop(p) for p in parts])
    traj.poses = poses(case, model, Q, V)
    return traj


def poses(case, model: Model, Q, V) -> dict:
    """Body name -> (R (n, 3, 3), p (n, 3)) of every body of the case at the states Q, V
    (`channels.Trajectory.poses`): its body frame, from the kinematics of the energy's evaluation
    (X0); the identity for a beam split into segments, whose points are global (`joined`)."""
    data, n = make_data(model), len(Q)
    R, p = np.zeros((n, model.nb + 1, 3, 3)), np.zeros((n, model.nb + 1, 3))
    for k, (q, v) in enumerate(zip(Q, V)):
        entry.energy(model, data, q, v)
        R[k], p[k] = pose(data.X0)
    whole = (np.broadcast_to(np.eye(3), (n, 3, 3)), np.zeros((n, 3)))
    return {b: whole if b in case.segments else (R[:, model.index(b)], p[:, model.index(b)]) for b in case.bodies}


def pose(X) -> tuple:
    """(R (n, 3, 3) body -> global, p (n, 3) the body's origin) of the transforms X (n, 6, 6) from
    the global frame to a body's (Plücker): n instants of one body, or one instant's bodies."""
    E = X[:, :3, :3]
    rx = -np.einsum("nji,njk->nik", E, X[:, 3:, :3])                        # r~ of the body's origin
    return np.swapaxes(E, 1, 2), np.stack([rx[:, 2, 1], rx[:, 0, 2], rx[:, 1, 0]], axis=1)


def cut_loads(loops: constraints.Loops | None, cuts: list | None, ev: Evaluated, i: int) -> list:
    """[(node, (n, 3) force in body i's frame)]: the cut joints' forces (`cut_forces`) on the nodes
    of flexible body i (their moments are not node forces and are left out, as a joint's are)."""
    if not loops:
        return []
    sides = [(k, c.C.x0, 1.0) for k, c in enumerate(loops.cuts) if c.C.body == i and c.C.Phi is not None] + \
            [(k, c.P.x0, -1.0) for k, c in enumerate(loops.cuts) if c.P.body == i and c.P.Phi is not None]
    fb = loops.model.bodies[loops.model.names[i]]
    W = np.array([[f for _, f, _, _ in c.wrenches] for c in cuts]).reshape(len(cuts), len(loops.cuts), 3)  # world
    E = ev.X0[:, i, :3, :3]                                                 # world -> body i
    return [(fb.node_at(x0[0]), sign * np.einsum("nij,nj->ni", E, W[:, k])) for k, x0, sign in sides]


def joined(case, model: Model, ev: Evaluated, Q, beam: str, parts: list) -> channels.Beam:
    """The Beam of a beam split into segments, from its segments' Beams `parts` (root first):
    points in the global frame, r_k + E_k^T (x0_p + Phi_t,p eta_k) with segment k's pose from X0,
    the root rotation E_1^T R_1 of segment 1's root node (None with hinged-hinged modes: the
    chord through the beam's ends), strains from the segment holding each stress section, and
    per validity measure the largest over the segments (each against its own length)."""
    L = case.bodies[beam].length
    first = model.index(case.place(beam, 0.0)[0])
    points, x0 = {}, {}
    for x in channels.points_needed(case, beam):
        name, local = case.place(beam, x)
        i = model.index(name)
        fb = model.bodies[name]
        eta = Q[:, model.body_madr[i]:model.body_madr[i] + model.body_nm[i]]
        p, p0 = channels.modal_points(fb, [local], eta)
        R, r = pose(ev.X0[:, i])
        points[x] = r + np.einsum("nij,nj->ni", R, p[local])
        x0[x] = p0[local] + np.array([x - local, 0.0, 0.0])
    root = parts[0].root
    if root is not None:
        root = np.einsum("nji,njk->nik", ev.X0[:, first, :3, :3], root)
    strains = {}
    for x in case.stress_sections(beam):
        name, local = case.place(beam, x)
        strains[x] = parts[case.segments[beam].index(name)].strains[local]
    extent = {k: np.max([b.extent[k] for b in parts], axis=0) for k in parts[0].extent}
    return channels.Beam(length=L, points=points, x0=x0, root=root, strains=strains, extent=extent)
