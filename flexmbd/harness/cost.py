"""Cost guards: before anything is solved, the memory and time of each stage of a run are estimated
from the case, and a run that would exceed the limits is refused with one line naming the key
that drives its cost (`check`, InputError; `--allow-large` lifts the refusal).

A stage is one step of a solver whose cost a few numbers of the case decide: the FE modes of a
beam (its nodes and retained modes), the integration (its steps and the cost of one step), the
output table and the channels computed from it (its samples x channels), the linearized system
of `flexmbd modes --system` (its coordinates), and, for pages built from stored results, the
reading and drawing of each stored result (its samples x columns, from its sidecar and file size,
before it is read). Each estimate is a formula in those numbers with a constant measured on this
project's reference machine (2 cores), rounded up; they are meant to be right within a factor of
a few, which is what a guard needs. What no formula knows is how an adaptive integrator's step
size will go: a model that nears a singular configuration (a beam so soft that it folds) makes
it take far smaller steps than estimated, which the progress bar then shows.

A solver's own stages are its module's knowledge (`stages(case, t_end, settings)`: the in-house
integrator's in solvers/inhouse.py, each peer's in its adapter), built from the shared estimates here (the
FE modes, fixed steps, the key that drives a step count); this module adds the output table every
solver writes, and a plug-in is estimated by that alone.

The limits (README.md, "Cost limits"): no stage may need more than MEMORY_LIMIT bytes (so that
the process stays under 4 GB with its libraries), nor take more than SILENT_LIMIT seconds
without showing progress on stderr; a stage that shows progress (the in-house integrator's bar,
the linearization's) may take up to PROGRESS_LIMIT seconds.
"""

from __future__ import annotations

import json
import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from flexmbd.fe import flexbody
from flexmbd.harness import registry
from flexmbd.core.errors import InputError

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


def check(jobs, t_end: float | None = None, allow_large: bool = False, about: str | None = None) -> None:
    """Refuse (InputError, one line) the first (case, solver) job with a stage beyond the limits;
    solver None: only the FE modes (`flexmbd modes`), and with `about` the linearization about
    that state too (`flexmbd modes --system`). Nothing is computed here but estimates. With
    `allow_large` each such stage is announced on stderr instead, and the work goes on."""
    for case, solver in jobs:
        more = system(case, about) if about and solver is None else []
        for st in stages(case, solver, t_end) + more:
            why = excess(st)
            if why and not allow_large:
                raise InputError(f"{case.path}: {st.key}: {st.what} {why}; change {st.key} "
                                 f"or pass --allow-large")
            if why:
                print(f"flexmbd: note: {case.name}{' / ' + solver if solver else ''}: {st.key}: {st.what} {why}; "
                      f"going on (--allow-large)", file=sys.stderr, flush=True)


def check_stored(sidecars, allow_large: bool = False) -> None:
    """Refuse (InputError, one line naming the sidecar) the first stored result whose reading and
    drawing (`stored`) is beyond the limits, before any is read; with `allow_large` announce it
    on stderr instead."""
    for js in sidecars:
        st = stored(js)
        why = excess(st) if st else ""
        if why and not allow_large:
            raise InputError(f"{js}: {st.key}: {st.what} {why}; resample it to fewer samples (flexmbd import) "
                             f"or pass --allow-large")
        if why:
            print(f"flexmbd: note: {js}: {st.key}: {st.what} {why}; going on (--allow-large)", file=sys.stderr,
                  flush=True)


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
    """Every costly stage of `solver` on `case` up to t_end (default: the case's duration): a
    built-in solver's own, from its module (`stages(case, t_end, settings)`: flexmbd's in
    solvers/inhouse.py, each peer's in its adapter), and the output table every solver writes (`output`)."""
    t_end = case.duration if t_end is None else t_end
    if solver is None:
        return modes(case)
    if registry.status_for(case, solver):               # unavailable or not applicable: nothing runs
        return []
    opt = registry.settings(case, solver)
    own = getattr(registry.module(solver), "stages", None) if solver in registry.BUILT_IN else None
    return (own(case, t_end, opt) if own else []) + [output(case, t_end)]      # a plug-in: its output only


