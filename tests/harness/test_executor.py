"""The executor: the same results, bitwise, in this process, on the local pool and on a Dask
LocalCluster; a lost worker loses no finished result and its job runs again; an interrupted set
of runs resumes where it stopped; no worker outlives its command.

The jobs are the cheapest there are (`analytic` on `cantilever_step`, a few variants through
overrides); the processes are real, and a test that races one waits for what it says (a progress
line, a result on disk) and stops what it started."""

import os
import signal
import subprocess
import sys
import time
import types
from pathlib import Path

import pandas as pd
import pytest

import flexmbd
from flexmbd import cases
from flexmbd.harness import executor, results
from flexmbd.cli import main
from flexmbd.core.errors import InputError

pytestmark = pytest.mark.heavy(29)       # seconds, measured with both cores busy (tests/conftest.py)

ROOT = Path(flexmbd.__file__).resolve().parent.parent
ENV = dict(os.environ, PYTHONPATH=str(ROOT), OPENBLAS_NUM_THREADS="1")
VARIANTS = [[], ["solvers.analytic.modes=2"], ["solvers.analytic.modes=8"], ["materials.steel.E=2.1e11"]]


def jobs():
    return [(cases.load("cantilever_step", v), "analytic") for v in VARIANTS]


def stored(where: executor.Where, out: Path) -> list[bytes]:
    """Every variant run where `where` says, each written into its own folder; the CSVs' bytes."""
    js = jobs()
    executor.execute(js, lambda k, r: results.write(r, out / str(k)), where)
    return [(out / str(k) / "cantilever_step" / "analytic.csv").read_bytes() for k in range(len(js))]


def test_the_pool_gives_the_results_of_a_run_in_this_process_bitwise(tmp_path):
    here = stored(executor.Where(workers=1), tmp_path / "here")
    assert stored(executor.Where(workers=2), tmp_path / "pool") == here
    assert len(set(here)) == len(here)                  # the variants differ: the comparison can fail


def test_a_run_that_leans_on_blas_gives_the_same_bytes_in_this_process_and_on_the_pool(tmp_path):
    """The full-order FE transient (600 DOFs: eigenvectors, dense products) moves by 7e-6 of its
    largest value between one and two OpenBLAS threads; every run uses one (registry.run)."""
    js = [(cases.load("cantilever_step", [f"duration={d}"]), "fe-linear") for d in (0.2, 0.3)]
    got = {}
    for name, where in (("here", executor.Where(workers=1)), ("pool", executor.Where(workers=2))):
        executor.execute(js, lambda k, r: results.write(r, tmp_path / name / str(k)), where)
        got[name] = [(tmp_path / name / str(k) / "cantilever_step" / "fe-linear.csv").read_bytes() for k in range(2)]
    assert got["here"] == got["pool"]


def test_a_dask_local_cluster_gives_the_pool_s_results_bitwise(tmp_path):
    pytest.importorskip("distributed")
    pool = stored(executor.Where(workers=2), tmp_path / "pool")
    assert stored(executor.Where(dask_local=2), tmp_path / "dask") == pool


# 3 x 3 points of the pendulum, 0.05 s each: the mode count (flexmbd's and exudyn-ffrf's modal
# bases) x exudyn-ffrf's step; flexmbd is the reference, so the two solvers are all that run
PENDULUM = ["pendulum", "--vary", "bodies.beam.modes.count=4,8,12", "--vary", "solvers.exudyn-ffrf.dt=2e-4,1e-4,5e-5",
            "--vary", 'report.reference="flexmbd"', "--vary", "duration=0.05", "--solvers", "flexmbd,exudyn-ffrf"]


def test_a_pendulum_study_gives_the_same_table_bitwise_on_the_pool_and_on_a_dask_cluster(tmp_path):
    """The grid on a pool of 2 workers, then on a LocalCluster of 2 started here on loopback (its
    workers' environment is this process's: one BLAS thread only because every run asks for it)."""
    pytest.importorskip("distributed")
    from dask.distributed import LocalCluster
    assert main(["study", *PENDULUM, "--out", str(tmp_path / "pool"), "--workers", "2"]) == 0
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cluster:
        assert main(["study", *PENDULUM, "--out", str(tmp_path / "dask"), "--scheduler", cluster.scheduler_address]) == 0
    pool, dask = (pd.read_parquet(tmp_path / name / "study.parquet") for name in ("pool", "dask"))
    assert pool.equals(dask)
    assert all(column_bytes(pool[c]) == column_bytes(dask[c]) for c in pool.columns)   # the table holds no times
    ok = pool[pool["status"] == "ok"]
    assert len(ok) == len(pool) == 9 * 2 * (5 * 5 + 3)              # points x solvers x (channels x metrics + S_eq 3, 5, damage)
    final = ok[(ok["metric"] == "final") & (ok["channel"] == "tip_deflection")]
    assert final.groupby("solver")["value"].nunique().to_dict() == {"exudyn-ffrf": 9, "flexmbd": 3}


