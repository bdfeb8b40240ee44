"""flexmbd: a validation and benchmarking harness for flexible multibody dynamics.

The Python API (docs/api.md): `load_case`, `run`, `compare`, `verdicts`, `durability`,
`system_modes` and `units`, returning pandas objects whose `attrs["units"]` names every column's unit. Importing
flexmbd is cheap; solvers and their compiled kernels load on first use."""

from __future__ import annotations

__all__ = ["load_case", "run", "compare", "verdicts", "durability", "system_modes", "units", "__version__"]


def load_case(name_or_path, overrides=()):
    """A validated case (cases.Case) from a name in cases/ or a TOML path, with `dotted.key=VALUE`
    overrides as `--set` takes them. Bad input raises flexmbd.core.errors.InputError naming the key. A
    case that names no reference solver gets its default (`registry.graded`, cases/README.md)."""
    from flexmbd import cases
    from flexmbd.harness import registry
    return registry.graded(cases.load(str(name_or_path), list(overrides)))


def _case(case):
    return case if hasattr(case, "resolved") else load_case(case)


def units(of) -> dict | str:
    """The units of what the API returns or of a case's channels: of a DataFrame, {column: unit}
    for its index and columns (from `attrs["units"]`); of a Series (a column), its unit; of a Case
    or a case name, {"t": "s", channel: SI unit} (`channels.unit`). A unit "1" is a ratio."""
    import pandas as pd

    if isinstance(of, (pd.DataFrame, pd.Series)):
        known = of.attrs.get("units")
        if known is None:
            raise ValueError("no units: this pandas object does not come from flexmbd (or lost its attrs)")
        if isinstance(of, pd.Series):
            if of.name not in known:
                raise ValueError(f"no unit for {of.name!r}: units are known for {', '.join(map(str, known))}")
            return known[of.name]
        return {k: known[k] for k in [of.index.name, *of.columns] if k in known}
    from flexmbd.harness import channels
    case = _case(of)
    return {"t": "s", **{name: channels.unit(case, name) for name in case.channels}}


def run(case, solver: str = "flexmbd", t_end: float | None = None, shapes: bool = False):
    """Run one solver on a case (a Case or a name): a pandas DataFrame indexed by time t [s], one
    column per channel in SI units, `attrs["units"]` {"t" and each column: unit}. `attrs` also
    holds the solver, its version, the status line, `ok`, the wall times, steps and settings (the
    JSON sidecar's content). With `shapes`, (that DataFrame, the deformed-shape snapshots:
    `shape_frame`)."""
    import pandas as pd

    from flexmbd.harness import registry
    case = _case(case)
    registry.check_name(solver, "solver")
    r = registry.run(case, solver, t_end)
    df = pd.DataFrame({k: r.channels[k] for k in r.channels}, index=pd.Index(r.t, name="t"))
    df.attrs.update({"case": case.name, "solver": solver, "solver_version": r.solver_version,
                     "status": str(r.status), "ok": r.ok, "wall_s": r.wall_s, "setup_s": r.setup_s,
                     "steps": r.steps, "rhs_evals": r.rhs_evals, "settings": r.settings,
                     "units": units(case)})
    return (df, shape_frame(r.extra.get("shapes", {}), case.name, solver)) if shapes else df


def shape_frame(snapshots: dict, case: str = "", solver: str = ""):
    """The deformed-shape snapshots of a run ({beam: {"x", "t", "u" (instant, point, 3)}}, as
    `channels.shapes` forms them; docs/formulation.md §7) as a long DataFrame: one row per (body,
    t, x) with the displacement ux, uy, uz of the point at x in the root-node (or chord) frame;
    `attrs["units"]`."""
    import numpy as np
    import pandas as pd

    parts = []
    for body, s in snapshots.items():
        u = np.asarray(s["u"], dtype=float).reshape(len(s["t"]), len(s["x"]), 3)
        t, x = np.meshgrid(s["t"], s["x"], indexing="ij")
        parts.append(pd.DataFrame({"body": body, "t": t.ravel(), "x": x.ravel(),
                                   "ux": u[..., 0].ravel(), "uy": u[..., 1].ravel(), "uz": u[..., 2].ravel()}))
    cols = ["body", "t", "x", "ux", "uy", "uz"]
    df = pd.concat(parts, ignore_index=True) if parts else pd.DataFrame(columns=cols)
    df.attrs.update({"case": case, "solver": solver, "units": {"t": "s", "x": "m", "ux": "m", "uy": "m", "uz": "m"}})
    return df


