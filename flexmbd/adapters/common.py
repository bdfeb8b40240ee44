"""Facts about a case that several adapters need, computed one way."""

from __future__ import annotations

import numpy as np

from flexmbd import channels
from flexmbd.spatial import rotation_rpy


def clamped_beam(case) -> tuple[str, str]:
    """(beam name, '') when the case is one beam clamped to ground at its root, else ('', why)."""
    bodies, joints = case["bodies"], case["joints"]
    if len(bodies) != 1 or len(joints) != 1:
        return "", "needs exactly one beam on one joint"
    (name, body), (jname, joint) = next(iter(bodies.items())), next(iter(joints.items()))
    if body["type"] != "beam" or body["rigid"]:
        return "", f"body {name!r} is not a flexible beam"
    if joint["type"] != "fixed" or joint["parent"] != "ground":
        return "", f"joint {jname!r} is not a fixed joint to ground (fixed-base cases only)"
    return name, ""


def body_force(case, load: dict) -> np.ndarray:
    """A load's force (3,) in the body frame of a beam clamped to ground (no motion of the frame)."""
    f = np.asarray(load["force"], dtype=float)
    if load["frame"] == "global":
        joint = next(iter(case["joints"].values()))
        f = rotation_rpy(joint["rpy"]).T @ f
    return f


def gravity_body(case) -> np.ndarray:
    """Gravity (3,) in the body frame of a beam clamped to ground, m/s^2."""
    joint = next(iter(case["joints"].values()))
    return rotation_rpy(joint["rpy"]).T @ np.asarray(case["gravity"], dtype=float)


def sample_times(case, t_end: float) -> np.ndarray:
    """Output instants 0, dt, ..., t_end of the case's output_dt."""
    dt = case["integrator"]["output_dt"]
    n = int(round(t_end / dt))
    return np.linspace(0.0, n * dt, n + 1)


def component_index(c: str) -> int:
    return "xyz".index(c)


def rigid_trajectory(case, model, t, angle, energy) -> channels.Trajectory:
    """The trajectory of a rigid-limit solver: joint coordinates from `angle(body index)` (n,),
    the total energy from `energy()` (n,); no beam deforms, reactions are not recovered."""
    traj = channels.Trajectory(t=t)
    for jname in channels.joints_needed(case):
        traj.joints[jname] = angle(model.index(case["joints"][jname]["child"]))
    if channels.wants_energy(case):
        traj.energy = {"total": energy()}
    return traj
