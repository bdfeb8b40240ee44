"""study and import: results beyond one run of a shipped case: a grid of overrides on cases and
solvers (its table and figures, docs/studies.md), and a result computed elsewhere, checked against
the case's channels before it is stored beside flexmbd's (docs/plugins.md)."""

from __future__ import annotations

from pathlib import Path

from flexmbd.core import files
from flexmbd.harness import registry
from flexmbd.cli.shared import _case, _load, _where, check_all, warn
from flexmbd.cli.status import OK
from flexmbd.core.errors import InputError


def cmd_import(args) -> int:
    from flexmbd.harness import external, results
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


def cmd_study(args) -> int:
    from flexmbd.harness import executor
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
        registry.check_name(name, "--solvers" if not args.file else f"{args.file}: study.solvers")
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
