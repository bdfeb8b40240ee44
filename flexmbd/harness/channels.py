"""Channels: each kind computed by one function, from a solver-neutral trajectory.

A solver — flexmbd or an adapter — reports what it knows of a run as a `Trajectory`: the
coordinates of the joints the channels name, the parts of the energy, the joint reactions if it
recovers them, and per flexible beam a `Beam`: the positions of the material points the channels
use, the rotation of the root node's frame, and the section strains at the stress sections. The
functions below turn that into channels, the same way for every solver:

    deflection   node p's displacement along an axis of the root-node frame (or, for a beam
                 with hinged-hinged modes, of the chord frame through both end nodes), minus its
                 undeformed offset from the root node: (R^T (r_p - r_0))_axis - (x0_p - x0_0)_axis
    stress_vm    von Mises stress sqrt(sigma^2 + 3 tau^2) at the section point (y, z), with
                 sigma = E (eps - y kappa_z + z kappa_y), tau = G r(y, z) twist rate; on a
                 solid, the von Mises stress of the stress tensor at the channel's point, from
                 the displacement gradient there of the element that holds it
    stress_normal    the normal stress along the beam's axis, sigma (signed, tension positive); on a
                 solid e^T sigma e along the channel's `direction` e (default the body's x axis)
    stress_signed_vm von Mises with the sign of the principal stress of largest magnitude (a
                 rainflow count of it keeps tension and compression apart, docs/durability.md)
    joint_angle  the joint's coordinate (rad; m for a prismatic joint)
    energy       the sum of the energy parts (kinetic, gravity, strain), J
    reaction_*   a component of the force the joint transmits from parent onto child, child frame

and, beside the channels, the deformed-shape snapshots (`shapes`): every component of the
deflection of `report.shape_points` evenly spaced points along each flexible beam, their positions
in the global frame and the stress at their sections, at the output samples nearest to the
instants `report.snapshots`, with the global poses of the other bodies there (`poses`), stored
with the result (`registry.run`). The global frame comes from the poses a solver reports
(`Trajectory.poses`, `placed`).

A beam that is not flexible in a solver's model (declared rigid, or every beam of a rigid-body
solver) has no Beam: its deflections and stresses are zero.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from flexmbd import cases
from flexmbd.fe import flexbody
from flexmbd.harness import results
from flexmbd.cases import closure
from flexmbd.fe.solid import von_mises as solid_von_mises
from flexmbd.fe.stress import section_stresses, von_mises


@dataclass
class Beam:
    """One flexible beam at n instants. Positions and the root rotation are in one frame F of the
    solver's choice (body, root node or global frame): the channels use only positions relative
    to the root node, in the root node's (or the chord's) frame.

    points  {x: (n, 3)}      position in F of the material point the solver tracks for the
                             position x along the beam (m, as the case names it); always x = 0
                             (root node) and, for the chord, x = length
    x0      {x: (3,)}        undeformed position of that point, body frame, m
    root    (n, 3, 3)|None   rotation of the root node's frame in F (None: chord frame)
    strains {x: (n, 4)}      section strains [eps, kappa_y, kappa_z, twist rate] at x (1, 1/m, rad/m)
    extent  {name: (n,)}     a modal solver's measures of its linear validity (`modal_extent`)
    origin                   the key of the root point: 0.0 on a beam; a solid's frame interface
    stresses {p: (n, 6)}     a solid's stresses [xx, yy, zz, yz, zx, xy] (Pa, body frame) at the
                             stress points p (3,) themselves (`modal_solid`, `flexbody.point_stress_rows`)

A solid is reported as a Beam too: its points are its interfaces' reference points (keyed by the
interface's name, the root its frame interface's), its root rotation that interface's.
    """

    length: float
    points: dict
    x0: dict
    root: np.ndarray | None
    strains: dict = field(default_factory=dict)
    extent: dict = field(default_factory=dict)
    origin: object = 0.0
    stresses: dict = field(default_factory=dict)
    surface: object = None      # a solid: k (samples) -> (len(k), nf, 6) stresses at its boundary faces' elements


@dataclass
class Trajectory:
    """What one run of one solver produced, at the output instants t (n,)."""

    t: np.ndarray
    beams: dict = field(default_factory=dict)      # flexible beam name -> Beam
    joints: dict = field(default_factory=dict)     # joint name -> (n,) coordinate of a 1-DOF joint
    energy: dict = field(default_factory=dict)     # part name -> (n,) J
    reactions: dict = field(default_factory=dict)  # joint name -> (n, 6) [moment; force], child frame
    poses: dict = field(default_factory=dict)      # body name -> (R (n, 3, 3), p (n, 3)), global (`placed`)


# ---------------------------------------------------------------------------------------------
# what a solver has to report


def points_needed(case, body: str) -> list:
    """Positions x (m) whose points a Beam must hold: the root, the tip, every deflection
    channel's point (`deflection_points`) and the shape points (`shape_positions`), in that
    order, without repeats (a shape point within 1e-9 L of a listed position is that position)."""
    xs = deflection_points(case, body)
    if case.bodies[body].type == "solid":
        return xs
    L = float(case.bodies[body].length)
    for x in evenly_spaced(case, body):
        if not any(abs(x - y) <= 1e-9 * L for y in xs):
            xs.append(x)
    return xs


def deflection_points(case, body: str) -> list:
    """Positions x (m) whose points the deflection channels read: the root and the tip (the chord)
    and every deflection channel's point; a solid's frame interface and its channels' points."""
    b = case.bodies[body]
    ends = [b.frame] if b.type == "solid" else [0.0, float(b.length)]
    return list(dict.fromkeys(ends + [c.at for c in case.channels.values()
                                      if c.kind == "deflection" and c.body == body]))


