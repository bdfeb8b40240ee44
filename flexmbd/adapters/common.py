"""Facts about a case that several adapters need, computed one way."""

from __future__ import annotations

import numpy as np

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


def rigid_channels(case, model, n: int, angle, energy) -> dict:
    """Channels of a rigid-limit solver: joint angles from `angle(body index)` (n,), `energy()` (n,);
    deflections and stresses of rigid beams are identically zero; reactions are not recovered."""
    out = {}
    for name, c in case["channels"].items():
        if c["kind"] == "joint_angle":
            out[name] = angle(model.index(case["joints"][c["joint"]]["child"]))
        elif c["kind"] == "energy":
            out[name] = energy()
        elif c["kind"] in ("deflection", "stress_vm"):
            out[name] = np.zeros(n)
    return out
