"""Regression against stored baselines: `references/baselines/CASE/SOLVER.csv`.

A baseline is a result table with a provenance header (lines starting with '#': source, solver
version, settings, date, units, columns, and the run's largest kinetic energy where the solver
reports it). `compare` measures every channel's RMS difference from the baseline with the
accuracy table's normalisation (`metrics.channel_norm`: the baseline's maximum magnitude, a
total energy against the largest kinetic energy of the case's reference run) and flags what moved beyond the case's
tolerance for that channel. `run` is `flexmbd regress`: which pairs, every input checked before
any solver runs, then fresh or stored results compared with (or written as) the baselines.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pandas as pd

from flexmbd import cases
from flexmbd.harness import channels, cost, executor, metrics, results, registry
from flexmbd.core import files
from flexmbd.core.errors import InputError
from flexmbd.core.files import atomic_write
from flexmbd.harness.results import Result

DEFAULT_TOLERANCE = 1e-3          # channels without a tolerance in the case file


def listing(base: Path) -> list[tuple[str, str]]:
    """(case, solver) of every baseline under base."""
    return sorted((p.parent.name, p.stem) for p in Path(base).glob("*/*.csv"))


def write(base: Path, case, r: Result) -> Path:
    """Store a result as the baseline of (case, solver), with its provenance header: the date,
    commit and Python of the run itself when the result carries them (a stored or a worker's
    result), else this process's."""
    env = {**results.environment(), **r.extra}           # the rule of `results.sidecar`
    units = "; ".join(["t s"] + [f"{c} {channels.unit(case, c)}" for c in r.channels])
    how = (f"flexmbd import {case.name} --solver {r.solver} {r.extra['imported']['file']}" if "imported" in r.extra
           else f"flexmbd run {case.name} --solver {r.solver}")
    head = [f"source: {how} (case file {case.path.name}, sha256 {case.sha256})",
            f"solver: {r.solver} {r.solver_version}",
            f"settings: {json.dumps(r.settings, sort_keys=True)}",
            f"date: {env['date']}; git commit: {env['git_commit']}; python {env['python']}",
            f"units: {units}",
            f"columns: {', '.join(['t'] + list(r.channels))}"]
    if r.extra.get("kinetic_max_J"):
        head.append(f"kinetic_max_J: {r.extra['kinetic_max_J']!r}")
    text = "".join(f"# {h}\n" for h in head) + r.table().to_csv(index=False, float_format="%.10g")
    path = Path(base) / case.name / f"{r.solver}.csv"
    atomic_write(path, text)
    return path


def read(base: Path, case: str, solver: str) -> pd.DataFrame:
    """The baseline table, checked as a stored table (`results.read_table`: a `t` column, the
    columns its header lists, finite numbers); its header's fields (`# key: value` lines) in
    `.attrs`. An InputError naming the file when it is missing or broken."""
    path = Path(base) / case / f"{solver}.csv"
    text = results.read_text(path)
    attrs = {}
    for line in text.splitlines():
        if not line.startswith("#"):
            break
        key, _, value = line[1:].strip().partition(": ")
        attrs[key] = value
    columns = [c.strip() for c in attrs["columns"].split(",")] if "columns" in attrs else None
    df = results.read_table(path, text, columns, comment="#")
    df.attrs.update(attrs)
    return df


def samples(case) -> int:
    """Output samples of a full run of the case."""
    return int(round(case.duration / case.integrator.output_dt)) + 1


def known(base: Path, case: str, solver: str, imported: bool = False) -> Path:
    """The path of the baseline of (case, solver); an InputError naming it when the solver is
    unknown: neither one of the registry's nor an imported result (`imported`, or a baseline
    whose source is `flexmbd import`)."""
    path = Path(base) / case / f"{solver}.csv"
    if solver not in registry.NAMES and not (imported or is_imported(path)):
        raise InputError(f"{path}: a baseline for an unknown solver {solver!r} (known: {', '.join(registry.NAMES)}, "
                         f"or a result brought in with flexmbd import)")
    return path


