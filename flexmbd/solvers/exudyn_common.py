"""What the two Exudyn adapters share: import, silence, solver settings, sensors, failures.

Exudyn prints progress and solver statistics to stdout; everything here runs with its console
output off, so `flexmbd run --json` keeps a clean stdout. A failed Exudyn solve (no Newton
convergence, singular system, exception) becomes a `failed: ...` Result carrying Exudyn's own
error text.

A solve runs as Exudyn's own users run one: no Python function is called at every step. The
progress bar reads Exudyn's own progress line (one every 2 s, `ConsoleProgress`), a signal is
noticed by Exudyn itself, which runs Python's signal handlers between steps, and prescribed joint
motion is a symbolic user function Exudyn evaluates in C++ (`motion_expr`, `symbolic`). The
divergence rule is checked at each output sample by a sensor user function (`watch`), which stops
a run that has failed.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import sys
import time
from dataclasses import replace
from types import MappingProxyType

import numpy as np

import exudyn as exu                     # ImportError here: the adapters are 'unavailable'
import exudyn.itemInterface as eii       # noqa: F401  (used by the adapters)
from exudyn.advancedUtilities import CreateSymbolicUserFunction

from flexmbd.harness import channels, results
from flexmbd.core import files
from flexmbd.core.errors import InputError
from flexmbd.mbd import profiles
from flexmbd.solvers import common
from flexmbd.harness.progress import Progress

from flexmbd.mbd.spatial import expm_so3

# solver name in the case file -> Exudyn's implicit solver type. "fox-goodwin" is Exudyn's
# generalized-alpha solver switched to Newmark beta = 1/12, gamma = 1/2 with index-2 constraints:
# no numerical damping, phase error (w h)^4/480 against the trapezoidal rule's (w h)^2/12, but
# only stable for w_max h < sqrt(6) (docs/exudyn.md)
IMPLICIT = {"generalized-alpha": exu.DynamicSolverType.GeneralizedAlpha,
            "trapezoidal-index2": exu.DynamicSolverType.TrapezoidalIndex2,
            "fox-goodwin": exu.DynamicSolverType.GeneralizedAlpha}


def version() -> str:
    return exu.__version__


def silence() -> None:
    """Exudyn's console output off."""
    console(False)


def console(on: bool) -> None:
    """Exudyn's console output on or off (the config flag; the older call where there is no flag)."""
    if hasattr(exu, "config") and hasattr(exu.config, "printToConsole"):
        exu.config.printToConsole = on
    else:
        exu.SetWriteToConsole(on)


def system():
    """A fresh (SystemContainer, MainSystem); the container must outlive the system."""
    silence()
    SC = exu.SystemContainer()
    return SC, SC.AddSystem()


@contextlib.contextmanager
def quiet(progress=None):
    """Silence Exudyn's C++ console output (fd 1) and Python prints while building / solving.

    With `progress`, a function of the simulated time (s), Exudyn's console output is switched on
    but read instead of printed: its progress lines go to `progress` (`ConsoleProgress`)."""
    silence()
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            with contextlib.redirect_stdout(ConsoleProgress(progress) if progress else io.StringIO()):
                if progress:
                    console(True)                        # Exudyn prints through Python's sys.stdout
                yield
    finally:
        silence()
        sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(saved)


class ConsoleProgress(io.TextIOBase):
    """Exudyn's console output during a solve, read instead of printed: each of its progress lines
    ('STEP9111, t = 0.9111s', one every 2 s of wall time with `verboseMode` 1) hands the simulated
    time to `progress`; everything else is dropped."""

    TIME = re.compile(r"\bt = ([-+0-9.eE]+) ?s\b")

    def __init__(self, progress):
        self.progress = progress

    def writable(self) -> bool:
        return True

    def write(self, text: str) -> int:
        m = self.TIME.search(text)
        if m:
            self.progress(float(m.group(1)))
        return len(text)


