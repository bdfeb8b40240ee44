"""The `flexmbd` command, as README.md ("Using it") documents it.

Exit statuses, one meaning each (README.md, and `EXIT` in the --help of the commands): 0 the
command did its work; 1 a difference: `regress` found a result moved or a solver failed, and with
--strict `run` a failed solver, `report` and `compare` a run that missed its tolerance, diverged
or was aborted, a stored result that could not be used, or nothing compared; 2 bad input or an
unusable file or location (one line on stderr naming it); 3 an internal error (one line on
stderr, the traceback saved to a file; --debug shows it); 130 / 143 ended by SIGINT / SIGTERM.

Why `report` and `compare` exit 0 over a fail unless --strict: their work is to write the pages,
and a fail is shown as a fail there (its colour and icon, the summary line, the --json verdicts).
`make report` is the project's main command on a fresh clone and runs every case on every solver;
some pairs miss their tolerances by design (a rigid peer, a linear model out of its range, see
each case's report.expected_failures), so an exit 1 on any fail would make the Makefile target
fail on every clone while the report it wrote is complete and right. A caller that wants a gate
asks for one (--strict). `regress` exists to be that gate: a moved result is exit 1 without it.
"""

from __future__ import annotations

import argparse
import datetime
import functools
import math
import os
import signal
import sys
import tempfile
import threading
import time
import traceback
from pathlib import Path

from flexmbd import cases, cost, files, resources, solvers
from flexmbd.errors import InputError
from flexmbd.progress import job, jobs_done
from flexmbd.version import __version__

OK, DIFFERENT, BAD_INPUT, INTERNAL = 0, 1, 2, 3


def _case(name: str, overrides=()) -> cases.Case:
    """A case loaded and its solver tables checked: bad input stops here, before any work. A case
    that names no reference solver gets its default (`solvers.graded`)."""
    case = cases.load(name, overrides)
    solvers.check(case)
    return solvers.graded(case)


def _load(args) -> cases.Case:
    return _case(args.case, getattr(args, "set", None) or [])


def _positive(text: str) -> float:
    """A finite positive number (an option's value): inf, like nan, is refused, since no run can
    last forever."""
    try:
        x = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (x > 0 and math.isfinite(x)):
        raise argparse.ArgumentTypeError(f"must be a finite positive number, got {text}")
    return x


def _count(text: str) -> int:
    """A whole number of at least 1 (an option's value)."""
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if n < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {n}")
    return n


def _where(args):
    """Where the command's runs go (executor.Where), from --workers, --scheduler, --dask-local."""
    from flexmbd import executor
    return executor.Where(args.workers, args.scheduler, args.dask_local)


# ---------------------------------------------------------------------------------------------
# commands


def cmd_list(args) -> int:
    """The cases named (names or paths of case files; default: every shipped case), each loaded
    and checked before any is printed, or with --solvers which solver models what."""
    if args.solvers:
        if args.cases:
            raise InputError("list: give CASE ... or --solvers, not both (see flexmbd list --help)")
        return list_solvers(args)
    rows = []
    for name in args.cases or cases.available():
        c = _case(name)
        rows.append({"case": c.name, "title": c.title, "bodies": list(c.bodies),
                     "solvers": {s: solvers.status_for(c, s) or "ok" for s in (*solvers.NAMES, *solvers.REFUSED)}})
    if args.json:
        print(files.json_text(rows, indent=2))
        return 0
    for r in rows:
        usable = [s for s, st in r["solvers"].items() if st == "ok"]
        print(f"{r['case']:<18} {r['title']}")
        print(f"{'':<18} bodies: {', '.join(r['bodies'])}; solvers: {', '.join(usable)}")
    return 0


def list_solvers(args) -> int:
    """`flexmbd list --solvers`: which solver models what (`capabilities.table`, docs/solvers.md)."""
    from flexmbd import capabilities
    tab = capabilities.table()
    if args.json:
        print(files.json_text(tab, indent=2))
    else:
        print(capabilities.markdown(tab), end="")
    return 0


def cmd_modes(args) -> int:
    from flexmbd import flexbody
    case = _load(args)
    cost.check([(case, None)], allow_large=args.allow_large, about=args.about if args.system else None)
    if args.system:
        return system_modes(case, args.about, args.json)
    if args.save:
        files.writable_dir(args.save, "--save")
    bodies = flexbody.for_case(case)
    out = {"case": case.name, "bodies": {}}
    for name, fb in bodies.items():
        out["bodies"][name] = {
            "boundary": fb.boundary, "nodes": fb.n_nodes,
            "modes": [{"index": i + 1, "freq_hz": float(f), "label": str(lab)}
                      for i, (f, lab) in enumerate(zip(fb.freq_hz, fb.labels))]}
        if args.save:
            flexbody.save(fb, Path(args.save) / f"{case.name}_{name}.npz")
    if args.json:
        print(files.json_text(out, indent=2))
        return 0
    for name, b in out["bodies"].items():
        print(f"{case.name} / {name}: {b['boundary']}, {b['nodes']} nodes")
        for m in b["modes"]:
            print(f"  {m['index']:3d}  {m['freq_hz']:12.4f} Hz  {m['label']}")
    return 0


