"""Faults of files, locations and processes: every one ends with its documented exit status,
one line on stderr naming the file or location, no traceback, and no leftover or mixed file.

Exit statuses (README.md): 0 success, 1 a difference (with --strict, also a failed solver),
2 bad input or an unusable file or location, 3 an internal error, 130 / 143 SIGINT / SIGTERM.
The cheapest solver (`analytic` on `cantilever_step`) keeps the module fast; most commands run
in-process through `main`, those that need a real process (signals, the file size limit, the
console's output) run `python -m flexmbd.cli`.
"""

import contextlib
import errno
import io
import json
import os
import re
import resource
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import flexmbd
from flexmbd.cli import main
from flexmbd.report import regress

ROOT = Path(flexmbd.__file__).resolve().parent.parent
# One OpenBLAS thread: on a loaded two-core machine OpenBLAS's threads make the 600-DOF eigen
# decomposition of a report's FE modes take seconds, native code in which no signal handler runs.
ENV = dict(os.environ, PYTHONPATH=str(ROOT), OPENBLAS_NUM_THREADS="1")
CASE, SOLVER = "cantilever_step", "analytic"
ONE = ["--cases", CASE, "--solvers", SOLVER]
# progress lines: run_all's bar and the integrators' bar
PROGRESS = re.compile(r"^\[[# ]{20}\] \d+/\d+ |^.* \[[# ]{30}\] t = ")


# ---------------------------------------------------------------------------------------------
# helpers


def messages(err: str) -> list[str]:
    return [line for line in err.splitlines() if line.strip() and not PROGRESS.match(line)]


def check(code: int, err: str, status: int, lines: int, names) -> list[str]:
    """The exit status, `lines` stderr lines besides progress, each starting 'flexmbd: ', no
    traceback, and every string of `names` in the message."""
    msg = messages(err)
    assert code == status, err
    assert "Traceback" not in err, err
    assert len(msg) == lines and all(m.startswith("flexmbd: ") for m in msg), msg
    for n in names:
        assert str(n) in " ".join(msg), (n, msg)
    return msg


def cli(argv, status: int, lines: int = 1, names=()) -> list[str]:
    """`flexmbd argv` in this process (main): see `check`."""
    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        code = main([str(a) for a in argv])
    return check(code, err.getvalue(), status, lines, names)


def process(argv, status: int, lines: int = 1, names=(), fsize: int | None = None, prelude: str = "",
            cwd=None) -> list[str]:
    """`python -m flexmbd.cli argv` in a subprocess (`fsize`: its file size limit in bytes, as
    `ulimit -f`; `prelude`: Python run before main, to plant an internal error): see `check`."""
    limit = (lambda: resource.setrlimit(resource.RLIMIT_FSIZE, (fsize, fsize))) if fsize else None
    code = (f"import sys\n{prelude}\nfrom flexmbd.cli import main\nsys.exit(main(sys.argv[1:]))" if prelude
            else None)
    cmd = [sys.executable, "-c", code] if code else [sys.executable, "-m", "flexmbd.cli"]
    r = subprocess.run(cmd + [str(a) for a in argv], capture_output=True, text=True, preexec_fn=limit,
                       env=ENV, cwd=cwd, timeout=120)
    assert "Traceback" not in r.stdout
    return check(r.returncode, r.stderr, status, lines, names)


def snapshot(folder: Path) -> dict:
    """Every file under folder: relative path -> (inode, bytes)."""
    return {str(p.relative_to(folder)): (p.stat().st_ino, p.read_bytes())
            for p in sorted(Path(folder).rglob("*")) if p.is_file()}


def no_leftovers(folder: Path) -> None:
    """No temporary or hidden staging file or folder anywhere under folder."""
    hidden = [str(p) for p in Path(folder).rglob("*") if p.name.startswith(".") or p.suffix == ".tmp"]
    assert hidden == [], hidden


