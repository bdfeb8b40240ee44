"""One executor for every set of runs: `report`, `compare`, `regress` and `study` hand it their jobs
(a case, a solver) and take each result as it comes (`execute`). Where the jobs run (`Where`):

- in this process, one after another (`workers = 1`, or a single job);
- a local pool of worker processes, as many as cores by default (`pool`);
- a Dask distributed cluster: an existing one by its scheduler's address, or a `LocalCluster`
  of N worker processes started for the command (`dask`; docs/studies.md).

A worker loads the case from its file and overrides (`Task`) and runs `registry.run`; the Result
comes back to this process, where `done` writes it. Workers write nothing, so a lost worker or a
signal here leaves every finished result written and nothing half-written, and a command run
again keeps what is stored (`cli.run_checked`). The same job gives the same result, bitwise,
wherever it runs: the same code on the same input, one thread of linear algebra in every run
(`registry.run`), no state shared between runs. A job whose worker dies (killed, out of memory, a crash in native
code) runs again once on a fresh worker; if that one dies too, the job is a failed result saying
so. A result computed from another case content, solver version or flexmbd source than this
process has (a cluster's workers at another version) is refused (`checked`: one line, exit 2).
"""

from __future__ import annotations

import dataclasses
import logging
import os
import signal
import socket
import sys
import time
import traceback
from collections import deque
from multiprocessing import connection, get_context

from threadpoolctl import threadpool_limits

from flexmbd import cases
from flexmbd.core import files
from flexmbd.harness import results, registry
from flexmbd.mbd.compiled import jit
from flexmbd.core.errors import InputError
from flexmbd.harness.progress import job, jobs_done
from flexmbd.harness.results import Result
from flexmbd.version import __version__

THREADS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS")
TRIES = 2               # runs of a job whose worker died, before it is a failed result
POOL_ABOVE = 5.0        # s of estimated work (`cost.stages`) from which the default pool starts workers
COMPILES = ("flexmbd",)  # solvers whose first run on a machine compiles the kernel (`jit.is_cached`)
START = "fork" if sys.platform.startswith("linux") else "spawn"   # how a local worker starts (`Worker`)
CONNECT_S = 5.0         # s within which a --scheduler must take a connection and answer Dask's handshake


class WorkerError(RuntimeError):
    """A worker's internal error: its exception's line, and its traceback as a note (saved with
    this process's by the command's internal-error handler)."""


@dataclasses.dataclass(frozen=True)
class Where:
    """Where jobs run: `workers` local processes (None: one per core; 1: in this process), or a
    Dask cluster at `scheduler` (tcp://HOST:PORT), or a Dask LocalCluster of `dask_local` workers."""
    workers: int | None = None
    scheduler: str | None = None
    dask_local: int | None = None

    def count(self) -> int:
        return self.workers or os.cpu_count() or 1


@dataclasses.dataclass(frozen=True)
class Task:
    """What a worker needs to run one job: the case file, its `--set` overrides and the solver
    (a Case itself stays in the process that loaded it)."""
    path: str
    overrides: tuple
    solver: str


def task(case, solver: str) -> Task:
    return Task(str(case.path.resolve()), tuple(case.overrides), solver)


def compute(t: Task) -> Result:
    """A worker's job: the case loaded as the command loaded it, and the run (`registry.run`),
    stamped with the worker's environment (`results.environment`: its machine, versions and
    date go into the sidecar, not those of the process that writes it)."""
    return timed(t)[0]


def timed(t: Task) -> tuple[Result, float]:
    """`compute`, and the run's own time where it ran (s, `registry.run` alone): what a worker
    answers. The time travels beside the Result, not in it (a result is the same bytes wherever
    it ran)."""
    case = cases.load(t.path, list(t.overrides))
    start = time.perf_counter()
    r = registry.run(case, t.solver)
    seconds = time.perf_counter() - start
    r.extra = {**results.environment(), **r.extra}
    return r, seconds


def label(case, solver: str) -> str:
    return f"{case.name} / {solver}" + (f" ({', '.join(case.overrides)})" if case.overrides else "")


