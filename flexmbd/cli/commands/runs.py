"""run, report, compare and regress: solvers run on cases and their results stored, drawn into
pages with their verdicts, or held against the baselines; the exit status of each as
`flexmbd.cli.status` says."""

from __future__ import annotations

import sys
import time
from pathlib import Path

from flexmbd import cases
from flexmbd.harness import cost, registry
from flexmbd.core import files
from flexmbd.cli.shared import _case, _load, _solver_list, _where, check_all, run_checked, stored_sidecars, warn
from flexmbd.cli.status import DIFFERENT, OK
from flexmbd.core.errors import InputError
from flexmbd.harness.progress import job, jobs_done


def cmd_run(args) -> int:
    from flexmbd.harness import results
    case = _load(args)
    registry.check_name(args.solver, "--solver")
    why = registry.status_for(case, args.solver)
    if why:
        raise InputError(f"{case.path}: solver {args.solver}: {why}")
    cost.check([(case, args.solver)], args.t_end, args.allow_large)
    files.writable_dir(results.folder(args.out) / case.name, "--out")
    if case.assembly:                                   # the branch every solver starts in
        print(f"{case.name}: loops assembled at {cases.assembly_line(case)}", file=sys.stderr)
    with files.signals_exit():                          # nothing written while it runs
        r = registry.run(case, args.solver, args.t_end)
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
