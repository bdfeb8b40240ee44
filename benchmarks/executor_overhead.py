"""The executor's scheduling overhead: 200 points of a cheap grid (the continuous-beam closed form,
`analytic`, on `cantilever_step`'s 2 s, with 300 ... 499 modes summed: a few tenths of a second
each), run once one after another in this process, timing each run (`registry.run`: the runs' own
times), then on the local pool of `workers` processes, and on a Dask LocalCluster of as many
workers. Run from the repository root, on an otherwise idle machine, several times (the figures
move by a few percent from run to run on a shared machine):

    .venv/bin/python benchmarks/executor_overhead.py [workers] [points]

For each executor it prints its wall time and two overheads, each wall x workers / (a sum of the
runs' own times) - 1:

- `scheduling`: against the runs' own times where each ran (`registry.run` timed in its worker,
  `executor.execute`'s `own`). It counts what keeps a worker from running a job: starting the
  workers (forked on Linux: at once; spawned or on Dask: the interpreter and flexmbd's imports,
  about a second each), the estimates and the
  order, a job's trip through the pipe, and the imbalance at the end.
- `against one process`: against the runs timed here one after another. It adds what sharing
  the cores costs the runs: with as many workers as cores, the command's own process (receiving
  and writing every result: a CSV of 2001 rows and its sidecar) and the workers' imports take
  CPU time from the runs; `contention` is how much longer the runs took in the workers.

The runs are a few tenths of a second and not a few milliseconds because a worker's start is a
fixed cost of about a second. The tests check that every executor gives the same results; how
much they cost is measured here, not asserted there.
"""

import sys
import tempfile
import time
from pathlib import Path

from flexmbd import cases
from flexmbd.harness import executor, results, registry


def grid(points: int) -> list:
    return [(cases.load("cantilever_step", [f"solvers.analytic.modes={300 + k}"]), "analytic") for k in range(points)]


def own_times(jobs: list) -> float:
    """The sum of the runs' own times: each run in this process, timed alone."""
    total = 0.0
    for case, solver in jobs:
        t0 = time.perf_counter()
        registry.run(case, solver)
        total += time.perf_counter() - t0
    return total


def wall(jobs: list, where: executor.Where) -> tuple[float, float]:
    """The wall time of the jobs run where `where` says, each result written as a command writes
    it, and the sum of the runs' own times where they ran."""
    own = {}
    with tempfile.TemporaryDirectory() as out:
        t0 = time.perf_counter()
        executor.execute(jobs, lambda k, r: results.write(r, Path(out) / str(k)), where, own=own)
        return time.perf_counter() - t0, sum(own.values())


def main(workers: int = 2, points: int = 200) -> None:
    jobs = grid(points)
    registry.run(*jobs[0])                               # imports and caches warm, as in a long study
    here = own_times(jobs)
    print(f"{points} runs of {jobs[0][1]}: sum of their own times {here:.2f} s ({here / points * 1e3:.1f} ms each)")
    for name, where in (("local pool", executor.Where(workers=workers)),
                        ("Dask LocalCluster", executor.Where(dask_local=workers))):
        w, there = wall(jobs, where)
        print(f"{name:18s} {workers} workers: wall {w:.2f} s, overhead: scheduling {w * workers / there - 1:+.1%}, "
              f"against one process {w * workers / here - 1:+.1%} (contention {there / here - 1:+.1%})")


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:3]))
