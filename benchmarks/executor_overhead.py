"""The executor's scheduling overhead: 200 points of a cheap grid (the continuous-beam closed form,
`analytic`, on `cantilever_step`'s 2 s, with 300 ... 499 modes summed: a few tenths of a second
each), run once one after another in this process, timing each run (`solvers.run`: the runs' own
times), then on the local pool of `workers` processes, and on a Dask LocalCluster of as many
workers. Run from the repository root, on an otherwise idle machine:

    .venv/bin/python benchmarks/executor_overhead.py [workers] [points]

It prints, for each executor, its wall time and its overhead: wall x workers / (sum of the runs'
own times) - 1, which counts everything that is not a run (starting the workers, sending each
case and result through a pipe, loading the case in the worker, writing the results) and any
imbalance at the end. Its fixed part, starting the workers (about a second each: the interpreter
and flexmbd's imports), is why the runs are a few tenths of a second and not a few milliseconds.
The tests check that every executor gives the same results; how much they
cost is measured here, not asserted there.
"""

import sys
import tempfile
import time
from pathlib import Path

from flexmbd import cases, executor, results, solvers


def grid(points: int) -> list:
    return [(cases.load("cantilever_step", [f"solvers.analytic.modes={300 + k}"]), "analytic") for k in range(points)]


def own_times(jobs: list) -> float:
    """The sum of the runs' own times: each run in this process, timed alone."""
    total = 0.0
    for case, solver in jobs:
        t0 = time.perf_counter()
        solvers.run(case, solver)
        total += time.perf_counter() - t0
    return total


def wall(jobs: list, where: executor.Where) -> float:
    with tempfile.TemporaryDirectory() as out:
        t0 = time.perf_counter()
        executor.execute(jobs, lambda k, r: results.write(r, Path(out) / str(k)), where)
        return time.perf_counter() - t0


def main(workers: int = 2, points: int = 200) -> None:
    jobs = grid(points)
    solvers.run(*jobs[0])                               # imports and caches warm, as in a long study
    own = own_times(jobs)
    print(f"{points} runs of {jobs[0][1]}: sum of their own times {own:.2f} s ({own / points * 1e3:.1f} ms each)")
    for name, where in (("local pool", executor.Where(workers=workers)),
                        ("Dask LocalCluster", executor.Where(dask_local=workers))):
        w = wall(jobs, where)
        print(f"{name:18s} {workers} workers: wall {w:.2f} s, overhead {w * workers / own - 1:+.1%}")


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:3]))
