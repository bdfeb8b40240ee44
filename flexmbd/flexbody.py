"""The reduced flexible body: the one object every solver reads.

A beam of the case file goes through the FE pre-processor (`flexmbd.fe`) once; what the solvers
need of it is kept here as plain arrays, in the body frame (beam along +x from the root node):

    x0      (N, 3)        undeformed node positions u_p, m
    m       (N,)          lumped translational node masses m_p, kg
    J       (N, 3, 3)     lumped rotary inertias J_p at the nodes, kg m^2
    Phi     (N, 6, nm)    mode block per node, rows [rot x,y,z; trans x,y,z] (spatial order)
    freq_hz (nm,)         natural frequencies of the reduced body, eig(Km, I9), Hz
    labels  (nm,)         'bending xy 1', 'torsion 1', ...
    Km, Cm  (nm, nm)      modal stiffness Phi^T K Phi and modal damping 2 zeta omega (diagonal)
    stress_x (ns,)        stress sections along the beam, m
    S_strain (ns, 4, nm)  modal section strains there, rows [eps, kappa_y, kappa_z, twist rate]
                          per unit modal coordinate (stresses at a section point:
                          `fe.stress.section_stresses`)

The node masses m_p, J_p are always the lumped ones: the floating-frame invariants are node sums,
and their modal mass I9 = sum Phi_r^T J_p Phi_r + m_p Phi_t^T Phi_t is Phi^T M_lumped Phi. The
case's FE mass matrix (lumped by default, as in the paper) chooses the retained modes; with
mass = "consistent" it chooses their span, within which they are re-orthonormalized in the lumped
mass (`in_node_masses`). With either mass I9 = 1 and Km is diagonal, and freq_hz (and the damping
Cm built from it) are the frequencies of the reduced body itself: with consistent mass these are
Ritz values of the lumped-mass beam, at or above its own frequencies.

Reference node. A body's parent joint acts on its frame origin, the root node (node 0, x = 0),
so the frame has to stay on that material point. Clamped-free modes hold node 0 (the frame is the
one tangent to the beam there) and hinged-hinged modes its position (the frame's x axis is the
chord through both hinges). Free-free and Craig-Bampton modes move node 0 like any other node, so
each loses its rigid-body motion of node 0 (`reference_node`): node 0's block of Phi is zero and
the frame is the one tangent to the beam at node 0, the paper's choice of the flexible body
reference frame. Free-free: the `count` lowest modes are held, and with the rigid-body motion the
frame carries they span what the free-free set spans. Craig-Bampton: the lowest `count` of the
held basis are kept; with an interface at node 0 the held basis is the Craig-Bampton basis of the
beam clamped there (node 0's constraint modes are rigid-body motions, which the frame carries).
"""

from __future__ import annotations

import functools
import json
from dataclasses import dataclass, fields
from typing import NamedTuple

import numpy as np

from flexmbd.fe import assembly, modes, section, stress
from flexmbd.jit import njit
from flexmbd.spatial import cross_force_into, skew


@dataclass(frozen=True)
class FlexBody:
    name: str
    length: float
    x0: np.ndarray
    m: np.ndarray
    J: np.ndarray
    Phi: np.ndarray
    freq_hz: np.ndarray
    labels: np.ndarray
    Km: np.ndarray
    Cm: np.ndarray
    boundary: str
    stress_x: np.ndarray
    S_strain: np.ndarray

    @property
    def n_nodes(self) -> int:
        return self.x0.shape[0]

    @property
    def n_modes(self) -> int:
        return self.Phi.shape[2]

    def node_at(self, x: float) -> int:
        """Index of the node nearest to position `x` along the beam (m), by `node_index`."""
        return node_index(self.length, self.n_nodes - 1, x)


def node_index(length: float, elements: int, x: float) -> int:
    """The node nearest to position x (m) along a beam meshed in `elements` equal elements: the
    one snapping rule of every solver (half-way between two nodes goes to the root side)."""
    return int(min(max(np.ceil(x * elements / length - 0.5), 0), elements))


def snapped(length: float, elements: int, x: float) -> float:
    """Position x (m) along a beam snapped to its nearest node (`node_index`), m."""
    return node_index(length, elements, x) * length / elements