def evenly_spaced(case, body: str) -> list:
    """`report.shape_points` positions evenly spaced from the root (0) to the tip (length), m."""
    L, n = float(case.bodies[body].length), case.report.shape_points
    return [L * k / (n - 1) for k in range(n)]          # L k / (n - 1): 0.45, not 3 x 0.15 = 0.44999999999999996


def shape_positions(case, body: str) -> list:
    """The keys of a Beam's points (`points_needed`) that are the beam's shape points, root to
    tip: `report.shape_points` evenly spaced positions (none when 0)."""
    if case.bodies[body].type == "solid":               # a solid's field is drawn at instants instead
        return []
    listed = points_needed(case, body)
    return [min(listed, key=lambda y: abs(y - x)) for x in evenly_spaced(case, body)]


def joints_needed(case) -> list:
    """Names of the joints whose coordinates the channels use."""
    return list(dict.fromkeys(c.joint for c in case.channels.values() if c.kind == "joint_angle"))


def wants_energy(case) -> bool:
    return any(c.kind == "energy" for c in case.channels.values())


def modal_points(fb: flexbody.FlexBody, xs, eta, nodes: dict | None = None) -> tuple[dict, dict]:
    """({x: (n, 3)}, {x: (3,)}): positions x0_p + Phi_t,p eta of the nodes nearest to xs in the
    body frame, and their undeformed positions, from modal coordinates eta (n, nm); `nodes`
    {x: p} where the nodes are known (a solid's interfaces)."""
    nodes = {x: fb.node_at(x) for x in xs} if nodes is None else nodes
    return ({x: fb.x0[p] + eta @ fb.Phi[p, 3:, :].T for x, p in nodes.items()},
            {x: fb.x0[p] for x, p in nodes.items()})


def modal_root(fb: flexbody.FlexBody, eta) -> np.ndarray | None:
    """(n, 3, 3) rotation of the root node's frame in the body frame, exp(Phi_r,0 eta)~; None on a
    beam with hinged-hinged modes (its deflections are measured from the chord)."""
    if fb.boundary == "hinged-hinged":
        return None
    return Rotation.from_rotvec((eta @ fb.Phi[0, :3, :].T).reshape(-1, 3)).as_matrix()


def modal_shape(fb: flexbody.FlexBody, xs, eta, nodes: dict | None = None, origin=0.0) -> Beam:
    """The Beam of a modal body with only the points at xs (`modal_points`; `nodes` {x: p} where
    known) and the root rotation, from modal coordinates eta (n, nm): what the divergence rule
    reads (`failure`) while a modal solver runs. origin: a solid's frame interface."""
    points, x0 = modal_points(fb, xs, eta, nodes)
    return Beam(length=fb.length, points=points, x0=x0, root=modal_root(fb, eta), origin=origin)


def modal_reach(fb: flexbody.FlexBody, nodes: dict, origin=0.0):
    """A function of modal coordinates eta (nm,) giving an upper bound (m) on the `displacement`
    of every point of `nodes` ({x: p}, `origin` among them) in the `modal_shape` they make, so on
    each deflection channel there. With dx0, du a point's undeformed offset from the origin's and
    its elastic part, |R' (dx0 + du) - dx0| <= |R - I| |dx0| + |du|, and |R - I| = 2 sin(phi / 2)
    for R's angle phi: in the root-node frame phi = |Phi_r,0 eta| bounds it; in the chord frame
    (hinged-hinged modes: the smallest turn of x onto the chord dx0_L + du_L, dx0_L = L x) sin phi
    <= |du_L| / (L - |du_L|) and phi <= 90 degrees while |du_L| < L, where 2 sin(phi / 2) <= sqrt(2)
    sin phi. inf where no bound is known (coordinates not finite, a chord that is not the body's x
    axis or whose tip moved by L or more). A few products where `failure` builds the Beam: the
    samples of a run far below the rule's bounds need no more."""
    p0, ps = nodes[origin], list(nodes.values())
    dPhi = (fb.Phi[ps, 3:, :] - fb.Phi[p0, 3:, :]).reshape(-1, fb.n_modes)             # (3K, nm)
    dx0 = np.linalg.norm(fb.x0[ps] - fb.x0[p0], axis=1)                                 # (K,)
    if fb.boundary != "hinged-hinged":
        Phi_r = fb.Phi[0, :3, :]
        turn = lambda eta: np.linalg.norm(Phi_r @ eta)
    else:
        pL = nodes.get(float(fb.length))
        a = fb.x0[pL] - fb.x0[p0] if pL is not None else np.zeros(3)
        if not (a[0] > 0.0 and np.linalg.norm(a[1:]) <= 1e-12 * a[0]):
            return lambda eta: np.inf
        dPhi_L = fb.Phi[pL, 3:, :] - fb.Phi[p0, 3:, :]

        def turn(eta):
            d = np.linalg.norm(dPhi_L @ eta)
            return np.sqrt(2.0) * d / (a[0] - d) if d < a[0] else np.inf

    def reach(eta) -> float:
        eta = np.asarray(eta, dtype=float).ravel()
        phi = turn(eta) if np.all(np.isfinite(eta)) else np.inf
        if phi == np.inf:
            return np.inf
        du = np.linalg.norm((dPhi @ eta).reshape(-1, 3), axis=1)
        return float(np.max(phi * dx0 + du)) * (1.0 + 1e-9)              # margin: the Beam's own rounding
    return reach


