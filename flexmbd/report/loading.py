"""Reading a case's stored results for its page: which solvers a page shows (`jobs`,
`page_solvers`), their stored results with unusable or stale ones kept as unavailable
(`load_results`), and whether a result comes from a run (`ran`).
"""

from __future__ import annotations

from pathlib import Path

from flexmbd.harness import results
from flexmbd.core.errors import InputError
from flexmbd.harness.results import Result


def jobs(case, names) -> list:
    """The solvers of `names` that the case's report runs (its `report.solvers`, when given), with
    the case's reference first when they need it (`with_reference`)."""
    listed = case.report.solvers
    return with_reference(case, [s for s in names if not listed or s in listed])


def with_reference(case, names) -> list:
    """`names` and, when one of them is to be compared with the case's reference solver and the
    reference is not among them, the reference first: every comparison needs its run."""
    ref = added_reference(case, names)
    return [ref] + list(names) if ref else list(names)


def added_reference(case, names) -> str | None:
    """The case's reference solver when `names` lacks it but holds a solver to compare with it;
    None otherwise (no `[report]` reference, or nothing to compare)."""
    ref = case.report.reference
    return ref if ref and names and ref not in names else None


def page_solvers(out: Path, case, names) -> list:
    """The solvers whose stored results a case page reads: `names` and those imported for the case
    (`results.imported`). The command line estimates their sizes from the same list before any is
    read (`cost.check_stored`)."""
    return list(names) + [s for s in results.imported(results.folder(out), case.name) if s not in names]


def load_results(out: Path, case, names, warn=None) -> dict:
    """Stored results of one case, by solver. A stored result that is missing or cannot be used
    (broken, truncated, its CSV gone) or that was run for another version of the case (stale) is
    kept as an unavailable result saying why, never as ok; `warn(line)` is told."""
    got = {}
    for s in names:
        note = ""                                       # what is wrong with the stored result
        try:
            r = results.read(results.folder(out), case.name, s)
            why = results.stale(r, case.sha256, case.channels)
            if why:
                note = f"{out / 'results' / case.name / (s + '.json')}: stale: {why}"
                r = Result(solver=s, case=case.name, status=results.unavailable(f"{results.STALE}: {why}"),
                           solver_version=r.solver_version, settings=r.settings, case_sha256=r.case_sha256)
        except InputError as e:
            note = str(e)
            r = Result(solver=s, case=case.name, status=results.unavailable(f"{results.UNUSABLE}: {e}"))
        if note and warn:
            warn(f"warning: {note}")
        got[s] = r
    return got


def ran(r: Result) -> bool:
    """Whether a result comes from a run (ok or failed), so that its times and counts mean something."""
    return r.status.kind in ("ok", "failed")
