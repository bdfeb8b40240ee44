"""What several commands share: a case loaded and checked before any work, the solvers an option
names, the checks of a set of runs and their running (where --workers, --scheduler, --dask-local
say), and the one form of a warning on stderr."""

from __future__ import annotations

import sys
from pathlib import Path

from flexmbd import cases
from flexmbd.harness import cost, durability, registry


def _case(name: str, overrides=()) -> cases.Case:
    """A case loaded and its solver tables checked: bad input stops here, before any work. A case
    that names no reference solver gets its default (`registry.graded`)."""
    case = cases.load(name, overrides)
    registry.check(case)
    durability.check(case)
    return registry.graded(case)


def _load(args) -> cases.Case:
    return _case(args.case, getattr(args, "set", None) or [])


def _where(args):
    """Where the command's runs go (executor.Where), from --workers, --scheduler, --dask-local."""
    from flexmbd.harness import executor
    return executor.Where(args.workers, args.scheduler, args.dask_local)


def _solver_list(text: str | None, flag: str) -> list:
    chosen = text.split(",") if text else list(registry.NAMES)
    for name in chosen:
        registry.check_name(name, flag)
    return chosen


def check_all(jobs: list, out: Path, allow_large: bool = False) -> None:
    """The cost of every (case, solver) job and the sizes of the imported results that the jobs'
    pages will read beside them, within the limits (cost.check, cost.check_stored)."""
    cost.check(jobs, allow_large=allow_large)
    cost.check_stored(stored_sidecars(out, [(c, []) for c in {c.name: c for c, _ in jobs}.values()]), allow_large)


def run_checked(jobs: list, out: Path, keep: bool = False, where=None, after=None) -> None:
    """Run jobs already checked (`check_all`) into out/results (`executor.into`: with `keep`, a
    stored result with the key of the run it would be is kept), where `where` says (executor.Where:
    a local pool of one worker per core by default); `after(case, solver)` told as each is in place."""
    from flexmbd.harness import executor, results
    executor.into(jobs, lambda case: results.folder(out), keep, where or executor.Where(), after)


def stored_sidecars(out, pages) -> list:
    """The sidecars of the stored results that case pages will read, for their sizes
    (`cost.check_stored`): pages [(case, the solvers read from storage)], each with the results
    imported for its case (`loading.page_solvers`)."""
    from flexmbd.harness import results
    from flexmbd.report import loading
    return [results.folder(out) / c.name / f"{s}.json" for c, names in pages for s in loading.page_solvers(out, c, names)]


def warn(line: str) -> None:
    print(f"flexmbd: {line}", file=sys.stderr)
