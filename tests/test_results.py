"""Result files and the run status: one status type, one divergence rule, the CSV/JSON pair."""

import contextlib
import errno
import io
import json
import os
import re
import resource
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest

from flexmbd import files, results
from flexmbd.errors import InputError
from flexmbd.results import Result, Status


# ---------------------------------------------------------------------------------------------
# status


@pytest.mark.parametrize("status", [Status(), results.failed("diverged (|v| > 1e+08)", 0.125),
                                    results.failed("Exudyn: no convergence"), results.not_applicable("no motion"),
                                    results.unavailable("No module named 'exudyn'"),
                                    results.failed("VODE return code -1 at t = 3 s inside", 2.5),
                                    results.outside_validity("deflection 161 % of length", 0.42),
                                    results.outside_validity("axial load 9.3 % of the buckling load")])
def test_status_reads_back_from_its_line(status):
    assert Status.parse(str(status)) == status


def test_status_line_and_kinds():
    assert str(results.failed("non-finite state", 0.0)) == "failed: non-finite state at t = 0 s"
    assert str(results.not_applicable("prescribed motion")) == "not applicable: prescribed motion"
    assert Status().ok and not results.failed("x").ok
    out = results.outside_validity("deflection 161 % of length", 0.42)
    assert str(out) == "ok, outside linear validity (deflection 161 % of length at t = 0.42 s)"
    assert out.ok and out.outside and not Status().outside and not results.failed("x", 1.0).outside
    with pytest.raises(ValueError):
        Status("crashed")
    with pytest.raises(ValueError):
        Status.parse("fine")


# ---------------------------------------------------------------------------------------------
# the divergence rule


def test_first_failure_finds_the_first_bad_sample_of_any_channel():
    t = np.linspace(0.0, 1.0, 11)
    tip = np.where(t < 0.55, 0.01, 3.5)                      # beyond 2 x 1.5 m from t = 0.6 s
    angle = np.where(t < 0.75, 0.0, np.nan)                  # non-finite from t = 0.8 s
    bounds = {"tip": 3.0}
    k, st = results.first_failure(t, {"angle": angle, "tip": tip}, bounds)
    assert k == 6 and st.t == pytest.approx(0.6) and st.kind == "failed"
    assert st.why == "diverged (|tip| beyond 3 m, 2 beam lengths)"
    k, st = results.first_failure(t, {"angle": angle, "tip": 0.01 + 0 * t}, bounds)
    assert k == 8 and st.why == "non-finite angle"
    assert results.first_failure(t, {"angle": 0 * t, "tip": 2.9 + 0 * t}, bounds) is None


def test_solvers_run_cuts_a_diverged_history(monkeypatch):
    """The rule is applied to every solver in solvers.run: an adapter's blown-up history ends
    at its first bad sample, with the samples before it kept."""
    from flexmbd import cases, solvers
    from flexmbd.adapters import analytic

    def blown_up(case, t_end, settings):
        t = np.linspace(0.0, t_end, 101)
        tip = np.where(t < 0.05, 0.01, 10.0)
        return Result(solver="analytic", case=case.name, t=t, channels={"tip_deflection": tip, "stress_vm": 0 * t})

    monkeypatch.setattr(analytic, "run", blown_up)
    r = solvers.run(cases.load("cantilever_step"), "analytic", 0.1)
    assert r.status.kind == "failed" and r.status.t == pytest.approx(0.05)
    assert len(r.t) == 50 and np.all(r.channels["tip_deflection"] == 0.01)


def test_an_exception_in_a_solver_is_a_failed_result(monkeypatch):
    from flexmbd import cases, solvers
    from flexmbd.adapters import analytic

    def broken(case, t_end, settings):
        raise RuntimeError("engine exploded")

    monkeypatch.setattr(analytic, "run", broken)
    r = solvers.run(cases.load("cantilever_step"), "analytic", 0.1)
    assert r.status.kind == "failed" and "RuntimeError: engine exploded" in r.status.why


# ---------------------------------------------------------------------------------------------
# the CSV/JSON pair


def _result(k: int, n: int = 20) -> Result:
    return Result(solver="s", case="c", t=np.arange(n) * 0.1, channels={"x": np.full(n, float(k))},
                  settings={"k": k}, status=results.failed("diverged", 1.5) if k % 2 else Status())


def test_pair_round_trip(tmp_path):
    results.write(_result(3), tmp_path)
    back = results.read(tmp_path, "c", "s")
    assert back.status == results.failed("diverged", 1.5) and back.settings == {"k": 3}
    np.testing.assert_array_equal(back.channels["x"], np.full(20, 3.0))
    meta = json.loads((tmp_path / "c" / "s.json").read_text())
    assert meta["csv_sha256"] == results.sha256((tmp_path / "c" / "s.csv").read_text())
    assert "numba" in meta["versions"]


