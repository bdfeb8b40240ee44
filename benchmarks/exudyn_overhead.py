"""What Python costs an Exudyn solve: the CPU time of one exudyn-ffrf or exudyn-beam solve as the
adapter runs it, against the same solve with a Python function called at every step (as a progress
bar fed by a pre-step function would be), with the prescribed joint motion as a Python function
instead of a symbolic one (cases with a driven joint) and, for exudyn-ffrf, against the step means
recorded by a post-step function and against the solve that stores its sensors at the output steps
only (no step means). Run from the repository root:

    .venv/bin/python benchmarks/exudyn_overhead.py [case] [t_end] [repeats]

(default: pendulum, 0.25 s, 5). The variants are run in turn, `repeats` times each; it prints the
smallest and the median CPU time of each, and the median's excess over the adapter's. On a shared
machine take the smallest: another process's load only adds to a time.
"""

import contextlib
import sys
import time

import numpy as np

from flexmbd import cases
from flexmbd.fe import flexbody
from flexmbd.harness import registry
from flexmbd.solvers import exudyn_beam as xb
from flexmbd.solvers import exudyn_common as xc
from flexmbd.solvers import exudyn_ffrf as xf


def ffrf(case, t_end: float, variant: str):
    """(mbs, settings, solver) of an exudyn-ffrf solve in one of the variants."""
    opt = xf.options(registry.settings(case, "exudyn-ffrf"))
    dt, out_dt = xf.step_size(case, opt), case.integrator.output_dt
    sim = xc.simulation_settings(case, t_end, dt, opt)
    with xc.quiet(), python_motion(variant == "python motion"):
        SC, mbs, items, S, joints = xf.build(case, flexbody.for_case(case), opt["rotary_inertia"], opt["gravity"])
        if variant in ("adapter", "pre-step", "python motion") and xf.step_sensors(S):
            xf.write_around_outputs(mbs, sim, dt, out_dt)
        mbs.Assemble()
    if variant == "pre-step":
        mbs.SetPreStepUserFunction(lambda mbs_, t: True)
    if variant == "post-step":
        mbs.SetPostStepUserFunction(post_step_record(xf.step_sensors(S), dt, out_dt))
    return SC, mbs, sim, opt["solver"]


@contextlib.contextmanager
def python_motion(on: bool):
    """Within the block, prescribed joint motion is built as a Python user function (when on)."""
    kinds = xc.SYMBOLIC
    xc.SYMBOLIC = () if on else kinds
    try:
        yield
    finally:
        xc.SYMBOLIC = kinds


def post_step_record(sensors: list, dt: float, out_dt: float):
    """A post-step function keeping the values of `sensors` at the steps next to and at every output
    step (how the step means were once recorded)."""
    every, rec = int(round(out_dt / dt)), {}

    def post_step(mbs_, t):
        i = int(round(t / dt))
        if min(i % every, every - i % every) <= 1:
            rec[i] = {x: np.asarray(mbs_.GetSensorValues(x), dtype=float) for x in sensors}
        return True
    return post_step


def beam(case, t_end: float, variant: str):
    """(mbs, settings, solver) of an exudyn-beam solve: as the adapter runs it, with a pre-step
    function, or with the prescribed motion as a Python function."""
    opt = {k: d for k, (_, d) in xb.SETTINGS.items()} | registry.settings(case, "exudyn-beam")
    out_dt = case.integrator.output_dt
    dt = out_dt / max(int(round(out_dt / opt["dt"])), 1) if opt["dt"] <= out_dt else opt["dt"]
    with xc.quiet(), python_motion(variant == "python motion"):
        SC, mbs, beams, S = xb.build(case, opt["elements"])
    sim = xc.simulation_settings(case, t_end, dt, opt)
    if opt["newton_atol"] is not None:
        sim.timeIntegration.newton.absoluteTolerance = opt["newton_atol"]
    if variant == "pre-step":
        mbs.SetPreStepUserFunction(lambda mbs_, t: True)
    return SC, mbs, sim, opt["solver"]


def cpu_s(build, case, t_end: float, variant: str) -> float:
    SC, mbs, sim, solver = build(case, t_end, variant)
    t0 = time.process_time()
    status = xc.solve(mbs, sim, solver)[0]
    assert status.ok, status
    return time.process_time() - t0


def main(name: str = "pendulum", t_end: float = 0.25, repeats: int = 5) -> None:
    case = cases.load(name)
    driven = ["python motion"] if any(j.motion is not None for j in case.joints.values()) else []
    runs = {"exudyn-ffrf": (ffrf, ["adapter", "no step means", "pre-step", "post-step"] + driven),
            "exudyn-beam": (beam, ["adapter", "pre-step"] + driven)}
    for solver, (build, variants) in runs.items():
        if registry.status_for(case, solver):              # not applicable or unavailable
            continue
        got = {v: [] for v in variants}
        for _ in range(repeats):
            for v in variants:
                got[v].append(cpu_s(build, case, t_end, v))
        base = np.median(got["adapter"])
        for v in variants:
            r = np.array(got[v])
            print(f"{name} {solver:12s} {v:14s} smallest {r.min():6.3f} s, median {np.median(r):6.3f} s "
                  f"({100 * (np.median(r) / base - 1):+5.1f} %)", flush=True)


if __name__ == "__main__":
    args = sys.argv[1:]
    main(args[0] if args else "pendulum", float(args[1]) if len(args) > 1 else 0.25,
         int(args[2]) if len(args) > 2 else 5)