def simulation_settings(case, t_end: float, dt: float, solver: dict):
    """Exudyn SimulationSettings: fixed step dt (s), implicit solver, no files, sensors in memory
    at output_dt, Exudyn's progress line every 2 s (read by `solve`, never printed).

    `solver`: solver, spectral_radius, newton_rtol, adaptive (bool), as in the adapters' SETTINGS.
    """
    s = exu.SimulationSettings()
    ti = s.timeIntegration
    ti.endTime = t_end
    ti.numberOfSteps = max(int(round(t_end / dt)), 1)
    ti.verboseMode = 1
    ti.stepInformation = 0
    ti.adaptiveStep = bool(solver["adaptive"])
    ti.newton.relativeTolerance = solver["newton_rtol"]
    ti.newton.absoluteTolerance = solver["newton_rtol"] * 1e-2
    ti.newton.useModifiedNewton = True
    ti.generalizedAlpha.spectralRadius = solver["spectral_radius"]
    if solver.get("solver") == "fox-goodwin":
        ga = ti.generalizedAlpha
        ga.useNewmark, ga.newmarkBeta, ga.newmarkGamma, ga.useIndex2Constraints = True, 1 / 12, 0.5, True
    ti.generalizedAlpha.computeInitialAccelerations = True
    s.solution.file.write = False
    s.solution.sensors.active = True
    s.solution.sensors.writePeriod = case.integrator.output_dt
    s.show.computationTime = False
    s.show.statistics = False
    s.show.globalTimers = False
    s.linearSolver.solverType = exu.LinearSolverType.EigenSparse
    return s


def solve(mbs, settings, solver_type: str, label: str = "exudyn"):
    """Run Exudyn's implicit solver, with a progress bar on stderr past a couple of seconds
    (`progress.Progress`, moved by Exudyn's own progress line: `quiet`); (status, wall_s, steps,
    newton_iterations).

    No Python function is called per step. A SIGINT or SIGTERM is noticed by Exudyn between two
    steps (it runs Python's signal handlers there) and raised again when the solve has returned
    (`files.signals_kept`). status is ok or failed with Exudyn's message; never raises for a
    solver failure.
    """
    t0 = time.perf_counter()
    status = results.Status()
    bar = Progress(settings.timeIntegration.endTime, label)
    try:
        with files.signals_kept(), quiet(bar.update):
            bar.update(settings.timeIntegration.startTime)       # the solve starts
            ok = mbs.SolveDynamic(settings, solverType=IMPLICIT[solver_type], showHints=False,
                                  showCausingItems=False)
        if not ok:
            status = results.failed("Exudyn SolveDynamic returned False")
    except Exception as e:                               # exu.SolverError, ExudynError, ...
        msg = error_string(mbs) or f"{type(e).__name__}: {e}"
        status = results.failed(f"Exudyn: {msg}")
    wall_s = time.perf_counter() - t0
    bar.close()
    it = mbs.sys["dynamicSolver"].it if "dynamicSolver" in mbs.sys else None
    steps = max(int(it.currentStepIndex) - 1, 0) if it is not None else 0   # index counts from 1
    newton = int(it.newtonStepsCount) if it is not None else 0
    return status, wall_s, steps, newton


def watch(mbs, case, beams) -> dict:
    """Stop the solve at the first output sample at which the divergence rule fails the run
    (`channels.failure`), judged on `beams(mbs)`: {body: its `channels.Beam` at that instant, read
    from the sensors' current values (`values`) as the channels will be after the run}, the bodies
    that cannot fail there left out (none: nothing to judge). A run
    that has failed is not integrated further: a linear floating frame that lost its stiffness
    would otherwise integrate its growing oscillation to the end. A sensor user function: Exudyn
    calls it only when it writes the sensors (no Python runs at the steps between); it looks at
    output samples only and raises the system's stop flag (`SetRenderEngineStopFlag`), which ends
    the solve after that step, so the failed sample is the last one stored. Returns (and keeps as
    mbs.variables["divergence"]) {"status": the rule's failed Status}, filled when it stops."""
    out_dt = case.integrator.output_dt
    seen = mbs.variables.setdefault("divergence", {})

    def check(mbs_, t, sensor_numbers, factors, configuration):
        if seen or abs(t / out_dt - round(t / out_dt)) > 1e-6:
            return [0.0]
        judged = beams(mbs_)
        hit = channels.failure(case, channels.Trajectory(t=np.array([t]), beams=judged)) if judged else None
        if hit is not None:
            seen["status"] = hit[1]
            mbs_.SetRenderEngineStopFlag(True)
        return [0.0]
    mbs.AddSensor(eii.SensorUserFunction(sensorUserFunction=check, writeToFile=False, storeInternal=False))
    return seen


def values(mbs, S):
    """The current values of the sensors S (a sensor or nested dicts of sensors): the same nesting
    of (1, k) arrays, one sample of what `sensor_series` reads after the run."""
    if isinstance(S, dict):
        return {k: values(mbs, x) for k, x in S.items()}
    return np.asarray(mbs.GetSensorValues(S), dtype=float)[None, :]