def test_a_sidecar_is_strict_json_with_null_for_what_is_not_known(tmp_path):
    """NaN and infinities are written as null (JSON has no NaN) and read back as NaN; a sidecar
    holding NaN (as written before) is still read."""
    r = _result(2)
    r.wall_s = np.nan
    r.extra.update({"kinetic_max_J": np.float64("nan"), "compile_s": np.inf,
                    "validity": {"largest": {"beam": {"deflection": np.float32(0.25)}}}})
    results.write(r, tmp_path)
    text = (tmp_path / "c" / "s.json").read_text()

    def refuse(constant):
        raise ValueError(f"not JSON: {constant}")
    meta = json.loads(text, parse_constant=refuse)                  # NaN, Infinity, -Infinity refused
    assert meta["wall_s"] is None and meta["kinetic_max_J"] is None and meta["compile_s"] is None
    assert meta["validity"]["largest"]["beam"]["deflection"] == 0.25
    back = results.read(tmp_path, "c", "s")
    assert np.isnan(back.wall_s) and np.isnan(back.extra["kinetic_max_J"]) and np.isnan(back.extra["compile_s"])
    assert text.count('"wall_s": null') == 1
    (tmp_path / "c" / "s.json").write_text(text.replace('"wall_s": null', '"wall_s": NaN'))
    assert np.isnan(results.read(tmp_path, "c", "s").wall_s)


def test_json_text_holds_python_numbers_and_null_for_non_finite_ones():
    text = files.json_text({"a": np.array([1.0, np.nan]), "b": np.int64(3), "c": -np.inf, "p": Path("x"),
                            "t": (1, None, True)})
    assert json.loads(text) == {"a": [1.0, None], "b": 3, "c": None, "p": "x", "t": [1, None, True]}


def test_a_csv_of_another_run_is_refused(tmp_path):
    results.write(_result(1), tmp_path)
    other = (tmp_path / "c" / "s.csv").read_text()
    results.write(_result(2), tmp_path)
    (tmp_path / "c" / "s.csv").write_text(other)
    with pytest.raises(InputError, match="s.csv: does not belong to s.json"):
        results.read(tmp_path, "c", "s")
    (tmp_path / "c" / "s.csv").unlink()
    with pytest.raises(InputError, match="s.csv: missing"):
        results.read(tmp_path, "c", "s")


def test_a_result_without_samples_has_no_csv(tmp_path):
    results.write(_result(2), tmp_path)
    results.write(Result(solver="s", case="c", status=results.not_applicable("no")), tmp_path)
    assert not (tmp_path / "c" / "s.csv").exists()
    assert results.read(tmp_path, "c", "s").status == results.not_applicable("no")


WRITER = """
import os
import sys
import numpy as np
from flexmbd import files, results
k = 0
try:
    with files.signals_handled():
        while True:
            k += 1
            n = 50 + k % 7
            results.write(results.Result(solver="s", case="c", t=np.arange(n) * 0.1,
                                         channels={"x": np.full(n, float(k))}, settings={"k": k}), sys.argv[1])
            if k == 1:
                print("ready", flush=True)                  # a pair is there, and the handler in place
except KeyboardInterrupt as e:
    os._exit(128 + e.signum)
"""


@contextlib.contextmanager
def child(cmd, **kw):
    """`cmd` started with SIGINT and SIGTERM at their defaults and unblocked (pytest started as a
    background job has SIGINT ignored, which a child inherits); killed (if still running) and
    waited for when the block ends."""
    def dispositions():
        for s in (signal.SIGINT, signal.SIGTERM):
            signal.signal(s, signal.SIG_DFL)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, (signal.SIGINT, signal.SIGTERM))

    with subprocess.Popen([str(c) for c in cmd], preexec_fn=dispositions, **kw) as p:
        try:
            yield p
        finally:
            if p.poll() is None:
                p.kill()


def listing(folder: Path) -> dict:
    """Every entry under `folder`, hidden ones included: relative path -> (inode, bytes, or None
    for a folder)."""
    return {str(q.relative_to(folder)): (q.stat().st_ino, q.read_bytes() if q.is_file() else None)
            for q in sorted(Path(folder).rglob("*"))}


