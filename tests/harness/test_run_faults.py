"""Faults met on the way to a result, each with the contract's answer: a loop case with an
integrator that cannot run it is refused when it is loaded (exit 2, one line naming the file and
the key, no solver run); a compiled-code cache that cannot be loaded is removed and compiled
again, and a cache folder that cannot be written is replaced by a temporary one, never by the
package's folder; a plug-in that returns arrays of the wrong shapes, or instants that stop
increasing, is a failed result saying so, and the command and the report complete around it.

The cache tests compile tiny functions of their own through `flexmbd.mbd.compiled.jit`, in fresh
processes with their own XDG_CACHE_HOME (about a second each), never the kernel."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import flexmbd
from flexmbd.harness import results
from flexmbd.mbd import integrate
from flexmbd.cases.validate import LOOP_METHODS
from flexmbd.cli import main
from tests.cli.test_bad_input import _in_process, _refused
from tests.harness.test_plugins import plug, trajectory_only

ROOT = Path(flexmbd.__file__).resolve().parent.parent


# ---------------------------------------------------------------------------------------------
# a closed loop and flexmbd's integrator


@pytest.mark.parametrize("method,solver", [("adams", "flexmbd"), ("exp-adams", "flexmbd"), ("adams", "pinocchio")])
def test_a_loop_case_with_an_integrator_that_cannot_project_is_refused_when_loaded(tmp_path, capsys, method, solver):
    # the [integrator] table is flexmbd's settings: checked whichever solver runs the case, as a
    # [solvers.NAME] table is; refused before any solver runs, nothing written
    code, err, written = _in_process(tmp_path, capsys, ["run", "four_bar_swing_rigid", "--solver", solver,
                                                        "--set", f"integrator.method={method}"])
    _refused(code, err, written, ["four_bar_swing_rigid.toml", "integrator.method", repr(method), "closed loop",
                                  "dopri5, fox-goodwin, rk45, dop853 or rk4"])
    # the methods accepted are those the loop integrator restarts after each projection
    assert set(LOOP_METHODS) == set(integrate.PROJECTED)


# ---------------------------------------------------------------------------------------------
# the compiled-code cache

TINY = '''
from flexmbd.mbd.compiled import jit
from flexmbd.mbd.compiled.jit import njit


@njit
def twice(x):
    return 2.0 * x


def plus_one(x):
    return x + 1.0


c = jit.cfunc("float64(float64)", plus_one)
print(twice(21.0), c.ctypes(42.0), sum(twice.stats.cache_hits.values()), c.cache_hits)
'''


def python(code_or_file, tmp_path: Path, **env):
    """A fresh interpreter running a file or `-c` code with flexmbd and tmp_path importable."""
    e = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), str(tmp_path)]), **env}
    args = [str(code_or_file)] if Path(str(code_or_file)).is_file() else ["-c", code_or_file]
    return subprocess.run([sys.executable, *args], capture_output=True, text=True, env=e, cwd=tmp_path, timeout=120)


def cache_files(cache: Path) -> dict:
    return {p: p.read_bytes() for p in sorted(cache.rglob("*.nb[ic]"))}


def test_a_cache_that_cannot_be_loaded_is_removed_and_compiled_again(tmp_path):
    (tmp_path / "tiny.py").write_text(TINY)
    cache = tmp_path / "cache"
    first = python(tmp_path / "tiny.py", tmp_path, XDG_CACHE_HOME=str(cache))
    assert first.returncode == 0 and first.stdout.split() == ["42.0", "43.0", "0", "0"], first.stderr
    kept = cache_files(cache)
    assert {p.suffix for p in kept} == {".nbi", ".nbc"} and all("numba-" in str(p) for p in kept)
    for p in kept:                                      # every index and data file overwritten
        p.write_bytes(b"garbage\n")
    second = python(tmp_path / "tiny.py", tmp_path, XDG_CACHE_HOME=str(cache))
    assert second.returncode == 0 and second.stdout.split() == ["42.0", "43.0", "0", "0"], second.stderr
    lines = second.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("flexmbd: compiled code cached in ") and "could not be loaded" \
        in lines[0] and "compiling it again" in lines[0], second.stderr
    rebuilt = cache_files(cache)
    assert set(rebuilt) == set(kept) and all(v != b"garbage\n" for v in rebuilt.values())
    third = python(tmp_path / "tiny.py", tmp_path, XDG_CACHE_HOME=str(cache))     # loaded from it, silently
    assert third.returncode == 0 and third.stdout.split() == ["42.0", "43.0", "1", "1"] and not third.stderr


@pytest.mark.parametrize("xdg", ["a file", "relative"])
def test_compiled_code_is_never_written_beside_the_sources(tmp_path, xdg):
    # XDG_CACHE_HOME a file: numba's own fallback would be the __pycache__ beside the sources
    # (flexmbd/__pycache__ for spatial.py); a folder of the process's own instead, removed at its
    # end, said in one line. Relative: ignored (the XDG specification), for ~/.cache, silently
    (tmp_path / "a file").write_text("not a folder")
    (tmp_path / "tmp").mkdir()
    package = lambda: sorted(str(p) for p in (ROOT / "flexmbd").rglob("*.nb[ic]"))   # noqa: E731
    before = package()
    code = ("import numpy as np; from flexmbd.mbd import spatial; from flexmbd.mbd.compiled import jit; "
            "print(spatial.skew(np.array([1.0, 2.0, 3.0]))[0, 1], jit.cache_dir())")
    r = python(code, tmp_path, XDG_CACHE_HOME=str(tmp_path / xdg) if xdg == "a file" else xdg,
               TMPDIR=str(tmp_path / "tmp"), HOME=str(tmp_path / "home"))
    assert r.returncode == 0 and r.stdout.split()[0] == "-3.0", r.stderr
    assert package() == before
    assert not list((tmp_path / "tmp").iterdir())       # a temporary cache removed at the end
    used, lines = Path(r.stdout.split()[1]), r.stderr.splitlines()
    if xdg == "relative":
        assert used.is_relative_to(tmp_path / "home" / ".cache" / "flexmbd") and not r.stderr
        assert not (tmp_path / xdg).exists()
        return
    assert used.is_relative_to(tmp_path / "tmp")
    assert len(lines) == 1 and lines[0].startswith("flexmbd: the cache folder ($XDG_CACHE_HOME/flexmbd") and \
        str(tmp_path / xdg) in lines[0] and "Not a directory" in lines[0], r.stderr


# ---------------------------------------------------------------------------------------------
# what a plug-in returns


def channels_of_wrong_length(case, t_end, settings):
    t = np.arange(0.0, t_end + 1e-12, case.integrator.output_dt)
    return results.Result("short", case.name, t=t, channels={"tip_deflection": np.zeros(t.size - 1)})


def points_in_two_dimensions(case, t_end, settings):
    traj = trajectory_only(case, t_end, lambda t: 0 * t, lambda t: 0 * t)
    L = case.bodies["beam"].length
    traj.beams["beam"].points[L] = traj.beams["beam"].points[L][:, :2]
    return traj


def sidecar(out: Path, solver: str) -> dict:
    return json.loads((out / "results" / "cantilever_step" / f"{solver}.json").read_text())


def test_a_plugin_returning_arrays_of_wrong_shapes_is_a_failed_result(tmp_path, capsys, monkeypatch):
    plug(monkeypatch, "short", channels_of_wrong_length)
    plug(monkeypatch, "flat", points_in_two_dimensions)
    out = tmp_path / "out"
    # cantilever_step: 2 s at 1 ms, 2001 instants; its beam 1.5 m long
    for solver, why in (("short", "channel tip_deflection has shape (2000,), expected (2001,)"),
                        ("flat", "trajectory.beams['beam'].points[1.5] has shape (2001, 2), expected (2001, 3)")):
        args = ["run", "cantilever_step", "--solver", solver, "--out", str(out)]
        assert main(args) == 0
        assert f"cantilever_step / {solver}: failed: {why};" in capsys.readouterr().out
        assert main(args + ["--strict"]) == 1
        meta = sidecar(out, solver)
        assert meta["status"] == f"failed: {why}" and meta["samples"] == 0
    # a report completes around them (exit 0), its page showing each with its status
    assert main(["report", "--cases", "cantilever_step", "--solvers", "fe-linear,short,flat", "--workers", "1",
                 "--out", str(out)]) == 0
    page = (out / "cantilever_step" / "index.html").read_text()
    assert "channel tip_deflection has shape (2000,), expected (2001,)" in page
    assert "points[1.5] has shape (2001, 2), expected (2001, 3)" in page


def test_a_plugin_returning_instants_that_stop_increasing_is_cut_there_and_failed(tmp_path, capsys, monkeypatch):
    def unsorted(case, t_end, settings):
        t = np.arange(0.0, t_end + 1e-12, case.integrator.output_dt)
        t[5] = t[3]
        return results.Result("unsorted", case.name, t=t, channels={"tip_deflection": 1e-3 * t})

    plug(monkeypatch, "unsorted", unsorted)
    out = tmp_path / "out"
    assert main(["run", "cantilever_step", "--solver", "unsorted", "--out", str(out)]) == 0
    why = "failed: column t does not increase at index 5 (0.003 s after 0.004 s) at t = 0.004 s"
    assert f"unsorted: {why};" in capsys.readouterr().out
    meta = sidecar(out, "unsorted")
    assert meta["status"] == why and meta["failed_at_s"] == pytest.approx(0.004) and meta["samples"] == 5
    kept = results.read(out / "results", "cantilever_step", "unsorted")     # the samples before it, kept
    np.testing.assert_allclose(kept.t, [0.0, 0.001, 0.002, 0.003, 0.004])
    # a time that is not a number is the same fault
    assert "column t holds nan at index 2" in str(results.disorder([0.0, 0.1, np.nan])[1])