def beam_section(body: dict) -> section.Section:
    """The FE section of a case beam; FE convention: extent h along y, b along z."""
    s = body["section"]
    if s["shape"] == "circle":
        return section.circle(s["d"])
    if s["h_axis"] == "y":
        return section.rectangle(b=s["b"], h=s["h"])
    return section.rectangle(b=s["h"], h=s["b"])


def shear_modulus(material: dict) -> float:
    return material["E"] / (2.0 * (1.0 + material["nu"]))


def fe_model(body: dict, material: dict):
    """Mesh and assembled matrices of a case beam: (nodes, elements, sec, K, M, M_lumped)."""
    sec = beam_section(body)
    nodes, elements = assembly.beam_mesh(body["length"], body["elements"])
    E, G, rho = material["E"], shear_modulus(material), material["rho"]
    K, M = assembly.beam_matrices(nodes, elements, E, G, rho, sec, mass=body["mass"], shear=body["shear"])
    if body["mass"] == "lumped":
        M_lumped = M
    else:
        _, M_lumped = assembly.beam_matrices(nodes, elements, E, G, rho, sec, mass="lumped")
    return nodes, elements, sec, K, M, M_lumped


def mode_set(body: dict, K, M, M_lumped, nodes: np.ndarray):
    """The reduced body's modes (6N, nm), orthonormal in the lumped mass, and their frequencies (Hz).

    The case's mass matrix M chooses the modes: the lowest `count` elastic modes of the boundary
    conditions, free-free and Craig-Bampton ones made to hold the reference node first
    (`reference_node`). Unless they already are (lumped M, clamped-free or hinged-hinged), the
    retained modes are then re-orthonormalized within their span in the lumped mass (`in_node_masses`).
    """
    m = body["modes"]
    if m["boundary"] in ("clamped-free", "hinged-hinged"):
        freq, Phi = modes.normal_modes(K, M, modes.boundary_dofs(m["boundary"], nodes.shape[0]), m["count"])
        if M is M_lumped:
            return freq, Phi
    else:
        Phi = reference_node(K, M, nodes, floating_modes(body, K, M))[:, : m["count"]]
    return in_node_masses(K, M_lumped, Phi)


def floating_modes(body: dict, K, M) -> np.ndarray:
    """Elastic modes (6N, k), M-orthonormal, of a free-free or Craig-Bampton beam (node 0 moves in them):
    the lowest `count` free-free modes, or every elastic direction of the Craig-Bampton basis."""
    m = body["modes"]
    if m["boundary"] == "free-free":
        return modes.normal_modes(K, M, [], m["count"])[1]
    L, n_el = body["length"], body["elements"]
    held = sorted({node_index(L, n_el, x) for x in m["interfaces"]})
    iface = np.array([6 * p + k for p in held for k in range(6)])
    n_normal = max(m["count"] - iface.size, 0)
    Phi = modes.craig_bampton(K, M, np.array([], dtype=int), iface, n_normal + 6)
    freq, Phi = modes.orthonormalize(K, M, Phi)
    return Phi[:, freq > 1e-6 * freq.max()]       # the floating frame carries the rigid-body motion


def reference_node(K, M, nodes: np.ndarray, Phi: np.ndarray) -> np.ndarray:
    """Modes (6N, k) spanning Phi less its rigid-body motion of node 0, M-orthonormal, K-diagonal,
    in ascending frequency: node 0's six DOFs are zero in each, so the body frame is the frame
    tangent to the beam at node 0, the material point the parent joint holds.

    Every mode loses the rigid displacement field with node 0's translation t and rotation theta
    (t + theta x (x_p - x_0) at node p, theta); K annihilates it, so Phi^T K Phi is unchanged.
    Modes without a rigid part stay independent: none is lost.
    """
    return modes.orthonormalize(K, M, modes.hold_node(Phi, nodes, 0))[1]


def in_node_masses(K, M_lumped, Phi: np.ndarray):
    """Modes (6N, k) spanning Phi, orthonormal in the lumped mass the invariants are summed from
    (I9 = 1) and K-diagonal, and their frequencies (Hz): those of the reduced body, from Km."""
    _, Phi = modes.orthonormalize(K, M_lumped, Phi)
    return np.sqrt(np.clip(np.diag(modal_stiffness(K, Phi)), 0.0, None)) / (2.0 * np.pi), Phi


