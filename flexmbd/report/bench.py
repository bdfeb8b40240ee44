"""`flexmbd bench`: timing measured against peers in the same process, on the same machine.

    work_precision    on each paper case: flexmbd (with geometric stiffening, its default) and
                      flexmbd-linear (without: the linear floating frame) over dopri5 and Adams
                      tolerances, fox-goodwin steps and exp-adams steps at two intervals between its
                      linearizations (integrator.refresh 25 and 12), exudyn-ffrf (the same linear
                      floating frame) over the steps of its generalized-alpha and Fox-Goodwin schemes; each row's
                      error = the worst deflection channel's RMS difference over the largest magnitude,
                      `error` against the converged run of the same model (CONVERGED) and
                      `error_reference` against the case's reference (its report.reference)
    models            per case: how far the converged runs lie from each other and from the reference
    matched_accuracy  the same model compared: for error targets 1e-3 and 1e-4 the fastest setting of
                      flexmbd-linear and of exudyn-ffrf meeting it (each against its own converged run)
                      and their ratio
    against_reference each solver against the case's reference: its floor (the reference error of its
                      most converged setting) and its fastest setting meeting each target there and
                      against its own converged run
    rigid_chain       one forward-dynamics evaluation of an n-link revolute chain, flexmbd vs
                      Pinocchio, median of many calls from Python
    flexible_chain    one evaluation for n flexible beams (12 modes) in a chain, each on its
                      parent's tip node; the fitted exponent of cost against n (n >= 4)
    solid_mesh        one evaluation of the same solid part (the paper's beam as hex20, 12 clamped-interface
                      modes, on a revolute joint under gravity) meshed at about 5,000 and 50,000 DOFs, with
                      the time and peak memory of each reduction: the run time does not depend on the mesh
    compile_s         first compilation of what a dopri5 run uses (empty cache, in a subprocess) and a cached load
    loops             the closed-loop cases (four_bar, slider_crank): each solver over its settings, the
                      fastest within 1e-3 of its own converged run (worst deflection channel, RMS over
                      the largest magnitude) and flexmbd's wall time over each peer's at that accuracy
    duty_cycle        the 50-revolution slider-crank (slider_crank_duty): each solver over its settings, the
                      S_eq (m = 5) of the rod's midpoint stress, its difference from the solver's own converged
                      S_eq and from the reference's, and the fastest setting within 1 % of its own converged S_eq

Wall times are solve-only (`Result.wall_s`) for both solvers. Nothing here asserts a time.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from flexmbd import cases
from flexmbd.harness import metrics, results, registry
from flexmbd.harness import durability as fatigue
from flexmbd.solvers.build import from_case
from flexmbd.core.errors import InputError
from flexmbd.core.files import json_text
from flexmbd.mbd.compiled.entry import forward
from flexmbd.mbd.model import make_data

BEAM = {"type": "beam", "material": "steel", "length": 1.5, "elements": 30,
        "section": {"shape": "rectangle", "b": 0.01, "h": 0.015}, "modes": {"count": 12}}


def chain_case(n: int, flexible: bool, stiffening: bool = True) -> cases.Case:
    """n links in a revolute chain (axis z) under gravity: rigid bars or 12-mode beams (with or
    without geometric stiffening), each on its parent's tip."""
    bodies, joints = {}, {}
    for k in range(n):
        if flexible:
            bodies[f"b{k}"] = dict(BEAM, stiffening=stiffening)
        else:
            bodies[f"b{k}"] = {"type": "rigid", "mass": 1.0, "com": [0.25, 0.0, 0.0],
                               "inertia": [1e-4, 2e-2, 2e-2, 0.0, 0.0, 0.0]}
        parent = "ground" if k == 0 else f"b{k - 1}"
        at = [0.0, 0.0, 0.0] if k == 0 else (1.5 if flexible else [0.5, 0.0, 0.0])
        joints[f"j{k}"] = {"type": "revolute", "parent": parent, "child": f"b{k}", "at": at}
    raw = {"title": f"{n}-link chain", "duration": 1.0, "gravity": [0.0, -9.81, 0.0],
           "materials": {"steel": {"E": 2.06e11, "nu": 0.29, "rho": 7820.0}}, "bodies": bodies,
           "joints": joints, "channels": {"energy": {"kind": "energy"}}}
    return cases.Case(name=f"chain{n}", path=Path("bench"), data=cases.validate(raw, "bench chain"))