def samples(case, t_end: float) -> int:
    """Rows of the result table: 0, output_dt, ..., t_end."""
    return int(round(t_end / case.integrator.output_dt)) + 1


def time_key(case, t_end: float, step_key: str, step: float, default: float) -> str:
    """The key that drives a step count: the step when it is below its default, else the duration."""
    if step < default:
        return step_key
    return "duration" if t_end == case.duration else "--t-end"


# One value of the result table (a channel at a sample): forming it from the trajectory
# (channels.channels and the points and section strains it reads: 0.04 us a deflection, 0.13 us
# a stress channel), the divergence rule, and writing it into the CSV (pandas' to_csv with
# float_format, 2.3-3.2 us; 1.7 us with few columns), with its arrays and the table's text alive
# (40-93 B). Measured on the pendulum with 500 to 5000 deflection or stress channels over 4001
# samples (`flexmbd run`: 5000 deflections 52 s and 1.6 GB, 1.2 GB above the 0.39 GB of 4
# channels) and on tables of 4001 x 50 to 400001 x 5 values, 2 cores shared.
VALUE_S = 3e-6              # s
VALUE_B = 64.0              # bytes


def output(case, t_end: float) -> Stage:
    """The result table and the channels computed from it: every sample holds the states, the
    per-body frames and forces of one evaluation (flexmbd), which take 0.15 ms and 0.05 ms per
    body to compute (the energies, the trajectory and the validity measures; measured: the
    pendulum 0.21 ms a sample, the double pendulum 0.26 ms, the flexible pendulum's 20 segments
    0.71 ms), and each channel, formed and written as one value of the table (VALUE_S, VALUE_B).
    The key is `channels` when the channels cost a sample more than its states do."""
    n, res = samples(case, t_end), case.modelled
    nb, nc = len(res.tree), len(case.channels)
    per_sample = 8 * (100 * (nb + 1) + 2 * (res.nq + res.nv) + 20)
    state_s = 1.5e-4 + 5e-5 * nb
    key = time_key(case, t_end, "integrator.output_dt", case.integrator.output_dt, 1e-3)
    if nc * VALUE_S > state_s:
        key = "channels"
    return Stage(f"forming and storing {nc} channels at {n} output samples (duration / output_dt), "
                 f"{n * (nc + 1):.3g} values", key, memory=n * (per_sample + VALUE_B * (nc + 1)),
                 seconds=n * (state_s + VALUE_S * (nc + 1)))


# One stored value (a column of a stored result at a sample) on a case page: read and checked
# (0.2-0.4 us), compared (accuracy measures, spectra) and drawn (PNG and SVG; matplotlib's
# legend placement goes over every point). Measured with `report --no-run` on the pendulum with
# an imported result of 3e5, 1e6 and 3e6 samples x 5 columns beside flexmbd's: 2.6, 2.5 and 5.3
# us and 84, 78 and 83 B a value more than without it (the 3e6: 80 s and 1.2 GB more), 2 cores
# shared. A value takes 14.7-16.1 B of CSV text, at most 18 (%.10g: 17 characters and a comma).
STORED_S = 6e-6             # s
STORED_B = 96.0             # bytes
CSV_B = 18.0                # bytes of CSV per value, at most
SIDECAR_MAX = 16e6          # bytes: a larger sidecar is not opened for its size (its CSV's is used)


def stored(js) -> Stage | None:
    """Reading and drawing the stored result of sidecar `js` (RESULTS/CASE/SOLVER.json), estimated
    before it is read: its values are the sidecar's samples x (channels + 1), or its CSV's size
    over CSV_B when that is more (a sidecar that does not say, or a CSV that is not its own). None
    when neither tells (reading the result says what is wrong with it)."""
    js = Path(js)
    csv = js.with_suffix(".csv")
    try:
        meta = json.loads(js.read_bytes()) if js.stat().st_size <= SIDECAR_MAX else {}
        rows, cols = int(meta["samples"]), len(meta["channels"]) + 1
    except (OSError, ValueError, TypeError, KeyError, RecursionError):
        rows, cols = 0, 0
    try:
        size = csv.stat().st_size
    except OSError:
        size = 0
    values = max(rows * cols, size / CSV_B)
    if not values:
        return None
    what = (f"reading and drawing its {rows} samples x {cols} columns" if rows * cols >= size / CSV_B else
            f"reading and drawing about {values:.3g} values ({size / 1e6:.3g} MB of CSV)")
    return Stage(what, "samples", memory=STORED_B * values, seconds=STORED_S * values)


