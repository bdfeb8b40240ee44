"""Result files and the run status: one status type, one divergence rule, the CSV/JSON pair."""

import contextlib
import dataclasses
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

from flexmbd.core import files
from flexmbd.harness import results
from flexmbd.core.errors import InputError
from flexmbd.harness.results import Result, Status

pytestmark = pytest.mark.kernel_free


# ---------------------------------------------------------------------------------------------
# status


@pytest.mark.parametrize("status", [Status(), results.diverged("diverged (|v| > 1e+08)", 0.125),
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
    """The rule is applied to every solver in registry.run: an adapter's blown-up history ends
    at its first bad sample, with the samples before it kept."""
    from flexmbd import cases
    from flexmbd.harness import registry
    from flexmbd.solvers import analytic

    def blown_up(case, t_end, settings):
        t = np.linspace(0.0, t_end, 101)
        tip = np.where(t < 0.05, 0.01, 10.0)
        return Result(solver="analytic", case=case.name, t=t, channels={"tip_deflection": tip, "stress_vm": 0 * t})

    monkeypatch.setattr(analytic, "run", blown_up)
    r = registry.run(cases.load("cantilever_step"), "analytic", 0.1)
    assert r.status.kind == "failed" and r.status.t == pytest.approx(0.05) and r.status.cause == "diverged"
    assert len(r.t) == 50 and np.all(r.channels["tip_deflection"] == 0.01)


def test_an_exception_in_a_solver_is_a_failed_result(monkeypatch):
    from flexmbd import cases
    from flexmbd.harness import registry
    from flexmbd.solvers import analytic

    def broken(case, t_end, settings):
        raise RuntimeError("engine exploded")

    monkeypatch.setattr(analytic, "run", broken)
    r = registry.run(cases.load("cantilever_step"), "analytic", 0.1)
    assert r.status.kind == "failed" and "RuntimeError: engine exploded" in r.status.why
    assert r.status.cause == "aborted"


# ---------------------------------------------------------------------------------------------
# a failed run's cause: a field, set where the failure is made, stored in the sidecar


def test_a_failed_run_s_cause_is_set_where_its_failure_is_made():
    """The divergence rule makes a diverged failure (a bound passed, a value not finite), instants
    out of order and any other failure an aborted one; the cause is what its maker says, never read
    from its why; only a failed status has one."""
    t = np.linspace(0.0, 1.0, 11)
    assert results.first_failure(t, {"tip": np.where(t < 0.55, 0.0, 9.0)}, {"tip": 3.0})[1].cause == "diverged"
    assert results.first_failure(t, {"a": np.where(t < 0.55, 0.0, np.nan)}, {})[1].cause == "diverged"
    assert results.disorder([0.0, 0.1, 0.1])[1].cause == results.disorder([0.0, np.nan])[1].cause == "aborted"
    assert results.diverged("no word of it", 0.2).cause == "diverged"
    assert results.failed("non-finite, in its words", 0.2).cause == "aborted"
    assert results.failed("x", 0.2, "diverged") == results.diverged("x", 0.2) != results.failed("x", 0.2)
    assert Status("failed", "made without one").cause == "aborted"
    assert {s.cause for s in (Status(), results.not_applicable("x"), results.unavailable("x"),
                              results.outside_validity("y", 1.0))} == {""}
    for kind, cause in (("failed", "crashed"), ("ok", "diverged"), ("unavailable", "aborted")):
        with pytest.raises(ValueError, match="cause"):
            Status(kind, "x", None, cause)


def test_the_integrators_end_becomes_a_status_with_its_cause():
    """`inhouse.status_of`: the integrators' whys of the divergence rule (a state or acceleration
    not finite, a velocity beyond integrate.DIVERGED) are diverged, every other end aborted, and a
    failure the divergence watch found keeps the watch's own status."""
    from flexmbd.solvers import inhouse
    from flexmbd.mbd import integrate
    assert inhouse.status_of(integrate.Ended()) == Status()
    assert set(integrate.NON_FINITE) < set(inhouse.DIVERGES) and len(inhouse.DIVERGES) == 3
    for why in inhouse.DIVERGES:
        assert inhouse.status_of(integrate.failed(why, 0.5)) == results.diverged(why, 0.5)
    others = set(integrate.WHY.values()) - set(inhouse.DIVERGES)
    for why in [*others, "VODE return code -1", "the loop of joint 'j' does not close (residual 0.1)"]:
        assert inhouse.status_of(integrate.failed(why, 0.5)) == results.failed(why, 0.5)
    watched = results.diverged("diverged (|tip| beyond 3 m, 2 beam lengths)", 0.3)
    assert inhouse.status_of(integrate.failed(watched.why, 0.3), [watched]) is watched


def test_an_exudyn_run_cut_short_keeps_its_cause():
    """A run Exudyn stopped fails at the last instant it reached with its own cause: the watch's
    divergence stays diverged, Exudyn's own failure aborted, a run that stopped without one aborted."""
    xc = pytest.importorskip("flexmbd.solvers.exudyn_common")
    t = np.linspace(0.0, 1.0, 11)
    for status, want in ((results.diverged("diverged (|tip| beyond 3 m, 2 beam lengths)", 0.9), "diverged"),
                         (results.failed("Exudyn: Newton did not converge"), "aborted"), (Status(), "aborted")):
        r = Result(solver="exudyn-ffrf", case="c", status=status)
        assert xc.reached(r, t, 4, 1.0) == 4
        assert (r.status.kind, r.status.cause, r.status.t) == ("failed", want, pytest.approx(0.3))


# ---------------------------------------------------------------------------------------------
# the CSV/JSON pair


def _result(k: int, n: int = 20) -> Result:
    return Result(solver="s", case="c", t=np.arange(n) * 0.1, channels={"x": np.full(n, float(k))},
                  settings={"k": k}, status=results.diverged("diverged", 1.5) if k % 2 else Status())


def test_pair_round_trip(tmp_path):
    results.write(_result(3), tmp_path)
    back = results.read(tmp_path, "c", "s")
    assert back.status == results.diverged("diverged", 1.5) and back.settings == {"k": 3}
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
from flexmbd.core import files
from flexmbd.harness import results
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
# the cause in the sidecar; older sidecars without it


CAUSED = [results.diverged("diverged (|tip| beyond 3 m, 2 beam lengths)", 0.5), results.diverged("non-finite tip", 0.5),
          results.diverged("a why without its word", 0.5), results.failed("Exudyn: no convergence", 0.5),
          results.failed("non-finite, yet aborted by its maker", 0.5)]


@pytest.mark.parametrize("status", CAUSED)
def test_the_cause_is_stored_in_the_sidecar_beside_the_same_line_and_read_back(tmp_path, status):
    r = _result(0)
    r.status = status
    results.write(r, tmp_path)
    meta = json.loads((tmp_path / "c" / "s.json").read_text())
    assert meta["status"] == str(status) == f"failed: {status.why} at t = 0.5 s" and meta["cause"] == status.cause
    assert results.read(tmp_path, "c", "s").status == status
    results.write(_result(0), tmp_path)                                  # an ok run: no cause
    assert json.loads((tmp_path / "c" / "s.json").read_text())["cause"] == ""
    assert results.read(tmp_path, "c", "s").status == Status()


@pytest.mark.parametrize("line, cause", [("failed: diverged (|tip| beyond 3 m, 2 beam lengths) at t = 0.5 s", "diverged"),
                                         ("failed: non-finite state at t = 0.5 s", "diverged"),
                                         ("failed: non-finite tip_deflection at t = 0.5 s", "diverged"),
                                         ("failed: step size too small at t = 0.5 s", "aborted"),
                                         ("failed: RuntimeError: boom (run, line 3)", "aborted"),
                                         ("ok", ""), ("not applicable: fixed base", "")])
def test_an_older_sidecar_without_a_cause_is_read_as_before(tmp_path, line, cause):
    """A sidecar written before sidecars held `cause`: its line alone, the cause derived from its
    why as the pages did (`results.derived_cause`), and the same line written again."""
    results.write(_result(0), tmp_path)
    js = tmp_path / "c" / "s.json"
    meta = json.loads(js.read_text())
    del meta["cause"]
    meta.update(status=line, failed_at_s=0.5 if line.startswith("failed") else None)
    js.write_text(json.dumps(meta))
    back = results.read(tmp_path, "c", "s")
    assert back.status.cause == cause and str(back.status) == line.replace(" (run, line 3)", " (run, line 3) at t = 0.5 s")
    assert Status.parse(line).cause == cause


@pytest.mark.parametrize("status, cause, back", [
    (results.diverged("x", 0.5), "crashed", None), (results.diverged("x", 0.5), 3, None),
    (results.diverged("diverged (|tip| beyond 3 m, 2 beam lengths)", 0.5), "", "diverged"),   # none: as an older one
    (results.failed("non-finite state", 0.5), "", "diverged"),
    (Status(), "diverged", "")])                                  # a line edited to ok: the line says what the run is
def test_a_stored_cause_is_one_of_the_words_and_a_failed_run_s(tmp_path, status, cause, back):
    r = _result(0)
    r.status = status
    results.write(r, tmp_path)
    js = tmp_path / "c" / "s.json"
    js.write_text(js.read_text().replace(f'"cause": "{status.cause}"', f"\"cause\": {json.dumps(cause)}"))
    if back is None:
        with pytest.raises(InputError, match="s.json: cause: expected diverged or aborted for a failed run"):
            results.read(tmp_path, "c", "s")
    else:
        assert results.read(tmp_path, "c", "s").status == dataclasses.replace(status, cause=back)


# ---------------------------------------------------------------------------------------------
# the keys stored results depend on: one recipe (`version.cache_key`), the same bytes as before it


def test_the_keys_of_stored_results_are_the_same_as_before_the_one_recipe(tmp_path, monkeypatch):
    """Values computed with each key's own recipe before they all went through `version.cache_key`:
    a run's key (a plug-in's, with its module file, and a built-in's), a CSV's hash, a file's digest;
    a case's hashes by the old recipes (their values move with the shipped files)."""
    import hashlib
    from types import SimpleNamespace

    from flexmbd import cases, version
    from flexmbd.fe import flexbody
    from flexmbd.harness import registry
    monkeypatch.setattr(registry, "source_sha256", lambda: "f" * 64)
    (tmp_path / "plug.py").write_text("VERSION = '1.0'\n")
    plug = SimpleNamespace(__file__=str(tmp_path / "plug.py"), version=lambda: "1.0")
    case = SimpleNamespace(content_sha256="c" * 64, duration=2.0)
    assert registry._key(case, "my-plugin", plug, {"dt": 1e-3, "scheme": "a"}, None) == \
        "64819a937f2b85b5555a9804f6a5bfd28ed77f5853f1509ae4aeb82eedea76ba"
    assert registry._key(case, "analytic", SimpleNamespace(version=lambda: "2"), {}, 1.5) == \
        "0706a40aec78e10d81b90d27d0568ec3232dc6f1ded7130f308f11bac818a02f"
    assert results.sha256("t,x\n0,1\n") == "2236b4989592e6ce72adf96ba645c7a1b486744aca25334c60217c4d1da992d7"
    (tmp_path / "m.bin").write_bytes(b"\x00mesh\x01")
    assert flexbody.digest(tmp_path / "m.bin") == "dd74ed9f3828347263f2571efa22d3205a7dd04ef26e446ced950510d682a9c2"
    assert version.cache_key("abc") == version.cache_key(b"a", "b", b"c") == hashlib.sha256(b"abc").hexdigest()
    assert version.cache_key({"b": 1, "a": [1.5, None]}, digits=12) == \
        hashlib.sha256(b'{"a": [1.5, null], "b": 1}').hexdigest()[:12]
    for name, overrides in (("pendulum", ["integrator.rtol=1e-7"]), ("cantilever_step", []), ("brick_pendulum", [])):
        c = cases.load(name, overrides)
        text = cases.find(name).read_text()
        assert c.sha256 == hashlib.sha256((text + "\n".join(overrides)).encode()).hexdigest()[:16]
        h = hashlib.sha256(json.dumps(c.data, sort_keys=True, default=str).encode())
        for b in c.bodies.values():
            if b.type == "solid":
                for f in (b.mesh.file, b.mesh.stiffness, b.mesh.mass):
                    if f:
                        h.update(Path(f).read_bytes())
        assert c.content_sha256 == h.hexdigest(), name


# ---------------------------------------------------------------------------------------------
# faults while a pair is written (`flexmbd run`): exit 2 naming the file, the old pair there byte
# for byte (the same files), no temporary or kept copy left

CASE, SOLVER = "cantilever_step", "analytic"
ROOT = Path(results.__file__).resolve().parents[2]


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
    from flexmbd.core import files
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
    from flexmbd.core import files
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
    from flexmbd.core import files
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
    from flexmbd import cases
    from flexmbd.harness import results, registry
    case = cases.load("cantilever_step", ["materials.steel.E=2.1e11", "duration=0.01"])
    _, js = results.write(registry.run(case, "analytic"), tmp_path)
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
