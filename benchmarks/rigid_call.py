"""One rigid-chain evaluation from Python, taken apart: what the call costs before any work, and
what the work costs, against Pinocchio's `aba` on the same chain.

    .venv/bin/python benchmarks/rigid_call.py [N ...]        (default: 1 2 8 links)

For each n-link revolute chain of `flexmbd bench` (`bench.chain_case`) at the bench's fixed
random state (`bench.state`), in microseconds per call:

    forward     `compiled.entry.forward(model, data, t, q, v, tau)`, as `flexmbd bench` times it
    dispatch    numba's dispatch of a compiled function with `_accelerations`' six arguments and
                an empty body: the price of calling compiled code from Python with them
    python      the rest of `forward` in Python: the call, finding the model's bound kernel data
                (two identity checks), returning data.qdd (forward - dispatch - compiled)
    compiled    the evaluation itself, called from a compiled loop (no dispatch)
    aba         `pinocchio.aba(model, data, q, v, tau)` on the same chain

Medians of 7 x 2000 calls (`bench.median_us`); the compiled loop best of one run of 2e5 calls.
Nothing is written. Times vary by about 20 % between processes on the 2-core machine.
"""

from __future__ import annotations

import sys
import time

from numba import njit


def main(ns) -> None:
    import pinocchio as pin

    from flexmbd.report import bench
    from flexmbd.solvers import pinocchio_model
    from flexmbd.solvers.build import from_case
    from flexmbd.mbd.compiled.bound import call_entry
    from flexmbd.mbd.compiled.entry import ACCELERATIONS, _bound_of, forward
    from flexmbd.mbd.model import make_data

    @njit
    def empty(fn, address, t, q, v, tau):
        return None

    @njit
    def loop(fn, address, t, q, v, tau, out, mode, calls):
        for _ in range(calls):
            call_entry(fn, address, t, q, v, tau, out, mode)

    print("| links | forward | dispatch | python | compiled | aba |")
    print("|---|---|---|---|---|---|")
    for n in ns:
        model = from_case(bench.chain_case(n, flexible=False))
        data = make_data(model)
        q, v, tau = bench.state(model)
        *_, fn, address = _bound_of(model, data)
        pm, _ = pinocchio_model.build(model)
        pd = pm.createData()
        loop(fn, address, 0.0, q, v, tau, q, ACCELERATIONS, 1)
        calls = 200_000
        t0 = time.perf_counter()
        loop(fn, address, 0.0, q, v, tau, q, ACCELERATIONS, calls)
        compiled = (time.perf_counter() - t0) / calls * 1e6
        whole = bench.median_us(lambda: forward(model, data, 0.0, q, v, tau))
        dispatch = bench.median_us(lambda: empty(fn, address, 0.0, q, v, tau))
        row = [whole, dispatch, whole - dispatch - compiled, compiled,
               bench.median_us(lambda: pin.aba(pm, pd, q, v, tau))]
        print(f"| {n} | " + " | ".join(f"{x:.2f}" for x in row) + " |")


if __name__ == "__main__":
    main([int(a) for a in sys.argv[1:]] or [1, 2, 8])
