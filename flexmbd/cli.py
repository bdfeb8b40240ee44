"""The `flexmbd` command (DESIGN.md §6). Bad input: one line on stderr, exit status 2."""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from flexmbd import cases, cost, solvers
from flexmbd.errors import InputError


def _case(name: str, overrides=()) -> cases.Case:
    """A case loaded and its solver tables checked: bad input stops here, before any work."""
    case = cases.load(name, overrides)
    solvers.check(case)
    return case


def _load(args) -> cases.Case:
    return _case(args.case, getattr(args, "set", None) or [])


def _positive(text: str) -> float:
    try:
        x = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not x > 0:
        raise argparse.ArgumentTypeError(f"must be positive, got {text}")
    return x


# ---------------------------------------------------------------------------------------------
# commands


def cmd_list(args) -> int:
    rows = []
    for name in cases.available():
        c = _case(name)
        rows.append({"case": name, "title": c["title"], "bodies": list(c["bodies"]),
                     "solvers": {s: solvers.status_for(c, s) or "ok" for s in solvers.NAMES}})
    if args.json:
        print(json.dumps(rows, indent=2))
        return 0
    for r in rows:
        usable = [s for s, st in r["solvers"].items() if st == "ok"]
        print(f"{r['case']:<18} {r['title']}")
        print(f"{'':<18} bodies: {', '.join(r['bodies'])}; solvers: {', '.join(usable)}")
    return 0


def cmd_modes(args) -> int:
    from flexmbd import flexbody
    case = _load(args)
    cost.check([(case, None)], allow_large=args.allow_large)
    bodies = flexbody.for_case(case)
    out = {"case": case.name, "bodies": {}}
    for name, fb in bodies.items():
        out["bodies"][name] = {
            "boundary": fb.boundary, "nodes": fb.n_nodes,
            "modes": [{"index": i + 1, "freq_hz": float(f), "label": str(lab)}
                      for i, (f, lab) in enumerate(zip(fb.freq_hz, fb.labels))]}
        if args.save:
            path = Path(args.save) / f"{case.name}_{name}.npz"
            path.parent.mkdir(parents=True, exist_ok=True)
            flexbody.save(fb, path)
    if args.json:
        print(json.dumps(out, indent=2))
        return 0
    for name, b in out["bodies"].items():
        print(f"{case.name} / {name}: {b['boundary']}, {b['nodes']} nodes")
        for m in b["modes"]:
            print(f"  {m['index']:3d}  {m['freq_hz']:12.4f} Hz  {m['label']}")
    return 0


def cmd_run(args) -> int:
    from flexmbd import results
    case = _load(args)
    solvers.check_name(args.solver, "--solver")
    why = solvers.status_for(case, args.solver)
    if why:
        raise InputError(f"{case.path}: solver {args.solver}: {why}")
    cost.check([(case, args.solver)], args.t_end, args.allow_large)
    r = solvers.run(case, args.solver, args.t_end)
    csv, js = results.write(r, Path(args.out))
    if r.status.outside:
        print(f"flexmbd: warning: {case.name} / {r.solver} ran outside its model's linear validity "
              f"({r.status.why}); see docs/formulation.md §7", file=sys.stderr)
    if args.json:
        print(js.read_text(), end="")
    else:
        print(f"{case.name} / {r.solver}: {r.status}; {r.steps} steps, solve {r.wall_s:.3f} s, "
              f"set-up {r.setup_s:.3f} s -> {js.parent}")
    return 0 if r.ok else 1


def _solver_list(text: str | None, flag: str) -> list:
    chosen = text.split(",") if text else list(solvers.NAMES)
    for name in chosen:
        solvers.check_name(name, flag)
    return chosen


def run_all(jobs: list, out: Path, allow_large: bool = False) -> None:
    """Run (case, solver) jobs into out/results with a progress bar; failures become results."""
    from flexmbd import results
    cost.check(jobs, allow_large=allow_large)
    t0 = time.perf_counter()
    for k, (c, s) in enumerate(jobs, 1):
        progress(k, len(jobs), f"{c.name} / {s}", time.perf_counter() - t0)
        results.write(solvers.run(c, s), out / "results")
    progress_done(len(jobs), time.perf_counter() - t0)