def stopped(r, mbs) -> None:
    """A run the divergence watch stopped (`watch`) fails as the rule says, at that sample."""
    seen = mbs.variables.get("divergence", {})
    if "status" in seen:
        r.status = seen["status"]


def error_string(mbs) -> str:
    """Exudyn's own description of why the last solve stopped ('' when it has none)."""
    solver = mbs.sys.get("dynamicSolver")
    if solver is None:
        return ""
    try:
        msg = solver.GetErrorString()
    except Exception:                                    # noqa: BLE001 - best effort only
        return ""
    return " ".join(str(msg).split())


def reached(r, t: np.ndarray, n_ok: int, t_end: float) -> int:
    """Set r.status for a run that reached n_ok of the output instants t: a run that stopped
    early fails at the last instant it reached (as it failed: its why and cause; aborted when it
    had not). Returns n_ok."""
    if n_ok < t.size:
        at = t[max(n_ok - 1, 0)]
        r.status = results.failed(r.status.why, at, r.status.cause) if not r.ok else \
            results.failed(f"Exudyn stopped before {t_end:g} s", at)
    return n_ok


def stored(mbs, sensor) -> np.ndarray:
    """A sensor's stored rows (m, 1 + k): time, then its k values."""
    d = np.asarray(mbs.GetSensorStoredData(sensor))
    return d[None, :] if d.ndim == 1 else d


def sensor_series(mbs, sensor, t_out: np.ndarray) -> np.ndarray:
    """A sensor's stored values on the output grid t_out (n,): (n, k) (`series`)."""
    return series(stored(mbs, sensor), t_out)


def series(d: np.ndarray, t_out: np.ndarray) -> np.ndarray:
    """Stored rows d (m, 1 + k) (time, then k values) on the output grid t_out (n,): (n, k); the
    rows stored at t_out when there are (others may lie between them), else resampled linearly."""
    t, v = d[:, 0], d[:, 1:]
    row = np.clip(np.searchsorted(t, t_out - 1e-9), 0, t.size - 1)
    if np.all(np.abs(t[row] - t_out) <= 1e-9):
        return v[row]
    return np.column_stack([np.interp(t_out, t, v[:, k]) for k in range(v.shape[1])])


def completed(mbs, sensor, t_out: np.ndarray) -> int:
    """Number of output instants a (possibly failed) run reached."""
    d = stored(mbs, sensor)
    if d.size == 0:
        return 0
    return int(np.searchsorted(t_out, d[-1, 0] + 1e-9))


# motion profiles written as Exudyn symbolic expressions (`motion_expr`); a table stays in Python
SYMBOLIC = ("constant_rate", "harmonic", "spin_up")


def motion_expr(prof: dict, t, q0: float) -> tuple:
    """(q, qd) of a motion profile of a `SYMBOLIC` kind at the symbolic time t (exu.symbolic.Real):
    `profiles.motion_at`'s operations, in its order, as Exudyn symbolic expressions."""
    sym, kind = exu.symbolic, prof["type"]
    if kind == "constant_rate":
        return q0 + prof["rate"] * t, prof["rate"] + 0.0 * t
    if kind == "harmonic":
        a, w, ph = prof["amplitude"], 2.0 * np.pi * prof["frequency"], prof["phase"]
        return q0 + prof["offset"] + a * sym.sin(w * t + ph), a * w * sym.cos(w * t + ph)
    W, T = prof["W"], prof["T"]
    k = 2.0 * np.pi / T
    q = sym.IfThenElse(t >= T, q0 + W * (t - T / 2.0), q0 + (W / T) * (t * t / 2.0 + (sym.cos(k * t) - 1.0) / (k * k)))
    return q, sym.IfThenElse(t >= T, W + 0.0 * t, (W / T) * (t - sym.sin(k * t) / k))


def symbolic(mbs, function, name: str, item_type: str):
    """The user function `function` (written for Exudyn's symbolic arguments) recorded once as an
    expression Exudyn evaluates in C++ for the item type's user function `name`: no Python runs
    when it is called. Kept alive as long as mbs (its `variables`)."""
    f = CreateSymbolicUserFunction(mbs, function, name, itemTypeName=item_type)
    mbs.variables.setdefault("symbolic user functions", []).append(f)
    return f