def beams(case, rigid: bool = False) -> list:
    """(name, elements, count, segments) of the beams the modal solvers reduce (a beam declared
    rigid or without modes, or every beam with `rigid`, keeps its mesh, whole, and no modes)."""
    return [(name, b.elements, 0, 1) if b.rigid or rigid or b.modes.count == 0 else
            (name, b.elements, b.modes.count, b.segments)
            for name, b in case.bodies.items() if b.type == "beam"]


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
    for name, b in case.bodies.items():
        if b.type == "solid":
            dofs = solid_dofs(b)
            out.append(Stage(f"assembling and reducing solid {name!r} ({dofs} DOFs, {b.modes.count} modes)",
                             f"bodies.{name}.mesh", memory=SOLID_BYTES * dofs, seconds=SOLID_SECONDS * dofs))
    return out


# a solid's assembly and clamped-interface modes (fe.solid), per DOF of its mesh: measured with
# benchmarks/solid_reduction.py on hex20 meshes, 12 modes: 5,463 / 23,511 / 64,053 DOFs in
# 0.4 / 4.1 / 10.4 s, peak 118 / 248 / 613 MB (the process's whole resident memory)
SOLID_SECONDS, SOLID_BYTES = 2e-4, 1.2e4


def solid_nodes(b) -> int:
    """The node count of a case solid's mesh."""
    import dataclasses
    return flexbody.solid_mesh(**dataclasses.asdict(b.mesh)).n_nodes


def solid_dofs(b) -> int:
    """The DOF count of a case solid's mesh: three a node, six a node of a frame."""
    return (6 if b.is_frame else 3) * solid_nodes(b)


def evaluation(case) -> float:
    """Seconds of one evaluation of the in-house equations (forward dynamics of the modelled
    tree): 10 us per body, and per flexible body 3e-8 m^2 + 2.5e-10 m^3 s for its m retained modes
    (its modal blocks); the mesh does not enter. Measured, the best of 5 x 50 right-hand sides at
    the initial state (2 cores shared): the pendulum 16 us (12 modes; 13 us with 1000 elements),
    the double pendulum 30 us, 20 segments of 8 modes 312 us, 5 segments of 40 modes 351 us, one
    beam of 100 modes 325 us, 200 modes 2.5 ms, 400 modes 17.8 ms; the formula is within a factor
    of 2 of each."""
    return sum(1e-5 + 3e-8 * b.modes ** 2 + 2.5e-10 * b.modes ** 3 for b in case.modelled.tree)


def highest_frequency(case) -> tuple[float, str]:
    """(omega, beam): an estimate of the highest retained natural frequency (rad/s) of the modal
    model, which bounds an explicit method's step (h omega of order 1): the `count` lowest of the
    continuous beam's bending (two planes), axial and torsion frequencies of each segment, at
    most the highest frequency its elements can carry. (0, '') without flexible beams."""
    best = (0.0, "")
    for name, b in case.bodies.items():
        if b.type == "solid" and b.flexible:            # as the beam of its bounding box's section
            best = max(best, (solid_frequency(b), name))
        if b.type != "beam" or not b.flexible:
            continue
        sec = b.geometry
        E, rho, G = b.material.E, b.material.rho, b.material.G
        Ls, le = b.length / b.segments, b.length / b.elements
        m = min(b.modes.count, 10000)
        waves = [(j - 0.5) * math.pi for j in range(1, m + 1)]
        freqs = sorted([(w / Ls) ** 2 * math.sqrt(E * I / (rho * sec.A)) for w in waves for I in (sec.Iy, sec.Iz)]
                       + [w / Ls * math.sqrt(E / rho) for w in waves]
                       + [w / Ls * math.sqrt(G * sec.J / (rho * sec.Ip)) for w in waves])
        mesh = max(2.0 * math.sqrt(12.0 * E * max(sec.Iy, sec.Iz) / (rho * sec.A * le ** 4)), 2.0 * math.sqrt(E / rho) / le)
        best = max(best, (min(freqs[m - 1], mesh), name))
    return best