def system_modes(case, about: str, as_json: bool) -> int:
    """The assembled system's frequencies, damping and labels (linearize.py), with a progress bar
    past a couple of seconds."""
    from flexmbd import linearize
    from flexmbd.mbd.compiled import jit
    if not jit.is_cached():
        from flexmbd import solver
        warn(solver.compiling(", to linearize the case"))
    with files.signals_exit():                          # may compile the kernel; writes nothing
        modes = linearize.for_case(case, about, progress=True)
    rows = [{"index": k + 1, "freq_hz": m.freq_hz, "damping": m.damping, "damping_resolution": m.damping_resolution,
             "label": m.label, "share": m.share} for k, m in enumerate(modes)]
    if as_json:
        print(files.json_text({"case": case.name, "about": about, "modes": rows}, indent=2))
        return 0
    print(f"{case.name}: system modes about the {'initial state' if about == 'initial' else 'static equilibrium'}")
    for r in rows:
        print(f"  {r['index']:3d}  {r['freq_hz']:12.4f} Hz  damping {r['damping']:.3g} "
              f"(resolved to {r['damping_resolution']:.1g})  {r['label']} "
              f"({100 * r['share']:.0f} % of the kinetic energy)")
    if not rows:
        print("  none: no coordinate vibrates about this state (rigid bodies, or motion without stiffness)")
    for note in mode_notes(rows, case):
        print(f"  note: {note}")
    return 0


def mode_notes(rows: list, case) -> list:
    """What a reader of `modes --system` needs to read its columns: a negative damping ratio and an
    energy share above 100 % (docs/formulation.md §10)."""
    out = []
    if any(r["damping"] < -r["damping_resolution"] for r in rows):
        moving = any(j.motion is not None or any(j.qd0) for j in case.joints.values())
        out.append("a negative damping ratio is growth of the system frozen at this state"
                   + (" (a moving state: a driven joint or initial rates), not of the run, which moves on"
                      if moving else "") + "; within its resolution it is 0")
    if any(r["share"] > 1.0 + 1e-9 for r in rows):
        out.append("an energy share above 100 % is the leading family's own part of the kinetic energy; the "
                   "others' cross terms with it (through the coupled mass matrix) are negative and the shares "
                   "sum to 100 %")
    return out


def cmd_run(args) -> int:
    from flexmbd import results
    case = _load(args)
    solvers.check_name(args.solver, "--solver")
    why = solvers.status_for(case, args.solver)
    if why:
        raise InputError(f"{case.path}: solver {args.solver}: {why}")
    cost.check([(case, args.solver)], args.t_end, args.allow_large)
    files.writable_dir(results.folder(args.out) / case.name, "--out")
    if case.assembly:                                   # the branch every solver starts in
        print(f"{case.name}: loops assembled at {cases.assembly_line(case)}", file=sys.stderr)
    with files.signals_exit():                          # nothing written while it runs
        r = solvers.run(case, args.solver, args.t_end)
    csv, js = results.write(r, results.folder(args.out))
    if r.status.outside:
        print(f"flexmbd: warning: {case.name} / {r.solver} ran outside its model's linear validity "
              f"({r.status.why}); see docs/formulation.md §7", file=sys.stderr)
    if args.json:
        print(js.read_text(), end="")
    else:
        print(f"{case.name} / {r.solver}: {r.status}; {r.steps} steps, solve {r.wall_s:.3f} s, "
              f"set-up {r.setup_s:.3f} s -> {js.parent}")
    return DIFFERENT if args.strict and r.status.kind == "failed" else OK


def cmd_import(args) -> int:
    from flexmbd import external, results
    case = _load(args)
    r = external.load(case, args.solver, Path(args.file), Path(args.meta) if args.meta else None)
    files.writable_dir(results.folder(args.out) / case.name, "--out")
    csv, js = results.write(r, results.folder(args.out))
    if args.json:
        print(js.read_text(), end="")
    else:
        print(f"{case.name} / {r.solver}: imported {len(r.t)} samples of {', '.join(r.channels)} "
              f"({r.status}) -> {js.parent}")
    return OK


def _solver_list(text: str | None, flag: str) -> list:
    chosen = text.split(",") if text else list(solvers.NAMES)
    for name in chosen:
        solvers.check_name(name, flag)
    return chosen


def check_all(jobs: list, out: Path, allow_large: bool = False) -> None:
    """The cost of every (case, solver) job and the sizes of the imported results that the jobs'
    pages will read beside them, within the limits (cost.check, cost.check_stored)."""
    cost.check(jobs, allow_large=allow_large)
    cost.check_stored(stored_sidecars(out, [(c, []) for c in {c.name: c for c, _ in jobs}.values()]), allow_large)


def run_checked(jobs: list, out: Path, keep: bool = False, where=None, after=None) -> None:
    """Run jobs already checked (`check_all`) into out/results (`executor.into`: with `keep`, a
    stored result with the key of the run it would be is kept), where `where` says (executor.Where:
    a local pool of one worker per core by default); `after(case, solver)` told as each is in place."""
    from flexmbd import executor, results
    executor.into(jobs, lambda case: results.folder(out), keep, where or executor.Where(), after)


def stored_sidecars(out, pages) -> list:
    """The sidecars of the stored results that case pages will read, for their sizes
    (`cost.check_stored`): pages [(case, the solvers read from storage)], each with the results
    imported for its case (`loading.page_solvers`)."""
    from flexmbd import results
    from flexmbd.report import loading
    return [results.folder(out) / c.name / f"{s}.json" for c, names in pages for s in loading.page_solvers(out, c, names)]


def warn(line: str) -> None:
    print(f"flexmbd: {line}", file=sys.stderr)