def into(jobs: list, folder, keep: bool = False, where: Where = Where(), after=None) -> None:
    """Run the (case, solver) jobs and write each result into folder(case) (a results folder:
    FOLDER/CASE/SOLVER.{csv,json}) as it comes. With `keep`, a job whose stored result is readable
    and has the key of the run it would make (`up_to_date`) is not run: its result stays. `after(case,
    solver)`, when given, is told as each job's result is in place (kept or written)."""
    t0 = time.perf_counter()
    todo, n = [], 0
    told = after or (lambda c, s: None)
    for c, s in jobs:
        if keep and up_to_date(folder(c), c, s):
            n += 1
            job(n, len(jobs), f"{label(c, s)} (stored, unchanged)", time.perf_counter() - t0)
            told(c, s)
        else:
            todo.append((c, s))

    def done(k: int, r: Result) -> None:
        results.write(r, folder(todo[k][0]))
        told(*todo[k])
    execute(todo, done, where, skipped=len(jobs) - len(todo), t0=t0)


def up_to_date(folder, case, solver: str) -> bool:
    """True when `folder` holds a readable result of `solver` on `case` whose key is the one a run
    would have now (`registry.content_key`); for a solver that cannot run the case here (no key),
    one that says the same of the same case file (its status), so that nothing a page is drawn
    from is rewritten (`report.build.page_key`)."""
    key = registry.content_key(case, solver)
    try:
        r = results.read(folder, case.name, solver)
    except InputError:
        return False
    if key is None:
        return r.case_sha256 == case.sha256 and str(r.status) == registry.status_for(case, solver)
    return r.extra.get("key") == key


def execute(jobs: list, done, where: Where = Where(), skipped: int = 0, t0: float | None = None,
            own: dict | None = None) -> None:
    """Run the (case, solver) jobs where `where` says, calling done(k, result) in this process as
    each result comes (k: the job's index in `jobs`), with the k-of-n job bar on stderr (after
    `skipped` jobs already counted, from `t0`). A job its solver cannot run (unavailable, not
    applicable) is answered here at once; the others start longest first (`cost.stages`'
    estimates), so the last to finish are short. Without a count of workers, work estimated
    under POOL_ABOVE seconds runs in this process (starting workers would cost more); with one,
    the pool's workers start before the estimates, which they take the time of. `own`, when
    given, gets k -> the run's own time (s, `registry.run` alone, where it ran)."""
    t0 = time.perf_counter() if t0 is None else t0
    own = {} if own is None else own
    total, n = len(jobs) + skipped, skipped
    runnable = []
    for k, (case, solver) in enumerate(jobs):
        if registry.status_for(case, solver):
            n += 1
            job(n, total, label(case, solver), time.perf_counter() - t0)
            done(k, _run(jobs, k, own))
        else:
            runnable.append(k)
    sure = (where.workers or 0) > 1 and len(runnable) > 1 and not (where.scheduler or where.dask_local)
    workers = [Worker() for _ in range(min(where.count(), len(runnable)))] if sure else []
    try:
        order, seconds = _longest_first(jobs, runnable)
        started = lambda m, k: job(n + m, total, label(*jobs[k]), time.perf_counter() - t0)
        small = where.workers is None and sum(seconds.values()) < POOL_ABOVE
        if order and (where.scheduler or where.dask_local):
            dask(jobs, order, done, started, where, own)
        elif where.count() == 1 or len(order) <= 1 or small:
            for m, k in enumerate(order, 1):
                started(m, k)
                with files.signals_exit():              # nothing written while it runs
                    r = _run(jobs, k, own)
                done(k, r)
        else:
            workers = workers or [Worker() for _ in range(min(where.count(), len(order)))]
            pool(jobs, order, done, started, workers, own)
    finally:
        for w in workers:
            w.stop()
    jobs_done(total, time.perf_counter() - t0)


def _run(jobs: list, k: int, own: dict) -> Result:
    """Job k run in this process; its own time into own[k]."""
    start = time.perf_counter()
    r = registry.run(*jobs[k])
    own[k] = time.perf_counter() - start
    return r