def modal_stiffness(K, Phi_fe: np.ndarray) -> np.ndarray:
    """Km = Phi^T K Phi (nm, nm), symmetrized."""
    Km = Phi_fe.T @ (K @ Phi_fe)
    return 0.5 * (Km + Km.T)


def spatial_blocks(Phi_fe: np.ndarray) -> np.ndarray:
    """FE mode matrix (6N, nm), node DOFs [u; theta] -> per-node spatial blocks (N, 6, nm), [theta; u]."""
    n = Phi_fe.shape[0] // 6
    B = Phi_fe.reshape(n, 6, -1)
    return np.concatenate([B[:, 3:6], B[:, 0:3]], axis=1)


def build(name: str, body: dict, material: dict, stress_points=()) -> FlexBody:
    """Reduce a case beam to a FlexBody. `stress_points`: positions x along the beam (m) of the
    sections whose strains the channels need."""
    nodes, elements, sec, K, M, M_lumped = fe_model(body, material)
    freq, Phi_fe = mode_set(body, K, M, M_lumped, nodes)

    # lumped node masses and rotary inertias, from the lumped diagonal
    d = M_lumped.diagonal().reshape(-1, 6)
    m = d[:, 0].copy()
    J = np.zeros((nodes.shape[0], 3, 3))
    J[:, [0, 1, 2], [0, 1, 2]] = d[:, 3:6]

    # constant modal stiffness and damping
    Km = modal_stiffness(K, Phi_fe)
    omega = 2.0 * np.pi * np.asarray(freq)
    Cm = np.diag(2.0 * body["damping_ratio"] * omega)

    # modal strain recovery
    E, G = material["E"], shear_modulus(material)
    xs = [float(x) for x in stress_points]
    S = [stress.strain_rows(nodes, elements, E, G, sec, x, shear=body["shear"]) @ Phi_fe for x in xs]
    nm = Phi_fe.shape[1]
    return FlexBody(
        name=name, length=body["length"], x0=nodes, m=m, J=J, Phi=spatial_blocks(Phi_fe),
        freq_hz=np.asarray(freq), labels=np.array(modes.mode_labels(Phi_fe) if nm else [], dtype=str), Km=Km, Cm=Cm,
        boundary=body["modes"]["boundary"], stress_x=np.array(xs, dtype=float),
        S_strain=np.array(S).reshape(len(xs), 4, nm))


def for_case(case) -> dict:
    """Every flexible beam of a case, reduced, by body name (`cases.Resolved.flexible`)."""
    return case.resolved.flexible()


def reduce(name: str, body: dict, material: dict, stress_points=()) -> FlexBody:
    """`build`, once per content: the reduction is cached by everything it depends on (name,
    body table, material, stress points), so the solver, the report, the command line and every
    adapter share one computation per process. Its arrays are read-only."""
    key = json.dumps([name, body, material, [float(x) for x in stress_points]], sort_keys=True)
    return _reduced(key)


def undeformed(name: str, body: dict, material: dict) -> FlexBody:
    """A beam declared rigid: its node masses and positions, no modes (`reduce` with count 0)."""
    return reduce(name, {**body, "modes": {**body["modes"], "count": 0}}, material)


@functools.lru_cache(maxsize=64)
def _reduced(key: str) -> FlexBody:
    name, body, material, points = json.loads(key)
    fb = build(name, body, material, points)
    for f in fields(fb):
        a = getattr(fb, f.name)
        if isinstance(a, np.ndarray):
            a.flags.writeable = False
    return fb


def save(fb: FlexBody, path) -> None:
    """Write the body to one .npz file."""
    np.savez(path, **{f.name: np.asarray(getattr(fb, f.name)) for f in fields(fb)})


def load(path) -> FlexBody:
    """Read a body written by `save`."""
    with np.load(path, allow_pickle=False) as z:
        kw = {f.name: z[f.name] for f in fields(FlexBody)}
    kw["name"], kw["boundary"] = str(kw["name"]), str(kw["boundary"])
    kw["length"] = float(kw["length"])
    return FlexBody(**kw)


