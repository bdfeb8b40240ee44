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
from flexmbd.core import resources
from flexmbd.cli import main
from flexmbd.core.errors import Interrupted

pytestmark = pytest.mark.heavy(50)       # seconds, measured with both cores busy (tests/conftest.py)

ROOT = Path(flexmbd.__file__).resolve().parent.parent
# One OpenBLAS thread: on a loaded two-core machine OpenBLAS's threads make the 600-DOF eigen
# decomposition of a report's FE modes take seconds, native code in which no signal handler runs.
ENV = dict(os.environ, PYTHONPATH=str(ROOT), OPENBLAS_NUM_THREADS="1")
CASE, SOLVER = "cantilever_step", "analytic"
# with the case's reference (fe-linear, as cheap), which a report runs anyway (said in one line)
ONE = ["--cases", CASE, "--solvers", f"fe-linear,{SOLVER}"]
BASE = ["--cases", CASE, "--solvers", SOLVER]          # regress: the analytic baseline alone
# progress lines: the executor's job bar and the integrators' bar
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
def stored(cantilever_report) -> Path:
    """A report folder of analytic on cantilever_step (with its reference fe-linear, and pinocchio,
    which does not apply): results/ plus the pages; the session's (conftest.py), which said
    nothing on stderr but its progress."""
    check(0, Path(f"{cantilever_report}.stderr").read_text(), 0, 0, ())
    return cantilever_report


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
    shutil.copy(resources.BASELINES / CASE / f"{SOLVER}.csv", b / CASE)
    return b


def regress_stored(base: Path, results: Path, status: int, lines: int = 1, names=(), extra=()) -> list[str]:
    return cli(["regress", "--baseline", base, "--results", results.parent, *BASE, *extra], status, lines, names)


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
        meta["csv_sha256"] = flexmbd.harness.results.sha256(csv.read_text())
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


def test_report_strict_is_exit_1_when_a_solver_failed(report, cantilever_argv):
    cli([*cantilever_argv, "--out", report], 0, 0)                     # made with --strict: every run passes
    edit_result(report / "results", change_meta=lambda m: m.update(status="failed: boom at t = 0.1 s"))
    cli(["report", *ONE, "--out", report, "--no-run"], 0, 0)
    cli(["report", *ONE, "--out", report, "--no-run", "--strict"], 1, 0)


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
    from flexmbd.harness import registry
    monkeypatch.setattr(registry, "run", lambda *a, **k: pytest.fail("a solver ran"))
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
    from flexmbd.core import files
    from flexmbd.harness import registry
    monkeypatch.setattr(files.os, "access", lambda p, mode: Path(p) != tmp_path)
    monkeypatch.setattr(registry, "run", lambda *a, **k: pytest.fail("a solver ran"))
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
    cli(["regress", "--update", "--baseline", tmp_path / "f", "--results", results.parent, *BASE], 2,
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
    process(["regress", "--update", "--baseline", base, "--results", results.parent, *BASE], 2, fsize=16 * 1024,
            names=[base / CASE / f"{SOLVER}.csv", "file too large"])
    assert snapshot(base) == before
    no_leftovers(base)


def test_modes_save_past_the_file_size_limit_leaves_no_part(tmp_path):
    process(["modes", CASE, "--save", tmp_path, "--json"], 2, fsize=8 * 1024,
            names=[tmp_path / f"{CASE}_beam.npz", "file too large"])
    assert list(tmp_path.iterdir()) == []


def test_a_full_disk_during_a_report_keeps_the_old_report(report, monkeypatch):
    """ENOSPC on the third file written (a full file system, planted in the one writer)."""
    from flexmbd.core import files
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
# signals: a report is of one generation, no temporary is left, no signal is lost, an ignored one
# stays ignored. A test that signals a child waits for what the child says (a readiness file, a
# progress line), starts it with the dispositions it means (pytest started as a background job
# has SIGINT ignored, which a child inherits) and stops it whether the test passes or not.


@contextlib.contextmanager
def child(cmd, ignored=(), env=None, **kw):
    """`cmd` started with SIGINT and SIGTERM at their defaults (those in `ignored`: ignored) and
    unblocked; killed (if still running) and waited for when the block ends."""
    def dispositions():
        for s in (signal.SIGINT, signal.SIGTERM):
            signal.signal(s, signal.SIG_IGN if s in ignored else signal.SIG_DFL)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, (signal.SIGINT, signal.SIGTERM))

    with subprocess.Popen([str(c) for c in cmd], preexec_fn=dispositions, env=env or ENV, **kw) as p:
        try:
            yield p
        finally:
            if p.poll() is None:
                p.kill()