def _longest_first(jobs: list, runnable: list) -> tuple[list, dict]:
    """The runnable jobs' indices, longest first, and k -> its estimated seconds (`cost.stages`;
    while the kernel is not compiled, the first job of COMPILES also pays its solver's COMPILE_S)."""
    seconds = {k: _seconds(*jobs[k]) for k in runnable}
    first = next((k for k in runnable if jobs[k][1] in COMPILES), None)
    if first is not None and not jit.is_cached():       # its compile: the longest job of all
        seconds[first] += registry.module(jobs[first][1]).COMPILE_S
    return sorted(runnable, key=lambda k: -seconds[k]), seconds


def _seconds(case, solver: str) -> float:
    from flexmbd.harness import cost
    return sum(st.seconds for st in cost.stages(case, solver))


def checked(case, solver: str, r: Result) -> Result:
    """A worker's result, if it is the run this process would have made: its key (`solvers.
    content_key`: case content, solver, settings, versions, flexmbd's source) is this process's."""
    key = registry.content_key(case, solver)
    if key is not None and r.extra.get("key") != key:
        raise InputError(f"{case.path}: {solver}: a worker's result is of another flexmbd, solver or case version "
                         f"than this command's (the source changed while it ran, or a cluster's worker differs: "
                         f"docs/studies.md)")
    return r


def lost(case, solver: str, why: str) -> Result:
    """The failed result of a job whose worker died TRIES times."""
    return Result(solver=solver, case=case.name, case_sha256=case.sha256,
                  status=results.failed(f"its worker process died {TRIES} times ({why})"))


# ---------------------------------------------------------------------------------------------
# the local pool


def pool(jobs: list, order: list, done, started, workers: list, own: dict) -> None:
    """The jobs on the worker processes `workers` (started: `Worker`), each fed one job at a time
    through a pipe; a worker that answers is given its next job before its result is written (it
    waits for no file). While the kernel is not compiled, one job of COMPILES at a time runs (the
    others would compile it again, side by side); the rest go on meanwhile. A worker that dies
    takes only its job with it: the job goes back to the queue (TRIES in all) and a fresh worker
    replaces it. On any exception here (a signal: Interrupted) every worker is killed before it is
    passed on. `own`: k -> the run's own time in its worker (s)."""
    todo, tries, count, n = deque(order), {}, [0], len(workers)
    idle, busy = list(workers), {}                      # busy: worker -> the job k it runs

    def next_job():
        """The first job of the queue that may start now, or None."""
        compiling = any(jobs[k][1] in COMPILES for k in busy.values()) and not jit.is_cached()
        k = next((k for k in todo if not (compiling and jobs[k][1] in COMPILES)), None)
        if k is not None:
            todo.remove(k)
        return k

    def feed():
        """The next jobs that may start, to the idle workers, and to fresh ones up to n."""
        while todo and (idle or len(busy) < n):
            k = next_job()
            if k is None:
                return
            w = idle.pop() if idle else Worker()
            tries[k] = tries.get(k, 0) + 1
            count[0] += 1
            started(count[0], k)
            w.send(task(*jobs[k]))
            busy[w] = k

    try:
        while todo or busy:
            feed()
            ready = connection.wait([x for w in busy for x in (w.conn, w.proc.sentinel)])
            for w in [w for w in busy if w.conn in ready or w.proc.sentinel in ready]:
                k = busy.pop(w)
                got = w.receive()
                if got is not None:
                    idle.append(w)
                    feed()                              # its next job first, then the writing
                    r, own[k] = got
                    done(k, checked(*jobs[k], r))
                    continue
                why = w.death()
                if tries[k] < TRIES:
                    todo.appendleft(k)
                    count[0] -= 1
                else:
                    done(k, lost(*jobs[k], why))
    finally:
        for w in idle + list(busy):
            w.stop()


