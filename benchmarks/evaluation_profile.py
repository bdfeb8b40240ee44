"""Where the time of one evaluation goes: the articulated-body algorithm's passes, timed in a
compiled loop, with the cost of reaching them from Python and from the integrators.

    .venv/bin/python benchmarks/evaluation_profile.py [--json FILE]

For each model (the paper's cantilever, the pendulum and the double pendulum as their cases
build them, and 8-link rigid and flexible chains of `flexmbd bench`) at the bench's fixed random
state (`bench.evaluation`):

    passes      one compiled loop runs the passes of `dynamics.aba` cumulatively, the first k
                of (prescribed, forward_kinematics, external_forces, body_forces,
                articulated_inertias, accelerations); a pass's cost is the difference between
                k and k-1 (each pass reads only what the ones before it wrote)
    entry       the whole evaluation through the kernel's C entry, as the integrators reach it
                (`compiled.bound.call_entry`, [dq/dt; qdd] written)
    python      `compiled.entry.forward` from Python, as a user calls it (`bench.median_us`)

Best of 7 repeats of a loop of many evaluations, in microseconds per evaluation. The compiled
loop is compiled here (about half a minute); nothing else is written. Times vary by about 20 %
between processes on the 2-core machine: read the shares, not the last digit.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np

from flexmbd import cases
from flexmbd.report.bench import chain_case, evaluation, median_us
from flexmbd.solvers.build import from_case
from flexmbd.mbd.dynamics import (accelerations, articulated_inertias, body_forces, external_forces,
                                  forward_kinematics, prescribed)
from flexmbd.mbd.compiled.jit import njit
from flexmbd.mbd.compiled.bound import bind, bound_at, call_entry
from flexmbd.mbd.compiled.entry import entry_address
from flexmbd.mbd.model import make_data

PASSES = ("prescribed", "forward_kinematics", "external_forces", "body_forces",
          "articulated_inertias", "accelerations")


@njit
def _passes(address, n, upto, t, q0, v0, tau):
    """n evaluations of the first `upto` passes of `dynamics.aba` for the Bound at `address`."""
    b = bound_at(address)
    model, data = b.model, b.data
    for _ in range(n):
        q, v = q0, v0
        if upto >= 1:
            q, v = prescribed(model, data, t, q0, v0)
        if upto >= 2:
            forward_kinematics(model, data, q, v)
        if upto >= 3:
            external_forces(model, data, q)
        if upto >= 4:
            body_forces(model, data, q, v, tau)
        if upto >= 5:
            articulated_inertias(model, data, tau)
        if upto >= 6:
            accelerations(model, data)


@njit
def _entry(fn, address, n, t, q, v, tau, out):
    """n evaluations through the C entry at `fn`, [dq/dt; qdd] into out."""
    for _ in range(n):
        call_entry(fn, address, t, q, v, tau, out, 1)


def best_us(f, n: int, repeats: int = 7) -> float:
    """The best of `repeats` timings of f(n), per call, in microseconds."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        f(n)
        times.append(time.perf_counter() - t0)
    return min(times) / n * 1e6


def profile(model, n: int) -> dict:
    """The passes' and the calls' times (us per evaluation) for one model."""
    f, (q, v, tau) = evaluation(model)
    b = bind(model, make_data(model))
    fn = entry_address()
    out = np.empty(q.size + v.size)
    cumulative = [best_us(lambda k, u=upto: _passes(b.address, k, u, 0.0, q, v, tau), n)
                  for upto in range(len(PASSES) + 1)]
    row = {p: cumulative[i + 1] - cumulative[i] for i, p in enumerate(PASSES)}
    row["passes"] = cumulative[-1] - cumulative[0]
    row["entry"] = best_us(lambda k: _entry(fn, b.address, k, 0.0, q, v, tau, out), n)
    row["python"] = median_us(f)
    row["nv"] = int(model.nv)
    return row


def models() -> dict:
    """The profiled models, by label."""
    out = {}
    for name in ("cantilever_step", "pendulum", "double_pendulum"):
        out[name] = from_case(cases.load(name))
    out["rigid chain, 8 links"] = from_case(chain_case(8, flexible=False))
    out["flexible chain, 8 beams"] = from_case(chain_case(8, flexible=True))
    return out


def table(rows: dict) -> str:
    """The profile as a Markdown table: us per evaluation, a pass's share of the passes' sum."""
    head = "| model | nv | " + " | ".join(PASSES) + " | all passes | C entry | from Python |"
    lines = [head, "|" + "---|" * (len(PASSES) + 5)]
    for label, r in rows.items():
        cells = [f"{r[p]:.2f} ({100 * r[p] / r['passes']:.0f} %)" for p in PASSES]
        lines.append(f"| {label} | {r['nv']} | " + " | ".join(cells)
                     + f" | {r['passes']:.2f} | {r['entry']:.2f} | {r['python']:.2f} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--json", help="also write the rows as JSON to this file")
    args = parser.parse_args(argv)
    print("compiling the profile's loops (about half a minute) ...", file=sys.stderr)
    rows = {}
    for label, model in models().items():
        calls = 20000 if model.nv < 20 else 2000
        rows[label] = profile(model, calls)
        print(f"  {label}: {rows[label]['passes']:.2f} us", file=sys.stderr)
    print(table(rows))
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