def wait_for(marker: Path, p) -> None:
    """Until the child `p` has created `marker` (FLEXMBD_READY_FILE: its signal handlers are in
    place); a failure if it ends first, or has not within 120 s (it hangs)."""
    deadline = time.monotonic() + 120
    while not marker.exists():
        if p.poll() is not None:
            pytest.fail(f"the child ended ({p.returncode}) before it was ready")
        if time.monotonic() > deadline:
            pytest.fail("the child never said it was ready")
        time.sleep(0.002)


@pytest.fixture
def signals_default():
    """In this process for the test: SIGINT raising KeyboardInterrupt, SIGTERM at its default,
    whatever pytest was started with (a command respects an ignored signal); put back after."""
    old = {signal.SIGINT: signal.signal(signal.SIGINT, signal.default_int_handler),
           signal.SIGTERM: signal.signal(signal.SIGTERM, signal.SIG_DFL)}
    yield
    for s, handler in old.items():
        signal.signal(s, signal.SIG_DFL if handler is None else handler)


def plant_signal(monkeypatch, module, name: str, sig) -> None:
    """Send `sig` to this process while module.name runs (a figure or a table being written)."""
    real = getattr(module, name)

    def wrapped(*a, **k):
        os.kill(os.getpid(), sig)
        return real(*a, **k)

    monkeypatch.setattr(module, name, wrapped)


@pytest.mark.signals
@pytest.mark.parametrize("module, name, sig", [("figures", "savefig", signal.SIGTERM),
                                              ("tables", "latex_document", signal.SIGTERM),
                                              ("tables", "html_table", signal.SIGINT)],
                         ids=["SIGTERM while a figure is written", "SIGTERM while a table is written",
                              "SIGINT while a page is written"])
def test_a_signal_while_the_report_is_written_leaves_the_old_report(report, monkeypatch, signals_default, module,
                                                                     name, sig):
    from flexmbd.report import figures, tables
    target = {"figures": figures.plt.Figure, "tables": tables}[module]
    plant_signal(monkeypatch, target, name, sig)
    before = snapshot(report)
    cli(["report", *ONE, "--out", report, "--no-run"], 128 + sig, names=[f"interrupted ({signal.Signals(sig).name})"])
    assert snapshot(report) == before
    no_leftovers(report)


@pytest.mark.signals
def test_sigterm_while_compare_draws_leaves_the_old_page(report, monkeypatch, signals_default):
    from flexmbd.report import figures
    plant_signal(monkeypatch, figures.plt.Figure, "savefig", signal.SIGTERM)
    before = snapshot(report / CASE)
    cli(["compare", CASE, "--solvers", f"fe-linear,{SOLVER}", "--out", report], 143, names=["interrupted (SIGTERM)"])
    assert snapshot(report / CASE) == before
    no_leftovers(report)


@pytest.mark.signals
@pytest.mark.parametrize("where", ["replace", "rmtree"], ids=["right after a swap", "while the old pages go"])
def test_a_signal_after_the_swap_leaves_no_staging_folder(tmp_path, monkeypatch, signals_default, where):
    """SIGTERM right after each entry of a generation is swapped in, or while the old entries
    are removed: it waits for the swap and the removal, so `dest` holds the whole new set and
    neither the `.new-*` staging folder nor an old entry kept aside is left."""
    from flexmbd.core import files
    dest = tmp_path / "rep"
    (dest / CASE).mkdir(parents=True)
    for page in ("index.html", f"{CASE}/index.html"):
        (dest / page).write_text("old")
    plant_signal(monkeypatch, files.os if where == "replace" else files.shutil, where, signal.SIGTERM)
    with pytest.raises(Interrupted), files.signals_handled(), files.generation(dest) as stage:
        (stage / CASE).mkdir()
        for page in ("index.html", f"{CASE}/index.html"):
            (stage / page).write_text("new")
    monkeypatch.undo()
    assert [(dest / page).read_text() for page in ("index.html", f"{CASE}/index.html")] == ["new", "new"]
    no_leftovers(dest)