def angle_z(R: np.ndarray) -> np.ndarray:
    """Rotation angle about z of rotation matrices (n, 3, 3), unwrapped over the run, rad."""
    return np.unwrap(np.arctan2(R[:, 1, 0], R[:, 0, 0]))


def axis_frame(axis) -> np.ndarray:
    """Rotation (3, 3) whose third column is the unit joint axis (z when axis is z)."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    z = np.array([0.0, 0.0, 1.0])
    k = np.cross(z, a)
    s, c = np.linalg.norm(k), z @ a
    if s < 1e-14:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    return rotvec(k / s * np.arctan2(s, c))


def rotvec(w) -> np.ndarray:
    """Rotation matrix of a rotation vector (Rodrigues)."""
    return expm_so3(np.asarray(w, dtype=float))


def is_planar(case) -> str:
    """'' when the case moves in the global x-y plane: every joint axis along z with no tilt,
    gravity and loads in the plane, no rigid-body axis out of it; else why not."""
    if abs(case.gravity[2]) > 0:
        return "gravity has a z component"
    for jn, j in case.joints.items():
        if any(abs(a) > 0 for a in j.rpy):
            return f"joint {jn!r} has a tilted triad (rpy)"
        if j.type == "revolute" and (abs(j.axis[0]) > 0 or abs(j.axis[1]) > 0):
            return f"joint {jn!r}: revolute axis not along z"
        if j.type == "prismatic" and abs(j.axis[2]) > 0:
            return f"joint {jn!r}: prismatic axis out of the x-y plane"
        if j.type in ("spherical", "free") and any(abs(x) > 0 for x in j.q0[:2] + j.qd0[:2]):
            return f"joint {jn!r} starts out of the x-y plane"
        if abs(j.offset[2]) > 0:
            return f"joint {jn!r} sits out of the x-y plane"
    for ln, ld in case.loads.items():
        if abs(ld.force[2]) > 0 or abs(ld.offset[2]) > 0:
            return f"load {ln!r} has a z component"
    return ""


def fixed_to_ground(case, name: str) -> bool:
    """True when a chain of fixed joints ties the body frame to ground, each on its parent's frame
    (ground, a rigid body, a flexible body's root node): a body fixed to a flexible node (a tip
    mass) turns with the node's elastic rotation."""
    while name != "ground":
        j = case.joint_of(name)
        if j.type != "fixed" or j.motion is not None:
            return False
        parent = case.bodies.get(j.parent)
        if parent is not None and parent.type != "rigid" and not parent.rigid and j.node > 0:
            return False
        name = j.parent
    return True


def output_grid(case, t_end: float) -> np.ndarray:
    return common.sample_times(case, t_end)


def reach(sim, t_last: float, dt: float) -> None:
    """Steps of exactly dt (s) up to the last output instant t_last (`output_grid`) or just past
    it: Exudyn's step is endTime / numberOfSteps, so with endTime the case's duration and
    duration / dt not whole (slider_crank's 4 pi / 150 s) it would be neither dt nor reach the
    last output instant, which lies up to half an output interval past the duration."""
    n = max(int(np.ceil(t_last / dt - 1e-9)), 1)
    sim.timeIntegration.numberOfSteps, sim.timeIntegration.endTime = n, n * dt


# ---------------------------------------------------------------------------------------------
# the system's natural frequencies by Exudyn's own eigenvalue solver (the adapters' `system_frequencies`)

# A prescribed joint held at its initial value: a constant profile, which the adapters build as the
# constraint of a driven joint with its offset always zero, the lock of that coordinate.
HOLD = MappingProxyType({"type": "constant_rate", "rate": 0.0})

# An eigenvalue omega^2 at most ZERO times the largest is a zero one (a rigid-body mode): eigh
# computes an exact zero within about eps times the largest (measured 1e-17 of it on the four-bar
# with its crank free, both adapters), while a beam mesh's lowest vibration lies near 1e-9 of
# its largest (the element's shear-rotation mode, 1e6 Hz on the four-bar's strips) and a reduced
# body's far higher; 1e-13 keeps 1e4 from either, and drops frequencies below 3e-7 of the largest.
ZERO = 1e-13
# Singular values of the constraint Jacobian below SINGULAR are redundant constraints (a planar
# loop of 3-D joints holds its out-of-plane motion twice), which the null-space projection drops:
# they come out at rounding (at most 3e-16 on the four-bar), the independent ones at 0.25 and above
# (the unit rows of position constraints, lever arms, Euler parameters).
SINGULAR = 1e-10