@pytest.mark.signals
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_an_interrupted_writer_leaves_a_matching_pair(tmp_path, sig):
    """A process that keeps rewriting one result is stopped by a real signal at random moments
    (once it says its first pair is written); every time it ends by the signal, the CSV on disk
    belongs to the JSON beside it, and no temporary is left."""
    rng = np.random.default_rng(int(sig))
    for trial in range(6):
        out = tmp_path / f"trial{trial}"
        with child([sys.executable, "-c", WRITER, out], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                   text=True) as p:
            assert p.stdout.readline().strip() == "ready", p.stderr.read()
            time.sleep(0.2 * rng.random())          # the moment only: any is checked below
            os.kill(p.pid, sig)
            try:
                p.wait(timeout=60)
            except subprocess.TimeoutExpired:
                p.kill()
                pytest.fail(f"trial {trial}: still writing 60 s after the signal (lost): {p.communicate()[1][-3000:]}")
        assert p.returncode == 128 + sig, p.stderr.read()
        meta = json.loads((out / "c" / "s.json").read_text())
        back = results.read(out, "c", "s")
        k = meta["settings"]["k"]
        assert len(back.t) == meta["samples"] == 50 + k % 7
        assert np.all(back.channels["x"] == k), (trial, k, back.channels["x"][:3])
        assert sorted(q.name for q in (out / "c").iterdir()) == ["s.csv", "s.json"]


# ---------------------------------------------------------------------------------------------
# faults while a pair is written (`flexmbd run`): exit 2 naming the file, the old pair there byte
# for byte (the same files), no temporary or kept copy left

CASE, SOLVER = "cantilever_step", "analytic"
ROOT = Path(results.__file__).resolve().parent.parent


def run(out: Path) -> tuple[int, str]:
    """`flexmbd run CASE --solver SOLVER --out OUT` in this process: (exit status, stderr)."""
    from flexmbd.cli import main
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(["run", CASE, "--solver", SOLVER, "--out", str(out)])
    return code, err.getvalue()


@pytest.fixture
def old(tmp_path) -> Path:
    """The folder of a stored pair, OUT/results/CASE."""
    assert run(tmp_path) == (0, "")
    return tmp_path / "results" / CASE


def test_a_sidecar_that_cannot_be_replaced_keeps_the_old_pair(old, monkeypatch):
    """An immutable old sidecar (chattr +i; planted: renaming onto it fails with EPERM), met after
    the CSV was swapped in: the old CSV is put back."""
    from flexmbd import files
    before, real = listing(old), os.replace

    def replace(src, dst, **kw):
        if Path(dst) == old / f"{SOLVER}.json":
            raise PermissionError(errno.EPERM, "Operation not permitted", str(src), None, str(dst))
        return real(src, dst, **kw)

    monkeypatch.setattr(files.os, "replace", replace)
    code, err = run(old.parent.parent)
    monkeypatch.undo()
    assert (code, err) == (2, f"flexmbd: {old / SOLVER}.json: not writable (operation not permitted)\n")
    assert listing(old) == before


def test_a_folder_where_the_sidecar_goes_is_refused_before_any_replace(old):
    (old / f"{SOLVER}.json").unlink()
    (old / f"{SOLVER}.json").mkdir()
    (old / f"{SOLVER}.json" / "keep").write_text("keep")
    before = listing(old)
    assert run(old.parent.parent) == (2, f"flexmbd: {old / SOLVER}.json: a folder is there, not a file\n")
    assert listing(old) == before


def test_a_failing_second_temporary_leaves_no_first(old, monkeypatch):
    """A full disk met while the second temporary of the pair is written (planted: ENOSPC)."""
    from flexmbd import files
    before, real, opened = listing(old), os.fdopen, []

    def full(fd, *a, **k):
        opened.append(fd)
        if len(opened) == 2:
            os.close(fd)
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(fd, *a, **k)

    monkeypatch.setattr(files.os, "fdopen", full)
    code, err = run(old.parent.parent)
    monkeypatch.undo()
    assert (code, err) == (2, f"flexmbd: {old / SOLVER}.csv: no space left on the device\n")
    assert listing(old) == before


@pytest.mark.parametrize("limit, name", [(1024, f"{SOLVER}.json"), (16 * 1024, f"{SOLVER}.csv")],
                         ids=["ulimit -f 1: the first temporary", "16 KiB: the second temporary"])
def test_past_the_file_size_limit_the_old_pair_stays(old, limit, name):
    """`ulimit -f` (RLIMIT_FSIZE, bytes here) below the size of one of the pair's files, in a real
    process (SIGXFSZ ignored by the command: EFBIG)."""
    before = listing(old)
    fsize = lambda: resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    r = subprocess.run([sys.executable, "-m", "flexmbd.cli", "run", CASE, "--solver", SOLVER, "--out",
                        str(old.parent.parent)], capture_output=True, text=True, preexec_fn=fsize, timeout=300,
                       env=dict(os.environ, PYTHONPATH=str(ROOT), OPENBLAS_NUM_THREADS="1"))
    assert (r.returncode, r.stderr) == (2, f"flexmbd: {old / name}: file too large (the file size limit, ulimit -f, "
                                           f"was reached)\n")
    assert listing(old) == before