def cmd_report(args) -> int:
    from flexmbd.report import build
    out = Path(args.out)
    names = args.cases.split(",") if args.cases else cases.available()
    chosen = _solver_list(args.solvers, "--solvers")
    loaded = [_case(n) for n in names]
    jobs = [(c, s) for c in loaded for s in chosen if not c["report"]["solvers"] or s in c["report"]["solvers"]]
    if not args.no_run:
        run_all(jobs, out, args.allow_large)
    index = build.write(out, [c.name for c in loaded], chosen)
    print(f"report: {index}")
    return 0


def cmd_compare(args) -> int:
    from flexmbd.report import build
    out = Path(args.out)
    case = _load(args)
    chosen = _solver_list(args.solvers, "--solvers")
    run_all([(case, s) for s in chosen], out, args.allow_large)
    build.case_page(out, case, chosen)
    print(f"page: {out / case.name / 'index.html'}")
    return 0


def cmd_regress(args) -> int:
    from flexmbd.report import regress, tables
    from flexmbd import results
    base = Path(args.baseline)
    pairs = regress.listing(base)
    if args.update and (args.cases or args.solvers):          # create baselines too, not only rewrite
        names = args.cases.split(",") if args.cases else cases.available()
        pairs = [(c, s) for c in names for s in _solver_list(args.solvers, "--solvers")
                 if not solvers.status_for(_case(c), s)]
    if args.cases:
        pairs = [p for p in pairs if p[0] in args.cases.split(",")]
    if args.solvers:
        pairs = [p for p in pairs if p[1] in _solver_list(args.solvers, "--solvers")]
    if not pairs:
        raise InputError(f"--baseline {base}: no baselines (expected CASE/SOLVER.csv files)")
    if not args.results:
        cost.check([(_case(c), s) for c, s in pairs], allow_large=args.allow_large)
    rows = []
    t0 = time.perf_counter()
    for k, (case_name, solver) in enumerate(pairs, 1):
        progress(k, len(pairs), f"{case_name} / {solver}", time.perf_counter() - t0)
        case = _case(case_name)
        if args.results:
            r = results.read(Path(args.results), case_name, solver)
        else:
            r = solvers.run(case, solver)
        if args.update:
            if not r.ok:
                raise InputError(f"{case_name} / {solver}: {r.status}; baseline not written")
            print(f"updated {regress.write(base, case, r)}")
            continue
        rows += regress.compare(case, r, regress.read(base, case_name, solver))
    progress_done(len(pairs), time.perf_counter() - t0)
    if args.update:
        return 0
    head = ["case", "solver", "channel", "RMS diff / max|baseline|", "tolerance", "moved", "note"]
    body = [[r["case"], r["solver"], r["channel"], r["rms"], r["tolerance"], "MOVED" if r["moved"] else "ok",
             r["why"]] for r in rows]
    print(tables.markdown(head, body), end="")
    moved = [r for r in rows if r["moved"]]
    for r in moved:
        print(f"moved: {r['case']} / {r['solver']} / {r['channel']}: RMS difference {tables.fmt(r['rms'])} "
              f"> tolerance {tables.fmt(r['tolerance'])}", file=sys.stderr)
    return 1 if moved else 0


def cmd_bench(args) -> int:
    from flexmbd import bench

    def show(row):
        sys.stderr.write(f"bench: {row['case']} / {row['solver']} {row['scheme']} {row['setting']}: "
                         f"error {row['error']:.3g}, {row['wall_s']:.2f} s\n")

    result = bench.run(quick=args.quick, with_work_precision=not args.no_work_precision, progress=show)
    bench.plots(result, Path(args.out))
    if args.json:
        print(json.dumps(result, default=float))
        return 0
    c = result["compile_s"]
    print(f"compile: {c['cold_s']:.1f} s first time, {c['cached_s']:.1f} s from the cache")
    for r in result["rigid_chain"]:
        print(f"rigid chain n={r['n']:3d}: flexmbd {r['flexmbd_us']:9.1f} us, pinocchio {r['pinocchio_us']:7.2f} us, "
              f"ratio {r['ratio']:.1f}")
    for r in result["flexible_chain"]:
        print(f"flexible chain n={r['n']:3d}: {r['flexmbd_us']:10.1f} us")
    print(f"flexible chain exponent (n >= 4): {result['flexible_chain_exponent']:.2f}")
    for r in result.get("matched_accuracy", []):
        print(f"{r['case']:16s} error {r['error_target']:.0e}: flexmbd {r['flexmbd_wall_s']:.2f} s, "
              f"exudyn-ffrf {r['exudyn_ffrf_wall_s']:.2f} s, ratio {r['ratio']:.2f} "
              f"({r['flexmbd_setting'] or '-'} / {r['exudyn_ffrf_setting'] or '-'})")
    print(f"plots: {Path(args.out) / 'index.html'}")
    return 0


