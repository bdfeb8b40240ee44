"""The solver registry and `run`: one solver on one case, timed, never crashing the caller.

A solver is a module with
    SETTINGS                 schema of its `[solvers.NAME]` table in a case file (see cases.py)
    version() -> str
    applies(case) -> str     '' when the solver can run the case, else why not
    run(case, t_end, settings) -> Result    t and the run's `channels.Trajectory` (`trajectory`),
                             status, steps, rhs_evals, wall_s, setup_s; or the Trajectory alone
Solvers that are not part of this build are listed (so case files may name them) and reported
as unavailable. Other packages add solvers through the entry-point group `flexmbd.solvers`
(docs/plugins.md); a plug-in that fails to load, or whose name cannot name a result file
(`results.bad_name`), is unavailable, saying why, and never ends a command.

A solver reports what it computed as a `channels.Trajectory`; `run` is the one place where a
solver's exception becomes a result, and where, the same for every solver (plug-ins included),
what it returned is checked (arrays of the wrong shape: failed, saying which; instants that stop
increasing: cut there, failed), the channels are formed from the trajectory, the model's linear
validity becomes a status, the divergence rule (`results.first_failure`, bounds `channels.bounds`)
cuts a run (a failed run keeps the samples before its failure; the solvers also check it while they run, `channels.failure`, and
stop at the first sample beyond it), and the deformed-shape snapshots (`channels.shapes`) and the
other bodies' poses there (`channels.poses`) of the samples kept go into the sidecar's `shapes`
and `poses`. A run uses one thread of linear algebra (threadpoolctl): a multi-threaded
BLAS sums in an order that depends on its thread count, and a result must be the same bytes in
this process, on a pool's worker and on a cluster's (the full-order FE transient of
cantilever_step moves by 7e-6 of its largest value between one and two OpenBLAS threads). A plug-in may instead fill a Result's `channels` itself (no trajectory: no
validity, no snapshots).
"""

from __future__ import annotations

import dataclasses
import importlib
import time
import traceback
from importlib.metadata import entry_points
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from flexmbd import cases, version
from flexmbd.harness import channels, results
from flexmbd.core.errors import InputError
from flexmbd.harness.results import Result

# registered name -> module (None: not part of this build)
BUILT_IN = {
    "flexmbd": "flexmbd.solvers.inhouse",
    "fe-linear": "flexmbd.solvers.fe_linear",
    "analytic": "flexmbd.solvers.analytic",
    "exudyn-ffrf": "flexmbd.solvers.exudyn_ffrf",
    "exudyn-beam": "flexmbd.solvers.exudyn_beam",
    "mujoco-rod": "flexmbd.solvers.mujoco_rod",
    "pinocchio": "flexmbd.solvers.pinocchio_rigid",
    "mujoco": "flexmbd.solvers.mujoco_rigid",
}
GROUP = "flexmbd.solvers"           # entry-point group of solver plug-ins (docs/plugins.md)


def plugins() -> dict:
    """Installed plug-in solvers: entry-point name -> module path (the value names a module). A
    plug-in may not take a built-in name."""
    return {ep.name: ep.value.partition(":")[0] for ep in entry_points(group=GROUP) if ep.name not in BUILT_IN}


def registry() -> tuple[dict, dict]:
    """(name -> module path of every solver, name -> why not of every plug-in refused for its
    name): a solver's name names its result files, so one that cannot (`results.bad_name`: a
    path, hidden, spaces, control characters) is never run, chosen or written; `flexmbd list`
    shows it as unavailable, saying why."""
    named = {**BUILT_IN, **plugins()}
    refused = {n: f"plug-in name {results.bad_name(n)}" for n in named if results.bad_name(n)}
    return {n: path for n, path in named.items() if n not in refused}, refused


MODULES, REFUSED = registry()
NAMES = tuple(MODULES)
CALLS = ("version", "applies", "run")       # what a solver module must define (docs/plugins.md)


def load(name: str) -> tuple[object, str]:
    """(the solver's module, '') when it can be used here, else (None, 'unavailable: why'). A
    built-in solver whose dependency is missing (ImportError) is unavailable; so is a plug-in
    that raises anything while it loads or lacks one of CALLS: a broken plug-in is its own
    status, never the end of a command (a built-in's other exception is a bug, and raised)."""
    if name in REFUSED:
        return None, f"unavailable: {REFUSED[name]}"
    path = MODULES[name]
    if path is None:
        return None, "unavailable: not part of this version of flexmbd"
    plugin = name not in BUILT_IN
    try:
        mod = importlib.import_module(path)
    except (Exception, SystemExit) as e:                # noqa: BLE001 - a plug-in's failure is its status
        if not plugin and not isinstance(e, ImportError):
            raise
        return None, f"unavailable: plug-in {name} failed to load: {_error(e)}" if plugin else f"unavailable: {e}"
    lacks = [c for c in CALLS if not callable(getattr(mod, c, None))] if plugin else []
    if lacks:
        return None, (f"unavailable: plug-in {name} failed to load: its module {path} lacks "
                      f"{', '.join(lacks)} (docs/plugins.md)")
    return mod, ""