def modal_strains(fb: flexbody.FlexBody, eta) -> dict:
    """{x: (n, 4)} section strains at the body's stress sections from modal coordinates eta (n, nm)."""
    return {float(x): eta @ fb.S_strain[k].T for k, x in enumerate(fb.stress_x)}


def node_forces(m: np.ndarray, acc: np.ndarray, loads=(), joints=()) -> np.ndarray:
    """(n, N, 3) net force on each node of a beam, body frame: the one node-force sum of every
    modal solver (docs/formulation.md §7). m (N,) node masses, kg; acc (n, N, 3) each node's
    acceleration relative to free fall (gravity taken off), body frame; `loads` the point loads
    and `joints` the forces the beam's child joints exert on it, each (node, (n, 3) body frame)."""
    F = -m[None, :, None] * acc
    for p, f in loads:
        F[:, p, :] += f
    for p, f in joints:
        F[:, p, :] += f
    return F


def rotary_moments(J: np.ndarray, Pr: np.ndarray, w, al, eta_d, eta_dd) -> np.ndarray:
    """(n, N, 3) d'Alembert moment of each node's rotary inertia, body frame (docs/formulation.md
    §7c): -[J_p (al + Phi_r,p eta_dd) + w x J_p (w + Phi_r,p eta_d)], the rate of the node's angular
    momentum J_p (w + Phi_r,p eta_d) as the kinetic energy of §3 holds it (J_p fixed in the body
    frame). J (N, 3, 3), Pr (N, 3, nm) the modes' node rotations; w, al (n, 3) the body's angular
    velocity and acceleration; eta_d, eta_dd (n, nm)."""
    wp = w[:, None, :] + flexbody.modal_field(Pr, eta_d)                    # (n, N, 3)
    ap = al[:, None, :] + flexbody.modal_field(Pr, eta_dd)
    return -(np.einsum("pij,npj->npi", J, ap) + np.cross(w[:, None, :], np.einsum("pij,npj->npi", J, wp)))


def section_loads(x0: np.ndarray, r: np.ndarray, F: np.ndarray, T: np.ndarray, x: float) -> np.ndarray:
    """(n, 6) [moment; force] that the part of a beam beyond the section at x (x0_p > x) exerts
    on the rest through it, body frame, the moment about the section's node: the force summation
    of docs/formulation.md §7c. x0 (N, 3) the nodes' undeformed and r (n, N, 3) their deformed
    positions; F (n, N, 3) the net force on each node (`node_forces`) and T (n, N, 3) its net
    moment (rotary inertia, the moments of joints on it). A node at the cut counts half, but at
    the beam's ends, where nothing lies beyond: at the root the sum is the whole body's, the
    negative of its joint's reaction."""
    ends = (x0[:, 0].min(), x0[:, 0].max())
    at = np.isclose(x0[:, 0], x, rtol=0.0, atol=1e-12 * max(abs(ends[1]), 1.0))
    w = np.where(at, 1.0 if x in ends else 0.5, np.where(x0[:, 0] > x, 1.0, 0.0))
    s = int(np.argmax(at)) if at.any() else int(np.argmin(np.abs(x0[:, 0] - x)))
    Fs = np.einsum("p,npi->ni", w, F)
    Ms = np.einsum("p,npi->ni", w, np.cross(r - r[:, s:s + 1], F) + T)
    return np.hstack([Ms, Fs])


def summed_strains(fb: flexbody.FlexBody, r: np.ndarray, F: np.ndarray, T: np.ndarray, mat, sec) -> dict:
    """{x: (n, 4)} section strains at a modal beam's stress sections by force summation: the outer
    part's resultants (`section_loads`) read through the section's stiffness (`resultant_strains`).
    r, F, T (n, N, 3): the deformed node positions and net node forces and moments, body frame;
    mat: the beam's `cases.Material`."""
    return {float(x): resultant_strains(section_loads(fb.x0, r, F, T, float(x)), mat.E, mat.G, sec) for x in fb.stress_x}


def resultant_strains(loads: np.ndarray, E: float, G: float, sec) -> np.ndarray:
    """(n, 4) section strains [eps, kappa_y, kappa_z, twist rate] of section resultants loads (n, 6)
    [T, My, Mz; N, Vy, Vz] (`section_loads`): N / (E A), My / (E Iy), Mz / (E Iz), T / (G J), the
    section's constitutive law read backwards (docs/formulation.md §7c)."""
    return np.stack([loads[:, 3] / (E * sec.A), loads[:, 1] / (E * sec.Iy), loads[:, 2] / (E * sec.Iz),
                     loads[:, 0] / (G * sec.J)], axis=1)


def axial_rule(stiffened: bool, stressed: bool, fb: flexbody.FlexBody) -> tuple[bool, bool]:
    """(load, strain): where a modal beam's quasi-static axial force N(x) enters, the one rule of
    every modal solver (docs/formulation.md §7). In a model without geometric stiffening it is a
    validity measure (`axial_load`: the model is linear only while it is far below buckling); in
    a stressed beam whose retained modes carry no axial motion (`flexbody.axial_free`) it adds
    N / (E A) to the section strains. A solver computes the node forces (`node_forces`) when
    either holds."""
    return not stiffened, stressed and flexbody.axial_free(fb)