def _verdict(args, runs: list, acc: list) -> int:
    """With --strict, DIFFERENT when a solver failed (or its stored result could not be used), a
    comparison missed its tolerance, or nothing could be compared (no run with a tolerance against
    a reference: one line says so). `runs`: accuracy.Outcome."""
    failed = any(o.status.kind == "failed" or o.status.unread for o in runs)
    compared = any(a["pass"] in ("pass", "fail") for a in acc)
    if args.strict and not compared and not failed:
        warn("--strict: nothing was compared with a tolerance against a reference")
    return DIFFERENT if args.strict and (failed or not compared or any(a["pass"] == "fail" for a in acc)) else OK


def _show(args, what: str, page: Path, runs: list, acc: list) -> None:
    """The verdict summary and the page on stdout; with --json one object: the page, the summary
    line, one entry per run (case, solver, verdict kind and text, worst difference, wall time) and
    the accuracy rows. `runs`: accuracy.Outcome."""
    from flexmbd.report import accuracy
    line = accuracy.summary([o.verdict for o in runs])
    if getattr(args, "json", False):
        entries = [{"case": o.case, "solver": o.solver, "verdict": o.verdict.kind, "text": o.verdict.text,
                    "worst_rms": o.worst, "wall_s": o.wall_s} for o in runs]
        print(files.json_text({what: str(page), "summary": line, "runs": entries, "accuracy": acc}, indent=1))
        return
    print(line)
    for o in runs:
        if o.verdict.kind in ("fail", "diverged", "aborted"):
            print(f"  {o.case} / {o.solver}: {o.verdict}")
    print(f"{what}: {page}")


def cmd_report(args) -> int:
    from flexmbd.report import build, history, loading
    out = Path(args.out)
    names = args.cases.split(",") if args.cases else cases.available()
    chosen = _solver_list(args.solvers, "--solvers")
    loaded = [_case(n) for n in names]                      # every name and path, before any work
    files.writable_dir(out, "--out")
    jobs = [(c, s) for c in loaded for s in loading.jobs(c, chosen)]
    if not args.no_run:
        check_all(jobs, out, args.allow_large)
    else:                                                   # their sizes, before any is read
        cost.check_stored(stored_sidecars(out, [(c, loading.jobs(c, chosen)) for c in loaded]), args.allow_large)
    for c in loaded:
        ref = next((s for s in loading.jobs(c, chosen) if s not in chosen), None)
        if ref:
            warn(f"{c.name}: its reference {ref} {'is read' if args.no_run else 'runs'} too "
                 f"(every comparison is against it)")
    run = None if args.no_run else lambda after: run_checked(jobs, out, keep=not args.rerun, where=_where(args),
                                                              after=after)
    reuse = not (args.no_run or args.rerun)                 # unchanged pages kept (--no-run, --rerun: all drawn)
    files.make_dir(history.folder(out))                     # the index links the history page drawn below
    t0 = []

    def bar(k: int, n: int, label: str) -> None:           # the pages' bar, timed from its first line
        t0.append(t0[0] if t0 else time.perf_counter())
        job(k, n, label, time.perf_counter() - t0[0])
    index, runs, acc = build.write(out, loaded, chosen, warn, bar, reuse, run)      # pages drawn as runs end
    jobs_done(len(loaded) + 1, time.perf_counter() - t0[0])
    if not args.no_run:                                     # stored results of other code are not this commit's
        history.record(out, runs, acc)
    history.page(out, warn)
    _show(args, "report", index, runs, acc)
    return _verdict(args, runs, acc)


def shortened(args) -> cases.Case:
    """compare's case: with --t-end, the case and its --set overrides with the override
    duration=SECONDS after them, so that the page, the keys and the provenance of its runs say how
    long they ran; an error that only the duration brings names --t-end."""
    case = _load(args)
    if args.t_end is None:
        return case
    try:
        return _case(args.case, [*(args.set or []), f"duration={args.t_end!r}"])
    except InputError as e:
        raise InputError(f"--t-end {args.t_end:g}: {e}") from None


def cmd_compare(args) -> int:
    """The page of the compared solvers goes to OUT/compare/CASE/, so that it never replaces the
    report's page of the case (OUT/CASE/: every solver of the report, which the index links)."""
    from flexmbd.report import build, loading, spectra
    out = Path(args.out)
    case = shortened(args)
    chosen = _solver_list(args.solvers, "--solvers")
    files.writable_dir(out, "--out")
    names = loading.with_reference(case, chosen)
    jobs = [(case, s) for s in names]
    check_all(jobs, out, args.allow_large)
    if names != chosen:
        warn(f"{case.name}: its reference {names[0]} runs too (every comparison is against it)")
    run_checked(jobs, out, keep=not args.rerun, where=_where(args))
    spectra.prepare([case], warn)
    got = build.case_page(out, case, names, warn, out / "compare")
    _show(args, "page", out / "compare" / case.name / "index.html", got["runs"], got["accuracy"])
    return _verdict(args, got["runs"], got["accuracy"])


def framed_runs(args, names: list, flag: str) -> tuple:
    """(the case, its frames' runs {solver: Result}) of `animate` and `export`: each solver run as
    `flexmbd run` runs it (`solvers.run`, after the same checks), on the case whose shapes are
    recorded at --frames instants (`animation.framed`). A solver that cannot run the case is
    refused before any work; the runs are not stored."""
    from flexmbd.report import animation
    case = _load(args)
    for name in names:
        solvers.check_name(name, flag)
        why = solvers.status_for(case, name)
        if why:
            raise InputError(f"{case.path}: solver {name}: {why}")
    cost.check([(case, s) for s in names], args.t_end, args.allow_large)     # bounds the output samples
    runs = animation.framed(case, animation.instants(case, args.t_end, args.frames))    # at most one frame each
    got = {}
    with files.signals_exit():                          # nothing written while they run
        for name in names:
            got[name] = solvers.run(runs, name, args.t_end)
            if got[name].status.kind == "failed":
                warn(f"{case.name} / {name}: {got[name].status}; its shapes end there")
    return case, got


