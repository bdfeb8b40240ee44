"""bench and history: this machine's timing and work-precision against the peers, and the page
of each solver's accuracy and time across commits (docs/history.md), fed by the records that
`report` and `bench` keep."""

from __future__ import annotations

import math
import sys
from pathlib import Path

from flexmbd.core import files
from flexmbd.cli.status import OK


def cmd_history(args) -> int:
    from flexmbd.report import history
    out = files.writable_dir(args.out, "--out")
    if args.add:
        n = history.add(out, args.add)
        print(f"{n} record{'s' * (n != 1)} added to {history.folder(out)}")
    print(f"history: {history.page(out)}")
    return OK


def cmd_bench(args) -> int:
    from flexmbd.report import bench

    def show(row):
        what = f"S_eq {row['seq5_MPa']:.4g} MPa" if "seq5_MPa" in row else f"error {row['error']:.3g}"
        sys.stderr.write(f"bench: {row['case']} / {row['solver']} {row['scheme']} {row['setting']}: "
                         f"{what}, {row['wall_s']:.2f} s\n")

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
    duty = result.get("duty_cycle")
    if duty:
        print(f"duty cycle ({duty['case']}): the fastest setting within {duty['target']:.0%} of the solver's own "
              f"converged S_eq (m = 5), and that S_eq against the reference's ({duty['reference']}) converged one:")
    for r in (duty or {}).get("fastest", []):
        at = f"{r['wall_s']:.2f} s at {r['setting']}" if math.isfinite(r["wall_s"]) else "none within it"
        print(f"  {r['solver']:12s} {at}; S_eq {r['seq5_MPa']:.4g} MPa (converged {r['converged_seq5_MPa']:.4g}), "
              f"{r['error_reference']:.2%} from the reference's")
    got = result.get("loops")
    if got:
        print(f"closed loops: each solver's fastest setting within {got['target']:.0e} of its own converged run "
              f"(worst deflection channel), and flexmbd's time over each peer's there:")
    for r in (got or {}).get("fastest", []):
        at = f"{r['wall_s']:.2f} s at {r['setting']}" if math.isfinite(r["wall_s"]) else "none within it"
        print(f"  {r['case']:16s} {r['solver']:12s} {at}; {r['error_reference']:.2e} from the reference")
    for r in (got or {}).get("ratios", []):
        print(f"  {r['case']:16s} flexmbd / {r['peer']}: {r['ratio']:.2f}")
    print(f"plots: {Path(args.out) / 'index.html'}")
    return 0
