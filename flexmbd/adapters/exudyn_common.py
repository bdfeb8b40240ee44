"""What the two Exudyn adapters share: import, silence, solver settings, sensors, failures.

Exudyn prints progress and solver statistics to stdout; everything here runs with its console
output off, so `flexmbd run --json` keeps a clean stdout. A failed Exudyn solve (no Newton
convergence, singular system, exception) becomes a `failed: ...` Result carrying Exudyn's own
error text.
"""

from __future__ import annotations

import contextlib
import io
import os
import sys
import time

import numpy as np

import exudyn as exu                     # ImportError here: the adapters are 'unavailable'
import exudyn.itemInterface as eii       # noqa: F401  (used by the adapters)

from flexmbd import files, results
from flexmbd.adapters import common
from flexmbd.progress import Progress

from flexmbd.spatial import expm_so3

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
    """Exudyn's console output off (the config flag; the older call where there is no flag)."""
    if hasattr(exu, "config") and hasattr(exu.config, "printToConsole"):
        exu.config.printToConsole = False
    else:
        exu.SetWriteToConsole(False)


def system():
    """A fresh (SystemContainer, MainSystem); the container must outlive the system."""
    silence()
    SC = exu.SystemContainer()
    return SC, SC.AddSystem()


@contextlib.contextmanager
def quiet():
    """Silence Exudyn's C++ console output (fd 1) and Python prints while building / solving."""
    silence()
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            with contextlib.redirect_stdout(io.StringIO()):
                yield
    finally:
        sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(saved)


def simulation_settings(case, t_end: float, dt: float, solver: dict):
    """Exudyn SimulationSettings: fixed step dt (s), implicit solver, no files, sensors in memory.

    `solver`: solver, spectral_radius, newton_rtol, adaptive (bool), as in the adapters' SETTINGS.
    """
    s = exu.SimulationSettings()
    ti = s.timeIntegration
    ti.endTime = t_end
    ti.numberOfSteps = max(int(round(t_end / dt)), 1)
    ti.verboseMode = 0
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
    (`progress.Progress`); (status, wall_s, steps, newton_iterations).

    status is ok or failed with Exudyn's message; never raises for a solver failure.
    """
    t0 = time.perf_counter()
    status = results.Status()
    bar = Progress(settings.timeIntegration.endTime, label)
    mbs.SetPreStepUserFunction(lambda mbs, t: bar.update(t) or True)
    try:
        with files.signals_kept(), quiet():
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
    early fails at the last instant it reached. Returns n_ok."""
    if n_ok < t.size:
        at = t[max(n_ok - 1, 0)]
        r.status = results.failed(r.status.why if not r.ok else f"Exudyn stopped before {t_end:g} s", at)
    return n_ok


def sensor_series(mbs, sensor, t_out: np.ndarray) -> np.ndarray:
    """A sensor's stored values resampled on the output grid t_out (n,): (n, k)."""
    d = np.asarray(mbs.GetSensorStoredData(sensor))
    if d.ndim == 1:
        d = d[None, :]
    t, v = d[:, 0], d[:, 1:]
    if t.size == t_out.size and np.allclose(t, t_out, atol=1e-9):
        return v
    return np.column_stack([np.interp(t_out, t, v[:, k]) for k in range(v.shape[1])])


def completed(mbs, sensor, t_out: np.ndarray) -> int:
    """Number of output instants a (possibly failed) run reached."""
    d = np.asarray(mbs.GetSensorStoredData(sensor))
    if d.size == 0:
        return 0
    return int(np.searchsorted(t_out, np.atleast_2d(d)[-1, 0] + 1e-9))


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


def output_grid(case, t_end: float) -> np.ndarray:
    return common.sample_times(case, t_end)