def cmd_animate(args) -> int:
    from flexmbd.report import animation
    names = _solver_list(args.solvers, "--solvers")
    out = Path(args.out) if args.out else Path("reports") / "animations" / f"{Path(args.case).stem}.gif"
    animation.writer(out)                               # the file's kind, before any work
    files.writable_dir(out.parent, "--out")
    case, got = framed_runs(args, names, "--solvers")
    ref = case.report.reference if case.report.reference in got else None
    n = animation.animate(case, got, out, ref, args.fps)
    print(f"{case.name}: {n} frames of {', '.join(got)} -> {out}")
    return OK


def cmd_export(args) -> int:
    from flexmbd.report import animation
    folder = files.writable_dir(args.vtk, "--vtk")
    case, got = framed_runs(args, [args.solver], "--solver")
    pvd, n = animation.vtk(case, got[args.solver], folder)
    print(f"{case.name} / {args.solver}: {n} instants -> {pvd}")
    return OK


def cmd_regress(args) -> int:
    from flexmbd.report import regress, tables
    listed = lambda text: text.split(",") if text else None
    rows = regress.run(Path(args.baseline), listed(args.cases), listed(args.solvers), args.results, args.update,
                       args.allow_large, load=_case, warn=warn, updated=lambda path: print(f"updated {path}"),
                       where=_where(args))
    if args.update:
        return OK
    if args.json:
        print(files.json_text({"moved": sum(r["moved"] for r in rows), "rows": rows}, indent=1))
        return DIFFERENT if any(r["moved"] for r in rows) else OK
    head = ["case", "solver", "channel", "RMS diff / norm", "tolerance", "moved", "note"]
    body = [[r["case"], r["solver"], r["channel"], r["rms"], r["tolerance"], "MOVED" if r["moved"] else "ok",
             r["why"]] for r in rows]
    print(tables.markdown(head, body), end="")
    moved = [r for r in rows if r["moved"]]
    for r in moved:
        print(f"moved: {r['case']} / {r['solver']} / {r['channel']}: RMS difference {tables.fmt(r['rms'])} "
              f"> tolerance {tables.fmt(r['tolerance'])}", file=sys.stderr)
    return DIFFERENT if moved else OK


def cmd_study(args) -> int:
    from flexmbd import executor
    from flexmbd.report import study
    from flexmbd.report import loading
    out = Path(args.out)
    if args.file:
        st = study.from_file(Path(args.file))
        if args.cases or args.vary or args.reference_at:
            raise InputError(f"{args.file}: give the study in the file or on the command line, not both")
    else:
        if not args.cases or not args.vary:
            raise InputError("study: give CASE ... and --vary KEY=V1,V2,... (or --file STUDY.toml)")
        st = study.Study(tuple(args.cases), tuple(study.parse_vary(v) for v in args.vary),
                         tuple(args.solvers.split(",")) if args.solvers else (), args.reference_at or "each")
    for name in st.solvers:
        solvers.check_name(name, "--solvers" if not args.file else f"{args.file}: study.solvers")
    study.check(st, _case, f"{args.file}: study.vary" if args.file else "--vary", args.allow_large)   # before the grid
    points = study.loaded(st, _case)                    # every point, before any runs
    files.writable_dir(out, "--out")
    jobs = [(c, s) for c, names in points for s in names]
    check_all(jobs, out, args.allow_large)
    refs = {c.name: loading.added_reference(c, list(st.solvers)) for c, _ in points if st.solvers}
    for name, ref in refs.items():
        if ref:
            where = "once, on the case without the overrides" if st.reference == "base" else "at every point too"
            warn(f"{name}: its reference {ref} runs {where} (rms_vs_reference is against it)")
    executor.into(jobs, lambda case: study.folder(out, case.overrides), not args.rerun, _where(args))
    df = study.write(st, out, points)
    print(f"{len(points)} points, {len(jobs)} runs, {len(df)} rows")
    print(f"table: {out / 'study.parquet'}")
    print(f"figures: {out / 'figures'}")
    return OK


def cmd_history(args) -> int:
    from flexmbd.report import history
    out = files.writable_dir(args.out, "--out")
    if args.add:
        n = history.add(out, args.add)
        print(f"{n} record{'s' * (n != 1)} added to {history.folder(out)}")
    print(f"history: {history.page(out)}")
    return OK


def cmd_completion(args) -> int:
    from flexmbd import completion
    print(completion.bash(parser(), cases.available(), solvers.NAMES), end="")
    return OK