# ---------------------------------------------------------------------------------------------
# inertia shape invariants (docs/formulation.md §3)
#
# Node p of the deformed body sits at r_p = x0_p + Phi_t,p eta (body frame); its kinetic energy
# is 1/2 m_p |v + w x r_p + Phi_t,p eta_d|^2 + 1/2 (w + Phi_r,p eta_d)^T J_p (w + Phi_r,p eta_d).
# The node sums of that expression are precomputed once; a~ is the skew matrix of a, and
# Phi_k = Phi_t,p[:, k] the translation of node p in mode k.


class Invariants(NamedTuple):
    """Invariants of one or more bodies, stacked on a leading body axis b and zero-padded to the
    largest mode count nm; in the formulas below the body index is dropped."""

    I1: np.ndarray     # (nb, 3, 3)          sum J_p - m_p x0~ x0~: rotational inertia of the undeformed body
    I2: np.ndarray     # (nb, nm, 3, 3)      -sum m_p (x0~ Phi_k~ + Phi_k~ x0~): its first-order change per mode
    I3: np.ndarray     # (nb, nm, nm, 3, 3)  -sum m_p Phi_k~ Phi_l~: its second-order change
    I4: np.ndarray     # (nb, 3)             sum m_p x0_p: first moment of mass of the undeformed body
    I5: np.ndarray     # (nb, 3, nm)         sum m_p Phi_t,p: change of the first moment per mode
    I6: np.ndarray     # (nb, 3, nm)         sum m_p x0~ Phi_t,p: rotation-mode coupling, translational part
    I7: np.ndarray     # (nb, nm, 3, nm)     sum m_p Phi_k~ Phi_t,p: change of the coupling (column k is zero)
    I8: np.ndarray     # (nb,)               sum m_p: mass
    I9: np.ndarray     # (nb, nm, nm)        sum Phi_r^T J_p Phi_r + m_p Phi_t^T Phi_t: modal mass
    I10: np.ndarray    # (nb, 3, nm)         sum J_p Phi_r,p: rotation-mode coupling, rotary part


def invariants(fb: FlexBody) -> Invariants:
    """The inertia shape invariants I1..I10 of one reduced body (leading axis of size 1)."""
    m, x0, J = fb.m, fb.x0, fb.J
    Pr, Pt = fb.Phi[:, :3, :], fb.Phi[:, 3:, :]                     # (N, 3, nm)
    eye = np.eye(3)

    # second moments of the node masses: x0 x0, x0 Phi_k, Phi_k Phi_l
    Q0 = np.einsum("p,pa,pb->ab", m, x0, x0)
    Q1 = np.einsum("p,pa,pbk->kab", m, x0, Pt)                      # (nm, 3, 3): sum m x0 Phi_k^T
    Q2 = np.einsum("p,pak,pbl->klab", m, Pt, Pt)                    # (nm, nm, 3, 3): sum m Phi_k Phi_l^T

    # a~ b~ = b a^T - (a . b) I turns the skew products into second moments
    I1 = J.sum(axis=0) + np.trace(Q0) * eye - Q0
    tr1 = np.trace(Q1, axis1=1, axis2=2)
    I2 = 2.0 * tr1[:, None, None] * eye - Q1 - Q1.transpose(0, 2, 1)
    tr2 = np.trace(Q2, axis1=2, axis2=3)
    I3 = tr2[:, :, None, None] * eye - Q2.transpose(1, 0, 2, 3)

    I4 = m @ x0
    I5 = np.einsum("p,pak->ak", m, Pt)
    I6 = np.einsum("p,pab,pbk->ak", m, _skew_rows(x0), Pt)
    I7 = np.einsum("p,pkab,pbl->kal", m, _skew_rows(Pt.transpose(0, 2, 1)), Pt)
    I9 = np.einsum("pak,pab,pbl->kl", Pr, J, Pr) + np.einsum("p,pak,pal->kl", m, Pt, Pt)
    I10 = np.einsum("pab,pbk->ak", J, Pr)
    one = lambda a: np.ascontiguousarray(a, dtype=float)[None]
    return Invariants(I1=one(I1), I2=one(I2), I3=one(I3), I4=one(I4), I5=one(I5), I6=one(I6),
                      I7=one(I7), I8=np.array([m.sum()]), I9=one(0.5 * (I9 + I9.T)), I10=one(I10))