def column_bytes(col: pd.Series) -> bytes:
    """A column's values as bytes: a number column's doubles, any other its values' text."""
    if pd.api.types.is_float_dtype(col) or pd.api.types.is_integer_dtype(col):
        return col.to_numpy().tobytes()
    return "\0".join(map(str, col)).encode()


def test_done_is_told_each_job_once_with_its_index(tmp_path):
    got = {}
    js = jobs()
    executor.execute(js, lambda k, r: got.setdefault(k, []).append(r), executor.Where(workers=2))
    assert sorted(got) == list(range(len(js))) and all(len(v) == 1 for v in got.values())
    assert [got[k][0].extra["overrides"] for k in range(len(js))] == VARIANTS


def test_a_result_of_another_flexmbd_is_refused():
    case, solver = jobs()[0]
    r = executor.compute(executor.task(case, solver))
    assert executor.checked(case, solver, r) is r
    r.extra["key"] = "0" * 64                           # as a worker at another version would give it
    with pytest.raises(InputError, match="another flexmbd"):
        executor.checked(case, solver, r)


def test_a_dask_cluster_of_another_flexmbd_is_refused_before_any_job(monkeypatch):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        executor.same_flexmbd(client, "--dask-local")   # the same source: accepted
        with monkeypatch.context() as m:
            m.setattr(executor.registry, "source_sha256", lambda: "f" * 64)      # this side edited
            with pytest.raises(InputError, match=r"^--dask-local: the Dask worker at tcp://127.0.0.1:\d+ has "
                                                 r"flexmbd \S+ with source \w{12}, this command .* with source ffffffffffff"):
                executor.same_flexmbd(client, "--dask-local")
        # a worker whose flexmbd has no such function (an older version): a module only this process has
        elsewhere = types.ModuleType("flexmbd_only_here")
        real = executor.identity

        def identity():
            return real()
        identity.__module__, identity.__qualname__ = elsewhere.__name__, "identity"
        elsewhere.identity = identity
        monkeypatch.setitem(sys.modules, elsewhere.__name__, elsewhere)
        monkeypatch.setattr(executor, "identity", identity)
        with pytest.raises(InputError, match=r"^--scheduler tcp://x:1: a Dask worker cannot run this flexmbd's "
                                             r"jobs \(\w+: .*\); every worker needs flexmbd"):
            executor.same_flexmbd(client, "--scheduler tcp://x:1")


def test_a_stored_result_is_up_to_date_when_it_has_the_key_of_the_run(tmp_path):
    """`executor.up_to_date` (one name per meaning: `report.figures.kept` is a figure drawn once):
    no stored result, a result of another key or another status, and one with the run's key."""
    from flexmbd.harness import registry
    case = cases.load("cantilever_step")
    assert not hasattr(executor, "kept") and not executor.up_to_date(tmp_path, case, "analytic")
    r = results.Result(solver="analytic", case=case.name, case_sha256=case.sha256,
                       extra={"key": registry.content_key(case, "analytic")})
    results.write(r, tmp_path)
    assert executor.up_to_date(tmp_path, case, "analytic")
    r.extra["key"] = "0" * 64
    results.write(r, tmp_path)
    assert not executor.up_to_date(tmp_path, case, "analytic")


def test_a_job_whose_worker_died_twice_is_a_failed_result_saying_so():
    case, solver = jobs()[0]
    r = executor.lost(case, solver, "killed by SIGKILL")
    assert r.status.kind == "failed" and "worker process died 2 times (killed by SIGKILL)" in str(r.status)


# ---------------------------------------------------------------------------------------------
# real processes: a study killed in part or whole


