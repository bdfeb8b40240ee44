"""The report: a pure function of stored results (`OUT/results/CASE/SOLVER.{csv,json}`).

    OUT/index.html, index.md          summary table case x solver, links to every page
    OUT/CASE/index.html, index.md     one page per case (figures next to it)
    OUT/accuracy.{csv,md,tex}         reviewer tables, the same numbers as the pages

Each is built in a staging folder swapped in whole (`files.generation`): the stored results are
read by `loading`, the system modes the spectra are matched against come from `spectra`, the
pages are written by `pages` and the reviewer tables by `tables`.
"""

from __future__ import annotations

from pathlib import Path

from flexmbd import files
from flexmbd.report import loading, pages, tables


def case_page(out: Path, case, names, warn=None) -> dict:
    """Write one case's page and figures (`out/CASE/`, swapped in whole: `files.generation`);
    {"accuracy": its accuracy rows, "runs": each run's accuracy.Outcome}."""
    indexed = (Path(out) / "index.html").is_file()
    with files.generation(out) as stage:
        return pages.write_case(out, stage, case, names, warn, indexed)


def write(out: Path, chosen_cases, names, warn=None, progress=None) -> tuple[Path, list, list]:
    """Every case page, the index and the reviewer tables, as one generation (built in a staging
    folder and swapped in at the end: `files.generation`); (the index path, every run's
    accuracy.Outcome, the accuracy rows). `progress(k, n, label)` is told before each page."""
    out = Path(out)
    with files.generation(out) as stage:
        all_acc, runs = _write(out, stage, chosen_cases, names, warn, progress)
    return out / "index.html", runs, all_acc


def _write(out: Path, stage: Path, chosen_cases, names, warn, progress=None) -> tuple[list, list]:
    """Every case page, the reviewer tables and the index into `stage`: (accuracy rows, runs)."""
    all_acc, runs = [], []
    for k, case in enumerate(chosen_cases, 1):
        if progress:
            progress(k, len(chosen_cases) + 1, f"page {case.name}")
        got = pages.write_case(out, stage, case, loading.jobs(case, names), warn)
        all_acc += got["accuracy"]
        runs += got["runs"]
    if progress:
        progress(len(chosen_cases) + 1, len(chosen_cases) + 1, "index and reviewer tables")
    tables.write_accuracy(stage, all_acc)
    pages.write_index(out, stage, runs, warn)
    return all_acc, runs
