"""list, modes and completion: what there is to run (the cases, which solver models what), a
case's modes (each flexible body's, or the assembled system's) and the shell completion of the
commands themselves."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from flexmbd import cases
from flexmbd.harness import cost, registry
from flexmbd.harness.progress import Progress
from flexmbd.core import files
from flexmbd.cli.shared import _case, _load, warn
from flexmbd.cli.status import OK
from flexmbd.core.errors import InputError


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
                     "solvers": {s: registry.status_for(c, s) or "ok" for s in (*registry.NAMES, *registry.REFUSED)}})
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
    from flexmbd.harness import capabilities
    tab = capabilities.table()
    if args.json:
        print(files.json_text(tab, indent=2))
    else:
        print(capabilities.markdown(tab), end="")
    return 0


def cmd_modes(args) -> int:
    from flexmbd.fe import flexbody
    case = _load(args)
    cost.check([(case, None)], allow_large=args.allow_large, about=args.about if args.system else None)
    if args.sweep and not args.system:
        raise InputError("--sweep: a frequency map is of the system's modes: add --system")
    if args.peers and not args.system:
        raise InputError("--peers: the peers' eigen-solves are of the system: add --system")
    if args.system and args.sweep:
        return frequency_map(case, args)
    if args.system:
        return system_modes(case, args.about, args.json, peers(args.peers))
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


def peers(text: str) -> dict:
    """{solver: its system_frequencies} of `--peers` (comma-separated); a solver without an eigen-solve
    of the assembled system, or not installed, is one line naming `--peers`."""
    from flexmbd.harness import registry
    from flexmbd.report import frequency_map as fmap
    names = [n.strip() for n in text.split(",") if n.strip()]
    for n in names:
        registry.check_name(n, "--peers")
    got, refused = fmap.peer_functions(names)
    if refused:
        n, why = next(iter(refused.items()))
        raise InputError(f"--peers: {n}: {why}")
    return got


LOWEST = 3      # a peer's lowest frequencies compared with flexmbd's (above them a finer model has modes the
#                 retained ones leave out)


def system_modes(case, about: str, as_json: bool, others: dict | None = None) -> int:
    """The assembled system's frequencies, damping and labels (solvers/linearize.py), with a progress bar
    past a couple of seconds; `others`: solver -> its own eigen-solve (`peers`), its lowest
    frequencies printed beside flexmbd's."""
    from flexmbd.solvers import linearize
    from flexmbd.mbd.compiled import jit
    from flexmbd.report import frequency_map as fmap
    if not jit.is_cached():
        from flexmbd.solvers import inhouse
        warn(inhouse.compiling(", to linearize the case"))
    with files.signals_exit():                          # may compile the kernel; writes nothing
        modes = linearize.for_case(case, about, progress=True)
    rows = [{"index": k + 1, "freq_hz": m.freq_hz, "damping": m.damping, "damping_resolution": m.damping_resolution,
             "label": m.label, "share": m.share} for k, m in enumerate(modes)]
    if about != "initial" and others:
        raise InputError("--peers: the peers' eigen-solves are about the initial state: use --about initial")
    with files.signals_exit():
        theirs = {n: [float(x) for x in f(case, len(rows))] for n, f in (others or {}).items()}
    if as_json:
        print(files.json_text({"case": case.name, "about": about, "modes": rows, "peers": theirs}, indent=2))
        return 0
    print(f"{case.name}: system modes about the {'initial state' if about == 'initial' else 'static equilibrium'}")
    for r in rows:
        print(f"  {r['index']:3d}  {r['freq_hz']:12.4f} Hz  damping {r['damping']:.3g} "
              f"(resolved to {r['damping_resolution']:.1g})  {r['label']} "
              f"({100 * r['share']:.0f} % of the kinetic energy)")
    if not rows:
        print("  none: no coordinate vibrates about this state (rigid bodies, or motion without stiffness)")
    for n, f in theirs.items():
        diff = fmap.nearest(f[:LOWEST], [r["freq_hz"] for r in rows])
        print(f"  {n} (its own eigen-solve): " + ", ".join(f"{g:.4f}" for g in f) + " Hz"
              + (f"; its lowest {min(LOWEST, len(f))} against the nearest of flexmbd's: largest |f / f_flexmbd - 1| "
                 f"{diff:.2g}" if rows else ""))
    for note in mode_notes(rows, case):
        print(f"  note: {note}")
    return 0


def frequency_map(case, args) -> int:
    """`modes --system --sweep KEY=START:STOP:N`: the system's frequencies at each value, the modes
    tracked by shape (`linearize.tracked`), and with --peers each peer's own lowest frequencies; a
    table on stdout (or JSON), and with --out the table as OUT/CASE_sweep.csv and the map as
    OUT/CASE_sweep.png."""
    from flexmbd.solvers import linearize
    from flexmbd.report import frequency_map as fmap
    key, values = linearize.sweep_values(args.sweep)
    if args.out:
        files.writable_dir(args.out, "--out")
    others = peers(args.peers)
    bar = Progress(len(values), f"{case.name} / sweeping {key}", unit="values")
    with files.signals_exit():
        steps = linearize.sweep(case, key, values, args.about, progress=lambda k, n, x: bar.update(k), peers=others)
    bar.close()
    tracks = linearize.tracked(steps)
    m = fmap.Map(key, values, tracks, {n: np.array([s[3][n] for s in steps]) for n in others}, {})
    if args.out:
        from flexmbd.report import figures
        files.atomic_write(Path(args.out) / f"{case.name}_sweep.csv", fmap.table(m))
        figures.frequency_map(values, tracks, key, Path(args.out) / f"{case.name}_sweep.png", case.name, peers=m.peers)
    if args.json:
        rows = list(csv.DictReader(io.StringIO(fmap.table(m))))
        print(files.json_text({"case": case.name, "key": key, "about": args.about, "rows": rows}, indent=2))
        return 0
    print(f"{case.name}: system modes against {key} (tracked by shape; MAC with the previous value)")
    print(f"  {key:>24s}  " + "  ".join(f"{j + 1:>10d}" for j in range(len(tracks))))
    for k, x in enumerate(values):
        print(f"  {x:24.6g}  " + "  ".join(f"{t['freq_hz'][k]:10.4f}" for t in tracks))
    for j, t in enumerate(tracks):
        print(f"  track {j + 1}: {t['label']} (at {values[0]:g}); smallest MAC {np.nanmin(t['mac']):.3f}")
    for n, F in m.peers.items():
        print(f"  {n} (its own eigen-solve, sorted):")
        for k, x in enumerate(values):
            print(f"  {x:24.6g}  " + "  ".join(f"{f:10.4f}" for f in F[k]))
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


def cmd_completion(args) -> int:
    from flexmbd.cli import completion
    from flexmbd.cli.arguments import parser
    print(completion.bash(parser(), cases.available(), registry.NAMES), end="")
    return OK