def cmd_bench(args) -> int:
    from flexmbd import bench

    def show(row):
        sys.stderr.write(f"bench: {row['case']} / {row['solver']} {row['scheme']} {row['setting']}: "
                         f"error {row['error']:.3g}, {row['wall_s']:.2f} s\n")

    files.writable_dir(args.out, "--out")
    stored = Path(args.results) / "results" if args.results else None
    result = bench.run(quick=args.quick, with_work_precision=not args.no_work_precision, progress=show,
                       stored=stored)
    bench.plots(result, Path(args.out))
    if Path(args.out).name == "bench":                  # a report folder's OUT/bench: kept in OUT/history too
        from flexmbd.report import history
        history.keep_bench(Path(args.out).parent, result)
    if args.json:
        print(files.json_text(result))
        return 0
    c = result["compile_s"]
    print(f"compile: {c['cold_s']:.1f} s first time, {c['cached_s']:.1f} s from the cache")
    for r in result["rigid_chain"]:
        print(f"rigid chain n={r['n']:3d}: flexmbd {r['flexmbd_us']:9.1f} us, pinocchio {r['pinocchio_us']:7.2f} us, "
              f"ratio {r['ratio']:.1f}")
    for r in result["flexible_chain"]:
        print(f"flexible chain n={r['n']:3d}: {r['flexmbd_us']:10.1f} us")
    print(f"flexible chain exponent (n >= 4): {result['flexible_chain_exponent']:.2f}")
    if result.get("matched_accuracy"):
        print("matched accuracy, the same model (flexmbd without stiffening and exudyn-ffrf, each against its own "
              "converged run):")
    for r in result.get("matched_accuracy", []):
        print(f"  {r['case']:16s} error {r['error_target']:.0e}: flexmbd {r['flexmbd_wall_s']:.3f} s, "
              f"exudyn-ffrf {r['exudyn_ffrf_wall_s']:.3f} s, ratio {r['ratio']:.2f} "
              f"({r['flexmbd_setting'] or '-'} / {r['exudyn_ffrf_setting'] or '-'})")
    if result.get("against_reference"):
        print("against each case's reference (floor: the most converged setting's error; fastest setting meeting "
              "1e-3, 1e-4 there and against its own converged run):")
    for r in result.get("against_reference", []):
        at = lambda k: f"{r[f'wall_s_at_{k}']:.3f} s" if math.isfinite(r[f"wall_s_at_{k}"]) else "-"
        print(f"  {r['case']:16s} {r['solver']:15s} floor {r['floor']:.2e}; "
              f"1e-03: {at('1e-03')}; 1e-04: {at('1e-04')}")
    print(f"plots: {Path(args.out) / 'index.html'}")
    return 0


# ---------------------------------------------------------------------------------------------
# stdout: what a command prints is its answer, so a stdout that cannot take it is an unusable location


def stdout_checked(command):
    """`command` (a cmd_ function) with its output checked: a closed stdout is refused before any
    work, and a write to stdout that fails ends the command (`Stdout`), each as one line naming
    stdout (InputError: exit 2); what the command wrote to files before is complete."""
    @functools.wraps(command)
    def checked(args) -> int:
        if sys.stdout is None or getattr(sys.stdout, "closed", False):
            raise InputError("stdout: closed (the command's output goes there: redirect it to a file or "
                             "/dev/null instead)")
        real, sys.stdout = sys.stdout, Stdout(sys.stdout)
        try:
            code = command(args)
            sys.stdout.flush()
        finally:
            sys.stdout = real
        return code
    return checked


class Stdout:
    """sys.stdout while a command runs: a write or flush that fails (a full device, a descriptor
    not open for writing) is an InputError naming stdout and why, and what is left unwritten is
    dropped, so that the interpreter does not try again at its exit and print a second error. A
    reader that left (BrokenPipeError) is `main`'s to handle."""

    def __init__(self, stream):
        self.stream = stream

    def write(self, text):
        return self._checked(self.stream.write, text)

    def flush(self):
        return self._checked(self.stream.flush)

    def _checked(self, call, *a):
        try:
            return call(*a)
        except BrokenPipeError:
            raise
        except OSError as e:
            drop_output(self.stream)
            raise files.unusable("stdout", e) from None

    def __getattr__(self, name):
        return getattr(self.stream, name)


def drop_output(stream) -> None:
    """Send what is left of a stream's output to /dev/null (its descriptor, when it has one)."""
    try:
        fd = stream.fileno()
    except (OSError, ValueError):
        return
    os.dup2(os.open(os.devnull, os.O_WRONLY), fd)


# ---------------------------------------------------------------------------------------------
# parser


class Help(argparse.HelpFormatter):
    """Help that shows an option's default when it has a value worth showing."""

    def _get_help_string(self, action):
        text = action.help or ""
        if ("%(default)" not in text and action.option_strings and action.default not in (None, False)
                and action.default is not argparse.SUPPRESS):
            text += " (default: %(default)s)"
        return text


class Parser(argparse.ArgumentParser):
    """argparse with its errors as one line naming the option (exit 2), not a usage block."""

    def __init__(self, *a, **k):
        k.setdefault("formatter_class", Help)
        super().__init__(*a, **k)

    def error(self, message):
        where = self.prog.partition(" ")[2] or "command line"
        raise InputError(f"{where}: {' '.join(message.split())} (see {self.prog} --help)")


# what each command's exit status 0 and 1 mean (the module docstring; README.md's table)
EXIT = {"run": "Exit status: 0 once the result is stored, also that of a solver that failed (its status printed); "
               "1 with --strict when the solver failed; 2 bad input.",
        "report": "Exit status: 0 once the report is written, a fail shown as a fail on its pages, in the summary "
                  "line and in --json; 1 with --strict when a run missed its tolerance, diverged or was aborted, a "
                  "stored result could not be used, or nothing was compared; 2 bad input.",
        "compare": "Exit status: 0 once the page is written (OUT/compare/CASE/index.html), a fail shown as a fail "
                   "on it, in the summary line and in --json; 1 with --strict when a run missed its tolerance, "
                   "diverged or was aborted, a stored result could not be used, or nothing was compared; 2 bad "
                   "input.",
        "regress": "Exit status: 0 when nothing moved; 1 when a result moved beyond its tolerance or a solver "
                   "failed (with or without --strict); 2 bad input or a bad baseline."}