def median_us(f, calls: int = 2000, repeats: int = 7) -> float:
    """Median over repeats of the mean time of one call, microseconds."""
    f()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(calls):
            f()
        times.append((time.perf_counter() - t0) / calls)
    return float(np.median(times) * 1e6)


MODAL_SCALE = 1e-3      # modal coordinates of the random state, against 0.3 rad and rad/s on the joints


def evaluation(model):
    """A zero-argument call of one flexmbd forward-dynamics evaluation at the fixed random `state`:
    `compiled.entry.forward` on the model and a Data, as a user calls it from Python; and that state."""
    data = make_data(model)
    q, v, tau = state(model)
    return lambda: forward(model, data, 0.0, q, v, tau), (q, v, tau)


def state(model) -> tuple:
    """A fixed random state (q (nq,), v (nv,), tau (nv,) = 0): joint coordinates and rates ~ 0.3,
    modal ones ~ MODAL_SCALE (a 12-mode beam of the chain bends by millimetres: with 0.3 on every
    mode its stiffened mass matrix would not be positive definite and the accelerations not finite)."""
    rng = np.random.default_rng(0)
    sq, sv = np.full(model.nq, 0.3), np.full(model.nv, 0.3)
    for i in range(1, model.nb + 1):                   # body_madr: the same index in q and in v
        a, n = model.body_madr[i], model.body_nm[i]
        sq[a:a + n] = sv[a:a + n] = MODAL_SCALE
    q, v = rng.normal(size=model.nq) * sq, rng.normal(size=model.nv) * sv
    return q, v, np.zeros(model.nv)


def rigid_chain(ns=(1, 2, 8, 32, 64)) -> list[dict]:
    import pinocchio as pin
    from flexmbd.solvers import pinocchio_model
    rows = []
    for n in ns:
        model = from_case(chain_case(n, flexible=False))
        f, (q, v, tau) = evaluation(model)
        pm, _ = pinocchio_model.build(model)
        pd = pm.createData()
        ours = median_us(f)
        theirs = median_us(lambda: pin.aba(pm, pd, q, v, tau))
        rows.append({"n": n, "flexmbd_us": ours, "pinocchio_us": theirs, "ratio": ours / theirs})
    return rows