# 8 jobs, fe-linear's 4 first: each at least its ~1 s matrix exponential (its `exact` scheme, at any
# duration: 0.2 s of the case keeps the runs short), so a signal sent as a progress line says a job
# started finds it running
STUDY = ["cantilever_step", "--vary", "integrator.output_dt=1e-3,5e-4", "--vary", "solvers.analytic.modes=2,8",
         "--vary", "duration=0.2", "--vary", "solvers.fe-linear.scheme=exact",
         "--solvers", "fe-linear,analytic"]


def study(out: Path, *extra) -> subprocess.Popen:
    def dispositions():                                 # SIGINT and SIGTERM at their defaults, whatever pytest has
        for s in (signal.SIGINT, signal.SIGTERM):
            signal.signal(s, signal.SIG_DFL)
    return subprocess.Popen([sys.executable, "-m", "flexmbd.cli", "study", *STUDY, "--out", str(out), "--workers", "2",
                             *extra], env=ENV, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True,
                            preexec_fn=dispositions)


def workers_of(pid: int) -> list[int]:
    """The worker processes of process pid: its children forked from it (its own command line) or
    started by multiprocessing's spawn."""
    out, own = [], Path(f"/proc/{pid}/cmdline").read_bytes()
    for d in Path("/proc").iterdir():
        try:
            stat = (d / "stat").read_text()
            cmd = (d / "cmdline").read_bytes()
        except (OSError, ValueError):
            continue
        if int(stat.rpartition(")")[2].split()[1]) == pid and (cmd == own or b"spawn_main" in cmd):
            out.append(int(d.name))
    return out


def alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()[0] != "Z"
    except OSError:
        return False


def until(p, what, timeout: float = 120.0):
    """Read p's stderr lines until what(line) holds; those lines. A failure if p ends first."""
    lines, deadline = [], time.monotonic() + timeout
    while time.monotonic() < deadline:
        line = p.stderr.readline()
        if not line:
            pytest.fail(f"the study ended ({p.wait()}) first: {''.join(lines)[-500:]}")
        lines.append(line)
        if what(line):
            return lines
    pytest.fail("the study never said it")


def points(out: Path) -> list[Path]:
    return sorted(out.glob("points/*/results/cantilever_step/*.json"))


@pytest.mark.signals
def test_a_killed_worker_loses_no_finished_result_and_its_job_runs_again(tmp_path):
    out = tmp_path / "study"
    p = study(out)
    try:
        lines = until(p, lambda line: " 2/8 " in line)                 # both workers have a job
        victims = workers_of(p.pid)
        assert len(victims) == 2, lines
        os.kill(victims[0], signal.SIGKILL)
        err = "".join(lines) + p.stderr.read()
        assert p.wait(timeout=300) == 0, err
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    assert "Traceback" not in err and len(points(out)) == 8
    assert all(results.read(f.parent.parent, "cantilever_step", f.stem).ok for f in points(out))
    assert not any(alive(w) for w in victims)                           # none outlives the command
    again = subprocess.run([sys.executable, "-m", "flexmbd.cli", "study", *STUDY, "--out", str(out)], env=ENV,
                           capture_output=True, text=True, timeout=300)
    assert again.returncode == 0 and again.stderr.count("(stored, unchanged)") == 8, again.stderr


@pytest.mark.signals
def test_an_interrupted_study_resumes_where_it_stopped(tmp_path):
    out = tmp_path / "study"
    p = study(out)
    try:
        until(p, lambda line: " 4/8 " in line)     # a first result is written (a worker's next job starts first)
        victims = workers_of(p.pid)
        p.send_signal(signal.SIGTERM)
        err = p.stderr.read()
        assert p.wait(timeout=120) == 143, err
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    assert err.strip().splitlines()[-1] == "flexmbd: interrupted (SIGTERM)", err
    assert not any(alive(w) for w in victims)
    hidden = [q for q in out.rglob("*") if q.name.startswith(".") or q.suffix == ".tmp"]
    assert hidden == []                                                 # nothing half-written
    done = len(points(out))
    assert 1 <= done < 8
    again = subprocess.run([sys.executable, "-m", "flexmbd.cli", "study", *STUDY, "--out", str(out)], env=ENV,
                           capture_output=True, text=True, timeout=300)
    assert again.returncode == 0, again.stderr
    assert again.stderr.count("(stored, unchanged)") == done and len(points(out)) == 8