def _error(e: BaseException) -> str:
    """An exception as one line: its type and message."""
    msg = " ".join(str(e).split())
    return f"{type(e).__name__}{': ' + msg if msg else ''}"


def module(name: str):
    """The solver's module, or None when it is not available here (`load`)."""
    return load(name)[0]


def settings_schema(name: str) -> dict:
    mod = module(name)
    return getattr(mod, "SETTINGS", {}) if mod else {}


def check_name(name, key: str, where: str = "") -> str:
    """A registered solver name, else InputError naming where (file) and key it was given at."""
    if isinstance(name, str) and name in REFUSED:
        raise InputError(f"{where + ': ' if where else ''}{key}: {REFUSED[name]}")
    if name not in NAMES:
        raise InputError(f"{where + ': ' if where else ''}{key}: unknown solver {name!r}{cases.hint(str(name), NAMES)} "
                         f"(known: {', '.join(NAMES)})")
    return name


def settings(case, name: str) -> dict:
    """The case's `[solvers.NAME]` table checked against the solver's SETTINGS, defaults filled
    (as given when the solver is not available here: its run says so)."""
    where = str(case.path)
    check_name(name, f"solvers.{name}", where)
    raw = dict(case.solvers.get(name, {}))
    if unavailable_reason(name):
        return dict(raw)
    return cases.check_table(raw, settings_schema(name), where, f"solvers.{name}.")


def check(case) -> None:
    """Check every solver name and `[solvers.NAME]` table of a case before any work starts
    (InputError: one line naming the file and key). Imports only the solvers it names."""
    where, rep = str(case.path), case.report
    if rep.reference is not None:
        check_name(rep.reference, "report.reference", where)
    for name in rep.solvers or []:
        check_name(name, "report.solvers", where)
    for name in case.solvers:
        settings(case, name)


# the reference of a case that names none (report.reference): the first of these that can run it
# here (`status_for` is ''), among report.solvers when the case lists them; independent solvers only,
# the geometrically exact beam first: flexmbd, the solver under test, is never a case's reference
REFERENCES = ("exudyn-beam", "fe-linear", "exudyn-ffrf", "pinocchio", "mujoco", "mujoco-rod", "analytic")


def default_reference(case) -> str | None:
    """The reference a case without report.reference is compared with (REFERENCES), None when
    none of them can run it here."""
    listed = case.report.solvers
    return next((n for n in REFERENCES if (not listed or n in listed) and _precondition(case, n) is None), None)


def graded(case):
    """The case with its report's reference filled by `default_reference` when it names none
    (`case.report.defaults` then says so); the case itself otherwise."""
    rep = case.report
    ref = None if rep.reference is not None else default_reference(case)
    if ref is None:
        return case
    rep = dataclasses.replace(rep, reference=ref, defaults=("reference", *rep.defaults))
    return dataclasses.replace(case, resolved=dataclasses.replace(case.resolved, report=rep))


def unavailable_reason(name: str) -> str:
    """'' when the solver can be used on this machine, else why not (`load`)."""
    return load(name)[1]


def status_for(case, name: str) -> str:
    """'' when `name` can run `case`, else 'unavailable: ...' or 'not applicable: ...'."""
    st = _precondition(case, name)
    return str(st) if st else ""


def _precondition(case, name: str) -> results.Status | None:
    """None when `name` can run `case`, else the unavailable / not applicable status."""
    mod, why = load(name)
    if why:
        return results.unavailable(why.removeprefix("unavailable: "))
    if case.loops and not getattr(mod, "LOOPS", False):    # a solver models closed loops only when it says so
        return results.not_applicable(f"closed kinematic loops are not modelled (joint {next(iter(case.loops))!r} "
                                      f"closes one)")
    solid = next((b.name for b in case.bodies.values() if b.type == "solid"), None)
    if solid and not getattr(mod, "SOLIDS", False):         # a solver models solid bodies only when it says so
        kind = "a frame" if case.bodies[solid].is_frame else "one"
        return results.not_applicable(f"solid bodies and frames are not modelled (body {solid!r} is {kind})")
    try:
        why = mod.applies(case)
    except Exception as e:                              # noqa: BLE001 - a plug-in's failure is its status
        if name in BUILT_IN:
            raise
        return results.unavailable(f"plug-in {name} failed: its applies(case) raised {_error(e)}")
    return results.not_applicable(why) if why else None