@pytest.fixture(scope="module")
def stored(tmp_path_factory) -> Path:
    """A report folder of analytic on cantilever_step: results/ plus the pages."""
    out = tmp_path_factory.mktemp("stored") / "rep"
    cli(["report", *ONE, "--out", out], 0, 0)
    return out


@pytest.fixture
def report(stored, tmp_path) -> Path:
    """A fresh copy of the stored report."""
    out = tmp_path / "rep"
    shutil.copytree(stored, out)
    return out


@pytest.fixture
def results(report) -> Path:
    """Stored results (RESULTS/cantilever_step/analytic.{csv,json})."""
    return report / "results"


@pytest.fixture
def base(tmp_path) -> Path:
    """A copy of the stored baseline of analytic on cantilever_step."""
    b = tmp_path / "baselines"
    (b / CASE).mkdir(parents=True)
    shutil.copy(regress.BASELINES / CASE / f"{SOLVER}.csv", b / CASE)
    return b


def regress_stored(base: Path, results: Path, status: int, lines: int = 1, names=(), extra=()) -> list[str]:
    return cli(["regress", "--baseline", base, "--results", results.parent, *ONE, *extra], status, lines, names)


def edit_csv(path: Path, change) -> None:
    """Rewrite a CSV's lines (header comments kept) through change(lines) -> lines."""
    lines = path.read_text().splitlines()
    head = [line for line in lines if line.startswith("#")]
    path.write_text("\n".join(head + change(lines[len(head):])) + "\n")


def edit_result(results: Path, change_csv=None, change_meta=None) -> None:
    """Change a stored result; the sidecar's CSV hash follows the CSV, so only the content
    checks can catch the change."""
    csv, js = results / CASE / f"{SOLVER}.csv", results / CASE / f"{SOLVER}.json"
    meta = json.loads(js.read_text())
    if change_csv:
        edit_csv(csv, change_csv)
        meta["csv_sha256"] = flexmbd.results.sha256(csv.read_text())
    if change_meta:
        change_meta(meta)
    js.write_text(json.dumps(meta))


# ---------------------------------------------------------------------------------------------
# exit statuses and one-line messages


def test_a_negative_t_end_is_one_line_naming_the_option(tmp_path):
    process(["run", CASE, "--solver", SOLVER, "--t-end", "-1", "--out", tmp_path / "o"], 2, names=["--t-end"])
    assert not (tmp_path / "o").exists()


def test_an_unknown_option_is_one_line_naming_it():
    cli(["run", CASE, "--solver", SOLVER, "--frobnicate"], 2, names=["--frobnicate"])


def test_a_missing_required_option_is_one_line_naming_it():
    cli(["run", CASE], 2, names=["--solver"])


def test_an_unknown_command_is_one_line():
    cli(["frobnicate"], 2, names=["frobnicate"])


def test_a_failed_solver_is_exit_0_and_with_strict_exit_1(tmp_path):
    run = ["run", CASE, "--solver", SOLVER, "--set", "loads.tip_force.force=[0.0,-1e7,0.0]", "--t-end", "0.05",
           "--out", tmp_path]
    cli(run, 0, 0)
    assert json.loads((tmp_path / "results" / CASE / f"{SOLVER}.json").read_text())["status"].startswith("failed: diverged")
    cli(run + ["--strict"], 1, 0)


def test_report_strict_is_exit_1_when_a_solver_failed(tmp_path):
    cli(["report", *ONE, "--out", tmp_path, "--strict"], 0, 0)
    edit_result(tmp_path / "results", change_meta=lambda m: m.update(status="failed: boom at t = 0.1 s"))
    cli(["report", *ONE, "--out", tmp_path, "--no-run"], 0, 0)
    cli(["report", *ONE, "--out", tmp_path, "--no-run", "--strict"], 1, 0)


