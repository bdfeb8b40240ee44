"""`flexmbd`, the in-house solver, behind the same interface as every other solver (solvers.py)."""

from __future__ import annotations

import sys
import time

import numpy as np

import flexmbd
from flexmbd import flexbody, integrate, outputs
from flexmbd.build import from_case
from flexmbd.kernel import jit
from flexmbd.results import Result

SETTINGS = {}           # the case's [integrator] table holds this solver's settings


def version() -> str:
    return flexmbd.__version__


def applies(case) -> str:
    return ""


def run(case, t_end, settings, progress: bool = True) -> Result:
    t0 = time.perf_counter()
    model = from_case(case, flexbody.for_case(case))
    setup_s = time.perf_counter() - t0

    # compile (or load from the cache) before the clock starts
    if not jit.is_cached():
        print("flexmbd: compiling the solver's kernels once for this source version "
              "(a few minutes; cached afterwards)", file=sys.stderr, flush=True)
    t0 = time.perf_counter()
    integrate.warm_up(model)
    compile_s = time.perf_counter() - t0

    ig = case["integrator"]
    sim = integrate.simulate(model, t_end, method=ig["method"], rtol=ig["rtol"], atol=ig["atol"],
                             max_step=ig["max_step"], dt=ig["dt"], output_dt=ig["output_dt"],
                             progress=progress, label=f"{case.name} / flexmbd")
    ch = outputs.channels(case, model, sim.t, sim.q, sim.v)
    modes = {n: {"count": fb.n_modes, "boundary": fb.boundary, "freq_hz": np.round(fb.freq_hz, 4).tolist()}
             for n, fb in model.bodies.items()}
    kinetic_max = float(outputs.energies(model, sim.q, sim.v)[:, 0].max()) if len(sim.t) else 0.0
    return Result(solver="flexmbd", case=case.name, t=sim.t, channels=ch, status=sim.status,
                  wall_s=sim.wall_s, setup_s=setup_s, steps=sim.steps, rhs_evals=sim.rhs_evals,
                  settings={**sim.settings, "modes": modes},
                  extra={"compile_s": compile_s, "kinetic_max_J": kinetic_max})
