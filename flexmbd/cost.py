"""Cost guards: before anything is solved, the memory and time of each stage of a run are estimated
from the case, and a run that would exceed the limits is refused with one line naming the key
that drives its cost (`check`, InputError; `--allow-large` lifts the refusal).

A stage is one step of a solver whose cost a few numbers of the case decide: the FE modes of a
beam (its nodes and retained modes), the integration (its steps and the cost of one step), the
output table and the channels computed from it (its samples). Each estimate is a formula in
those numbers with a constant measured on this project's reference machine (2 cores), rounded up;
they are meant to be right within a factor of a few, which is what a guard needs.

The limits (README.md, "Cost limits"): no stage may need more than MEMORY_LIMIT bytes (so that
the process stays under 4 GB with its libraries), nor take more than SILENT_LIMIT seconds
without showing progress on stderr; a stage that shows progress (the in-house integrator's bar)
may take up to PROGRESS_LIMIT seconds.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass

from flexmbd import flexbody, solvers
from flexmbd.errors import InputError

MEMORY_LIMIT = 3e9          # bytes, of one stage
SILENT_LIMIT = 10.0         # s, a stage that shows no progress
PROGRESS_LIMIT = 3600.0     # s, a stage that shows progress on stderr

DENSE_EIG = 3000            # FE DOFs up to which the modes come from a dense eigensolver (fe.modes)


@dataclass(frozen=True)
class Stage:
    what: str               # what is estimated, with the numbers it is estimated from
    key: str                # the dotted key (or command-line option) that drives the cost
    memory: float           # bytes
    seconds: float
    progress: bool = False  # shows progress on stderr while it runs


# ---------------------------------------------------------------------------------------------
# the refusal


def check(jobs, t_end: float | None = None, allow_large: bool = False) -> None:
    """Refuse (InputError, one line) the first (case, solver) job with a stage beyond the limits;
    solver None: only the FE modes (`flexmbd modes`). Nothing is computed here but estimates.
    With `allow_large` each such stage is announced on stderr instead, and the work goes on."""
    for case, solver in jobs:
        for st in stages(case, solver, t_end):
            why = excess(st)
            if why and not allow_large:
                raise InputError(f"{case.path}: {st.key}: {st.what} {why}; change {st.key} "
                                 f"or pass --allow-large")
            if why:
                print(f"flexmbd: note: {case.name}{' / ' + solver if solver else ''}: {st.key}: {st.what} {why}; "
                      f"going on (--allow-large)", file=sys.stderr, flush=True)


def excess(st: Stage) -> str:
    """'' when a stage is within the limits, else what it needs against which limit."""
    if st.memory > MEMORY_LIMIT:
        return f"needs about {st.memory / 1e9:.3g} GB of memory, beyond the limit of {MEMORY_LIMIT / 1e9:g} GB"
    limit = PROGRESS_LIMIT if st.progress else SILENT_LIMIT
    if st.seconds > limit:
        how = "with progress shown" if st.progress else "without progress shown"
        return f"takes about {_duration(st.seconds)}, beyond the limit of {limit:g} s {how}"
    return ""


def _duration(s: float) -> str:
    return f"{s:.3g} s" if s < 1e5 else f"{s / 86400:.3g} days"


# ---------------------------------------------------------------------------------------------
# the estimates


def stages(case, solver: str | None, t_end: float | None = None) -> list:
    """Every costly stage of `solver` on `case` up to t_end (default: the case's duration)."""
    t_end = case["duration"] if t_end is None else t_end
    if solver is None:
        return modes(case)
    if solvers.status_for(case, solver):               # unavailable or not applicable: nothing runs
        return []
    opt = solvers.settings(case, solver)
    out = {"flexmbd": lambda: modes(case) + flexmbd(case, t_end),
           "exudyn-ffrf": lambda: modes(case) + exudyn_ffrf(case, t_end, opt),
           "fe-linear": lambda: fe_linear(case, t_end, opt),
           "analytic": lambda: analytic(case, t_end, opt),
           "exudyn-beam": lambda: exudyn_beam(case, t_end, opt),
           "mujoco-rod": lambda: mujoco_rod(case, t_end, opt),
           "mujoco": lambda: modes(case, rigid=True) + fixed_step(case, t_end, opt["dt"], "solvers.mujoco.dt", 6e-6),
           "pinocchio": lambda: modes(case, rigid=True)}.get(solver, list)()      # a plug-in: its output only
    return out + [output(case, t_end)]


def samples(case, t_end: float) -> int:
    """Rows of the result table: 0, output_dt, ..., t_end."""
    return int(round(t_end / case["integrator"]["output_dt"])) + 1


def _time_key(case, t_end: float, step_key: str, step: float, default: float) -> str:
    """The key that drives a step count: the step when it is below its default, else the duration."""
    if step < default:
        return step_key
    return "duration" if t_end == case["duration"] else "--t-end"


def output(case, t_end: float) -> Stage:
    """The result table and the channels computed from it: every sample holds the states, the
    per-body frames and forces of one evaluation (flexmbd) and each channel; computing the
    channels of a sample takes about 0.1 ms per body."""
    n, res = samples(case, t_end), case.segmented.resolved
    nb = len(res.bodies)
    per_sample = 8 * (100 * (nb + 1) + 2 * (res.nq + res.nv) + 4 * len(case["channels"]) + 20)
    key = _time_key(case, t_end, "integrator.output_dt", case["integrator"]["output_dt"], 1e-3)
    return Stage(f"storing {n} output samples (duration / output_dt) and their channels", key,
                 memory=n * per_sample, seconds=n * (1e-4 + 1e-4 * nb))


def beams(case, rigid: bool = False) -> list:
    """(name, elements, count, segments) of the beams the modal solvers reduce (a beam declared
    rigid or without modes, or every beam with `rigid`, keeps its mesh, whole, and no modes)."""
    return [(name, b["elements"], 0, 1) if b["rigid"] or rigid or b["modes"]["count"] == 0 else
            (name, b["elements"], b["modes"]["count"], b["segments"])
            for name, b in case["bodies"].items() if b["type"] == "beam"]


def modes(case, rigid: bool = False) -> list:
    """The FE modes of every beam: assembly, the eigensolver (dense up to DENSE_EIG DOFs, else
    sparse shift-invert), the mode shapes and the foreshortening sums (nodes x modes^2); with
    `rigid` only the meshes of the beams (the rigid-limit solvers)."""
    out = []
    for name, elements, m, n_seg in beams(case, rigid):
        el = elements // n_seg
        nodes, dofs = el + 1, 6 * (el + 1)
        if dofs <= DENSE_EIG:
            eig_s, eig_b = 5e-10 * dofs ** 3, 40.0 * dofs ** 2
        else:
            eig_s, eig_b = 6e-7 * el ** 2 + 2e-8 * dofs * m ** 2, 8.0 * dofs * (4 * m + 150)
        shape_s, shape_b = 5e-7 * nodes * m ** 2, 8.0 * (3 * nodes * m ** 2 + 24 * dofs * m + 40 * m ** 2)
        seconds = n_seg * (1e-4 * el + eig_s * (m > 0) + shape_s)
        key = f"bodies.{name}.modes.count" if shape_s > eig_s else f"bodies.{name}.elements"
        seg = f" in each of {n_seg} segments" if n_seg > 1 else ""
        out.append(Stage(f"computing the FE modes of beam {name!r} ({dofs} DOFs, {m} modes{seg})", key,
                         memory=eig_b + shape_b + 8.0 * 200 * dofs, seconds=seconds))
    return out


def flexmbd(case, t_end: float) -> list:
    """The in-house integrator: evaluations x the cost of one (its modal terms grow with modes^2).
    Adaptive methods take at least duration / max_step steps; rk45 and dop853 show no progress."""
    ig, res = case["integrator"], case.segmented.resolved
    m2 = sum(b.modes ** 2 for b in res.bodies)
    nodes = sum(b.nodes for b in res.bodies)
    per_eval = 1e-5 + 5e-8 * m2 + 2e-8 * nodes
    method = ig["method"]
    if method in ("rk4", "fox-goodwin"):
        steps = t_end / ig["dt"]
        evals = steps * (4 if method == "rk4" else res.nv + 3)
        key, how = _time_key(case, t_end, "integrator.dt", ig["dt"], 1e-4), "duration / dt"
    else:
        omega, beam = highest_frequency(case)
        reach = {"adams": 1.0, "dopri5": 3.0, "rk45": 3.0, "dop853": 4.0}[method]     # stable h omega
        steps = max(t_end / ig["max_step"], t_end * omega / reach)
        evals = steps * {"adams": 2, "dopri5": 7, "rk45": 7, "dop853": 13}[method]
        key, how = _time_key(case, t_end, "integrator.max_step", ig["max_step"], 1e-3), "at least duration / max_step"
        if t_end * omega / reach > t_end / ig["max_step"]:
            key = "duration" if t_end == case["duration"] else "--t-end"
            how = f"at least duration x the highest retained frequency of beam {beam!r}, {omega / (2 * math.pi):.3g} Hz"
    return [Stage(f"integrating {steps:.3g} {method} steps ({how})", key, memory=0.0, seconds=evals * per_eval,
                  progress=method not in ("rk45", "dop853"))]


def highest_frequency(case) -> tuple[float, str]:
    """(omega, beam): an estimate of the highest retained natural frequency (rad/s) of the modal
    model, which bounds an explicit method's step (h omega of order 1): the `count` lowest of the
    continuous beam's bending (two planes), axial and torsion frequencies of each segment, at
    most the highest frequency its elements can carry. (0, '') without flexible beams."""
    best = (0.0, "")
    for name, b in case["bodies"].items():
        if b["type"] != "beam" or b["rigid"] or b["modes"]["count"] == 0:
            continue
        mat, sec = case["materials"][b["material"]], flexbody.beam_section(b)
        E, rho, G = mat["E"], mat["rho"], flexbody.shear_modulus(mat)
        Ls, le = b["length"] / b["segments"], b["length"] / b["elements"]
        m = min(b["modes"]["count"], 10000)
        waves = [(j - 0.5) * math.pi for j in range(1, m + 1)]
        freqs = sorted([(w / Ls) ** 2 * math.sqrt(E * I / (rho * sec.A)) for w in waves for I in (sec.Iy, sec.Iz)]
                       + [w / Ls * math.sqrt(E / rho) for w in waves]
                       + [w / Ls * math.sqrt(G * sec.J / (rho * sec.Ip)) for w in waves])
        mesh = max(2.0 * math.sqrt(12.0 * E * max(sec.Iy, sec.Iz) / (rho * sec.A * le ** 4)), 2.0 * math.sqrt(E / rho) / le)
        best = max(best, (min(freqs[m - 1], mesh), name))
    return best


def fixed_step(case, t_end: float, dt: float, key: str, per_step: float) -> list:
    """A solver stepping at dt rounded to divide output_dt."""
    out_dt = case["integrator"]["output_dt"]
    steps = (samples(case, t_end) - 1) * max(round(out_dt / dt), 1)
    return [Stage(f"stepping {steps:.3g} steps of {out_dt / max(round(out_dt / dt), 1):.3g} s", _time_key(case, t_end, key, dt, 1e-4),
                  memory=0.0, seconds=steps * per_step)]


def fe_linear(case, t_end: float, opt: dict) -> list:
    """Full-order FE: the exact scheme exponentiates the dense 2n x 2n system matrix and steps by
    dense products; newmark factorizes once and steps by sparse solves; damping takes a dense
    eigensolution of all n DOFs."""
    (name, body), = case["bodies"].items()
    n = 6 * body["elements"]
    scheme = opt["scheme"]
    dt = opt["dt"] or (case["integrator"]["output_dt"] if scheme == "exact" else 5e-5)
    out_dt = case["integrator"]["output_dt"]
    stride = max(round(out_dt / dt), 1)
    steps = (samples(case, t_end) - 1) * stride
    damped = body["damping_ratio"] > 0
    if scheme == "exact":
        setup_s, setup_b, per_step = 3e-10 * (2 * n) ** 3, 48.0 * (2 * n) ** 2, 1e-9 * (2 * n) ** 2
    else:
        setup_s, setup_b, per_step = 1e-5 * n, 8.0 * 200 * n, 1e-8 * 12 * n + 2e-5
    if damped:
        setup_s, setup_b = setup_s + 5e-10 * n ** 3, setup_b + 40.0 * n ** 2
    matrix = f"bodies.{name}.elements"
    steps_key = "solvers.fe-linear.dt" if opt["dt"] and opt["dt"] < out_dt else \
        ("duration" if t_end == case["duration"] else "--t-end")
    return [Stage(f"setting up the {scheme} scheme for {n} DOFs", matrix, memory=setup_b, seconds=setup_s),
            Stage(f"stepping {n} DOFs through {steps:.3g} {scheme} steps of {out_dt / stride:.3g} s",
                  steps_key if steps * per_step > setup_s else matrix,
                  memory=32.0 * samples(case, t_end) * n, seconds=steps * per_step)]


def analytic(case, t_end: float, opt: dict) -> list:
    """Closed forms: modes per plane x output samples (the modal responses) and x 4001 quadrature
    points (the modal loads of gravity), two planes."""
    n, k = opt["modes"], samples(case, t_end)
    key = "solvers.analytic.modes" if n > 200 else _time_key(case, t_end, "integrator.output_dt",
                                                              case["integrator"]["output_dt"], 1e-3)
    return [Stage(f"summing {n} continuous modes per plane over {k} samples", key,
                  memory=8.0 * n * (6 * k + 3 * 4001), seconds=2e-7 * n * k + 2e-4 * n)]


def exudyn_beam(case, t_end: float, opt: dict) -> list:
    """Exudyn's beam elements: steps x elements (sparse Newton iterations), with progress shown."""
    n_beams = sum(1 for b in case["bodies"].values() if b["type"] == "beam")
    el, out_dt, dt = opt["elements"] * n_beams, case["integrator"]["output_dt"], opt["dt"]
    dt = out_dt / max(round(out_dt / dt), 1) if dt <= out_dt else dt
    steps = t_end / dt
    key = "solvers.exudyn-beam.elements" if el > 10000 else _time_key(case, t_end, "solvers.exudyn-beam.dt", opt["dt"], 1e-4)
    return [Stage(f"stepping {el} beam elements through {steps:.3g} steps", key,
                  memory=8.0 * 6 * (el + n_beams) * 300, seconds=steps * (2e-5 + 2e-6 * el), progress=True)]


def exudyn_ffrf(case, t_end: float, opt: dict) -> list:
    """Exudyn's reduced bodies: steps x the dense modal blocks (modes^2), with progress shown."""
    m2 = sum((m + 7) ** 2 for _, _, m, _ in beams(case))
    out_dt, dt = case["integrator"]["output_dt"], opt["dt"]
    dt = out_dt / max(round(out_dt / dt), 1) if dt <= out_dt else dt
    steps = t_end / dt
    return [Stage(f"stepping the reduced bodies through {steps:.3g} steps", _time_key(case, t_end, "solvers.exudyn-ffrf.dt",
                                                                         opt["dt"], 2.5e-5),
                  memory=0.0, seconds=steps * (5e-5 + 4e-7 * m2), progress=True)]


def mujoco_rod(case, t_end: float, opt: dict) -> list:
    """MuJoCo's rod: steps x edges, with progress shown."""
    edges = opt["edges"]
    st = fixed_step(case, t_end, opt["dt"], "solvers.mujoco-rod.dt", 1e-5 + 4e-6 * edges)[0]
    key = "solvers.mujoco-rod.edges" if edges > 1000 else st.key
    return [Stage(f"{st.what} with a rod of {edges} edges", key, memory=8.0 * 2000 * edges, seconds=st.seconds,
                  progress=True)]