def test_an_internal_error_is_exit_3_with_its_traceback_in_a_file():
    prelude = "import flexmbd.cli as c\ndef boom(args): raise TypeError('planted')\nc.cmd_list = boom"
    [msg] = process(["list"], 3, prelude=prelude, names=["internal error: TypeError: planted", "traceback saved to"])
    saved = Path(msg.split("traceback saved to ")[1].rstrip(")"))
    assert saved.is_file() and "Traceback" in saved.read_text() and "planted" in saved.read_text()
    saved.unlink()


def test_debug_shows_an_internal_error_s_traceback():
    prelude = "import flexmbd.cli as c\ndef boom(args): raise TypeError('planted')\nc.cmd_list = boom"
    r = subprocess.run([sys.executable, "-c", f"import sys\n{prelude}\nfrom flexmbd.cli import main\n"
                        "sys.exit(main(sys.argv[1:]))", "--debug", "list"], capture_output=True, text=True,
                       env=ENV)
    assert r.returncode == 3 and "Traceback" in r.stderr and "planted" in r.stderr
    Path(r.stderr.split("traceback saved to ")[1].strip().rstrip(")")).unlink()


# ---------------------------------------------------------------------------------------------
# output locations


def test_run_out_is_a_file(tmp_path):
    (tmp_path / "f").write_text("keep")
    cli(["run", CASE, "--solver", SOLVER, "--out", tmp_path / "f"], 2, names=[tmp_path / "f", "--out"])
    assert (tmp_path / "f").read_text() == "keep"


def test_run_out_lies_under_a_file(tmp_path):
    (tmp_path / "f").write_text("keep")
    cli(["run", CASE, "--solver", SOLVER, "--out", tmp_path / "f" / "sub"], 2, names=[tmp_path / "f" / "sub"])


def test_run_out_case_folder_is_a_file(tmp_path, monkeypatch):
    from flexmbd import solvers
    monkeypatch.setattr(solvers, "run", lambda *a, **k: pytest.fail("a solver ran"))
    (tmp_path / "results").mkdir()
    (tmp_path / "results" / CASE).write_text("keep")
    cli(["run", CASE, "--solver", SOLVER, "--out", tmp_path], 2, names=[tmp_path / "results" / CASE])
    assert (tmp_path / "results" / CASE).read_text() == "keep"
    no_leftovers(tmp_path)


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into a read-only folder")
def test_run_out_is_unwritable(tmp_path):
    (tmp_path / "ro").mkdir(mode=0o500)
    cli(["run", CASE, "--solver", SOLVER, "--out", tmp_path / "ro" / "sub"], 2, names=["not writable"])


def test_an_unwritable_out_is_refused_before_work(tmp_path, monkeypatch):
    """As any user (root passes the permission bits, so os.access is planted): nothing runs."""
    from flexmbd import files, solvers
    monkeypatch.setattr(files.os, "access", lambda p, mode: Path(p) != tmp_path)
    monkeypatch.setattr(solvers, "run", lambda *a, **k: pytest.fail("a solver ran"))
    cli(["report", *ONE, "--out", tmp_path / "rep"], 2, names=[tmp_path / "rep", "not writable"])
    assert list(tmp_path.iterdir()) == []


def test_report_out_is_a_file(tmp_path):
    (tmp_path / "f").write_text("keep")
    cli(["report", *ONE, "--out", tmp_path / "f"], 2, names=[tmp_path / "f", "--out"])


def test_compare_out_lies_under_a_file(tmp_path):
    (tmp_path / "f").write_text("keep")
    cli(["compare", CASE, "--solvers", SOLVER, "--out", tmp_path / "f" / "x"], 2, names=[tmp_path / "f" / "x"])


def test_modes_save_onto_a_file(tmp_path):
    (tmp_path / "f").write_text("keep")
    cli(["modes", CASE, "--save", tmp_path / "f"], 2, names=[tmp_path / "f", "--save"])
    assert (tmp_path / "f").read_text() == "keep"


def test_bench_out_is_a_file(tmp_path):
    (tmp_path / "f").write_text("keep")
    cli(["bench", "--quick", "--out", tmp_path / "f"], 2, names=[tmp_path / "f", "--out"])