def modal_beam(fb: flexbody.FlexBody, eta, mat, sec, points: dict, x0: dict, root, F=None,
               rule: tuple = (False, False), summed: dict | None = None) -> Beam:
    """The Beam of a modal beam from its modal coordinates eta (n, nm): the solver's tracked
    points and root rotation, the section strains and validity measures, and, as `rule`
    (`axial_rule`) says, the quasi-static axial force from the node forces F (n, N, 3)
    (`node_forces`) in the measures and in the strains. The strains are the modes' (mode
    displacement) or, given `summed` ({x: (n, 4)}, force summation: `section_loads`), those, which
    hold the axial force already. mat: the beam's `cases.Material`."""
    load, strain = rule
    strains = modal_strains(fb, eta) if summed is None else summed
    extent = modal_extent(fb, eta, sec)
    if load:
        extent["axial_load"] = axial_load(axial_force(fb.x0, F, 0.5 * fb.x0[1, 0]), mat.E, sec, fb.length,
                                          fb.boundary)
    if strain and summed is None:
        strains = with_axial_strain(strains, {x: axial_force(fb.x0, F, x) for x in strains}, mat.E * sec.A)
    return Beam(length=fb.length, points=points, x0=x0, root=root, strains=strains, extent=extent)


def modal_solid(fb: flexbody.FlexBody, solid, keys: list, points, eta) -> Beam:
    """The Beam of a modal solid (`cases.Solid`) from its modal coordinates eta (n, nm): the
    reference points of its interfaces `keys` (the frame's first), the frame interface's rotation
    (the identity: the modes hold it), the stresses at its stress points (`points`, the order of
    FlexBody.S_solid) and its largest elastic node displacement over its length (`solid_extent`)."""
    at, x0 = modal_points(fb, keys, eta, {k: solid.node(k) for k in keys})
    stresses = {tuple(p): eta @ fb.S_solid[k].T for k, p in enumerate(points)}
    surface = None
    if not solid.is_frame:                              # a frame's bars have no faces to draw
        _, inverse, S = flexbody.surface_stress_modes(solid, fb)
        surface = surface_stresses(S, inverse, eta)
    return Beam(length=fb.length, points=at, x0=x0, root=modal_root(fb, eta), origin=solid.frame,
                stresses=stresses, extent=solid_extent(fb, eta), surface=surface)


def solid_extent(fb: flexbody.FlexBody, eta, block: int = 256) -> dict:
    """{"deflection": (n,)} the largest elastic node displacement |Phi_t,p eta| over the body's
    length, in blocks of samples (a solid has many nodes). A solid's rotations and strains are
    not measured here: its stress channels show them."""
    Pt = fb.Phi[:, 3:, :]
    out = [np.linalg.norm(flexbody.modal_field(Pt, eta[k:k + block]), axis=2).max(axis=1)
           for k in range(0, len(eta), block)]
    return {"deflection": (np.concatenate(out) if out else np.zeros(0)) / fb.length}


def axial_force(x0: np.ndarray, F: np.ndarray, x: float) -> np.ndarray:
    """(n,) quasi-static axial force N(x) (tension positive), N, from the net forces F (n, N, 3)
    on the nodes at x0 (N, 3) in the body frame (applied loads, gravity and d'Alembert inertia
    -m_p a_p, and the forces of child joints): the x component of their sum over the outer part,
    x0_p > x, a node at the cut counting half. It is what a beam whose retained modes have no
    axial motion carries along its axis (docs/formulation.md §7)."""
    w = np.where(x0[:, 0] > x, 1.0, np.where(x0[:, 0] == x, 0.5, 0.0))
    return F[:, :, 0] @ w


def with_axial_strain(strains: dict, N: dict, EA: float) -> dict:
    """Section strains {x: (n, 4)} with the axial strain N(x) / (E A) added at every section."""
    out = {}
    for x, s in strains.items():
        s = s.copy()
        s[:, 0] += N[x] / EA
        out[x] = s
    return out


# ---------------------------------------------------------------------------------------------
# linear validity of a modal beam (docs/formulation.md §7)

# limits of a linear modal model: the largest elastic displacement of a node over the beam's
# length, the largest elastic node rotation (rad), the largest strain, and - when the model has
# no geometric stiffening - the largest axial force over the beam's Euler load (`axial_load`: pinned
# at both ends for hinged-hinged modes, else clamped at its root) (beyond ~2 % the axial force shifts the bending frequencies
# by ~1 % and the phase drifts within tens of cycles)
LIMITS = {"deflection": 0.10, "rotation": 0.10, "strain": 0.005, "axial_load": 0.02}
WORDS = {"deflection": "deflection {:.0f} % of length", "rotation": "node rotation {:.2f} rad",
         "strain": "strain {:.2f} %", "axial_load": "axial load {:.0f} % of the buckling load"}
PERCENT = {"deflection", "strain", "axial_load"}


