"""flexmbd: a validation and benchmarking harness for flexible multibody dynamics.

The Python API (docs/api.md): `load_case`, `run`, `compare`, `system_modes`, returning pandas
objects. Importing flexmbd is cheap; solvers and their compiled kernels load on first use."""

from __future__ import annotations

from flexmbd.version import __version__

__all__ = ["load_case", "run", "compare", "system_modes", "__version__"]


def load_case(name_or_path, overrides=()):
    """A validated case (cases.Case) from a name in cases/ or a TOML path, with `dotted.key=VALUE`
    overrides as `--set` takes them. Bad input raises flexmbd.errors.InputError naming the key. A
    case that names no reference solver gets its default (`solvers.graded`, cases/README.md)."""
    from flexmbd import cases, solvers
    return solvers.graded(cases.load(str(name_or_path), list(overrides)))


def _case(case):
    return case if hasattr(case, "resolved") else load_case(case)


def run(case, solver: str = "flexmbd", t_end: float | None = None):
    """Run one solver on a case (a Case or a name); a pandas DataFrame indexed by time t [s], one
    column per channel (SI units). `df.attrs` holds the solver, its version, the status line,
    `ok`, the wall times, steps and settings (the JSON sidecar's content), and the deformed-shape
    snapshots `shapes` ({beam: {"x", "t", "u" (instant, point, 3)}}, m; docs/formulation.md §7)."""
    import pandas as pd

    from flexmbd import solvers
    case = _case(case)
    solvers.check_name(solver, "solver")
    r = solvers.run(case, solver, t_end)
    df = pd.DataFrame({k: r.channels[k] for k in r.channels}, index=pd.Index(r.t, name="t"))
    df.attrs.update({"case": case.name, "solver": solver, "solver_version": r.solver_version,
                     "status": str(r.status), "ok": r.ok, "wall_s": r.wall_s, "setup_s": r.setup_s,
                     "steps": r.steps, "rhs_evals": r.rhs_evals, "settings": r.settings,
                     "shapes": r.extra.get("shapes", {})})
    return df


def compare(case, solvers=None, t_end: float | None = None):
    """Run the solvers (default: the case's report list) and compare each with the case's reference
    solver: a DataFrame with one row per (solver, channel): RMS, largest and peak differences over
    the reference's largest magnitude, the tolerance and `passes` (RMS within tolerance).
    `df.attrs["status"]` maps each solver to its status line; `df.attrs["not_graded"]` is '' or,
    for a case without a reference solver (no `[report]` table), why nothing is graded (the
    solvers run, and the DataFrame has no rows)."""
    import pandas as pd

    from flexmbd import solvers as registry
    from flexmbd.report import accuracy, spectra
    case = _case(case)
    names = list(solvers or case.report.solvers or registry.NAMES)
    ref = case.report.reference
    if ref is not None and ref not in names:
        names.insert(0, ref)
    for n in names:
        registry.check_name(n, "solvers")
    res = {n: registry.run(case, n, t_end) for n in names}
    ok = {n: r for n, r in res.items() if r.ok}
    freqs = spectra.fe_frequencies(case)
    rows = accuracy.rows(case, ok, {n: registry.module(n) for n in ok}, freqs)
    df = pd.DataFrame(rows, columns=["case", "solver", "reference", "channel", "rms", "max", "peak", "tolerance"])
    df["passes"] = df["rms"] <= df["tolerance"]
    df.attrs["status"] = {n: str(r.status) for n, r in res.items()}
    df.attrs["not_graded"] = accuracy.ungraded(case)
    return df


def system_modes(case, about: str = "initial"):
    """The assembled system's frequencies [Hz], damping ratios and labels, linearized about the
    initial state or the static equilibrium (docs/formulation.md §10): a DataFrame."""
    import pandas as pd

    from flexmbd import linearize
    modes = linearize.for_case(_case(case), about)
    return pd.DataFrame(modes, columns=["freq_hz", "damping", "label", "share"])