source_sha256 = version.source_sha256      # flexmbd's source, part of every run's key (version.py)


def content_key(case, name: str, t_end: float | None = None) -> str | None:
    """SHA-256 (hex) of everything a run of solver `name` on `case` to `t_end` (s; None: the case's
    duration) depends on: the case's content (`Case.content_sha256`), the run's end time, the
    solver's name, settings and version, a plug-in's own source file, and flexmbd's source
    (`source_sha256`). A run with the key of a stored result would give that
    result again: `flexmbd report` and `compare` keep it (`--rerun`: run anyway). None when the
    solver cannot run the case here (unavailable, not applicable: nothing to keep)."""
    if _precondition(case, name) is not None:
        return None
    return _key(case, name, module(name), settings(case, name), t_end)


def _key(case, name: str, mod, chosen: dict, t_end: float | None) -> str:
    """`content_key` of a solver that can run the case, its module and settings at hand."""
    own = Path(getattr(mod, "__file__", None) or "") if name not in BUILT_IN else None
    t_end = case.duration if t_end is None else t_end
    parts = {"case": case.content_sha256, "t_end": float(t_end), "solver": name, "settings": chosen,
             "version": mod.version(),
             "module": version.cache_key(own.read_bytes()) if own and own.is_file() else "",
             "flexmbd": source_sha256()}
    return version.cache_key(parts)


def run(case, name: str, t_end: float | None = None) -> Result:
    """Run one solver on one case, and form what every solver's run is judged by, once: the
    channels from the trajectory the solver reports (`channels.channels`), its model's linear
    validity (`channels.validity`: an ok run past a limit is `results.outside_validity`), the
    divergence cut (`results.first_failure`: a failed run keeps the samples before it; so does
    one whose instants stop increasing, `results.disorder`) and the deformed-shape snapshots
    (`channels.shapes`). A failure inside the solver, or in what it returned (`reported`, the
    channels formed from it), becomes a failed result."""
    t_end = case.duration if t_end is None else t_end
    pre = _precondition(case, name)
    if pre is not None:
        return Result(solver=name, case=case.name, status=pre, case_sha256=case.sha256)
    mod = module(name)
    chosen = settings(case, name)
    key = _key(case, name, mod, chosen, t_end)
    start = time.perf_counter()
    try:
        with threadpool_limits(limits=1):               # one BLAS thread: the same bytes on any machine
            r = reported(mod.run(case, t_end, chosen), name, case)
            traj = formed(case, r)
    except Exception as e:                              # an external code's failure is a result
        where = traceback.extract_tb(e.__traceback__)[-1]
        r, traj = Result(solver=name, case=case.name,
                         status=results.failed(f"{type(e).__name__}: {e} ({where.name}, line {where.lineno})")), None
        r.wall_s = time.perf_counter() - start
    cuts = [results.disorder(r.t), results.first_failure(r.t, r.channels, channels.bounds(case))] if len(r.t) else []
    cut = min(filter(None, cuts), key=lambda c: c[0], default=None)
    if cut is not None and (r.ok or None in (r.status.t, cut[1].t) or cut[1].t <= r.status.t):
        r.truncate(cut[0])
        r.status = cut[1]
    moved = started(case, traj) if traj is not None and len(r.t) else None
    if moved is not None:
        r.truncate(1)
        r.status = moved
    r.solver, r.case, r.case_sha256 = name, case.name, case.sha256
    r.solver_version = r.solver_version or mod.version()
    r.extra["overrides"] = list(case.overrides)        # the --set items, recorded in the sidecar
    r.extra["key"] = key                                # what the run depends on (`content_key`)
    if case.assembly:                                   # the loops' assembly it started from
        r.extra["assembly"] = {n: x for n, _, x in case.assembly}
    if traj is not None:                                # the kept samples' deformed shapes, once for every solver
        kept = dataclasses.replace(traj, t=r.t)
        for part, snapshots in (("shapes", channels.shapes), ("fields", channels.fields),
                               ("poses", channels.poses)):    # poses: the other bodies' places there
            got = snapshots(case, kept, case.report.snapshots)
            if got:
                r.extra[part] = got
    return r


START = 1e-6     # rad (m): a dependent joint's first sample this far from the case's assembly starts elsewhere
                 # (the assembly closes to 1e-9 of the mechanism's size; a solver's own closure from it
                 # moves it by its own tolerance, 1e-9 or less; another branch is tenths of a radian away)