def modal_extent(fb: flexbody.FlexBody, eta, sec) -> dict:
    """{measure: (n,)} of a modal beam at modal coordinates eta (n, nm): the largest elastic node
    displacement |Phi_t,p eta| / L, the largest elastic node rotation |Phi_r,p eta| (rad), and the
    largest element strain (|du_x| + cy |d theta_z| + cz |d theta_y|) / l between neighbouring
    nodes (the element's mean axial and outer-fibre bending strain)."""
    u = flexbody.modal_field(fb.Phi[:, 3:, :], eta)                     # (n, N, 3)
    th = flexbody.modal_field(fb.Phi[:, :3, :], eta)
    l = np.diff(fb.x0[:, 0])
    du, dth = np.diff(u, axis=1), np.diff(th, axis=1)
    strain = (np.abs(du[:, :, 0]) + sec.cy * np.abs(dth[:, :, 2]) + sec.cz * np.abs(dth[:, :, 1])) / l
    return {"deflection": np.linalg.norm(u, axis=2).max(axis=1) / fb.length,
            "rotation": np.linalg.norm(th, axis=2).max(axis=1),
            "strain": strain.max(axis=1)}


# the effective length over L of a beam's Euler load pi^2 E I / (K L)^2, by the boundary condition
# of its modes: a beam on hinges at both ends buckles in a half sine (K = 1), any other is taken
# as clamped at its root and free at its tip (K = 2, the lowest of a beam held at one end)
BUCKLING_LENGTH = {"hinged-hinged": 1.0}


def axial_load(N, E: float, sec, length: float, boundary: str = "clamped-free") -> np.ndarray:
    """(n,) |N| over the Euler load pi^2 E I_min / (K L)^2 of the beam with its modes' boundary
    condition (K: BUCKLING_LENGTH, 2 for a beam clamped at its root)."""
    K = BUCKLING_LENGTH.get(boundary, 2.0)
    return np.abs(N) / (np.pi ** 2 * E * min(sec.Iy, sec.Iz) / (K * length) ** 2)


def validity(traj: Trajectory) -> tuple[dict, tuple | None]:
    """({body: {measure: largest value}}, (why, t) or None): the largest excess over LIMITS of
    the geometric measures (deflection, rotation, strain), or, when none is exceeded, of the
    axial load (a beam that deflects beyond its linear range is reported by how far it deflects)."""
    summary, worst = {}, {}
    for name, beam in traj.beams.items():
        summary[name] = {k: float(np.max(v)) if len(v) else 0.0 for k, v in beam.extent.items()}
        for k, v in beam.extent.items():
            if not len(v):
                continue
            i = int(np.argmax(v))
            ratio, group = v[i] / LIMITS[k], "axial" if k == "axial_load" else "geometric"
            if ratio > 1.0 and ratio > worst.get(group, (0.0,))[0]:
                why = WORDS[k].format(100.0 * v[i] if k in PERCENT else v[i])
                worst[group] = (ratio, why if len(traj.beams) == 1 else f"{name}: {why}", float(traj.t[i]))
    pick = worst.get("geometric") or worst.get("axial")
    return summary, None if pick is None else pick[1:]


# ---------------------------------------------------------------------------------------------
# one function per channel kind


def chord_frames(e) -> np.ndarray:
    """Rotations (n, 3, 3) taking the x axis onto the directions e (n, 3) by the smallest turn:
    with u = e / |e|, k = x ~ u (|k| = sin of the turn, u_x its cosine), Rodrigues' formula
    R = 1 + k~ + k~^2 / (1 + u_x); the identity where |k| < 1e-15 (u along +x or -x)."""
    u = e / np.linalg.norm(e, axis=-1, keepdims=True)
    K = np.zeros((len(u), 3, 3))
    K[:, 0, 1], K[:, 0, 2] = -u[:, 1], -u[:, 2]            # k~ for k = (0, -u_z, u_y)
    K[:, 1, 0], K[:, 2, 0] = u[:, 1], u[:, 2]
    turned = np.hypot(u[:, 1], u[:, 2]) >= 1e-15
    R = np.broadcast_to(np.eye(3), K.shape).copy()
    R[turned] += K[turned] + K[turned] @ K[turned] / (1.0 + u[turned, 0])[:, None, None]
    return R


def displacement(beam: Beam, x: float, k=slice(None)) -> np.ndarray:
    """(n, 3) displacement of the point at x in the root-node frame (or the chord frame), minus
    its undeformed offset from the root node, m; at the samples k (all by default)."""
    r0 = beam.points[beam.origin][k]
    R = None if beam.root is None else beam.root[k]
    if R is None:
        R = chord_frames((beam.points[beam.length][k] - r0).reshape(-1, 3))
    d = np.einsum("nji,nj->ni", R, beam.points[x][k] - r0)
    return d - (beam.x0[x] - beam.x0[beam.origin])


def deflection(beam: Beam, x: float, axis: int) -> np.ndarray:
    """(n,) displacement of the point at x along `axis` (0, 1, 2) of the root-node frame (or the
    chord frame), minus its undeformed offset from the root node, m."""
    return displacement(beam, x)[:, axis]