def held(case):
    """The resolved case with every joint of prescribed motion held at its initial value: its
    motion `HOLD` from the profile's q(0), rate 0."""
    base = getattr(case, "resolved", case)
    joints = {jn: j if j.motion is None else
              replace(j, q0=(float(profiles.motion(j.motion, 0.0, float(j.q0[0]))[0]),), qd0=(0.0,), motion=HOLD)
              for jn, j in base.joints.items()}
    return replace(base, joints=MappingProxyType(joints))


def loaded(case) -> str:
    """'' when no load acts on the case at t = 0, else which does: Exudyn's eigenvalue solver
    takes the stiffness at its initial coordinates with the Lagrange multipliers zero and the
    beams unstressed, so the stiffness a load sets up (a pendulum's under gravity, the constraint
    forces' and a beam's prestress) is not in it."""
    if any(abs(g) > 0 for g in case.gravity):
        return "gravity acts on it"
    for ln, ld in case.loads.items():
        if any(abs(f) > 0 for f in ld.force) and float(profiles.load_factor(ld.profile, 0.0)) != 0.0:
            return f"load {ln!r} acts at t = 0"
    return ""


def at_rest(mbs, case) -> str:
    """'' when the assembled system starts at rest (every initial velocity coordinate zero), else
    which joints set it moving: Exudyn's eigenvalue solver has no velocity terms."""
    v = np.asarray(mbs.systemData.GetODE2Coordinates_t(configuration=exu.ConfigurationType.Initial), dtype=float)
    if not np.any(v):
        return ""
    moving = [jn for jn, j in case.joints.items() if j.motion is None and any(abs(x) > 0 for x in j.qd0)]
    return f"its initial state moves ({', '.join(f'joint {jn!r}' for jn in moving) or 'a body'} starts with a rate)"


def frequencies(mbs, count: int) -> np.ndarray:
    """The lowest `count` nonzero natural frequencies (count,) in Hz, ascending, of the assembled
    system at its initial coordinates: Exudyn's `ComputeODE2Eigenvalues` on the constrained system
    (the dense mass and stiffness matrices projected onto the null space of the constraint
    Jacobian, `SINGULAR`; eigh), undamped. The eigenvalues omega^2 are taken signed (not Exudyn's
    absolute values, which would fold a negative one onto a frequency): those within `ZERO` of the
    largest are the zero ones of rigid-body motion and are dropped; ValueError for a negative one
    beyond it (the state is unstable) or fewer than `count` left."""
    lam = mbs.ComputeODE2Eigenvalues(useAbsoluteValues=False, ignoreAlgebraicEquations=False,
                                     singularValuesTolerance=SINGULAR, computeComplexEigenvalues=False)[0]
    lam = np.asarray(lam, dtype=float)
    zero = ZERO * np.abs(lam).max(initial=0.0)
    if np.any(lam < -zero):
        raise ValueError(f"a negative eigenvalue (omega^2 = {lam.min():.4g} 1/s^2): the state is unstable")
    f = np.sqrt(lam[lam > zero]) / (2.0 * np.pi)
    if f.size < count:
        raise ValueError(f"the model has {f.size} nonzero natural frequencies, {count} asked for")
    return np.sort(f)[:count]


def system_frequencies(case, count: int, solver: str, applies, model) -> np.ndarray:
    """The adapters' `system_frequencies`: the lowest `count` nonzero natural frequencies (count,),
    Hz, ascending (`frequencies`), of the case with its prescribed joints held (`held`), at rest
    and unloaded, its model from model(held case) -> (SystemContainer, assembled MainSystem).
    What the solver cannot take, `applies(held case)` or this (`loaded`, `at_rest`, Exudyn's
    refusal), is an InputError of one line naming the case file."""
    if int(count) < 1:
        raise InputError(f"{case.path}: {solver} system frequencies: count must be at least 1, not {count!r}")
    fixed = held(case)
    why = applies(fixed) or loaded(fixed)
    f = None
    if not why:
        try:
            with quiet():
                SC, mbs = model(fixed)
                why = at_rest(mbs, fixed)
                f = None if why else frequencies(mbs, int(count))
        except (ValueError, RuntimeError, np.linalg.LinAlgError) as e:    # exu.ExudynError is a RuntimeError
            why = " ".join(str(e).split()) or type(e).__name__
    if why:
        raise InputError(f"{case.path}: {solver} system frequencies: {why}")
    return f
