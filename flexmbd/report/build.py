"""The report: a pure function of stored results (`OUT/results/CASE/SOLVER.{csv,json}`).

    OUT/index.html, index.md          summary table case x solver, links to every page
    OUT/CASE/index.html, index.md     one page per case (figures next to it)
    OUT/accuracy.{csv,md,tex}         reviewer tables, the same numbers as the pages

Each is built in a staging folder swapped in whole (`files.generation`): the stored results are
read by `loading`, the system modes the spectra are matched against come from `spectra`, the
pages are written by `pages` and the reviewer tables by `tables`.

A case page is a function of its inputs only: the case (its text and content), the solvers it
shows, their stored results (sidecar and CSV bytes), whether the report has an index, and
flexmbd's source. `OUT/CASE/page.json` records their digest (`page_key`) with what the page gave
the index (its accuracy rows, its runs' outcomes, the warnings said while it was built); a report
that may reuse pages (`reuse`) copies an unchanged page into the new generation and says its
warnings again, instead of drawing it again.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import traceback
from multiprocessing import get_context
from pathlib import Path

from flexmbd.core import files
from flexmbd.harness import results, registry
from flexmbd import version
from flexmbd.report import accuracy, convergence, durability, loading, pages, spectra, tables

RECORD = "page.json"        # in OUT/CASE/: the page's key and what it gave the index
DRAWERS = os.cpu_count() or 1   # processes drawing pages during a report's runs, at most


def case_page(out: Path, case, names, warn=None, folder: Path | None = None) -> dict:
    """Write one case's page and figures from the results under `out` into `folder/CASE/` (default
    `out`: the report's page; `flexmbd compare`'s goes to OUT/compare), swapped in whole
    (`files.generation`); {"accuracy": its accuracy rows, "runs": each run's accuracy.Outcome}."""
    folder = Path(folder or out)
    indexed = (Path(out) / "index.html").is_file()
    with files.generation(folder) as stage:
        return pages.write_case(out, stage, case, names, warn, indexed,
                                up=Path(os.path.relpath(out, folder / case.name)).as_posix())


def write(out: Path, chosen_cases, names, warn=None, progress=None, reuse: bool = False,
          run=None) -> tuple[Path, list, list]:
    """Every case page, the index and the reviewer tables, as one generation (built in a staging
    folder and swapped in at the end: `files.generation`); (the index path, every run's
    accuracy.Outcome, the accuracy rows). `progress(k, n, label)` is told before each page. With
    `reuse`, a case page whose inputs are unchanged is copied, not drawn again (`page_key`).

    With `run`, the solvers run first: run(after) runs every job of the pages, telling after(case,
    solver) as each result is in place, and a case's page is drawn as soon as its last job is,
    by a process of its own (`Drawer`) while the other jobs still run. What the pages need that
    may take long (`spectra.prepare`) is done here for the pages drawn after the runs."""
    out = Path(out)
    with files.generation(out) as stage:
        drawn = drawn_while(run, out, stage, chosen_cases, names, reuse) if run else {}
        spectra.prepare([c for c in chosen_cases if c.name not in drawn and not (reuse and unchanged(out, c, names))],
                        warn)
        all_acc, runs = _write(out, stage, chosen_cases, names, warn, progress, reuse, drawn)
    return out / "index.html", runs, all_acc


def _write(out: Path, stage: Path, chosen_cases, names, warn, progress=None, reuse: bool = False,
           drawn=None) -> tuple[list, list]:
    """Every case page, the reviewer tables and the index into `stage`: (accuracy rows, runs).
    `drawn`: case name -> (what its page gave, its warnings) of the pages already in `stage`."""
    all_acc, runs, fatigue = [], [], []
    drawn = drawn or {}
    for k, case in enumerate(chosen_cases, 1):
        shown = loading.jobs(case, names)
        key = page_key(out, case, shown)
        got = reused(out, stage, case, key, warn) if reuse and case.name not in drawn else None
        if progress:
            progress(k, len(chosen_cases) + 1, f"page {case.name}" + (" (unchanged, kept)" if got else
                                                                       " (drawn while the runs went on)"
                                                                       if case.name in drawn else ""))
        if got is None and case.name in drawn:
            got, said = drawn[case.name]
            for line in said:
                if warn:
                    warn(line)
            files.atomic_write(stage / case.name / RECORD, record(key, got, said))
        elif got is None:
            said = []
            got = pages.write_case(out, stage, case, shown, lambda line: said.append(line) or (warn and warn(line)))
            files.atomic_write(stage / case.name / RECORD, record(key, got, said))
        all_acc += got["accuracy"]
        runs += got["runs"]
        fatigue += got.get("durability", [])
    if progress:
        progress(len(chosen_cases) + 1, len(chosen_cases) + 1, "index and reviewer tables")
    tables.write_accuracy(stage, all_acc, runs)
    pages.write_index(out, stage, runs, warn, durability.write_index(stage, fatigue))
    return all_acc, runs


def drawn_while(run, out: Path, stage: Path, chosen_cases, names, reuse: bool) -> dict:
    """run(after) (the jobs of the pages), with each case's page drawn into `stage` by a `Drawer`
    as soon as after(case, solver) has been told of its last job (a page that `reuse` keeps is
    not drawn). A page goes to the Drawer with the fewest pages in hand; another Drawer starts
    while every one is busy, up to one per core (`DRAWERS`), so that the pages left when the runs
    end are drawn side by side; but the first does not start once every job is done: the page is
    then left to this process (`_write`), which a Drawer started only then would keep waiting while
    it imports what drawing needs (about 1.5 s: a one-case report's whole page, later). Returns
    case name -> (what its page gave, its warnings) of the pages drawn."""
    left = {c.name: set(loading.jobs(c, names)) for c in chosen_cases}
    drawers, most = [], min(DRAWERS, len(chosen_cases))

    def after(case, solver: str) -> None:
        todo = left.get(case.name)
        if todo is None or solver not in todo:
            return
        todo.discard(solver)
        if todo or (reuse and unchanged(out, case, names)):
            return
        if not drawers and not any(left.values()):      # the runs are over, no page being drawn: this
            return                                      # process draws it (`_write`), sooner than a new one
        if len(drawers) < most and all(d.pending() for d in drawers):
            drawers.append(Drawer(out, stage, True))            # the report writes its index
        min(drawers, key=Drawer.pending).send(case, loading.jobs(case, names))

    try:
        run(after)
        got = {}
        for d in drawers:
            got.update(d.collect())
        return got
    finally:
        for d in drawers:
            d.stop()


class Drawer:
    """A process (spawned, SIGINT ignored, dying with its parent) that draws case pages into a
    report's staging folder (`pages.write_case`) while this process waits for runs. A page it
    could not give (the process died) is drawn by the caller instead; an internal error in it is
    raised here with its traceback."""

    def __init__(self, out: Path, stage: Path, indexed: bool):
        ctx = get_context("spawn")
        self.conn, theirs = ctx.Pipe()
        self.proc = ctx.Process(target=_draw, args=(theirs, str(out), str(stage), indexed), daemon=True)
        self.proc.start()
        theirs.close()
        self.sent, self.answers, self.dead = [], [], False

    def send(self, case, names) -> None:
        self.conn.send((str(case.path.resolve()), tuple(case.overrides), list(names)))
        self.sent.append(case.name)

    def _take(self, wait: bool) -> bool:
        """Receive one answer (waiting for it when `wait`); False when none came."""
        try:
            if self.dead or not (wait or self.conn.poll()):
                return False
            self.answers.append(self.conn.recv())
            return True
        except (EOFError, OSError):
            self.dead = True
            return False

    def pending(self) -> int:
        """The pages sent and not yet answered (taking the answers already in); a Drawer that died
        counts as never free."""
        while len(self.answers) < len(self.sent) and self._take(False):
            pass
        return len(self.sent) - len(self.answers) + (len(self.sent) + 1) * self.dead

    def collect(self) -> dict:
        """Case name -> (what its page gave, its warnings), for each page sent that was drawn."""
        while len(self.answers) < len(self.sent) and self._take(True):
            pass
        got = {}
        for name, (kind, value) in zip(self.sent, self.answers):
            if kind == "error":
                err = RuntimeError(f"{value.strip().splitlines()[-1]} (drawing the page of {name})")
                err.add_note(f"The drawing process's traceback:\n{value}")
                raise err
            got[name] = value
        return got

    def stop(self) -> None:
        if self.proc.is_alive():
            self.proc.kill()
        self.proc.join()
        self.conn.close()


def _draw(conn, out: str, stage: str, indexed: bool) -> None:
    """The Drawer's life: take (case file, overrides, solver names), draw the page, answer ("ok",
    (what it gave, its warnings)) or ("error", traceback), until the pipe closes."""
    from flexmbd import cases
    from flexmbd.harness import executor, progress
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    executor.die_with_parent()
    progress.silence()
    while True:
        try:
            path, overrides, names = conn.recv()
        except (EOFError, OSError):
            return
        try:
            said = []
            got = pages.write_case(Path(out), Path(stage), registry.graded(cases.load(path, list(overrides))), names, said.append,
                                   indexed)
            answer = ("ok", (got, said))
        except Exception:                               # noqa: BLE001 - the parent raises it
            answer = ("error", traceback.format_exc())
        conn.send(answer)


def page_key(out: Path, case, names) -> str:
    """SHA-256 (hex) of everything a case page in a report (with an index) is drawn from: the case's
    text and content, the solvers it shows (`names` and those imported), the bytes of their stored
    sidecars and CSVs, its convergence studies' files (`convergence.files`), and flexmbd's source
    (`registry.source_sha256`)."""
    studies = convergence.files(case)                       # the stored convergence studies drawn on it
    stored = [results.folder(out) / case.name / f"{s}.{ext}" for s in loading.page_solvers(out, case, names)
              for ext in ("json", "csv")]
    return version.cache_key({"case": [case.sha256, case.content_sha256], "flexmbd": registry.source_sha256(),
                              "names": list(names)},
                             *(part for f in studies for part in (f"\0{f.name}\0", version.cache_key(f.read_bytes()))),
                             *(part for f in stored for part in (f"\0{f.name}\0", version.cache_key(f.read_bytes())
                                                                 if f.is_file() else "absent")))


def unchanged(out: Path, case, names) -> bool:
    """Whether the case's page in `out` was drawn from exactly the inputs it would be drawn from
    now (its record's key is `page_key`): a report that reuses pages keeps it."""
    return _record(out, case, page_key(out, case, loading.jobs(case, names))) is not None


def _record(out: Path, case, key: str) -> dict | None:
    """The page record of `case` in `out` when it has `key` and its page is there, else None."""
    old = Path(out) / case.name
    try:
        rec = json.loads((old / RECORD).read_text())
    except (OSError, ValueError):
        return None
    return rec if isinstance(rec, dict) and rec.get("key") == key and (old / "index.html").is_file() else None


def record(key: str, got: dict, said: list) -> str:
    """The page's record (RECORD): its key, accuracy rows, runs' outcomes and warnings, as JSON."""
    runs = [{"case": o.case, "solver": o.solver, "status": [o.status.kind, o.status.why, o.status.t, o.status.cause],
             "verdict": list(o.verdict), "worst": o.worst, "wall_s": o.wall_s, "channel": o.channel} for o in got["runs"]]
    return files.json_text({"key": key, "accuracy": got["accuracy"], "runs": runs, "warnings": said,
                            "durability": got.get("durability", [])}) + "\n"


def reused(out: Path, stage: Path, case, key: str, warn) -> dict | None:
    """The page of `case` in `out`, copied into `stage`, when its record has `key` (its inputs are
    unchanged); its warnings said again (`warn`). None when it must be drawn (no page, no record,
    another key, a record that cannot be read)."""
    rec = _record(out, case, key)
    if rec is None:
        return None
    nan = lambda v: float("nan") if v is None else v                   # written as null (files.json_text)
    try:
        runs = [accuracy.Outcome(o["case"], o["solver"], results.Status(*o["status"]), accuracy.Verdict(*o["verdict"]),
                                 nan(o["worst"]), nan(o["wall_s"]), o.get("channel", "")) for o in rec["runs"]]
        got = {"accuracy": [{k: nan(v) for k, v in row.items()} for row in rec["accuracy"]], "runs": runs,
               "durability": [{k: nan(v) for k, v in row.items()} for row in rec.get("durability", [])]}
    except (OSError, ValueError, KeyError, TypeError):
        return None
    shutil.copytree(Path(out) / case.name, stage / case.name)
    for line in rec.get("warnings", []):
        if warn:
            warn(line)
    return got