def solid_frequency(b) -> float:
    """An estimate (rad/s) of a solid's highest retained frequency: the `count`-th bending or
    axial frequency of a clamped beam with the solid's largest extent as length and the other two
    as a rectangular section."""
    import dataclasses
    mesh = flexbody.solid_mesh(**dataclasses.asdict(b.mesh))
    L, h, w = sorted(np.ptp(mesh.nodes, axis=0), reverse=True)
    if mesh.is_frame:                                   # a frame: its bars' largest I / A, as d^2 / 12
        h = w = math.sqrt(12.0 * float((mesh.bars[:, 1:3].max(axis=1) / mesh.bars[:, 0]).max()))
    E, rho, m = b.material.E, b.material.rho, min(b.modes.count, 10000)
    waves = [(j - 0.5) * math.pi for j in range(1, m + 1)]
    freqs = sorted([(k / L) ** 2 * math.sqrt(E * d * d / (12.0 * rho)) for k in waves for d in (h, w)]
                   + [k / L * math.sqrt(E / rho) for k in waves])
    return freqs[m - 1]


def system(case, about: str = "initial") -> list:
    """`flexmbd modes --system` (solvers/linearize.py) beyond the FE modes: the state matrix by central
    differences, 4 evaluations per free coordinate and one more for the mass matrix of the labels
    (`linearize.mass_matrix`; `evaluation` each), with progress shown; its dense eigenproblem, 2n x 2n, no progress (one LAPACK call:
    7e-9 (2n)^3 s, measured with numpy's eig of random 400^2 to 1600^2 matrices on 2 busy cores;
    the system's own matrices take 2-5e-9; A, its blocks, eigenvectors and workspace 80 B (2n)^2);
    and with `about` = 'equilibrium' the descent to it, about 2.5 n^2 energies (BFGS with
    difference gradients: 1539, 10737 and 25080 of them for 26, 64 and 114 coordinates), no
    progress. The key: the beam with the most modal coordinates (its modes.count, or its
    segments when they multiply them more)."""
    res = case.modelled
    n, per = res.nv, evaluation(case)
    biggest = max(((b.modes.count * b.segments, name, b) for name, b in case.bodies.items()
                   if b.type == "beam" and not b.rigid), default=(0, "", None))
    key = "bodies" if biggest[2] is None else (f"bodies.{biggest[1]}.segments"
                                               if biggest[2].segments > biggest[2].modes.count
                                               else f"bodies.{biggest[1]}.modes.count")
    out = [Stage(f"linearizing {n} coordinates by central differences ({4 * n} evaluations)", key,
                 memory=8.0 * 6 * n * n, seconds=5 * n * per, progress=True),
           Stage(f"solving the {2 * n} x {2 * n} eigenproblem of the linearized system", key,
                 memory=80.0 * (2 * n) ** 2, seconds=7e-9 * (2 * n) ** 3)]
    if about == "equilibrium":
        out.append(Stage(f"descending to the static equilibrium over {n} coordinates (about {2.5 * n * n:.3g} "
                         f"energy evaluations)", key, memory=8.0 * 2 * n * n, seconds=2.5 * n * n * per))
    return out


def fixed_step(case, t_end: float, dt: float, key: str, per_step: float) -> list:
    """A solver stepping at dt rounded to divide output_dt."""
    out_dt = case.integrator.output_dt
    steps = (samples(case, t_end) - 1) * max(round(out_dt / dt), 1)
    return [Stage(f"stepping {steps:.3g} steps of {out_dt / max(round(out_dt / dt), 1):.3g} s", time_key(case, t_end, key, dt, 1e-4),
                  memory=0.0, seconds=steps * per_step)]

