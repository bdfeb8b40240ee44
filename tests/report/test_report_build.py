"""The report's build (report/build.py): an unchanged page is kept and any change draws it again,
pages drawn side by side are those drawn one after another, a failing solver or an interrupt
stops nothing else and leaves nothing half-written. Each starts from the session's report of the
cantilever (conftest.py) or its stored runs, so that what is tested is the build, not the runs."""

import json
import re
import shutil
from pathlib import Path

import pytest

from flexmbd import cases
from flexmbd.cli import main

pytestmark = pytest.mark.heavy(53)       # seconds, measured with both cores busy (tests/conftest.py)

FAST = "analytic,fe-linear"


@pytest.fixture(scope="module")
def report(cantilever_report):
    """A report of cantilever_step by analytic, its reference fe-linear and pinocchio (which does not
    apply): the session's (conftest.py). Read only: a test that changes it works on a copy."""
    return cantilever_report


def stored(report: Path, tmp_path: Path, *names: str) -> Path:
    """tmp_path/rep holding the report's stored results of cantilever_step by `names` (a report
    there keeps them: nothing runs that is stored)."""
    folder = tmp_path / "rep" / "results" / "cantilever_step"
    folder.mkdir(parents=True)
    for name in names:
        for f in (report / "results" / "cantilever_step").glob(f"{name}.*"):
            shutil.copy(f, folder)
    return tmp_path / "rep"


def test_a_failing_solver_does_not_stop_the_report(report, tmp_path, monkeypatch):
    from flexmbd.solvers import analytic

    def boom(*a, **k):
        raise RuntimeError("boom")

    out = stored(report, tmp_path, "fe-linear")                     # the reference kept: analytic alone runs
    monkeypatch.setattr(analytic, "run", boom)                  # in this process: the runs too (--workers 1)
    assert main(["report", "--cases", "cantilever_step", "--solvers", FAST, "--out", str(out), "--workers", "1"]) == 0
    index = (out / "index.html").read_text()
    assert "aborted: RuntimeError: boom" in index                  # a solver's error: aborted, not diverged
    assert "fe-linear" in index


def test_an_interrupted_report_leaves_no_half_written_files(report, tmp_path, monkeypatch):
    """Interrupted while it draws (its runs stored already: nothing runs)."""
    from flexmbd.report import figures
    out = stored(report, tmp_path, "analytic", "fe-linear")
    calls = {"n": 0}
    real_savefig = figures.plt.Figure.savefig

    def interrupt(self, *a, **k):
        calls["n"] += 1
        if calls["n"] == 2:
            raise KeyboardInterrupt
        return real_savefig(self, *a, **k)

    monkeypatch.setattr(figures.plt.Figure, "savefig", interrupt)
    # every figure drawn, none from the user's figure cache (an empty one; the compiled kernel's
    # cache, in the same user folder, stays where it is: a fresh one would compile it again, 40 s)
    monkeypatch.setattr(figures, "user_cache", lambda *parts: tmp_path.joinpath("cache", *parts))
    assert main(["report", "--cases", "cantilever_step", "--solvers", FAST, "--out", str(out)]) == 130
    leftovers = [p for p in tmp_path.rglob("*") if p.name.startswith(".")]
    assert leftovers == []
    for p in tmp_path.rglob("*.png"):
        assert p.stat().st_size > 1000


def test_a_page_whose_inputs_are_unchanged_is_kept_and_any_change_draws_it_again(report, cantilever_argv, tmp_path,
                                                                                  capsys):
    """A second report keeps each unchanged page (copied, its record's key the same), with the same
    index and tables; a changed stored result draws its page again; --no-run draws every page. The
    first report is the session's (a copy of it)."""
    out = tmp_path / "rep"
    shutil.copytree(report, out)
    argv = [*cantilever_argv, "--out", str(out), "--workers", "1"]

    def pages():        # the index says when it was generated (to the minute): the one part that may move
        got = {p: (out / p).read_bytes() for p in ("index.html", "accuracy.csv", "cantilever_step/index.html")}
        got["index.html"] = re.sub(rb"Generated \d{4}-\d\d-\d\d \d\d:\d\d UTC", b"Generated (when)", got["index.html"])
        return got
    first = pages()
    assert b"Generated (when)" in first["index.html"]
    capsys.readouterr()
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert "page cantilever_step (unchanged, kept)" in err and "(stored, unchanged)" in err
    assert pages() == first
    sidecar = out / "results" / "cantilever_step" / "analytic.json"
    meta = json.loads(sidecar.read_text())
    meta["wall_s"] *= 2                                  # the page's timing table shows it
    sidecar.write_text(json.dumps(meta, indent=2) + "\n")
    assert main(argv) == 0
    assert "page cantilever_step (unchanged, kept)" not in capsys.readouterr().err
    assert main([*argv, "--no-run"]) == 0
    assert "(unchanged, kept)" not in capsys.readouterr().err


def test_pages_drawn_side_by_side_are_the_pages_drawn_one_after_another(report, tmp_path, monkeypatch):
    """Two cases whose runs end at once while a third's still go on: the second page goes to a
    second Drawer while the first is busy (one per core at most, build.DRAWERS), and each page is
    the one a single Drawer draws. Once every run has ended no Drawer starts: the last page is
    left to the report's own process."""
    from flexmbd.report import build, loading
    out = tmp_path / "out"
    shutil.copytree(report / "results", out / "results")
    copy, later = tmp_path / "cantilever_copy.toml", tmp_path / "cantilever_later.toml"
    for path in (copy, later):
        path.write_text(cases.find("cantilever_step").read_text())
    shutil.copytree(out / "results" / "cantilever_step", out / "results" / "cantilever_copy")
    both = [cases.load("cantilever_step"), cases.load(str(copy))]
    running = cases.load(str(later))                   # its jobs never told: its runs go on
    names = FAST.split(",")
    pids = []
    send = build.Drawer.send
    monkeypatch.setattr(build.Drawer, "send", lambda self, case, shown: pids.append(self.proc.pid) or send(self, case, shown))

    def run(after):                                     # every job already stored: told at once
        for c in both:
            for s in loading.jobs(c, names):
                after(c, s)

    pages = {}
    for drawers in (1, 2):
        monkeypatch.setattr(build, "DRAWERS", drawers)
        stage = tmp_path / f"stage{drawers}"
        pids.clear()
        got = build.drawn_while(run, out, stage, both + [running], names, reuse=False)
        assert sorted(got) == ["cantilever_copy", "cantilever_step"]
        assert len(set(pids)) == drawers, pids
        pages[drawers] = {c.name: (stage / c.name / "index.md").read_text() for c in both}
    assert pages[1] == pages[2]
    pids.clear()                                        # one case: its runs over, no Drawer starts for its page
    assert build.drawn_while(run, out, tmp_path / "stage3", both[:1], names, reuse=False) == {} and pids == []