def test_regress_update_into_a_file(tmp_path, results):
    (tmp_path / "f").write_text("keep")
    cli(["regress", "--update", "--baseline", tmp_path / "f", "--results", results.parent, *ONE], 2,
        names=[tmp_path / "f", "--baseline"])


# ---------------------------------------------------------------------------------------------
# a full disk and the file size limit: the old files stay, no temporary is left


def test_run_past_the_file_size_limit_keeps_the_old_pair(results):
    before = snapshot(results)
    process(["run", CASE, "--solver", SOLVER, "--out", results.parent], 2, fsize=16 * 1024,
            names=[results / CASE / f"{SOLVER}.csv", "file too large"])
    assert snapshot(results) == before
    no_leftovers(results)


def test_report_past_the_file_size_limit_keeps_the_old_report(report):
    before = snapshot(report)
    process(["report", *ONE, "--out", report, "--no-run"], 2, fsize=40 * 1024, names=["file too large", ".png"])
    assert snapshot(report) == before
    no_leftovers(report)


def test_regress_update_past_the_file_size_limit_keeps_the_old_baseline(base, results):
    before = snapshot(base)
    process(["regress", "--update", "--baseline", base, "--results", results.parent, *ONE], 2, fsize=16 * 1024,
            names=[base / CASE / f"{SOLVER}.csv", "file too large"])
    assert snapshot(base) == before
    no_leftovers(base)


def test_modes_save_past_the_file_size_limit_leaves_no_part(tmp_path):
    process(["modes", CASE, "--save", tmp_path, "--json"], 2, fsize=8 * 1024,
            names=[tmp_path / f"{CASE}_beam.npz", "file too large"])
    assert list(tmp_path.iterdir()) == []


def test_a_full_disk_during_a_report_keeps_the_old_report(report, monkeypatch):
    """ENOSPC on the third file written (a full file system, planted in the one writer)."""
    from flexmbd import files
    real, calls = files.os.fdopen, []

    def full(fd, mode="r", *a, **k):
        f = real(fd, mode, *a, **k)
        calls.append(1)
        if len(calls) == 3:
            def write(_):
                raise OSError(errno.ENOSPC, "No space left on device")
            f.write = write
        return f

    monkeypatch.setattr(files.os, "fdopen", full)
    before = snapshot(report)
    cli(["report", *ONE, "--out", report, "--no-run"], 2, names=["no space left on the device"])
    assert snapshot(report) == before
    no_leftovers(report)


# ---------------------------------------------------------------------------------------------
# signals: a report is of one generation, no temporary is left


def plant_signal(monkeypatch, module, name: str, sig) -> None:
    """Send `sig` to this process while module.name runs (a figure or a table being written)."""
    real = getattr(module, name)

    def wrapped(*a, **k):
        os.kill(os.getpid(), sig)
        return real(*a, **k)

    monkeypatch.setattr(module, name, wrapped)


@pytest.mark.parametrize("module, name, sig", [("figures", "savefig", signal.SIGTERM),
                                              ("tables", "latex_document", signal.SIGTERM),
                                              ("tables", "html_table", signal.SIGINT)],
                         ids=["SIGTERM while a figure is written", "SIGTERM while a table is written",
                              "SIGINT while a page is written"])
def test_a_signal_while_the_report_is_written_leaves_the_old_report(report, monkeypatch, module, name, sig):
    from flexmbd.report import figures, tables
    target = {"figures": figures.plt.Figure, "tables": tables}[module]
    plant_signal(monkeypatch, target, name, sig)
    before = snapshot(report)
    cli(["report", *ONE, "--out", report, "--no-run"], 128 + sig, names=[f"interrupted ({signal.Signals(sig).name})"])
    assert snapshot(report) == before
    no_leftovers(report)


def test_sigterm_while_compare_draws_leaves_the_old_page(report, monkeypatch):
    from flexmbd.report import figures
    plant_signal(monkeypatch, figures.plt.Figure, "savefig", signal.SIGTERM)
    before = snapshot(report / CASE)
    cli(["compare", CASE, "--solvers", SOLVER, "--out", report], 143, names=["interrupted (SIGTERM)"])
    assert snapshot(report / CASE) == before
    no_leftovers(report)