def shapes(case, traj: Trajectory, instants) -> dict:
    """The deformed-shape snapshots of every flexible beam of a trajectory:
    {body: {"x": [nx], "t": [k], "u": (k, nx, 3), "r": (k, nx, 3), "stress": (k, nx)}, nested lists}.
    x are the shape points' undeformed positions along the beam as the solver tracks them (its
    nodes nearest to `shape_positions`, m), t the output samples nearest to `instants` (s), u each
    point's `displacement` there (root-node or chord frame, m), r its position in the global frame
    (m; where the beam is `placed`), stress the von Mises stress at the outer fibre of its section
    (Pa, `stress_vm`; where the run holds the strains at every shape point, as the runs of
    `flexmbd animate` and `export` do). An instant farther than half an output interval from every
    sample (the run ended before it) is left out, as is a sample at which a beam's values are not
    finite; a beam without shape points or snapshots is left out."""
    t, picks = np.asarray(traj.t, dtype=float), snapshot_samples(case, traj.t, instants)
    where = placed(case, traj) if picks else {}
    out = {}
    for name, beam in traj.beams.items():
        xs = shape_positions(case, name)
        if not xs or not picks:
            continue
        got = {"u": np.stack([displacement(beam, x, picks) for x in xs], axis=1)}            # (k, nx, 3)
        if name in where:
            got["r"] = to_global(where[name], picks, np.stack([beam.points[x][picks] for x in xs], axis=1))
        if all(x in beam.strains for x in xs):
            b = case.bodies[name]
            got["stress"] = np.stack([stress_vm(beam.strains[x][picks], b.material.E, b.material.G, b.geometry, None)
                                      for x in xs], axis=1)                                  # (k, nx)
        keep = np.all([np.isfinite(v).reshape(len(picks), -1).all(axis=1) for v in got.values()], axis=0)
        if keep.any():
            out[name] = {"x": [float(beam.x0[x][0] - beam.x0[0.0][0]) for x in xs],
                         "t": [float(t[i]) for i, ok in zip(picks, keep) if ok],
                         **{k: v[keep].tolist() for k, v in got.items()}}
    return out


def placed(case, traj: Trajectory) -> dict:
    """{body: (R (n, 3, 3), p (n, 3))}: where each body is in the global frame, R turning the frame
    its points are given in into the global one and p that frame's origin (m): a body without a
    Beam (rigid in the solver's model) by its body frame, a flexible body by its Beam's frame F
    (the identity where its points are global), as the solver reports them (`Trajectory.poses`);
    a body clamped to the ground by a fixed joint, whose pose the solver does not report, where
    the joint holds it. Any other body whose pose is not reported is left out."""
    out, n = {b: traj.poses[b] for b in case.bodies if b in traj.poses}, len(traj.t)
    clamped = [b for b in case.bodies if b not in out and case.joint_of(b).parent == "ground"
               and case.joint_of(b).type == "fixed"]
    if clamped:
        at = closure.body_poses(case, {name: j.q0 for name, j in case.joints.items()})
        out.update({b: (np.broadcast_to(at[b][0], (n, 3, 3)), np.broadcast_to(at[b][1], (n, 3))) for b in clamped})
    return out


def to_global(pose: tuple, k, x) -> np.ndarray:
    """(len(k), m, 3) points x ((len(k), m, 3), or (m, 3) fixed in the frame) given in the frame of
    `pose` (`placed`: R (n, 3, 3), p (n, 3)), in the global frame at the samples k, m."""
    R, p = (np.asarray(a, dtype=float)[k] for a in pose)
    x = np.broadcast_to(np.asarray(x, dtype=float), (len(R),) + np.shape(x)[-2:])
    return p[:, None, :] + np.einsum("kij,kmj->kmi", R, x)


def poses(case, traj: Trajectory, instants) -> dict:
    """The global poses of the bodies that have no shape points, at the samples `shapes` picks:
    {body: {"t": [k], "R": (k, 3, 3), "p": (k, 3)}, nested lists}, R the rotation from the body
    frame into the global one and p its origin (m), of every body `placed` that is rigid in the
    solver's model (a rigid body or point mass, a beam declared rigid, every beam of a rigid-body
    solver) and of every solid (its surface's frame); a sample at which a pose is not finite is
    left out."""
    t, picks = np.asarray(traj.t, dtype=float), snapshot_samples(case, traj.t, instants)
    out = {}
    for name, (R, p) in (placed(case, traj) if picks else {}).items():
        if name in traj.beams and case.bodies[name].type != "solid":
            continue                                    # a flexible beam's points are in its shapes
        R, p = np.asarray(R, dtype=float)[picks], np.asarray(p, dtype=float)[picks]
        keep = np.isfinite(R).all(axis=(1, 2)) & np.isfinite(p).all(axis=1)
        if keep.any():
            out[name] = {"t": [float(t[i]) for i, ok in zip(picks, keep) if ok], "R": R[keep].tolist(),
                         "p": p[keep].tolist()}
    return out


def snapshot_samples(case, t, instants) -> list:
    """The output samples (indices of t) nearest to `instants`, without repeats, leaving out an
    instant farther than half an output interval from every sample (the run ended before it)."""
    t, half = np.asarray(t, dtype=float), 0.5 * case.integrator.output_dt * (1.0 + 1e-9)
    picks = [int(np.argmin(np.abs(t - s))) for s in instants] if len(t) else []
    return list(dict.fromkeys(i for i, s in zip(picks, instants) if abs(t[i] - s) <= half))


def fields(case, traj: Trajectory, instants) -> dict:
    """The von Mises field on every solid's surface at the output samples nearest to `instants`:
    {body: {"t": [k], "vm": (k, nf) nested lists, Pa}}, one value per boundary face
    (`flexbody.surface_stress_modes`: its element's centre stress), as `shapes` picks its samples;
    a solid whose solver gives no field is left out."""
    t, picks = np.asarray(traj.t, dtype=float), snapshot_samples(case, traj.t, instants)
    out = {}
    for name, beam in traj.beams.items():
        if beam.surface is None or not picks:
            continue
        vm = solid_von_mises(np.asarray(beam.surface(np.array(picks)), dtype=float))
        keep = np.all(np.isfinite(vm), axis=1)
        if keep.any():
            out[name] = {"t": [float(t[i]) for i, ok in zip(picks, keep) if ok], "vm": vm[keep].tolist()}
    return out