class Worker:
    """One worker process and the pipe it takes Tasks from and answers through. On Linux it is
    forked from this process, which has flexmbd imported already: it is ready at once, where a
    spawned one (a fresh interpreter, elsewhere) spends about a second importing. It is forked
    with SIGINT and SIGTERM blocked, so that none meets the handlers it inherits (files: a
    signal's exit would remove this process's staging folders); `serve` sets its own and unblocks
    them. Nothing it inherits changes a result: it holds one thread of linear algebra from its
    start, as a spawned one does (`serve`), the reductions it may find computed are computed with
    one thread wherever they are (`flexbody`), and it reads flexmbd's source itself (its key)."""

    def __init__(self):
        ctx = get_context(START)
        self.conn, theirs = ctx.Pipe()
        mask = signal.pthread_sigmask(signal.SIG_BLOCK, files.SIGNALS)
        try:
            with _threads_one():
                self.proc = ctx.Process(target=serve, args=(theirs,), daemon=True)
                self.proc.start()
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        theirs.close()

    def send(self, t: Task) -> None:
        """Hand the worker a task. A worker killed after its last answer has closed its end: the
        task is not delivered, and its death is then seen as any other's (`receive` None, the job
        run again) rather than as this process's broken pipe."""
        try:
            self.conn.send(t)
        except (BrokenPipeError, ConnectionResetError):
            pass

    def receive(self) -> tuple[Result, float] | None:
        """The worker's answer (`timed`: the Result and the run's own time), or None when it died
        before giving one. An internal error in the worker is raised here (WorkerError, with its
        traceback)."""
        try:
            kind, value = self.conn.recv()
        except (EOFError, OSError):
            return None
        if kind == "error":
            err = WorkerError(f"{value.strip().splitlines()[-1]} (in a worker process)")
            err.add_note(f"The worker's traceback:\n{value}")
            raise err
        return value

    def death(self) -> str:
        """Why the process ended (waited for): its signal or exit status."""
        self.proc.join()
        code = self.proc.exitcode
        return f"killed by {signal.Signals(-code).name}" if code is not None and code < 0 else f"exit status {code}"

    def stop(self) -> None:
        if self.proc.is_alive():
            self.proc.kill()
        self.proc.join()
        self.conn.close()


class _threads_one:
    """The environment a worker starts with: one thread of linear algebra and of numba (the
    workers share the cores, and a result must not depend on a thread count) for what it loads
    itself (a forked worker's libraries, loaded here first, are held to one thread by `serve`)."""

    def __enter__(self):
        self.old = {k: os.environ.get(k) for k in THREADS}
        os.environ.update({k: "1" for k in THREADS})

    def __exit__(self, *exc):
        for k, v in self.old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def serve(conn) -> None:
    """A worker's life: take a Task, answer ("ok", `timed`) or ("error", traceback), until the pipe
    closes. SIGINT is ignored (a Ctrl-C reaches the whole process group: the parent stops the
    workers); the worker dies with its parent; no progress bars of its own."""
    from flexmbd.harness import progress
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    files.forget_live()                                 # the parent's staging folders are not its own
    registry.source_sha256.cache_clear()                 # its own reading: a source edited meanwhile shows
    threadpool_limits(limits=1)                         # a forked worker's BLAS started with the parent's
    signal.pthread_sigmask(signal.SIG_UNBLOCK, files.SIGNALS)
    die_with_parent()
    progress.silence()
    while True:
        try:
            t = conn.recv()
        except (EOFError, OSError):
            return
        try:
            answer = ("ok", timed(t))
        except Exception:                               # noqa: BLE001 - the parent raises it
            answer = ("error", traceback.format_exc())
        conn.send(answer)


def die_with_parent() -> None:
    """On Linux, SIGKILL when the parent process ends (a parent killed outright cannot stop its
    workers); elsewhere nothing (a worker then ends when it reads the closed pipe)."""
    try:
        import ctypes
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGKILL)    # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


# ---------------------------------------------------------------------------------------------
# Dask


def identity() -> tuple[str, str]:
    """(flexmbd's version, the SHA-256 of its source: `registry.source_sha256`) of this process."""
    return __version__, registry.source_sha256()


def same_flexmbd(client, flag: str) -> None:
    """Refuse (InputError, one line naming `flag`) a Dask cluster whose workers cannot run this
    flexmbd's jobs: a worker without flexmbd or with another version fails to take the call
    (`identity` is not there, or not the same), a worker with other source answers another
    digest. Checked before any job is sent; workers that join later are held by `checked`."""
    mine = identity()
    try:
        theirs = client.run(identity)
    except Exception as e:                              # the worker could not even take the call
        what = (str(e).strip().splitlines() or [""])[0]
        raise InputError(f"{flag}: a Dask worker cannot run this flexmbd's jobs ({type(e).__name__}: {what}); "
                         f"every worker needs flexmbd {mine[0]} from this source (docs/studies.md)") from None
    for address, got in sorted(theirs.items()):
        if tuple(got) != mine:
            raise InputError(f"{flag}: the Dask worker at {address} has flexmbd {got[0]} with source "
                             f"{str(got[1])[:12]}, this command {mine[0]} with source {mine[1][:12]}: every "
                             f"worker needs the same flexmbd (docs/studies.md)")