def flexible_chain(ns=(1, 2, 4, 8, 16, 32, 64)) -> tuple[list[dict], float]:
    rows = []
    for n in ns:
        model = from_case(chain_case(n, flexible=True))
        f, _ = evaluation(model)
        rows.append({"n": n, "flexmbd_us": median_us(f, calls=max(20, 2000 // n))})
    big = [(r["n"], r["flexmbd_us"]) for r in rows if r["n"] >= 4]
    if len(big) < 2:
        return rows, np.nan
    exponent = float(np.polyfit(np.log([b[0] for b in big]), np.log([b[1] for b in big]), 1)[0])
    return rows, exponent


SOLID_MESHES = {"5k": [60, 2, 2], "50k": [240, 4, 3]}      # hex20 divisions: 5,463 and 51,258 DOFs


def solid_case(divisions) -> cases.Case:
    """The paper's beam as a hex20 solid (12 clamped-interface modes) on a revolute joint under gravity."""
    raw = {"title": "solid pendulum", "duration": 1.0, "gravity": [0.0, -9.81, 0.0],
           "materials": {"steel": {"E": 2.06e11, "nu": 0.29, "rho": 7820.0}},
           "bodies": {"bar": {"type": "solid", "material": "steel", "frame": "root", "modes": {"count": 12},
                              "mesh": {"box": [1.5, 0.015, 0.01], "divisions": list(divisions)},
                              "interfaces": {"root": {"set": "x0", "kind": "rigid"}, "tip": {"set": "xL"}}}},
           "joints": {"pivot": {"type": "revolute", "parent": "ground", "child": "bar"}},
           "channels": {"tip": {"kind": "deflection", "body": "bar", "at": "tip"}}}
    return cases.Case(name="solid", path=Path("bench"), data=cases.validate(raw, "bench solid"))


def solid_mesh(meshes=SOLID_MESHES) -> list[dict]:
    """Per mesh: its DOFs, the reduction's time (s) and the process's peak resident memory after
    it (MB, so a larger mesh measured later shows its own peak), and one evaluation (us)."""
    import resource
    rows, calls = [], {}
    for name, div in meshes.items():
        case = solid_case(div)
        t0 = time.perf_counter()
        fb = case.reduced("bar")
        reduce_s = time.perf_counter() - t0
        calls[name] = evaluation(from_case(case))[0]
        rows.append({"mesh": name, "dofs": 3 * (fb.n_nodes - 2), "reduce_s": reduce_s,
                     "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024})
    times = {name: [] for name in calls}               # the evaluations timed in turn, after every reduction:
    for _ in range(3):                                  # no mesh is timed in a warmer or colder process
        for name, f in calls.items():
            times[name].append(median_us(f))
    for r in rows:
        r["flexmbd_us"] = float(np.median(times[r["mesh"]]))
    return rows


def compile_seconds(method: str = "dopri5") -> dict:
    """First compilation (empty cache, subprocess) and a cached start (same cache, second
    subprocess) of what a run with the compiled integrator `method` uses, and one evaluation
    from Python: the whole process, import included."""
    code = ("import time; t=time.perf_counter(); from flexmbd.report import bench; "
            "from flexmbd.solvers.build import from_case; m=from_case(bench.chain_case(2, True)); "
            f"f=bench.evaluation(m)[0]; f(); from flexmbd.mbd import integrate; integrate.warm_up(m, {method!r}); "
            "print(time.perf_counter()-t)")
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "XDG_CACHE_HOME": cache}
        cold = float(subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                                    check=True).stdout.split()[-1])
        warm = float(subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                                    check=True).stdout.split()[-1])
    return {"cold_s": cold, "cached_s": warm, "method": method}


# ---------------------------------------------------------------------------------------------
# work-precision


def deflection_error(case, ref, r) -> float:
    """Worst deflection channel's RMS difference from the reference over its maximum magnitude."""
    if not r.ok or ref is None or not ref.ok:
        return np.nan
    errs = [metrics.rms_diff(ref.channels[c], metrics.on_grid(ref.t, r.t, r.channels[c]))
            for c, ch in case.channels.items() if ch.kind == "deflection" and c in r.channels and c in ref.channels]
    return float(max(errs)) if errs else np.nan


# The converged run of each model, against which its own settings are graded: flexmbd (with
# geometric stiffening, its default) and flexmbd-linear (without: the linear floating frame) at
# rtol 1e-12 with dopri5; exudyn-ffrf (the same linear floating frame) with Fox-Goodwin at half the
# smallest step of the sweep (its error falls as (w h)^4, docs/exudyn.md).
CONVERGED = {"flexmbd": ["integrator.method=dopri5", "integrator.rtol=1e-12", "integrator.atol=1e-14"],
             "exudyn-ffrf": ['solvers.exudyn-ffrf.solver="fox-goodwin"', "solvers.exudyn-ffrf.dt=1.25e-5"]}


def linear(name: str) -> list[str]:
    """Overrides that turn geometric stiffening off on every flexible beam of case `name`: flexmbd's
    model is then the linear floating frame of exudyn-ffrf (docs/formulation.md §4b)."""
    case = cases.load(name)
    return [f"bodies.{b}.stiffening=false" for b, body in case.bodies.items()
            if body.type == "beam" and body.flexible]


def reference_run(name: str, stored: Path | None = None):
    """(solver, Result) of case `name`'s own reference (report.reference, or the default one) at
    the case's settings: the stored result in `stored` (a report's results folder) when it belongs
    to the current case, else a run of it."""
    case = registry.graded(cases.load(name))
    ref = case.report.reference
    if ref is None:
        return None, None
    if stored is not None:
        try:
            r = results.read(stored, name, ref)
            if not results.stale(r, case.sha256, case.channels) and r.ok:
                return ref, r
        except InputError:
            pass
    return ref, registry.run(case, ref)


def work_precision(names, flexmbd_settings, exudyn_settings, progress=None, stored: Path | None = None
                   ) -> tuple[list[dict], dict]:
    """Rows {case, solver, scheme, setting, error, error_reference, wall_s}: flexmbd (with geometric
    stiffening) and flexmbd-linear (without) over (method, setting) pairs, exudyn-ffrf over
    (scheme, dt) pairs. `error` is against the converged run of the same model (CONVERGED: flexmbd's
    own for flexmbd, flexmbd-linear's for flexmbd-linear, exudyn-ffrf's for exudyn-ffrf),
    `error_reference` against the case's reference (`reference_run`). Also, per case: the
    reference's solver and how far the converged runs of the linear floating frame lie from each
    other (`models`: flexmbd-linear's against exudyn-ffrf's, the same model solved twice) and from
    the reference; and per case and Exudyn scheme whether its error falls steadily as the step
    shrinks."""
    rows, info = [], {"convergence": {}, "models": {}}
    for name in names:
        lin = linear(name)
        case = cases.load(name)
        ref_solver, ref = reference_run(name, stored)
        own = {"flexmbd": registry.run(cases.load(name, CONVERGED["flexmbd"]), "flexmbd"),
               "flexmbd-linear": registry.run(cases.load(name, CONVERGED["flexmbd"] + lin), "flexmbd"),
               "exudyn-ffrf": registry.run(cases.load(name, CONVERGED["exudyn-ffrf"]), "exudyn-ffrf")}
        info["models"][name] = {
            "reference": ref_solver,
            "exudyn_ffrf_vs_flexmbd_linear": deflection_error(case, own["flexmbd-linear"], own["exudyn-ffrf"]),
            **{f"{s}_vs_reference".replace("-", "_"): deflection_error(case, ref, r) for s, r in own.items()}}

        def add(solver, scheme, setting, over, runs_as):
            c = cases.load(name, over)
            r = registry.run(c, runs_as)
            rows.append({"case": name, "solver": solver, "scheme": scheme, "setting": setting,
                         "error": deflection_error(c, own[solver], r), "error_reference": deflection_error(c, ref, r),
                         "wall_s": r.wall_s})
            if progress:
                progress(rows[-1])

        for solver, extra in (("flexmbd", []), ("flexmbd-linear", lin)):
            for method, value in flexmbd_settings:
                scheme = method
                if method == "fox-goodwin":                 # fixed step dt, Newton tolerance 1e-6
                    setting, over = f"dt={value:g}", [f"integrator.dt={value}", "integrator.rtol=1e-6"]
                elif method == "exp-adams":                 # fixed step dt and linearization interval, no tolerance
                    dt, refresh = value                     # one curve per interval: "exp-adams, refresh 25"
                    scheme, setting = f"{method}, refresh {refresh}", f"dt={dt:g}"
                    over = [f"integrator.dt={dt}", f"integrator.refresh={refresh}"]
                else:
                    setting, over = f"rtol={value:g}", [f"integrator.rtol={value}", f"integrator.atol={value * 1e-2}"]
                add(solver, scheme, setting, [f"integrator.method={method}"] + over + extra, "flexmbd")
        for scheme, dt in exudyn_settings:
            add("exudyn-ffrf", scheme, f"dt={dt:g}",
                [f"solvers.exudyn-ffrf.dt={dt}", f'solvers.exudyn-ffrf.solver="{scheme}"'], "exudyn-ffrf")
        for scheme in dict(exudyn_settings):
            info["convergence"][f"{name} / {scheme}"] = convergence(rows, name, scheme)
    return rows, info


def finite(x) -> bool:
    """Whether an error is a number: a diverged run's is nan, or null (None) in a stored run's JSON."""
    return x is not None and bool(np.isfinite(x))


def convergence(rows: list[dict], name: str, scheme: str) -> dict:
    """Whether exudyn-ffrf's error with `scheme` on case `name` falls steadily over its rows (in
    the order of shrinking step), diverged (non-finite) runs left out. flexmbd rows of a scheme
    of the same name (fox-goodwin) are not part of it."""
    errs = [r["error"] for r in rows if r["case"] == name and r["solver"] == "exudyn-ffrf" and r["scheme"] == scheme]
    fin = [e for e in errs if finite(e)]
    return {"errors": errs, "decreasing": bool(len(fin) > 1 and all(np.diff(fin) < 0)),
            "smallest": min(fin) if fin else np.nan}


def fastest(rows: list[dict], name: str, solver: str, target: float, key: str = "error") -> tuple:
    """(wall_s, "scheme setting") of `solver`'s fastest row on case `name` whose `key` error meets
    `target`; (nan, "") when none does."""
    ok = [(r["wall_s"], f"{r['scheme']} {r['setting']}") for r in rows if r["case"] == name
          and r["solver"] == solver and finite(r.get(key)) and r[key] <= target]
    return min(ok) if ok else (np.nan, "")


def matched_accuracy(rows: list[dict], targets=(1e-3, 1e-4), ours: str = "flexmbd-linear") -> list[dict]:
    """The same model compared: for each case and error target, the fastest setting of `ours`
    (flexmbd without stiffening, the linear floating frame) and of exudyn-ffrf, each graded against
    its own converged run (`error`), and the ratio of their wall times."""
    out = []
    for name in sorted({r["case"] for r in rows}):
        for target in targets:
            mine, theirs = fastest(rows, name, ours, target), fastest(rows, name, "exudyn-ffrf", target)
            out.append({"case": name, "error_target": target, "flexmbd_wall_s": mine[0],
                        "exudyn_ffrf_wall_s": theirs[0], "ratio": mine[0] / theirs[0],
                        "flexmbd_setting": mine[1], "exudyn_ffrf_setting": theirs[1], "model": ours})
    return out


def against_reference(rows: list[dict], targets=(1e-3, 1e-4)) -> list[dict]:
    """Each solver against the case's reference (`error_reference`): its floor, the reference
    error of its most converged setting (the smallest `error` against its own converged run),
    where its model, not its step, sets the error; and its fastest setting meeting each target
    against the reference while also within that target of its own converged run (nan when the
    model's own error lies above it). A coarse run can land nearer the reference than the
    converged one by chance (its own error far above the target): it counts for neither."""
    out = []
    for name in sorted({r["case"] for r in rows}):
        for solver in dict.fromkeys(r["solver"] for r in rows if r["case"] == name):
            mine = [r for r in rows if r["case"] == name and r["solver"] == solver
                    and finite(r.get("error")) and finite(r.get("error_reference"))]
            row = {"case": name, "solver": solver,
                   "floor": min(mine, key=lambda r: r["error"])["error_reference"] if mine else np.nan}
            for target in targets:
                row[f"wall_s_at_{target:.0e}"], row[f"setting_at_{target:.0e}"] = \
                    fastest([r for r in mine if r["error"] <= target], name, solver, target, "error_reference")
            out.append(row)
    return out


# ---------------------------------------------------------------------------------------------
# the duty cycle: a long history's fatigue count at each solver's settings

DUTY = "slider_crank_duty"
# each solver's settings, coarse to fine, the last its converged run: flexmbd's dopri5 tolerance
# (the case's: 1e-8), the Exudyn adapters' generalized-alpha step (the case's: 2.5e-5 s)
DUTY_SETTINGS = {
    "flexmbd": [(f"rtol={r:g}", [f"integrator.rtol={r}", f"integrator.atol={r / 10}"]) for r in (1e-4, 1e-6, 1e-8, 1e-10)],
    **{s: [(f"dt={dt:g}", [f"solvers.{s}.dt={dt}"]) for dt in (1e-4, 5e-5, 2.5e-5, 1.25e-5)]
       for s in ("exudyn-beam", "exudyn-ffrf")}}
DUTY_TARGET = 0.01          # |S_eq / its converged S_eq - 1| the fastest setting must meet


def duty_cycle(progress=None, settings=DUTY_SETTINGS, name: str = DUTY) -> dict:
    """Each solver of `settings` on case `name` at each of its settings: rows {solver, setting,
    seq3_MPa, seq5_MPa, wall_s, error (|S_eq,5 / the solver's converged S_eq,5 - 1|), error_reference
    (against the reference's converged run)}; and per solver its fastest setting within
    DUTY_TARGET of its own converged S_eq (`fastest`: nan when none)."""
    rows = []
    for solver, grid in settings.items():
        for setting, over in grid:
            case = cases.load(name, over)
            st = fatigue.settings(case)
            r = registry.run(case, solver)
            got = (fatigue.summary(*fatigue.counted(r.t, r.channels[st.channels[0]], st), st.curve)
                   if r.ok else {"seq3_MPa": np.nan, "seq5_MPa": np.nan})
            rows.append({"case": name, "solver": solver, "setting": setting, "seq3_MPa": got["seq3_MPa"],
                         "seq5_MPa": got["seq5_MPa"], "wall_s": r.wall_s, "status": str(r.status)})
            if progress:
                progress({**rows[-1], "scheme": "duty cycle", "error": np.nan})
    ref = cases.load(name).report.reference
    last = {s: [r for r in rows if r["solver"] == s][-1]["seq5_MPa"] for s in settings}
    for r in rows:
        r["error"] = abs(r["seq5_MPa"] / last[r["solver"]] - 1.0)
        r["error_reference"] = abs(r["seq5_MPa"] / last[ref] - 1.0) if ref in last else np.nan
    fastest = []
    for s in settings:
        ok = [r for r in rows if r["solver"] == s and finite(r["error"]) and r["error"] <= DUTY_TARGET]
        best = min(ok, key=lambda r: r["wall_s"]) if ok else None
        fastest.append({"solver": s, "setting": best["setting"] if best else "",
                        "wall_s": best["wall_s"] if best else np.nan, "seq5_MPa": best["seq5_MPa"] if best else np.nan,
                        "converged_seq5_MPa": last[s], "error_reference": best["error_reference"] if best else np.nan})
    return {"case": name, "reference": ref, "target": DUTY_TARGET, "rows": rows, "fastest": fastest}


# ---------------------------------------------------------------------------------------------
# closed loops: each solver's fastest setting within a target of its own converged run

LOOPS = ("four_bar", "slider_crank")
# each solver's settings, coarse to fine: flexmbd's fox-goodwin steps (Newton to 1e-4) and dopri5
# tolerances, the Exudyn adapters' steps (each case's scheme); then LOOP_CONVERGED, its converged run
LOOP_SETTINGS = {
    "flexmbd": [(f"fox-goodwin dt={dt:g}", ["integrator.method=fox-goodwin", f"integrator.dt={dt}",
                                            "integrator.rtol=1e-4", "integrator.atol=1e-6"]) for dt in (1e-4, 5e-5, 2.5e-5)]
    + [(f"dopri5 rtol={r:g}", ["integrator.method=dopri5", f"integrator.rtol={r}", f"integrator.atol={r / 10}"])
       for r in (1e-4, 1e-6, 1e-8)],
    **{s: [(f"dt={dt:g}", [f"solvers.{s}.dt={dt}"]) for dt in (1e-4, 5e-5, 2.5e-5, 1.25e-5)]
       for s in ("exudyn-beam", "exudyn-ffrf")}}
LOOP_CONVERGED = {"flexmbd": ["integrator.method=dopri5", "integrator.rtol=1e-12", "integrator.atol=1e-14"],
                  **{s: [f"solvers.{s}.dt=3.125e-6"] for s in ("exudyn-beam", "exudyn-ffrf")}}
LOOP_TARGET = 1e-3          # the worst deflection channel's RMS difference from the solver's own converged run


def loops(progress=None, settings=LOOP_SETTINGS, converged=LOOP_CONVERGED, names=LOOPS) -> dict:
    """Each solver of `settings` on each closed-loop case at each of its settings: rows {case,
    solver, setting, error (the worst deflection channel's RMS difference from the solver's own
    converged run, `converged`, over its largest magnitude: `deflection_error`), error_reference
    (from the case's reference at the case's settings), wall_s}; per case the fastest setting of
    each solver within LOOP_TARGET of its own converged run and flexmbd's time over each peer's."""
    rows, fastest = [], []
    for name in names:
        ref_solver, ref = reference_run(name)
        for solver, grid in settings.items():
            own = registry.run(cases.load(name, converged[solver]), solver)
            mine = []
            for setting, over in grid:
                case = cases.load(name, over)
                r = registry.run(case, solver)
                mine.append({"case": name, "solver": solver, "setting": setting, "scheme": "loop",
                             "error": deflection_error(case, own, r), "error_reference": deflection_error(case, ref, r),
                             "wall_s": r.wall_s, "status": str(r.status)})
                if progress:
                    progress(mine[-1])
            rows += mine
            ok = [r for r in mine if finite(r["error"]) and r["error"] <= LOOP_TARGET]
            best = min(ok, key=lambda r: r["wall_s"]) if ok else None
            fastest.append({"case": name, "solver": solver, "setting": best["setting"] if best else "",
                            "wall_s": best["wall_s"] if best else np.nan,
                            "error_reference": best["error_reference"] if best else np.nan})
    ratios = []
    for name in names:
        mine = next(f for f in fastest if f["case"] == name and f["solver"] == "flexmbd")
        for f in fastest:
            if f["case"] == name and f["solver"] != "flexmbd":
                ratios.append({"case": name, "peer": f["solver"], "ratio": mine["wall_s"] / f["wall_s"],
                               "flexmbd_setting": mine["setting"], "peer_setting": f["setting"]})
    return {"target": LOOP_TARGET, "rows": rows, "fastest": fastest, "ratios": ratios}


# ---------------------------------------------------------------------------------------------
# the command


def run(quick: bool = False, with_work_precision: bool = True, progress=None, stored: Path | None = None) -> dict:
    """Every measurement of the module docstring; `stored`: a report's results folder whose fresh
    reference runs are used instead of running them again (`reference_run`)."""
    out = {"machine": f"{os.cpu_count()} cpu", "quick": quick}
    out["compile_s"] = compile_seconds()
    out["rigid_chain"] = rigid_chain((1, 2, 8) if quick else (1, 2, 8, 32, 64))
    ns = (1, 4, 8) if quick else (1, 2, 4, 8, 16, 32, 64)
    out["flexible_chain"], out["flexible_chain_exponent"] = flexible_chain(ns)
    out["solid_mesh"] = solid_mesh({"5k": SOLID_MESHES["5k"]} if quick else SOLID_MESHES)
    if not quick:                                       # minutes: 12 runs of 50 revolutions
        out["duty_cycle"] = duty_cycle(progress)
        out["loops"] = loops(progress)                  # minutes: 34 runs of two closed-loop cases
    if with_work_precision:
        names = ["cantilever_step"] if quick else ["cantilever_step", "pendulum", "double_pendulum"]
        if quick:
            ours = [("dopri5", 1e-4), ("dopri5", 1e-6), ("adams", 1e-6)]
            theirs = [("generalized-alpha", 1e-4), ("fox-goodwin", 2e-4), ("fox-goodwin", 1e-4)]
        else:
            ours = ([("dopri5", r) for r in (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8)]
                    + [("fox-goodwin", dt) for dt in (5e-4, 2e-4, 1e-4, 5e-5, 2.5e-5)]
                    + [("exp-adams", (dt, refresh)) for refresh in (25, 12)
                       for dt in (3.2e-2, 1.6e-2, 8e-3, 4e-3, 2e-3, 1.5e-3, 1e-3, 5e-4)]
                    + [("adams", r) for r in (1e-5, 1e-7, 1e-9)])
            theirs = ([("generalized-alpha", dt) for dt in (2e-4, 1e-4, 5e-5, 2.5e-5)]
                      + [("fox-goodwin", dt) for dt in (8e-4, 4e-4, 3e-4, 2e-4, 1.5e-4, 1e-4, 5e-5, 2.5e-5)])
        out["work_precision"], info = work_precision(names, ours, theirs, progress, stored)
        out["exudyn_convergence"], out["models"] = info["convergence"], info["models"]
        out["matched_accuracy"] = matched_accuracy(out["work_precision"])
        out["against_reference"] = against_reference(out["work_precision"])
    return out


def plots(result: dict, folder: Path) -> list[str]:
    """Work-precision (`report.figures.work_precision`, one panel per case) and scaling plots plus
    an index page in `folder`; returns the file names."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from flexmbd.report import figures
    names = [figures.work_precision(result["work_precision"], folder / "work_precision.png")] \
        if result.get("work_precision") else []
    fig, ax = plt.subplots(figsize=(7, 4.5))
    rc, fc = result["rigid_chain"], result["flexible_chain"]
    ax.loglog([r["n"] for r in rc], [r["flexmbd_us"] for r in rc], "o-", label="flexmbd, rigid chain")
    ax.loglog([r["n"] for r in rc], [r["pinocchio_us"] for r in rc], "s--", label="pinocchio, rigid chain")
    ax.loglog([r["n"] for r in fc], [r["flexmbd_us"] for r in fc], "^-",
              label=f"flexmbd, flexible chain (exponent {result['flexible_chain_exponent']:.2f})")
    ax.set_xlabel("bodies n")
    ax.set_ylabel("one forward-dynamics evaluation [us]")
    ax.grid(alpha=0.3, which="both")
    ax.legend()
    names.append(figures.save(fig, folder / "scaling.png"))
    duty = result.get("duty_cycle")
    if duty:                                            # S_eq's difference from the converged one against the time
        fig, ax = plt.subplots(figsize=(7, 4.5))
        for s in dict.fromkeys(r["solver"] for r in duty["rows"]):
            pts = [r for r in duty["rows"] if r["solver"] == s and finite(r["error"]) and r["error"] > 0]
            ax.loglog([r["wall_s"] for r in pts], [r["error"] for r in pts], "o-", label=s)
            for r in pts:
                ax.annotate(r["setting"], (r["wall_s"], r["error"]), fontsize=7)
        ax.axhline(duty["target"], ls="--", color="k", lw=0.8, label=f"{duty['target']:.0%}")
        ax.set_xlabel("solve wall time [s]")
        ax.set_ylabel("|S_eq / its converged S_eq - 1| (m = 5)")
        ax.set_title(f"{duty['case']}: the fatigue count's convergence", fontsize=10)
        ax.grid(alpha=0.3, which="both")
        ax.legend()
        names.append(figures.save(fig, folder / "duty_cycle.png"))
    got = result.get("loops")
    if got:                                             # each loop case: the error against the time, per solver
        cases_ = list(dict.fromkeys(r["case"] for r in got["rows"]))
        fig, axes = plt.subplots(1, len(cases_), figsize=(6 * len(cases_), 4.5), squeeze=False)
        for ax, name in zip(axes[0], cases_):
            for s in dict.fromkeys(r["solver"] for r in got["rows"]):
                pts = sorted((r for r in got["rows"] if r["case"] == name and r["solver"] == s
                              and finite(r["error"]) and r["error"] > 0), key=lambda r: r["wall_s"])
                ax.loglog([r["wall_s"] for r in pts], [r["error"] for r in pts], "o", label=s)
            ax.axhline(got["target"], ls="--", color="k", lw=0.8, label=f"{got['target']:g}")
            ax.set_xlabel("solve wall time [s]")
            ax.set_ylabel("worst deflection RMS diff from its own converged run")
            ax.set_title(f"{name}: closed loop, each solver at its settings", fontsize=10)
            ax.grid(alpha=0.3, which="both")
            ax.legend(fontsize=8)
        names.append(figures.save(fig, folder / "loops.png"))
    page = ("<!doctype html><html><head><meta charset='utf-8'><title>flexmbd bench</title></head><body>"
            "<p><a href='../index.html'>report</a></p><h1>flexmbd bench</h1>"
            + "".join(f"<p><img src='{n}' alt='{n}'></p>" for n in names)
            + f"<pre>{json_text(result, indent=1)}</pre></body></html>")
    from flexmbd.core.files import atomic_write
    atomic_write(folder / "index.html", page + "\n")
    atomic_write(folder / "bench.json", json_text(result, indent=1) + "\n")
    return names + ["index.html", "bench.json"]