def surface_stresses(S: np.ndarray, inverse: np.ndarray, eta) -> object:
    """The `Beam.surface` of a modal solid: k -> (len(k), nf, 6) stresses at its boundary faces
    from the modal stresses S (ne, 6, nm) of their elements (`inverse`: face -> row of S)."""
    return lambda k: flexbody.modal_field(S, eta[k])[:, inverse]


def stress_vm(strains, E: float, G: float, sec, fibre) -> np.ndarray:
    """(n,) von Mises stress at the section point `fibre` (y, z) (None: (cy, 0)) from section
    strains (n, 4), Pa."""
    return von_mises(*section_stresses(strains, E, G, sec, fibre))


def solid_vm(stresses) -> np.ndarray:
    """(n,) von Mises stress of a solid's stresses (n, 6) at a point, Pa."""
    return solid_von_mises(np.asarray(stresses, dtype=float))


def principal_sign(stresses) -> np.ndarray:
    """(n,) +1 or -1: the sign of the principal stress of largest magnitude of stresses (n, 6)
    [xx, yy, zz, yz, zx, xy] (+1 where all are zero)."""
    S = np.asarray(stresses, dtype=float)
    T = np.stack([np.stack([S[:, 0], S[:, 5], S[:, 4]], -1), np.stack([S[:, 5], S[:, 1], S[:, 3]], -1),
                  np.stack([S[:, 4], S[:, 3], S[:, 2]], -1)], -2)
    lam = np.linalg.eigvalsh(T)                                  # ascending
    return np.where(np.abs(lam[:, 0]) > np.abs(lam[:, -1]), -1.0, 1.0)


def beam_stress(kind: str, strains, E: float, G: float, sec, fibre) -> np.ndarray:
    """(n,) stress channel `kind` (cases.STRESS_KINDS) at a beam's section point from its section
    strains (n, 4), Pa. The state there is sigma along the axis and the torsional shear tau, whose
    principal stresses sigma/2 +- sqrt(sigma^2/4 + tau^2) have the larger magnitude on sigma's side."""
    sigma, tau = section_stresses(strains, E, G, sec, fibre)
    if kind == "stress_normal":
        return sigma
    vm = von_mises(sigma, tau)
    return np.where(sigma < 0.0, -vm, vm) if kind == "stress_signed_vm" else vm


def solid_stress(kind: str, stresses, direction=None) -> np.ndarray:
    """(n,) stress channel `kind` from a solid's stresses (n, 6) at a point, Pa ([xx, yy, zz, yz,
    zx, xy]); stress_normal along the unit `direction` (3,), body frame: e^T sigma e (None: x,
    sigma_xx)."""
    S = np.asarray(stresses, dtype=float)
    if kind == "stress_normal":
        if direction is None:
            return S[:, 0].copy()
        e = np.asarray(direction, dtype=float)
        return S[:, :3] @ e ** 2 + 2.0 * S[:, 3:] @ np.array([e[1] * e[2], e[2] * e[0], e[0] * e[1]])
    vm = solid_vm(S)
    return principal_sign(S) * vm if kind == "stress_signed_vm" else vm


def energy(traj: Trajectory) -> np.ndarray:
    """(n,) total energy: the sum of the parts, J."""
    return sum(traj.energy.values())


def reaction(f, kind: str, component: str) -> np.ndarray:
    """(n,) one component of joint forces f (n, 6) [moment; force]."""
    return f[:, "xyz".index(component) + (3 if kind == "reaction_force" else 0)].copy()


SI_UNITS = {"deflection": "m", "stress_vm": "Pa", "stress_normal": "Pa", "stress_signed_vm": "Pa", "joint_angle": "rad",
            "energy": "J", "reaction_force": "N", "reaction_moment": "N m"}


def unit(case, name: str) -> str:
    """Channel `name`'s SI unit: by its kind, and m for the coordinate of a prismatic joint."""
    c = case.channels[name]
    if c.kind == "joint_angle" and c.joint in case.joints and case.joints[c.joint].type == "prismatic":
        return "m"
    return SI_UNITS[c.kind]


KIND_NAMES = {"deflection": "deflection", "stress_vm": "von Mises stress", "stress_normal": "normal stress",
              "stress_signed_vm": "signed von Mises stress", "joint_angle": "angle",
              "energy": "energy", "reaction_force": "reaction force", "reaction_moment": "reaction moment"}


