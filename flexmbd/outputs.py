"""Channels (DESIGN.md §2) computed from the states of a flexmbd run.

Deflections are measured geometrically from the deformed nodes, as every solver measures them:
on a body with hinged-hinged modes the signed distance from the chord through both end nodes,
in the chord frame; otherwise the displacement in the frame of the (deformed) root node, minus
the undeformed position. With clamped-root or hinged modes both reduce to Phi_t,p eta.
"""

from __future__ import annotations

import numpy as np

from flexmbd import dynamics, flexbody
from flexmbd.fe.stress import von_mises
from flexmbd.kernel import entry
from flexmbd.model import Model, make_data
from flexmbd.spatial import expm_so3


def deflection(fb: flexbody.FlexBody, p: int, axis: int, eta) -> float:
    """Deflection of node p along `axis` (0, 1, 2) of the root-node or chord frame, m."""
    r = fb.x0 + fb.Phi[:, 3:, :] @ eta                      # (N, 3) deformed nodes, body frame
    if fb.boundary == "hinged-hinged":
        e = r[-1] - r[0]
        R = chord_frame(e / np.linalg.norm(e))
    else:
        R = expm_so3(fb.Phi[0, :3, :] @ eta)
    return (R.T @ (r[p] - r[0]))[axis] - (fb.x0[p] - fb.x0[0])[axis]


def chord_frame(e) -> np.ndarray:
    """Rotation (3, 3) taking the body x axis onto unit vector e by the smallest turn."""
    x = np.array([1.0, 0.0, 0.0])
    k = np.cross(x, e)
    s = np.linalg.norm(k)
    if s < 1e-15:
        return np.eye(3)
    return expm_so3(k / s * np.arctan2(s, x @ e))


def energies(model: Model, Q, V) -> np.ndarray:
    """(n, 2): kinetic and potential (gravity + strain) energy of every state, J."""
    data = make_data(model)
    return np.array([dynamics.energy(model, data, q, v) for q, v in zip(Q, V)])


def reactions(model: Model, t, Q, V) -> np.ndarray:
    """(n, nb+1, 6): joint forces [moment; force] from parent onto body, body frame, at every
    state (one forward-dynamics evaluation each)."""
    data = make_data(model)
    tau = np.zeros(model.nv)
    out = np.empty((len(t), model.nb + 1, 6))
    for k, (tk, q, v) in enumerate(zip(t, Q, V)):
        entry.forward(model, data, float(tk), np.ascontiguousarray(q, dtype=float), np.ascontiguousarray(v, dtype=float), tau)
        out[k] = data.f
    return out


def channels(case, model: Model, t, Q, V) -> dict:
    """Every channel of the case, (n,) each, from states Q (n, nq), V (n, nv)."""
    out = {}
    stress_row, f = {}, None
    for name, c in case["channels"].items():
        kind = c["kind"]
        if kind == "joint_angle":
            out[name] = Q[:, model.jnt_qadr[model.index(case["joints"][c["joint"]]["child"])]].copy()
        elif kind == "energy":
            out[name] = energies(model, Q, V).sum(axis=1)
        elif kind in ("reaction_force", "reaction_moment"):
            i = model.index(case["joints"][c["joint"]]["child"])
            row = "xyz".index(c["component"]) + (3 if kind == "reaction_force" else 0)
            f = reactions(model, t, Q, V) if f is None else f
            out[name] = f[:, i, row].copy()
        elif c["body"] not in model.bodies:                  # a beam declared rigid does not deform
            out[name] = np.zeros(len(t))
        else:
            fb = model.bodies[c["body"]]
            i = model.index(c["body"])
            eta = Q[:, model.body_madr[i]:model.body_madr[i] + model.body_nm[i]]
            if kind == "deflection":
                p, axis = fb.node_at(c["at"]), "xyz".index(c["component"])
                out[name] = np.array([deflection(fb, p, axis, e) for e in eta])
            else:
                k = stress_row[c["body"]] = stress_row.get(c["body"], -1) + 1
                out[name] = von_mises(eta @ fb.S_sigma[k], eta @ fb.S_tau[k])
    return out