def progress(k: int, n: int, label: str, elapsed: float) -> None:
    """One-line progress on stderr (redrawn in place on a terminal)."""
    bar = "#" * int(20 * (k - 1) / n)
    end = "\r" if sys.stderr.isatty() else "\n"
    sys.stderr.write(f"[{bar:<20}] {k}/{n} {label:<40} {elapsed:6.1f} s{end}")
    sys.stderr.flush()


def progress_done(n: int, elapsed: float) -> None:
    sys.stderr.write(f"[{'#' * 20}] {n}/{n} done{'':<36} {elapsed:6.1f} s\n")


# ---------------------------------------------------------------------------------------------
# parser


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="flexmbd", description="Flexible multibody validation harness.")
    sub = p.add_subparsers(dest="command", required=True)

    s = sub.add_parser("list", help="the cases, with title, bodies and solvers")
    s.add_argument("--json", action="store_true")
    s.set_defaults(func=cmd_list)

    s = sub.add_parser("modes", help="retained mode frequencies (Hz) and labels per flexible body")
    s.add_argument("case")
    s.add_argument("--set", action="append", metavar="KEY=VALUE")
    s.add_argument("--save", metavar="DIR", help="also write each reduced body as DIR/CASE_BODY.npz")
    s.add_argument("--json", action="store_true")
    s.add_argument("--allow-large", action="store_true", help="run even beyond the cost limits (README.md)")
    s.set_defaults(func=cmd_modes)

    s = sub.add_parser("run", help="one solver on one case")
    s.add_argument("case")
    s.add_argument("--solver", required=True)
    s.add_argument("--out", default="results")
    s.add_argument("--t-end", type=_positive, default=None)
    s.add_argument("--set", action="append", metavar="KEY=VALUE")
    s.add_argument("--json", action="store_true")
    s.add_argument("--allow-large", action="store_true", help="run even beyond the cost limits (README.md)")
    s.set_defaults(func=cmd_run)

    s = sub.add_parser("report", help="every case on every available solver, and the report")
    s.add_argument("--cases", default=None, help="comma-separated case names (default: all)")
    s.add_argument("--solvers", default=None, help="comma-separated solver names (default: all)")
    s.add_argument("--out", default="reports")
    s.add_argument("--no-run", action="store_true", help="rebuild the pages from the stored results only")
    s.add_argument("--allow-large", action="store_true", help="run even beyond the cost limits (README.md)")
    s.set_defaults(func=cmd_report)

    s = sub.add_parser("compare", help="run solvers on one case and write its report page")
    s.add_argument("case")
    s.add_argument("--solvers", default=None, help="comma-separated solver names (default: all)")
    s.add_argument("--out", default="reports")
    s.add_argument("--set", action="append", metavar="KEY=VALUE")
    s.add_argument("--allow-large", action="store_true", help="run even beyond the cost limits (README.md)")
    s.set_defaults(func=cmd_compare)

    s = sub.add_parser("bench", help="timing and work-precision against peers on this machine")
    s.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    s.add_argument("--quick", action="store_true", help="fewer sizes and settings (a smoke run)")
    s.add_argument("--no-work-precision", action="store_true", help="skip the (long) work-precision sweeps")
    s.add_argument("--out", default="reports/bench")
    s.set_defaults(func=cmd_bench)

    s = sub.add_parser("regress", help="compare fresh results with stored baselines (exit 1 if anything moved)")
    s.add_argument("--baseline", default=str(Path(__file__).resolve().parent.parent / "references" / "baselines"))
    s.add_argument("--results", default=None, help="compare these stored results instead of running the solvers")
    s.add_argument("--cases", default=None)
    s.add_argument("--solvers", default=None)
    s.add_argument("--update", action="store_true", help="rewrite the baselines from fresh results")
    s.add_argument("--allow-large", action="store_true", help="run even beyond the cost limits (README.md)")
    s.set_defaults(func=cmd_regress)
    return p


def main(argv=None) -> int:
    args = parser().parse_args(argv)
    try:
        return args.func(args)
    except InputError as e:
        print(f"flexmbd: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("flexmbd: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