def label(case, name: str) -> str:
    """Channel `name` as a reader names it, with its SI unit (`unit`): 'deflection y at 8 m [m]',
    'von Mises stress at 0.05 m [Pa]', 'angle of hub [rad]' ('position' for a prismatic joint),
    'energy [J]', 'reaction force x at hub [N]'; a body named where the case has more than one
    flexible body; a solid's point with where it lies ('normal stress at (0.03, 0.0075, 0) m, on
    the +y face [Pa]', `flexbody.point_place`)."""
    c, u = case.channels[name], unit(case, name)
    if c.kind in ("deflection", *cases.STRESS_KINDS):
        comp = f" {c.component}" if c.kind == "deflection" else ""
        if c.where is not None:                         # a solid's stress point, and where it lies
            place = flexbody.point_place(case.bodies[c.body], tuple(c.where))
            at = "(" + ", ".join(f"{v:g}" for v in c.where) + ") m" + (f", {place}" if place else "")
        else:
            at = str(c.at) if isinstance(c.at, str) else f"{c.at:g} m"
        flexible = [b for b in case.bodies.values() if b.type in ("beam", "solid")]
        of = f" of {c.body}" if len(flexible) > 1 else ""
        along = "" if c.direction is None else " along (" + ", ".join(f"{v:.3g}" for v in c.direction) + ")"
        return f"{KIND_NAMES[c.kind]}{comp}{along}{of} at {at} [{u}]"
    if c.kind == "joint_angle":
        return f"{'position' if u == 'm' else 'angle'} of {c.joint} [{u}]"
    if c.kind in ("reaction_force", "reaction_moment"):
        return f"{KIND_NAMES[c.kind]} {c.component} at {c.joint} [{u}]"
    return f"{KIND_NAMES[c.kind]} [{u}]"


def physical_scale(case, name: str, kinetic_max: float | None = None) -> float:
    """The scale of channel `name` in the case, in its unit, that its differences are measured
    against where the reference's own magnitude can be noise (`metrics.channel_norm`):

        energy       the largest kinetic energy of the case's reference run (`kinetic_max`, J),
                     else the closed form `gravity_energy`
        deflection   its beam's length, m
        stress_vm    its beam's Young's modulus, Pa (the stress of a unit strain)
        joint_angle  1 (rad, or m for a prismatic joint)
        reaction_*   0: no scale (its reference's magnitude alone)
    """
    c = case.channels[name]
    kind = c.kind
    if kind == "energy":
        return float(kinetic_max) if kinetic_max else gravity_energy(case)
    if kind == "deflection":
        return float(case.bodies[c.body].length)
    if kind in cases.STRESS_KINDS:
        return float(case.bodies[c.body].material.E)
    return 1.0 if kind == "joint_angle" else 0.0


def gravity_energy(case) -> float:
    """|g| sum_b m_b l_b (J): the energy scale of a system moved by gravity, each body's mass m_b
    times the length l_b of the chain from the ground to its far end (beam lengths, a rigid body's
    centre of mass offset), the most its mass can descend by. 0 without gravity."""
    g = float(np.linalg.norm(case.gravity))

    def reach(name: str) -> float:
        b, parent = case.bodies[name], case.joint_of(name).parent
        own = b.length if b.type in ("beam", "solid") else float(np.linalg.norm(b.com))
        return own + (reach(parent) if parent != "ground" else 0.0)

    def mass(b) -> float:
        if b.type == "solid":                           # its consistent mass's total, the row sums
            return float(case.reduced(b.name).m.sum())
        return b.material.rho * b.geometry.A * b.length if b.type == "beam" else b.mass

    return g * sum(mass(b) * reach(n) for n, b in case.bodies.items())


# the divergence rule on channels (`results.first_failure`), after a run and while it runs


def bounds(case) -> dict:
    """Channel -> largest plausible magnitude (the divergence rule): a deflection,
    DIVERGED_LENGTHS times its beam's length; other channels need only be finite."""
    return {name: results.DIVERGED_LENGTHS * case.bodies[c.body].length
            for name, c in case.channels.items() if c.kind == "deflection"}


def failure(case, traj: Trajectory) -> tuple[int, results.Status] | None:
    """The first sample of `traj` at which the divergence rule fails a run, and why
    (`results.first_failure`), judged on the channels that have a bound (`bounds`): what a solver
    checks while it runs, at each output sample, to stop there instead of integrating a run that
    has already failed. Its beams need only their points and root rotation; a beam `traj` has no
    Beam for is rigid (its deflections zero). The whole rule is applied again to every channel
    once the run has ended (`registry.run`)."""
    bound = bounds(case)
    chans = {name: deflection(traj.beams[c.body], c.at, "xyz".index(c.component))
             for name, c in case.channels.items() if name in bound and c.body in traj.beams}
    return results.first_failure(traj.t, chans, bound) if chans else None


def channels(case, traj: Trajectory) -> dict:
    """Every channel of the case, (n,) each. What the solver does not report is left out: a joint
    coordinate, the energy (no parts), a reaction it does not recover. A beam the trajectory has no
    Beam for is rigid in the solver's model: its deflections and stresses are zero."""
    out, n = {}, len(traj.t)
    for name, c in case.channels.items():
        kind = c.kind
        if kind == "joint_angle":
            if c.joint in traj.joints:
                out[name] = np.array(traj.joints[c.joint], dtype=float)
        elif kind == "energy":
            if traj.energy:
                out[name] = np.asarray(energy(traj), dtype=float)
        elif kind in ("reaction_force", "reaction_moment"):
            if c.joint in traj.reactions:
                out[name] = reaction(traj.reactions[c.joint], kind, c.component)
        elif c.body not in traj.beams:
            out[name] = np.zeros(n)
        elif kind == "deflection":
            out[name] = deflection(traj.beams[c.body], c.at, "xyz".index(c.component))
        elif c.where is not None:                                   # a solid: at its point
            out[name] = solid_stress(kind, traj.beams[c.body].stresses[c.where], c.direction)
        else:
            body = case.bodies[c.body]
            out[name] = beam_stress(kind, traj.beams[c.body].strains[float(c.at)], body.material.E, body.material.G,
                                    body.geometry, c.fibre)
    return out