def parser() -> argparse.ArgumentParser:
    debug = Parser(add_help=False)
    debug.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                       help="show the traceback of an internal error on the terminal")
    p = Parser(prog="flexmbd", description="Flexible multibody validation harness: cases, solvers, reports. "
               "Exit status: 0 the command did its work (a page shows a fail as a fail), 1 a difference: regress "
               "found one, or, with --strict, run, report or compare did (each command's --help says which), 2 bad "
               "input or an unusable file, 3 an internal error, 130 / 143 interrupted.", parents=[debug])
    p.add_argument("--version", action="version", version=f"flexmbd {__version__}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=Parser, metavar="COMMAND")
    strict = ("exit 1 when a run misses its tolerance, diverges or is aborted, a stored result cannot be used, or "
              "nothing is compared with a tolerance (without it: exit 0 once the pages are written)")
    case = "a case name from cases/ (see flexmbd list) or the path of a case TOML file"
    over = "override a case value, e.g. materials.steel.E=2.1e11 (repeatable)"
    names = ", ".join(solvers.NAMES)
    large = "run even beyond the cost limits (README.md, Cost limits)"
    executors = Parser(add_help=False)                  # where the runs go (executor.Where; docs/studies.md)
    on = executors.add_argument_group("where the runs go").add_mutually_exclusive_group()
    on.add_argument("--workers", type=_count, default=None, metavar="N",
                    help="local worker processes (default: one per core; 1: one run after another in this process)")
    on.add_argument("--scheduler", default=None, metavar="tcp://HOST:PORT",
                    help="run on the Dask distributed cluster of this scheduler (docs/studies.md)")
    on.add_argument("--dask-local", type=_count, default=None, metavar="N",
                    help="run on a Dask LocalCluster of N worker processes started for the command")

    s = sub.add_parser("list", help="the cases, with title, bodies and solvers", parents=[debug])
    s.add_argument("cases", nargs="*", metavar="CASE", help=case + " (default: every case in cases/)")
    s.add_argument("--json", action="store_true", help="print one JSON array on stdout")
    s.add_argument("--solvers", action="store_true", help="instead, which solver models what: rigid bodies, beams, "
                   "tip masses, ... (from each solver's own applies on probe cases; docs/solvers.md)")
    s.set_defaults(func=cmd_list)

    s = sub.add_parser("modes", help="retained mode frequencies (Hz) and labels per flexible body, or the "
                       "system's (--system)", parents=[debug])
    s.add_argument("case", help=case)
    s.add_argument("--set", action="append", metavar="KEY=VALUE", help=over)
    s.add_argument("--save", metavar="DIR", help="also write each reduced body as DIR/CASE_BODY.npz")
    s.add_argument("--system", action="store_true",
                   help="the assembled system's frequencies (joint and modal coordinates, linearized)")
    s.add_argument("--about", choices=["initial", "equilibrium"], default="initial",
                   help="with --system: linearize about the initial state or the static equilibrium")
    s.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    s.add_argument("--allow-large", action="store_true", help=large)
    s.set_defaults(func=cmd_modes)

    s = sub.add_parser("run", help="one solver on one case", parents=[debug], description=EXIT["run"])
    s.add_argument("case", help=case)
    s.add_argument("--solver", required=True, help=f"one of: {names}")
    s.add_argument("--out", default="reports", help="the report folder: the result goes to OUT/results/CASE/SOLVER.{csv,json}")
    s.add_argument("--t-end", type=_positive, default=None, metavar="SECONDS",
                   help="simulate this long instead of the case's duration")
    s.add_argument("--set", action="append", metavar="KEY=VALUE", help=over)
    s.add_argument("--json", action="store_true", help="print the result's JSON sidecar on stdout")
    s.add_argument("--allow-large", action="store_true", help=large)
    s.add_argument("--strict", action="store_true", help="exit 1 when the solver fails (without it: exit 0 once "
                   "the result is stored, its status printed)")
    s.set_defaults(func=cmd_run)

    s = sub.add_parser("import", help="bring in a result computed elsewhere, checked against the case's channels "
                       "(docs/plugins.md)", parents=[debug])
    s.add_argument("case", help=case)
    s.add_argument("file", metavar="FILE.csv", help="a table of t [s] and any of the case's channels (SI units)")
    s.add_argument("--solver", required=True, metavar="NAME",
                   help="the name the result goes by on the pages (not one of flexmbd's solvers)")
    s.add_argument("--meta", metavar="FILE.json", default=None,
                   help="solver_version, settings, status, wall_s, machine, date, description, ... (docs/plugins.md)")
    s.add_argument("--out", default="reports", help="the report folder: the result goes to OUT/results/CASE/NAME.{csv,json}")
    s.add_argument("--set", action="append", metavar="KEY=VALUE", help=over + "; the case version the result was "
                   "computed for")
    s.add_argument("--json", action="store_true", help="print the result's JSON sidecar on stdout")
    s.set_defaults(func=cmd_import)

    s = sub.add_parser("report", help="every case on every available solver, and the report", parents=[debug, executors],
                       description=EXIT["report"])
    s.add_argument("--cases", default=None, help="comma-separated case names or paths (default: all)")
    s.add_argument("--solvers", default=None, help=f"comma-separated solver names (default: all: {names})")
    s.add_argument("--out", default="reports", help="the report folder (results in OUT/results)")
    s.add_argument("--no-run", action="store_true", help="rebuild the pages from the stored results only")
    s.add_argument("--rerun", action="store_true", help="run every solver again, also where a stored result has the "
                   "same case content, settings, versions and source (kept otherwise)")
    s.add_argument("--allow-large", action="store_true", help=large)
    s.add_argument("--json", action="store_true", help="print one JSON object on stdout (verdicts and accuracy rows)")
    s.add_argument("--strict", action="store_true", help=strict)
    s.set_defaults(func=cmd_report)

    s = sub.add_parser("compare", help="run solvers on one case and write its page of their comparison "
                       "(OUT/compare/CASE/)", parents=[debug, executors], description=EXIT["compare"])
    s.add_argument("case", help=case)
    s.add_argument("--solvers", default=None, help=f"comma-separated solver names (default: all: {names})")
    s.add_argument("--out", default="reports", help="the report folder (results in OUT/results, the page in "
                   "OUT/compare/CASE; the report's own page OUT/CASE is left as it is)")
    s.add_argument("--t-end", type=_positive, default=None, metavar="SECONDS",
                   help="simulate this long instead of the case's duration (as --set duration=SECONDS: the page "
                   "and the stored results are of the case run that long)")
    s.add_argument("--set", action="append", metavar="KEY=VALUE", help=over)
    s.add_argument("--rerun", action="store_true", help="run every solver again, also where a stored result has the "
                   "same case content, settings, versions and source (kept otherwise)")
    s.add_argument("--allow-large", action="store_true", help=large)
    s.add_argument("--json", action="store_true", help="print one JSON object on stdout (verdicts and accuracy rows)")
    s.add_argument("--strict", action="store_true", help=strict)
    s.set_defaults(func=cmd_compare)

    frames = Parser(add_help=False)                     # the instants of animate and export
    frames.add_argument("--frames", type=_count, default=None, metavar="N",
                        help="instants evenly spread over the run, each at its nearest output sample (default: 100, "
                        "or every output sample of a shorter run; at most the run's output samples)")
    frames.add_argument("--t-end", type=_positive, default=None, metavar="SECONDS",
                        help="simulate this long instead of the case's duration")
    frames.add_argument("--set", action="append", metavar="KEY=VALUE", help=over)
    frames.add_argument("--allow-large", action="store_true", help=large)

    s = sub.add_parser("animate", help="an animation (GIF, or MP4 with ffmpeg) of several solvers' deformed shapes "
                       "overlaid (docs/animation.md)", parents=[debug, frames])
    s.add_argument("case", help=case)
    s.add_argument("--solvers", required=True, metavar="A,B,...", help=f"comma-separated solver names: {names}")
    s.add_argument("--out", default=None, metavar="FILE.gif|FILE.mp4",
                   help="the animation (default: reports/animations/CASE.gif, which the case page links)")
    s.add_argument("--fps", type=_count, default=20, help="frames per second")
    s.set_defaults(func=cmd_animate)

    s = sub.add_parser("export", help="one solver's deformed shapes as a ParaView time series (.vtu files and a "
                       ".pvd; docs/animation.md)", parents=[debug, frames])
    s.add_argument("case", help=case)
    s.add_argument("--solver", required=True, help=f"one of: {names}")
    s.add_argument("--vtk", required=True, metavar="DIR", help="the folder of the .vtu files and the .pvd")
    s.set_defaults(func=cmd_export)

    s = sub.add_parser("study", help="a grid of overrides on cases and solvers: its table (Parquet) and figures "
                       "(docs/studies.md)", parents=[debug, executors])
    s.add_argument("cases", nargs="*", metavar="CASE", help=case)
    s.add_argument("--vary", action="append", metavar="KEY=V1,V2,...",
                   help="a case key and its values, coarse to fine (repeatable: the grid is their product)")
    s.add_argument("--solvers", default=None, help=f"comma-separated solver names (default: each case's report "
                   f"solvers; the case's reference runs too)")
    s.add_argument("--reference-at", default=None, choices=["each", "base"],
                   help="where each case's reference solver runs: at every point (each, the default) or once on the "
                   "case without the overrides (base: when the varied keys are a discretisation it does not read)")
    s.add_argument("--file", default=None, metavar="STUDY.toml", help="the study as a [study] table (cases, vary, "
                   "solvers, reference) instead of the arguments")
    s.add_argument("--out", default="reports/study", help="the study folder (its runs in OUT/points)")
    s.add_argument("--rerun", action="store_true", help="run every point again, also where a stored result has the "
                   "key of its run (kept otherwise)")
    s.add_argument("--allow-large", action="store_true", help=large)
    s.set_defaults(func=cmd_study)

    s = sub.add_parser("completion", help="print the shell completion script (bash; zsh through bashcompinit)",
                       parents=[debug], description='bash: eval "$(flexmbd completion bash)" in ~/.bashrc; zsh: '
                       'autoload -U +X bashcompinit && bashcompinit && eval "$(flexmbd completion bash)"')
    s.add_argument("shell", choices=["bash"], help="the shell")
    s.set_defaults(func=cmd_completion)

    s = sub.add_parser("bench", help="timing and work-precision against peers on this machine", parents=[debug])
    s.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    s.add_argument("--quick", action="store_true", help="fewer sizes and settings (a smoke run)")
    s.add_argument("--no-work-precision", action="store_true", help="skip the (long) work-precision sweeps")
    s.add_argument("--out", default="reports/bench", help="folder of the plots and their page")
    s.add_argument("--results", metavar="DIR", help="a report folder (make report's reports/) whose stored "
                   "reference runs, where they belong to the current cases, are used instead of running them")
    s.set_defaults(func=cmd_bench)

    s = sub.add_parser("history", help="the page of each solver's accuracy and time on each case across commits, "
                       "and of the bench runs (docs/history.md)", parents=[debug])
    s.add_argument("--out", default="reports", help="the report folder (records in OUT/history/MACHINE/COMMIT.json; "
                   "the page OUT/history.html)")
    s.add_argument("--add", action="append", metavar="DIR", help="first bring in the records of another report "
                   "folder or its history folder, e.g. another machine's (repeatable)")
    s.set_defaults(func=cmd_history)

    s = sub.add_parser("regress", help="compare fresh results with stored baselines (exit 1 if anything moved)",
                       parents=[debug, executors], description=EXIT["regress"])
    s.add_argument("--baseline", default=str(resources.BASELINES),
                   help="folder of baselines BASELINE/CASE/SOLVER.csv (default: the shipped references/baselines)")
    s.add_argument("--results", default=None, metavar="DIR",
                   help="compare the results stored in the report folder DIR (DIR/results/CASE/SOLVER.json) instead "
                        "of running the solvers; needed for imported results")
    s.add_argument("--cases", default=None, help="comma-separated case names (default: every baseline's)")
    s.add_argument("--solvers", default=None, help="comma-separated solver names (default: every baseline's)")
    s.add_argument("--update", action="store_true", help="rewrite the baselines from fresh results")
    s.add_argument("--allow-large", action="store_true", help=large)
    s.add_argument("--json", action="store_true", help="print one JSON object on stdout (the compared channels)")
    s.add_argument("--strict", action="store_true", help="accepted for symmetry: a failed solver is always a difference")
    s.set_defaults(func=cmd_regress)
    for command in sub.choices.values():                # every command's output checked
        command.set_defaults(func=stdout_checked(command.get_default("func")))
    return p


def save_traceback(e: BaseException) -> Path:
    """The full traceback of an internal error in a file under the temporary folder; its path."""
    folder = Path(tempfile.gettempdir()) / "flexmbd-errors"
    stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
    path = folder / f"{stamp}-{os.getpid()}.txt"
    text = f"flexmbd {' '.join(sys.argv[1:])}\n" + "".join(traceback.format_exception(e))
    try:
        files.atomic_write(path, text)
    except (InputError, OSError):
        return Path("(not saved: " + str(folder) + " is not writable)")
    return path


def main(argv=None) -> int:
    """Run one command; its exit status (module docstring). One handler takes SIGINT and SIGTERM
    for the whole command (files.signals_handled): a signal ends it with one line and status
    128 + the signal, at once or once a swap of files is done; a signal ignored when the command
    starts (a background job's SIGINT) stays ignored."""
    argv = sys.argv[1:] if argv is None else list(argv)
    try:
        with files.signals_handled():
            return _command(argv, "--debug" in argv)
    except KeyboardInterrupt as e:                          # Interrupted, or SIGINT outside the main thread
        signum = getattr(e, "signum", signal.SIGINT)
        print(f"flexmbd: interrupted ({signal.Signals(signum).name})", file=sys.stderr)
        return 128 + signum


def _command(argv: list, debug: bool) -> int:
    """The command's exit status, with every error but a signal's told in its one line (main)."""
    here = threading.current_thread() is threading.main_thread()         # where handlers can be set
    xfsz = signal.signal(signal.SIGXFSZ, signal.SIG_IGN) if here else None  # the file size limit: EFBIG, not a kill
    try:
        args = parser().parse_args(argv)
        return args.func(args)
    except InputError as e:
        print(f"flexmbd: {' '.join(str(e).split())}", file=sys.stderr)
        return BAD_INPUT
    except BrokenPipeError:                                 # the reader of stdout left (| head): not an error
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 128 + signal.SIGPIPE
    except OSError as e:
        if e.filename is None:
            return _internal(e, debug)
        print(f"flexmbd: {files.unusable(e.filename, e)}", file=sys.stderr)
        return BAD_INPUT
    except Exception as e:                                  # noqa: BLE001 - the one place
        return _internal(e, debug)
    finally:
        if here:
            signal.signal(signal.SIGXFSZ, signal.SIG_DFL if xfsz is None else xfsz)


def _internal(e: BaseException, debug: bool) -> int:
    """An internal error: one line naming it and where its traceback was saved (on the terminal
    too with --debug)."""
    if debug:
        traceback.print_exception(e, file=sys.stderr)
    where = save_traceback(e)
    msg = " ".join(str(e).split())[:200]
    print(f"flexmbd: internal error: {type(e).__name__}{': ' + msg if msg else ''} (traceback saved to {where})",
          file=sys.stderr)
    return INTERNAL


def exit_with(code: int):
    """End the process with `code`. After an interruption the interpreter is left at once (output
    flushed): Python may otherwise end itself by the signal at shutdown when a KeyboardInterrupt
    passed through native code, and the status would read -2, not 130."""
    if code >= 128:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    sys.exit(code)


if __name__ == "__main__":
    exit_with(main())