PAGES = ("index.html", "index.md", "accuracy.csv", "accuracy.md", "accuracy.tex", f"{CASE}/index.html",
         f"{CASE}/tip_deflection.png")


@pytest.mark.parametrize("sig, status, delay", [(signal.SIGTERM, 143, 0.1), (signal.SIGTERM, 143, 0.4),
                                                (signal.SIGINT, 130, 0.25)])
def test_a_real_signal_during_a_report_ends_it_with_one_generation(report, sig, status, delay):
    """A real signal to a `report` process once it has started work: it ends with exit
    128 + signal and one line, and the pages are all of the old report or all of the new one."""
    old = {p: (report / p).stat().st_ino for p in PAGES}
    p = subprocess.Popen([sys.executable, "-m", "flexmbd.cli", "report", *ONE, "--out", str(report)],
                         stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True,
                         env=ENV)
    first = p.stderr.readline()                      # the progress line: main is at work
    assert PROGRESS.match(first), first
    time.sleep(delay)
    p.send_signal(sig)
    err = first + p.stderr.read()
    p.wait(timeout=10)
    if p.returncode in (0, -sig):                    # finished before the signal came (or while exiting)
        assert p.returncode == 0 or "interrupted" not in err, (p.returncode, err[-300:])
        check(0, err, 0, 0, [])
    else:
        check(p.returncode, err, status, 1, ["interrupted"])    # how soon: benchmarks/signal_latency.py
    new = {q: (report / q).stat().st_ino for q in PAGES}
    assert all(new[q] == old[q] for q in PAGES) or all(new[q] != old[q] for q in PAGES), (old, new)
    no_leftovers(report)


# ---------------------------------------------------------------------------------------------
# stored baselines: checked before use, named in one line


def test_the_real_baseline_passes(base, results):
    regress_stored(base, results, 0, 0)


def test_a_truncated_baseline(base, results):
    edit_csv(base / CASE / f"{SOLVER}.csv", lambda rows: rows[:1500])
    regress_stored(base, results, 2, names=[base / CASE / f"{SOLVER}.csv", "rows, expected 2001"])


def test_a_baseline_with_nan_rows(base, results):
    edit_csv(base / CASE / f"{SOLVER}.csv", lambda rows: rows[:100] + ["nan,nan,nan"] * 5 + rows[105:])
    regress_stored(base, results, 2, names=[base / CASE / f"{SOLVER}.csv", "finite"])


def test_a_baseline_with_a_garbage_cell(base, results):
    edit_csv(base / CASE / f"{SOLVER}.csv", lambda rows: rows[:50] + ["0.049,abc,1"] + rows[51:])
    regress_stored(base, results, 2, names=[base / CASE / f"{SOLVER}.csv", "not a number"])


def test_a_binary_baseline(base, results):
    (base / CASE / f"{SOLVER}.csv").write_bytes(bytes(range(256)) * 8)
    regress_stored(base, results, 2, names=[base / CASE / f"{SOLVER}.csv", "not a text file"])


def test_an_empty_baseline(base, results):
    (base / CASE / f"{SOLVER}.csv").write_text("")
    regress_stored(base, results, 2, names=[base / CASE / f"{SOLVER}.csv", "not a table"])


def test_a_baseline_without_t(base, results):
    path = base / CASE / f"{SOLVER}.csv"
    path.write_text(re.sub(r"(?m)^t,", "time,", path.read_text().replace("# columns: t,", "# columns: time,")))
    regress_stored(base, results, 2, names=[path, "no `t` column"])


def test_a_baseline_for_an_unknown_solver(base, results):
    shutil.copy(base / CASE / f"{SOLVER}.csv", base / CASE / "nosuch.csv")
    cli(["regress", "--baseline", base, "--results", results.parent, "--cases", CASE], 2,
        names=[base / CASE / "nosuch.csv", "unknown solver"])