SWAPPER = """
import contextlib, json, os, random, signal, sys, time
from flexmbd.core import files


def loop(w, handled):
    for s in (signal.SIGINT, signal.SIGTERM):
        signal.signal(s, signal.SIG_DFL)
    os.dup2(os.open(os.devnull, os.O_WRONLY), 2)             # the line of signals_exit
    try:
        with files.signals_handled() if handled else contextlib.nullcontext():
            os.write(w, b"in")
            while True:
                for stretch in (files.signals_held, files.signals_exit, files.signals_kept):
                    with stretch():
                        pass
    except KeyboardInterrupt as e:
        os._exit(128 + e.signum)


ended = []
for k in range(int(sys.argv[1])):
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:
        os.close(r)
        loop(w, handled=k % 2)
    os.close(w)
    os.read(r, 2)                                           # it is in its loop
    os.close(r)
    time.sleep(random.random() * 1e-3)                      # at a random point of it
    os.kill(pid, signal.SIGTERM)
    deadline = time.monotonic() + 60
    while not (done := os.waitpid(pid, os.WNOHANG))[0] and time.monotonic() < deadline:
        time.sleep(1e-4)
    if not done[0]:                                         # the signal was lost: it loops for ever
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
        ended.append("lost")
        break
    ended.append(os.waitstatus_to_exitcode(done[1]))
print(json.dumps(ended))
"""


@pytest.mark.signals
def test_no_signal_is_lost_while_stretches_begin_and_end():
    """200 processes each entering and leaving the held, exit and kept stretches in a tight loop
    (every other one within a command's handler, the others installing and putting back the
    handler at each stretch) get a SIGTERM at a random point: every one ends by it, at once (no
    stretch here holds it long), as killed by the signal or with status 143; a process still
    looping 60 s after it (a signal lost between two handlers) ends the run."""
    with child([sys.executable, "-c", SWAPPER, "200"], stdout=subprocess.PIPE, text=True) as p:
        out, _ = p.communicate(timeout=1200)
    ended = json.loads(out)
    assert len(ended) == 200 and set(ended) <= {-signal.SIGTERM, 128 + signal.SIGTERM}, ended


FINALIZER = """
import os, sys, time
from flexmbd.core import files


class Slow:
    def __del__(self):
        sys.stdout.write("finalizing\\n")
        sys.stdout.flush()
        end = time.monotonic() + 60
        while time.monotonic() < end:                      # until the signal ends it
            pass


try:
    with files.signals_handled():
        Slow()
        end = time.monotonic() + 60
        while time.monotonic() < end:
            pass
except KeyboardInterrupt as e:
    os._exit(128 + e.signum)
"""


@pytest.mark.signals
def test_a_signal_while_a_finalizer_runs_is_not_lost():
    """A SIGTERM that comes while a finalizer (`__del__`) runs, once the child says it is in it:
    Python cannot pass the handler's exception on from there (it would print it and go on);
    the command still ends by the signal, with nothing printed (no loop of 60 s left)."""
    with child([sys.executable, "-c", FINALIZER], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) as p:
        assert p.stdout.readline() == "finalizing\n"
        p.send_signal(signal.SIGTERM)
        _, err = p.communicate(timeout=200)
    assert (p.returncode, err) == (128 + signal.SIGTERM, "")


@pytest.mark.signals
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_an_ignored_signal_stays_ignored(sig, tmp_path):
    """Started with a signal ignored (as `cmd &` leaves SIGINT in a non-interactive shell), the
    command ignores it throughout (README.md, "Exit statuses"): sent from the moment its loading
    handlers are in place until it ends, the signal changes nothing, the run finishes with
    status 0 and its result is written."""
    ready, out = tmp_path / "ready", tmp_path / "out"
    cmd = [sys.executable, "-m", "flexmbd", "run", CASE, "--solver", SOLVER, "--out", out]
    with child(cmd, ignored=(sig,), env=dict(ENV, FLEXMBD_READY_FILE=str(ready)), stdout=subprocess.PIPE,
               stderr=subprocess.PIPE, text=True) as p:
        wait_for(ready, p)
        sent = 0
        while p.poll() is None and sent < 20000:
            p.send_signal(sig)
            sent += 1
            time.sleep(0.002)
        _, err = p.communicate(timeout=120)
    check(p.returncode, err, 0, 0, [])
    assert sent > 1
    assert flexmbd.harness.results.read(out / "results", CASE, SOLVER).ok
    no_leftovers(out)


PAGES = ("index.html", "index.md", "accuracy.csv", "accuracy.md", "accuracy.tex", f"{CASE}/index.html",
         f"{CASE}/tip_deflection.png")


@pytest.mark.signals
@pytest.mark.parametrize("sig, status, delay", [(signal.SIGTERM, 143, 0.1), (signal.SIGTERM, 143, 0.4),
                                                (signal.SIGINT, 130, 0.25)])