def reach(address: str) -> None:
    """Refuse (InputError naming --scheduler and `address`) an address that is not a Dask
    scheduler's (tcp://HOST:PORT; tls:// too, and a bare HOST:PORT), or one where nothing takes a
    TCP connection within CONNECT_S: at once where nothing listens, not after Dask's 30 s."""
    from distributed.comm.addressing import parse_address, parse_host_port
    flag = f"--scheduler {address}"
    try:
        scheme, loc = parse_address(address)
        host, port = parse_host_port(loc, 8786)
    except (ValueError, TypeError) as e:
        raise InputError(f"{flag}: expected tcp://HOST:PORT ({e})") from None
    if not (host and 0 < port < 65536):
        raise InputError(f"{flag}: expected tcp://HOST:PORT, a port from 1 to 65535")
    if scheme not in ("tcp", "tls"):
        return
    try:
        socket.create_connection((host, port), timeout=CONNECT_S).close()
    except OSError as e:
        why = f"nothing answered within {CONNECT_S:g} s" if isinstance(e, TimeoutError) else \
            (e.strerror or str(e) or type(e).__name__).lower()
        raise InputError(f"{flag}: no Dask scheduler answers there ({why})") from None


def dask(jobs: list, order: list, done, started, where: Where, own: dict) -> None:
    """The jobs on a Dask distributed cluster: the one at `where.scheduler`, or a LocalCluster of
    `where.dask_local` single-threaded worker processes on loopback, closed at the end. Dask
    runs a lost worker's jobs again (its `allowed-failures`); a job that kills its workers that
    often is a failed result. Every worker must have this flexmbd and the case files at the same
    paths (docs/studies.md). `own`: k -> the run's own time in its worker (s)."""
    try:
        import dask as dask_
        from dask.distributed import Client, LocalCluster, as_completed
        from distributed.scheduler import KilledWorker
    except ImportError as e:
        raise InputError(f"--scheduler/--dask-local: Dask is not installed ({e}); "
                         f"pip install 'dask[distributed]'") from None
    cluster = None
    if where.scheduler:
        reach(where.scheduler)
    with dask_.config.set({"distributed.scheduler.allowed-failures": TRIES - 1}), _threads_one():
        if where.dask_local:
            cluster = LocalCluster(n_workers=where.dask_local, threads_per_worker=1, processes=True,
                                   host="127.0.0.1", dashboard_address=None, silence_logs=logging.ERROR)
        try:
            client = Client(cluster or where.scheduler, timeout=f"{CONNECT_S if where.scheduler else 30}s")
        except Exception as e:                          # at an address given: whatever answers, if not Dask
            if cluster is not None:
                cluster.close()
            if not (where.scheduler or isinstance(e, (OSError, TimeoutError, ValueError))):
                raise
            flag = f"--scheduler {where.scheduler}" if where.scheduler else f"--dask-local {where.dask_local}"
            what = " ".join(str(e).split())[:200] if isinstance(e, (OSError, TimeoutError)) else \
                f"what answers is not one: {type(e).__name__}"
            raise InputError(f"{flag}: no Dask scheduler answers there ({what})") from None
    try:
        same_flexmbd(client, f"--scheduler {where.scheduler}" if where.scheduler else "--dask-local")
        futures = {client.submit(timed, task(*jobs[k]), pure=False): k for k in order}
        for n, fut in enumerate(as_completed(futures), 1):
            k = futures[fut]
            started(n, k)                               # the cluster says when a job starts: shown as it ends
            try:
                r, own[k] = fut.result()
                r = checked(*jobs[k], r)
            except KilledWorker as e:
                r = lost(*jobs[k], str(e).splitlines()[0])
            done(k, r)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