def stack(invs: list, nm: int) -> Invariants:
    """Stack single-body invariants (None for a rigid body) into one, zero-padded to nm modes."""
    out = []
    for name, shape in zip(Invariants._fields, INV_SHAPES):
        full = np.zeros((len(invs),) + tuple(nm if d == "m" else d for d in shape))
        for b, inv in enumerate(invs):
            if inv is not None:
                x = getattr(inv, name)[0]
                full[(b,) + tuple(slice(0, n) for n in np.shape(x))] = x
        out.append(full)
    return Invariants(*out)


INV_SHAPES = [(3, 3), ("m", 3, 3), ("m", "m", 3, 3), (3,), (3, "m"), (3, "m"), ("m", 3, "m"), (),
              ("m", "m"), (3, "m")]


def _skew_rows(a: np.ndarray) -> np.ndarray:
    """Skew matrices of the last axis: (..., 3) -> (..., 3, 3)."""
    S = np.zeros(a.shape + (3,))
    S[..., 0, 1], S[..., 0, 2] = -a[..., 2], a[..., 1]
    S[..., 1, 0], S[..., 1, 2] = a[..., 2], -a[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -a[..., 1], a[..., 0]
    return S


# ---------------------------------------------------------------------------------------------
# the body-level terms, rebuilt from the invariants each evaluation (compiled; no node loops)


@njit(inline="always")
def contractions(inv, j, eta, eta_d, w):
    """The O(nm^2) contractions of I3 and I7 that the mass matrix, its rate and the quadratic
    forces share, for body j at modal state (eta, eta_d) and angular velocity w (3,).

    P_k = sum_l eta_l I3_kl; since I3_lk = I3_kl^T (I3_kl = sum_p m_p Phi_t,k~^T Phi_t,l~),
        I_O(eta)   = I1 + sum_k eta_k (I2_k + P_k)        rotational inertia about the origin (3, 3)
        N2_k(eta)  = dI_O/deta_k = I2_k + P_k + P_k^T
        I_O'       = sum_k eta_d_k N2_k                   (3, 3)
        wN2w_k     = w^T N2_k w                           (nm,)
        N1(eta)    = I6 + I10 + sum_k eta_k I7_k          rotation-mode block (3, nm)
        N1'        = sum_k eta_d_k I7_k                   (3, nm)
        wI7e_k     = w^T I7_k eta_d                       (nm,)
    """
    nm = eta.size
    P = np.empty((nm, 3, 3))
    for k in range(nm):
        for a in range(3):
            for b in range(3):
                s = 0.0
                for l in range(nm):
                    s += eta[l] * inv.I3[j, k, l, a, b]
                P[k, a, b] = s
    IO = np.empty((3, 3))
    IOd = np.empty((3, 3))
    for a in range(3):
        for b in range(3):
            s, sd = inv.I1[j, a, b], 0.0
            for k in range(nm):
                s += eta[k] * (inv.I2[j, k, a, b] + P[k, a, b])
                sd += eta_d[k] * (inv.I2[j, k, a, b] + P[k, a, b] + P[k, b, a])
            IO[a, b], IOd[a, b] = s, sd
    wN2w = np.empty(nm)
    wI7e = np.empty(nm)
    for k in range(nm):
        s, s7 = 0.0, 0.0
        for a in range(3):
            for b in range(3):
                s += w[a] * (inv.I2[j, k, a, b] + P[k, a, b] + P[k, b, a]) * w[b]
            for l in range(nm):
                s7 += w[a] * inv.I7[j, k, a, l] * eta_d[l]
        wN2w[k], wI7e[k] = s, s7
    N1 = np.empty((3, nm))
    N1d = np.empty((3, nm))
    for a in range(3):
        for l in range(nm):
            s, sd = inv.I6[j, a, l] + inv.I10[j, a, l], 0.0
            for k in range(nm):
                s += eta[k] * inv.I7[j, k, a, l]
                sd += eta_d[k] * inv.I7[j, k, a, l]
            N1[a, l], N1d[a, l] = s, sd
    return IO, IOd, wN2w, N1, N1d, wI7e


@njit(inline="always")
def first_moment(inv, j, eta):
    """c = I4 + I5 eta (3,): the body's mass times its centre of mass, body frame."""
    c = inv.I4[j].copy()
    for a in range(3):
        for k in range(eta.size):
            c[a] += inv.I5[j, a, k] * eta[k]
    return c


@njit(inline="always")
def mass_matrix_into(inv, j, IO, c, N1, M):
    """Assemble M (6+nm, 6+nm) over [w; v; eta_d] from I_O, c and N1, into M:

        M = [ I_O(eta)   c~        N1(eta) ]
            [ c~^T       I8 1      I5      ]
            [ N1^T       I5^T      I9      ]
    """
    nm = N1.shape[1]
    C = skew(c)
    for a in range(3):
        for b in range(3):
            M[a, b] = IO[a, b]
            M[a, 3 + b] = C[a, b]
            M[3 + b, a] = C[a, b]
            M[3 + a, 3 + b] = inv.I8[j] if a == b else 0.0
        for l in range(nm):
            M[a, 6 + l] = N1[a, l]
            M[6 + l, a] = N1[a, l]
            M[3 + a, 6 + l] = inv.I5[j, a, l]
            M[6 + l, 3 + a] = inv.I5[j, a, l]
    for k in range(nm):
        for l in range(nm):
            M[6 + k, 6 + l] = inv.I9[j, k, l]


@njit
def mass_matrix(inv, j, eta):
    """M(eta) (6+nm, 6+nm) over [w; v; eta_d] in the body frame (v: velocity of the body origin)."""
    z = np.zeros(eta.size)
    IO, _, _, N1, _, _ = contractions(inv, j, eta, z, np.zeros(3))
    M = np.empty((6 + eta.size, 6 + eta.size))
    mass_matrix_into(inv, j, IO, first_moment(inv, j, eta), N1, M)
    return M


@njit
def inertia_and_forces_into(inv, j, eta, v, eta_d, M, h):
    """M(eta) (6+nm, 6+nm) and the centrifugal and Coriolis forces h (6+nm,) of the free body,
    from Lagrange's equations, sharing one set of contractions; written into M and h.

    Reference rows:  v x* (M_r. [v; eta_d]) + (dM_r./dt) [v; eta_d]      (momentum form)
    Modal rows:      N1'^T w - dT/deta,  dT/deta_k = 1/2 w^T N2_k w + w . (I5_k x u) + w^T I7_k eta_d
    """
    nm = eta.size
    w, u = v[:3], v[3:]
    IO, IOd, wN2w, N1, N1d, wI7e = contractions(inv, j, eta, eta_d, w)
    c = first_moment(inv, j, eta)
    cd = first_moment(inv, j, eta_d) - inv.I4[j]
    mass_matrix_into(inv, j, IO, c, N1, M)
    # momentum p = M_r. [v; eta_d] and its rate through M only: pd = (dM_r./dt) [v; eta_d]
    p = np.empty(6)
    pd = np.empty(6)
    for a in range(6):
        s = 0.0
        for b in range(6):
            s += M[a, b] * v[b]
        for l in range(nm):
            s += M[a, 6 + l] * eta_d[l]
        p[a] = s
    for a in range(3):
        s = 0.0
        for b in range(3):
            s += IOd[a, b] * w[b]
        for l in range(nm):
            s += N1d[a, l] * eta_d[l]
        pd[a] = s
    pd[0] += cd[1] * u[2] - cd[2] * u[1]                # c~' u = c' x u
    pd[1] += cd[2] * u[0] - cd[0] * u[2]
    pd[2] += cd[0] * u[1] - cd[1] * u[0]
    pd[3] = w[1] * cd[2] - w[2] * cd[1]                 # c~'^T w = w x c'
    pd[4] = w[2] * cd[0] - w[0] * cd[2]
    pd[5] = w[0] * cd[1] - w[1] * cd[0]
    cross_force_into(v, p, h)
    for a in range(6):
        h[a] += pd[a]
    wxu = np.cross(w, u)
    for k in range(nm):
        dT = 0.5 * wN2w[k] + wI7e[k]
        n1dw = 0.0
        for a in range(3):
            dT -= inv.I5[j, a, k] * wxu[a]              # w . (I5_k x u) = -I5_k . (w x u)
            n1dw += N1d[a, k] * w[a]
        h[6 + k] = n1dw - dT