def test_regress_update_of_a_baseline_for_an_unknown_solver(base, results):
    shutil.copy(base / CASE / f"{SOLVER}.csv", base / CASE / "nosuch.csv")
    before = snapshot(base)
    cli(["regress", "--update", "--baseline", base, "--results", results.parent], 2,
        names=[base / CASE / "nosuch.csv", "unknown solver"])
    assert snapshot(base) == before


def test_a_baseline_with_a_channel_the_case_lacks(base, results):
    path = base / CASE / f"{SOLVER}.csv"
    path.write_text(path.read_text().replace("stress_vm", "stress_xx"))
    regress_stored(base, results, 2, names=[path, "stress_xx is not a channel"])


def test_a_baseline_of_another_version_of_the_case_is_stale(base, results):
    path = base / CASE / f"{SOLVER}.csv"
    path.write_text(re.sub(r"sha256 [0-9a-f]+", "sha256 0123456789abcdef", path.read_text(), count=1))
    regress_stored(base, results, 0, names=["warning", path, "another version of the case"])


# ---------------------------------------------------------------------------------------------
# stored results for regress --results: checked before use, named in one line


def test_regress_with_a_missing_result(base, results):
    shutil.rmtree(results / CASE)
    regress_stored(base, results, 2, names=[results / CASE / f"{SOLVER}.json", "missing"])


def test_regress_with_a_truncated_result_csv(base, results):
    csv = results / CASE / f"{SOLVER}.csv"
    csv.write_text(csv.read_text()[:5000])
    regress_stored(base, results, 2, names=[csv, "does not belong"])


def test_regress_with_a_result_csv_cut_to_fewer_rows(base, results):
    edit_result(results, change_csv=lambda rows: rows[:300])
    regress_stored(base, results, 2, names=[results / CASE / f"{SOLVER}.csv", "rows, expected 2001"])


def test_regress_with_a_garbage_result_csv(base, results):
    edit_result(results, change_csv=lambda rows: rows[:10] + ["0.009,x,y"] + rows[11:])
    regress_stored(base, results, 2, names=[results / CASE / f"{SOLVER}.csv", "not a number"])


def test_regress_with_a_broken_json_sidecar(base, results):
    js = results / CASE / f"{SOLVER}.json"
    js.write_text(js.read_text()[:200])
    regress_stored(base, results, 2, names=[js, "not a result sidecar"])


def test_regress_with_a_sidecar_of_another_solver(base, results):
    edit_result(results, change_meta=lambda m: m.update(solver="fe-linear"))
    regress_stored(base, results, 2, names=[results / CASE / f"{SOLVER}.json", "holds fe-linear"])


# ---------------------------------------------------------------------------------------------
# report --no-run: a bad stored result is shown as unusable, never as ok


def summary_status(report: Path) -> str:
    row = re.search(rf"<td>{SOLVER}</td><td[^>]*>([^<]*)</td>", (report / "index.html").read_text())
    return row.group(1)


def test_report_no_run_shows_a_result_whose_csv_was_deleted_as_unusable(report):
    (report / "results" / CASE / f"{SOLVER}.csv").unlink()
    cli(["report", *ONE, "--out", report, "--no-run"], 0, names=["warning", f"{SOLVER}.csv", "missing"])
    assert summary_status(report).startswith("unavailable: stored result unusable")
    no_leftovers(report)


def test_report_no_run_shows_a_missing_result_as_unusable(report):
    (report / "results" / CASE / f"{SOLVER}.json").unlink()
    cli(["report", *ONE, "--out", report, "--no-run"], 0, names=["warning", f"{SOLVER}.json", "missing"])
    assert summary_status(report).startswith("unavailable: stored result unusable")