def compare(case, solvers=None, t_end: float | None = None):
    """Run the solvers (default: the case's report list) and compare each with the case's reference
    solver, as the report does (`report.accuracy`): a DataFrame with the accuracy table's columns
    (`report.tables.ACCURACY_COLUMNS`, one row per solver and channel; `attrs["headers"]` their
    headings, `attrs["units"]`), and each run's verdict in `attrs["runs"]` (`verdicts` reads them
    as a DataFrame). `attrs["status"]` maps each solver to its status line; `attrs["not_graded"]`
    is '' or, for a case without a reference solver (no `[report]` table), why nothing is graded
    (the solvers run, and the DataFrame has no rows)."""
    import numpy as np
    import pandas as pd

    from flexmbd.harness import registry
    from flexmbd.report import accuracy, loading, spectra, tables
    case = _case(case)
    names = loading.with_reference(case, list(solvers or case.report.solvers or registry.NAMES))
    for n in names:
        registry.check_name(n, "solvers")
    res = {n: registry.run(case, n, t_end) for n in names}
    ok = {n: r for n, r in res.items() if r.ok}
    rows = accuracy.rows(case, ok, {n: registry.module(n) for n in ok}, spectra.fe_frequencies(case))
    ref = case.report.reference
    df = pd.DataFrame(rows, columns=[k for k, *_ in tables.ACCURACY_COLUMNS])
    runs = []
    for n, r in res.items():
        v = accuracy.verdict(r.status, n, ref, rows)
        runs.append({"solver": n, "verdict": v.kind, "text": v.text, "status": str(r.status),
                     "worst_rms": accuracy.worst(rows, n) if n != ref else np.nan,
                     "wall_s": r.wall_s if loading.ran(r) else np.nan})
    df.attrs.update({"case": case.name, "reference": ref, "runs": runs,
                     "status": {n: str(r.status) for n, r in res.items()},
                     "not_graded": accuracy.ungraded(case), "headers": {k: h for k, h, _ in tables.ACCURACY_COLUMNS},
                     "units": {k: u for k, u in tables.TIDY_METRICS if u}})
    return df


def verdicts(compared):
    """The verdict of each run of a `compare` DataFrame, as the report's index shows it: a
    DataFrame indexed by solver with `verdict` (its kind: report.accuracy.VERDICTS), `text` (the
    line shown), `status`, `worst_rms` (the largest normalised RMS difference of its graded
    channels; NaN for the reference) and `wall_s` (solve wall time, s)."""
    import pandas as pd

    df = pd.DataFrame(compared.attrs["runs"], columns=["solver", "verdict", "text", "status", "worst_rms", "wall_s"])
    df = df.set_index("solver")
    df.attrs["units"] = {"worst_rms": "1", "wall_s": "s"}
    return df


def durability(case, solvers=None, t_end: float | None = None):
    """The fatigue count of a case with a `[durability]` table (docs/durability.md): the solvers
    (default: the case's report list, with its reference) run as `compare` runs them, and for each
    signed stress channel and solver that gives it, its rainflow cycles, largest range, S_eq at
    m = 3 and 5, Palmgren-Miner damage per repeat, life, and against the reference: S_eq and
    damage ratios, the damage ratio the S_eq ratio predicts, the band the RMS stress difference
    predicts and the verdict on S_eq. A DataFrame (`harness.durability.COLUMNS`) with
    `attrs["units"]`, `attrs["cycles"]` {solver: DataFrame of its cycles} and `attrs["curve"]`."""
    import pandas as pd

    from flexmbd.core.errors import InputError
    from flexmbd.harness import durability as fatigue
    from flexmbd.harness import registry
    from flexmbd.report import durability as section
    from flexmbd.report import loading
    case = _case(case)
    if fatigue.settings(case) is None:
        raise InputError(f"{case.path}: durability: the case has no [durability] table (cases/README.md)")
    names = loading.with_reference(case, list(solvers or case.report.solvers or registry.NAMES))
    for n in names:
        registry.check_name(n, "solvers")
    res = {n: registry.run(case, n, t_end) for n in names}
    st, rows, cycles = section.counts(case, {n: r for n, r in res.items() if r.ok})
    df = pd.DataFrame(rows, columns=[k for k, _ in fatigue.COLUMNS])
    df.attrs.update({"case": case.name, "reference": case.report.reference, "curve": st.curve.name,
                     "units": {k: u for k, u in fatigue.COLUMNS if u},
                     "cycles": {n: pd.DataFrame(c) for n, c in cycles.items()}})
    return df


def system_modes(case, about: str = "initial"):
    """The assembled system's frequencies [Hz], damping ratios and labels, linearized about the
    initial state or the static equilibrium (docs/formulation.md §10): a DataFrame with
    `freq_hz`, `damping`, `damping_resolution`, `label` and `share`. A damping ratio within its
    mode's resolution (`linearize.damping_resolution`: the eigen-solver's round-off of the mode's
    eigenvalue, by its condition number, over |lambda|) is round-off and shows as 0."""
    import pandas as pd

    from flexmbd.solvers import linearize
    modes = linearize.for_case(_case(case), about)
    df = pd.DataFrame(modes, columns=list(linearize.SystemMode._fields))
    df = df[["freq_hz", "damping", "damping_resolution", "label", "share"]]
    df.attrs["units"] = {"freq_hz": "Hz", "damping": "1", "damping_resolution": "1", "share": "1"}
    return df


def __getattr__(name: str):
    """`flexmbd.__version__`, read on first use: importing a part of the package (the solver,
    `flexmbd.mbd`) loads nothing else of it."""
    if name == "__version__":
        from flexmbd.version import __version__
        return __version__
    raise AttributeError(f"module 'flexmbd' has no attribute {name!r}")