@pytest.mark.signals
def test_a_signal_while_the_temporaries_are_made_leaves_none(old, monkeypatch):
    """SIGTERM while the second temporary of the pair is made: exit 143 with its line, no temporary
    left, the old pair as it was."""
    from flexmbd import files
    before, real, made = listing(old), tempfile.mkstemp, []

    def mkstemp(*a, **k):
        made.append(1)
        if len(made) == 2:
            os.kill(os.getpid(), signal.SIGTERM)
        return real(*a, **k)

    monkeypatch.setattr(files.tempfile, "mkstemp", mkstemp)
    previous = signal.signal(signal.SIGTERM, signal.SIG_DFL)     # whatever pytest was started with
    try:
        code, err = run(old.parent.parent)
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_DFL if previous is None else previous)
        monkeypatch.undo()
    assert (code, err) == (143, "flexmbd: interrupted (SIGTERM)\n") and len(made) == 2
    assert listing(old) == before


def test_the_sidecar_records_every_override_and_the_versions(tmp_path):
    import json
    from flexmbd import cases, results, solvers
    case = cases.load("cantilever_step", ["materials.steel.E=2.1e11", "duration=0.01"])
    _, js = results.write(solvers.run(case, "analytic"), tmp_path)
    meta = json.loads(js.read_text())
    assert meta["overrides"] == ["materials.steel.E=2.1e11", "duration=0.01"]
    assert meta["versions"]["numba"] and meta["versions"]["exudyn"]


# ---------------------------------------------------------------------------------------------
# the deformed-shape snapshots in the sidecar

SHAPES = {"beam": {"x": [0.0, 0.75, 1.5], "t": [0.5, 1.0],
                   "u": [[[0.0, 0.0, 0.0], [1e-5, -3e-3, 0.0], [2e-5, -9e-3, 1e-4]],
                         [[0.0, 0.0, 0.0], [2e-5, -6e-3, 0.0], [4e-5, -1.8e-2, 2e-4]]]}}


def test_shapes_round_trip(tmp_path):
    r = _result(2)
    r.extra["shapes"] = SHAPES
    results.write(r, tmp_path)
    assert results.read(tmp_path, "c", "s").extra["shapes"] == SHAPES


@pytest.mark.parametrize("key,bad,words", [
    ("shapes", [1, 2], "shapes: expected a table"),
    ("beam", {"x": [0.0, 1.5], "t": [0.5]}, "shapes.beam: expected a table with the keys x, t and u"),
    ("u", float("nan"), "shapes.beam.u: expected nested lists"),
    ("u", float("inf"), "shapes.beam.u: expected nested lists"),
    ("u", "a string", "shapes.beam.u: expected nested lists"),
    ("x", [0.0, "0.75", 1.5], "shapes.beam.x: expected a list"),
    ("t", [0.5, True], "shapes.beam.t: expected a list"),
    ("t", [0.5, 10 ** 400], "shapes.beam.t: expected a list"),
    ("t", [0.5], "shapes.beam.u: 2 x 3 x 3 numbers, expected len(t) x len(x) x 3 = 1 x 3 x 3"),
    ("x", [0.0, 1.5], "shapes.beam.u: 2 x 3 x 3 numbers, expected len(t) x len(x) x 3 = 2 x 2 x 3"),
    ("u", "short row", "shapes.beam.u: rows of unequal lengths"),
])
def test_a_broken_shapes_block_is_refused_naming_the_key(tmp_path, key, bad, words):
    import copy
    r = _result(2)
    r.extra["shapes"] = copy.deepcopy(SHAPES)
    _, js = results.write(r, tmp_path)
    meta = json.loads(js.read_text())
    if key == "shapes":
        meta["shapes"] = bad
    elif key == "beam":
        meta["shapes"]["beam"] = bad
    elif isinstance(bad, float):
        meta["shapes"]["beam"]["u"][1][2][1] = bad
    elif bad == "short row":
        meta["shapes"]["beam"]["u"][1][1] = [0.0, 0.0]
    elif bad == "a string":
        meta["shapes"]["beam"]["u"][0][0][0] = bad
    else:
        meta["shapes"]["beam"][key] = bad
    js.write_text(json.dumps(meta))
    with pytest.raises(InputError, match="s.json: " + re.escape(words)):
        results.read(tmp_path, "c", "s")
