"""animate and export: solvers run as `flexmbd run` runs them on a case whose deformed shapes are
recorded at chosen instants, drawn overlaid as an animation or written as a ParaView time series
(docs/animation.md); these runs are not stored."""

from __future__ import annotations

from pathlib import Path

from flexmbd.harness import cost, registry
from flexmbd.core import files
from flexmbd.cli.shared import _load, _solver_list, warn
from flexmbd.cli.status import OK
from flexmbd.core.errors import InputError


def framed_runs(args, names: list, flag: str) -> tuple:
    """(the case, its frames' runs {solver: Result}) of `animate` and `export`: each solver run as
    `flexmbd run` runs it (`registry.run`, after the same checks), on the case whose shapes are
    recorded at --frames instants (`animation.framed`). A solver that cannot run the case is
    refused before any work; the runs are not stored."""
    from flexmbd.report import animation
    case = _load(args)
    for name in names:
        registry.check_name(name, flag)
        why = registry.status_for(case, name)
        if why:
            raise InputError(f"{case.path}: solver {name}: {why}")
    cost.check([(case, s) for s in names], args.t_end, args.allow_large)     # bounds the output samples
    runs = animation.framed(case, animation.instants(case, args.t_end, args.frames))    # at most one frame each
    got = {}
    with files.signals_exit():                          # nothing written while they run
        for name in names:
            got[name] = registry.run(runs, name, args.t_end)
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