def started(case, traj: channels.Trajectory) -> results.Status | None:
    """A failed status, naming the joint, when a run's first sample puts a dependent joint of the
    case's loops elsewhere than the assembly every solver is given (`cases.closure.assemble`,
    `Case.assembly`): another branch, or a start that its own closure moved; None otherwise."""
    for n, _, x in case.assembly:
        q = traj.joints.get(n)
        if q is None or not len(q):
            continue
        d = float(q[0]) - x
        if case.joints[n].type == "revolute":           # an angle whole turns apart is the same
            d = (d + np.pi) % (2 * np.pi) - np.pi
        if not abs(d) <= START:
            return results.failed(f"starts in another assembly of its loops: joint {n} at {float(q[0]):.6g} where "
                                  f"the case's assembly has {x:.6g} ({cases.assembly_line(case)})", 0.0)
    return None


def reported(out, name: str, case) -> Result:
    """A solver's run as a Result: what it returned, or a Result around a bare
    `channels.Trajectory` (a run that reports its trajectory only: ok, at the trajectory's
    instants). Anything else is the solver's failure; so is a Result whose arrays do not fit its
    instants (`arrays`): failed, naming the array and its shape against the expected, without
    samples (no table can be formed of them)."""
    if isinstance(out, channels.Trajectory):
        out = Result(solver=name, case=case.name, t=out.t, trajectory=out)
    if not isinstance(out, Result):
        raise TypeError(f"run(case, t_end, settings) returned {type(out).__name__}, not a Result or a "
                        f"channels.Trajectory (docs/plugins.md)")
    why = results.misshapen(arrays(out))
    if why:
        out.t, out.channels, out.trajectory, out.status = np.zeros(0), {}, None, results.failed(why)
    return out


def arrays(r: Result) -> dict:
    """What a run returned, name -> (array, the shape it must have at its n instants, t (n,)):
    each channel it filled itself (n,) and, of its trajectory (`channels.Trajectory`, `channels.Beam`),
    t (n,), every joint coordinate and energy part (n,), reaction (n, 6), and per beam each
    tracked point (n, 3) and its undeformed position (3,), the root rotation (n, 3, 3), the section
    strains (n, 4), the validity measures (n,) and a solid's stresses (n, 6); each body pose's
    rotation (n, 3, 3) and origin (n, 3)."""
    n = len(r.t) if np.ndim(r.t) else 1
    out = {"t": (r.t, (n,)), **{f"channel {k}": (v, (n,)) for k, v in r.channels.items()}}
    traj = r.trajectory
    if traj is None:
        return out
    out["trajectory.t"] = (traj.t, (n,))
    for group, each in (("joints", ()), ("energy", ()), ("reactions", (6,))):
        out.update({f"trajectory.{group}[{k!r}]": (v, (n, *each)) for k, v in getattr(traj, group).items()})
    for b, beam in traj.beams.items():
        at = f"trajectory.beams[{b!r}]"
        for group, shape in (("points", (n, 3)), ("x0", (3,)), ("strains", (n, 4)), ("extent", (n,)),
                             ("stresses", (n, 6))):
            out.update({f"{at}.{group}[{k!r}]": (v, shape) for k, v in getattr(beam, group).items()})
        if beam.root is not None:
            out[f"{at}.root"] = (beam.root, (n, 3, 3))
    for b, (R, p) in traj.poses.items():
        out.update({f"trajectory.poses[{b!r}].R": (R, (n, 3, 3)), f"trajectory.poses[{b!r}].p": (p, (n, 3))})
    return out


def formed(case, r: Result) -> channels.Trajectory | None:
    """The trajectory a run reported, taken out of its Result (None: it filled its channels
    itself), with the channels formed from it (`channels.channels`) and its model's validity
    judged (`judged`)."""
    traj, r.trajectory = r.trajectory, None
    if traj is not None:
        traj = dataclasses.replace(traj, t=np.asarray(r.t, dtype=float))
        r.channels = channels.channels(case, traj)
        judged(r, traj)
    return traj


def judged(r: Result, traj: channels.Trajectory) -> None:
    """The linear validity of a run's model, the same for every solver: the largest value of each
    measure its modal beams report (`channels.validity`) goes into the sidecar's `validity`, and an
    ok run past a limit becomes `results.outside_validity` (why and when)."""
    if not any(b.extent for b in traj.beams.values()):
        return
    extent, outside = channels.validity(traj)
    r.extra["validity"] = {"largest": extent, "limits": channels.LIMITS}
    if outside is not None and r.ok:
        r.status = results.outside_validity(*outside)