def test_report_no_run_shows_a_truncated_result_as_unusable(report):
    csv = report / "results" / CASE / f"{SOLVER}.csv"
    csv.write_text(csv.read_text()[:3000])
    cli(["report", *ONE, "--out", report, "--no-run"], 0, names=["warning", f"{SOLVER}.csv", "does not belong"])
    assert summary_status(report).startswith("unavailable: stored result unusable")


def test_report_no_run_shows_a_garbage_result_as_unusable(report):
    edit_result(report / "results", change_csv=lambda rows: rows[:10] + ["0.009,nan,1"] + rows[11:])
    cli(["report", *ONE, "--out", report, "--no-run"], 0, names=["warning", "finite"])
    assert summary_status(report).startswith("unavailable: stored result unusable")


def test_report_no_run_flags_a_stale_result(report):
    edit_result(report / "results", change_meta=lambda m: m.update(case_sha256="0123456789abcdef"))
    cli(["report", *ONE, "--out", report, "--no-run"], 0, names=["warning", "stale", "another version of the case"])
    assert summary_status(report).startswith("unavailable: stale stored result")


def test_report_no_run_with_a_broken_sidecar(report):
    (report / "results" / CASE / f"{SOLVER}.json").write_bytes(b"\xff\xfe\x00garbage")
    cli(["report", *ONE, "--out", report, "--no-run"], 0, names=["warning", f"{SOLVER}.json", "not a text file"])
    assert summary_status(report).startswith("unavailable: stored result unusable")


# ---------------------------------------------------------------------------------------------
# names and paths checked before any solver runs


def test_report_takes_a_case_path(tmp_path):
    cli(["report", "--cases", ROOT / "cases" / f"{CASE}.toml", "--solvers", SOLVER, "--out", tmp_path], 0, 0)
    assert (tmp_path / CASE / "index.html").is_file()


def test_report_with_an_unknown_case_among_known_ones_runs_nothing(tmp_path):
    cli(["report", "--cases", f"{CASE},nosuch", "--solvers", SOLVER, "--out", tmp_path / "rep"], 2,
        names=["nosuch"])
    assert not (tmp_path / "rep").exists()


def test_report_with_a_missing_case_path_runs_nothing(tmp_path):
    cli(["report", "--cases", f"{CASE},{tmp_path / 'no' / 'case.toml'}", "--solvers", SOLVER,
         "--out", tmp_path / "rep"], 2, names=["case.toml"])
    assert not (tmp_path / "rep").exists()


@pytest.mark.slow
def test_sigterm_ends_an_exudyn_solve(tmp_path):
    """Exudyn's solver is native code; it runs Python's signal handlers between steps and would
    turn the exception into a failed result (files.signals_kept raises it again)."""
    pytest.importorskip("exudyn")
    p = subprocess.Popen([sys.executable, "-m", "flexmbd.cli", "run", "pendulum", "--solver", "exudyn-beam",
                          "--out", str(tmp_path)], stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True,
                         env=ENV)
    time.sleep(1.8)                                   # imported, set up, solving (until about 3.5 s)
    p.send_signal(signal.SIGTERM)
    err = p.stderr.read()
    p.wait(timeout=10)
    check(p.returncode, err, 143, 1, ["interrupted (SIGTERM)"])    # how soon: benchmarks/signal_latency.py
    assert not (tmp_path / "pendulum" / "exudyn-beam.json").exists()
    no_leftovers(tmp_path)


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_signal_while_the_modules_load_is_one_line(sig, tmp_path):
    """`python -m flexmbd` (the `flexmbd` command's entry): a signal 0.3 s in, while numpy, numba and
    the solvers load, ends it with the same line and status as later on, and writes nothing."""
    p = subprocess.Popen([sys.executable, "-m", "flexmbd", "run", CASE, "--solver", SOLVER, "--out", str(tmp_path)],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV)
    time.sleep(0.3)
    p.send_signal(sig)
    out, err = p.communicate(timeout=60)
    check(p.returncode, err, 128 + sig, 1, [f"interrupted ({signal.Signals(sig).name})"])
    assert not any(tmp_path.iterdir())