def is_imported(path: Path) -> bool:
    """Whether a stored baseline was made from an imported result (its source line says so)."""
    try:
        with open(path, encoding="utf-8") as f:
            return f.readline().startswith("# source: flexmbd import ")
    except (OSError, UnicodeDecodeError):
        return False


def baseline(base: Path, case, solver: str) -> tuple[pd.DataFrame, str]:
    """The baseline of (case, solver) checked against the case: a known solver, the solver its
    header names, only the case's channels, a full run's samples. (table, why it is stale or
    ''); an InputError naming the file otherwise."""
    path = known(base, case.name, solver)
    df = read(base, case.name, solver)
    named = df.attrs.get("solver", "").split(" ")[0]
    if named and named != solver:
        raise InputError(f"{path}: its header says solver {named}, not {solver}")
    extra = [c for c in df.columns if c != "t" and c not in case.channels]
    if extra:
        raise InputError(f"{path}: column {extra[0]} is not a channel of {case.name}")
    if len(df) != samples(case):
        raise InputError(f"{path}: {len(df)} rows, expected {samples(case)} (a full run of {case.name}; truncated?)")
    sha = re.search(r"sha256 ([0-9a-f]+)", df.attrs.get("source", ""))
    why = "" if not sha or sha.group(1) == case.sha256 else \
        f"made from another version of the case (case sha256 {sha.group(1)}, now {case.sha256})"
    return df, why


def reference_kinetic(base: Path, case) -> float | None:
    """The largest kinetic energy (J) of the case's reference run, from the header of its
    baseline under `base` (None when there is no such baseline, or it records none): the scale
    of every solver's energy channel (`channels.physical_scale`), as in the report."""
    ref = case.report.reference
    path = Path(base) / case.name / f"{ref}.csv"
    if not ref or not path.is_file():
        return None
    try:
        kinetic = float(read(base, case.name, ref).attrs.get("kinetic_max_J", "nan"))
    except InputError:
        return None                     # the reference's own comparison names what is wrong with it
    return kinetic if np.isfinite(kinetic) and kinetic > 0 else None


def compare(case, r: Result, baseline: pd.DataFrame, kinetic: float | None = None) -> list[dict]:
    """One row per baseline channel: normalised RMS difference, tolerance, moved? Each channel is
    normalised as in the accuracy table (`metrics.channel_norm`), an energy by the case's
    reference run's largest kinetic energy `kinetic` (`reference_kinetic`; J)."""
    tol = case.report.tolerances
    t_ref = baseline["t"].to_numpy()
    rows = []
    for ch in baseline.columns:
        if ch == "t":
            continue
        limit = tol.get(ch, DEFAULT_TOLERANCE)
        if not r.ok or ch not in r.channels:
            rows.append({"case": case.name, "solver": r.solver, "channel": ch, "rms": np.nan, "tolerance": limit,
                         "moved": True, "why": str(r.status) if not r.ok else "channel missing"})
            continue
        y = metrics.on_grid(t_ref, r.t, r.channels[ch])
        ref = baseline[ch].to_numpy()
        d = metrics.rms_diff(ref, y, metrics.channel_norm(case.channels[ch].kind, ref,
                                                          channels.physical_scale(case, ch, kinetic)))
        short = np.isnan(y).any()
        rows.append({"case": case.name, "solver": r.solver, "channel": ch, "rms": d, "tolerance": limit,
                     "moved": bool(short or not d <= limit), "why": "shorter run" if short else ""})
    return rows


# ---------------------------------------------------------------------------------------------
# flexmbd regress