def test_a_real_signal_during_a_report_ends_it_with_one_generation(report, sig, status, delay):
    """A real signal to a `report` process once it says it is at work (its first progress line),
    `delay` s later, wherever that is: it ends with exit 128 + signal and one line, or finished
    before the signal came, and the pages are all of the old report or all of the new one."""
    old = {p: (report / p).stat().st_ino for p in PAGES}
    cmd = [sys.executable, "-m", "flexmbd.cli", "report", *ONE, "--out", report, "--rerun"]   # runs, then pages drawn
    with child(cmd, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True) as p:
        said = [p.stderr.readline()]
        while said[-1] and not PROGRESS.match(said[-1]):   # until the first progress line: main is at work
            said.append(p.stderr.readline())
        assert PROGRESS.match(said[-1]), said
        time.sleep(delay)                            # the moment only: every outcome is checked below
        p.send_signal(sig)
        err = "".join(said) + p.stderr.read()
        p.wait(timeout=60)
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


def test_report_takes_a_case_path(report, cantilever_argv, capsys):
    """The shipped case's file is the case of that name: its stored runs and its page are kept."""
    argv = [str(ROOT / "cases" / f"{CASE}.toml") if a == CASE else a for a in cantilever_argv]
    assert main([*argv, "--out", str(report)]) == 0
    err = capsys.readouterr().err
    assert err.count("(stored, unchanged)") == 3 and f"page {CASE} (unchanged, kept)" in err, err
    assert (report / CASE / "index.html").is_file()


def test_report_with_an_unknown_case_among_known_ones_runs_nothing(tmp_path):
    cli(["report", "--cases", f"{CASE},nosuch", "--solvers", SOLVER, "--out", tmp_path / "rep"], 2,
        names=["nosuch"])
    assert not (tmp_path / "rep").exists()


def test_report_with_a_missing_case_path_runs_nothing(tmp_path):
    cli(["report", "--cases", f"{CASE},{tmp_path / 'no' / 'case.toml'}", "--solvers", SOLVER,
         "--out", tmp_path / "rep"], 2, names=["case.toml"])
    assert not (tmp_path / "rep").exists()


SOLVING = """import sys
from flexmbd.harness import progress
real = progress.Progress.update
def update(self, t):
    if not getattr(update, "said", False):
        update.said = True
        sys.stderr.write("solving\\n")
        sys.stderr.flush()
    return real(self, t)
progress.Progress.update = update
from flexmbd.cli import exit_with, main
exit_with(main(sys.argv[1:]))
"""


@pytest.mark.slow
@pytest.mark.signals
def test_sigterm_ends_an_exudyn_solve(tmp_path):
    """Exudyn's solver is native code; it runs Python's signal handlers between steps and would
    turn the exception into a failed result (files.signals_kept raises it again). The signal
    comes once the child says the solver is at its steps (a line from its progress callback)."""
    pytest.importorskip("exudyn")
    cmd = [sys.executable, "-c", SOLVING, "run", "pendulum", "--solver", "exudyn-beam", "--out", tmp_path]
    with child(cmd, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True) as p:
        lines = []
        while not lines or lines[-1] not in ("solving\n", ""):
            lines.append(p.stderr.readline())
        assert lines[-1] == "solving\n", lines
        p.send_signal(signal.SIGTERM)
        err = "".join(lines[:-1]) + p.stderr.read()
        p.wait(timeout=60)
    check(p.returncode, err, 143, 1, ["interrupted (SIGTERM)"])    # how soon: benchmarks/signal_latency.py
    assert not (tmp_path / "pendulum" / "exudyn-beam.json").exists()
    no_leftovers(tmp_path)


@pytest.mark.signals
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_signal_while_the_modules_load_is_one_line(sig, tmp_path):
    """`python -m flexmbd` (the `flexmbd` command's entry): a signal once it says its loading
    handlers are in place (FLEXMBD_READY_FILE), while numpy, numba and the solvers load, ends it
    with the same line and status as later on, and writes nothing."""
    ready, out = tmp_path / "ready", tmp_path / "out"
    cmd = [sys.executable, "-m", "flexmbd", "run", CASE, "--solver", SOLVER, "--out", out]
    with child(cmd, env=dict(ENV, FLEXMBD_READY_FILE=str(ready)), stdout=subprocess.PIPE,
               stderr=subprocess.PIPE, text=True) as p:
        wait_for(ready, p)
        p.send_signal(sig)
        _, err = p.communicate(timeout=120)
    check(p.returncode, err, 128 + sig, 1, [f"interrupted ({signal.Signals(sig).name})"])
    assert not out.exists()