def run(base: Path, case_names, solver_names, stored_in, update: bool, allow_large: bool, load, warn,
        updated, where=None) -> list[dict]:
    """`flexmbd regress`: the rows of `compare` for every (case, solver) pair (`pairs`), fresh
    runs (on the executor, `where`: executor.Where) or, from the report folder `stored_in` (a path
    or None), stored results; with `update` the baselines are written instead (`updated(path)`
    told of each) and there are no rows. Every case, baseline and stored result is checked first
    (`checked`). `load(name)`: a case as the command line loads it; `warn(line)` is told of stale
    inputs."""
    pairs = selected(base, case_names, solver_names, bool(stored_in), update, load)
    loaded, stored, fresh = checked(base, pairs, stored_in, update, allow_large, load, warn)
    if not stored_in:
        jobs = [(loaded[c], s) for c, s in pairs]
        executor.execute(jobs, lambda k, r: fresh.__setitem__(pairs[k], r), where or executor.Where())
    rows = []
    for c, s in pairs:
        r, case = fresh[c, s], loaded[c]
        if update:
            if not r.ok:
                raise InputError(f"{c} / {s}: {r.status}; baseline not written")
            updated(write(base, case, r))
            continue
        rows += compare(case, r, stored[c, s], reference_kinetic(base, case))
    return rows


def selected(base: Path, case_names, solver_names, stored: bool, update: bool, load) -> list[tuple[str, str]]:
    """The (case, solver) pairs of a regression: every baseline under base (`listing`) or, with
    `update` and cases or solvers named, every pair of them that can run (a registered solver
    that applies to the case, or an imported result), narrowed to `case_names` and `solver_names`
    (lists, or None for all). A named solver must be registered, unless it has a baseline or the
    results are `stored`; an InputError when no pair is left."""
    pairs = listing(base)
    if solver_names:                    # registered solvers, and imported results by their baselines or --results
        for name in solver_names:
            if not (stored or name in {s for _, s in pairs}):
                registry.check_name(name, "--solvers")
    if update and (case_names or solver_names):          # create baselines too, not only rewrite
        pairs = [(c, s) for c in case_names or cases.available() for s in solver_names or registry.NAMES
                 if s not in registry.NAMES or not registry.status_for(load(c), s)]
    if case_names:
        pairs = [p for p in pairs if p[0] in case_names]
    if solver_names:
        pairs = [p for p in pairs if p[1] in solver_names]
    if not pairs:
        raise InputError(f"{base}: --baseline: no baselines (expected CASE/SOLVER.csv files)")
    return pairs


def checked(base: Path, pairs: list, stored_in, update: bool, allow_large: bool, load, warn) -> tuple[dict, dict, dict]:
    """Every case, baseline and stored result of `pairs` checked before any solver runs: (cases
    by name, baselines by pair (none with `update`: their folders must be writable instead),
    stored results by pair (from `stored_in`; else the fresh runs' cost is checked))."""
    loaded = {c: load(c) for c in dict.fromkeys(c for c, _ in pairs)}
    stored, fresh = {}, {}
    if update:
        files.writable_dir(base, "--baseline")
        brought = {c: results.imported(results_folder(stored_in), c) if stored_in else [] for c in loaded}
        for c, s in pairs:
            files.writable_dir(known(base, c, s, imported=s in brought[c]).parent, "--baseline")
    else:
        for c, s in pairs:
            stored[c, s], why = baseline(base, loaded[c], s)
            if why:
                warn(f"warning: {base / c / (s + '.csv')}: {why}")
    if stored_in:
        where = results_folder(stored_in)
        for c, s in pairs:
            fresh[c, s] = results.read(where, c, s)
            why = results.stale(fresh[c, s], loaded[c].sha256, loaded[c].channels)
            if why:
                warn(f"warning: {where / c / (s + '.json')}: stale: {why}")
    else:
        for c, s in pairs:
            if s not in registry.NAMES:
                known(base, c, s)                       # an unknown solver's baseline is named as such
                raise InputError(f"{base / c / (s + '.csv')}: {s} is an imported result, which cannot be rerun: "
                                 f"give --results DIR (the report folder it was imported into)")
        cost.check([(loaded[c], s) for c, s in pairs], allow_large=allow_large)
    return loaded, stored, fresh


def results_folder(out) -> Path:
    """The results of the report folder `out` (results.folder), which must exist."""
    where = results.folder(out)
    if not where.is_dir():
        raise InputError(f"{where}: --results: no results folder (give the report folder DIR whose results are "
                         f"DIR/results/CASE/SOLVER.json, as run, import, compare and report write them)")
    return where
