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
    D       (N, nm, nm)   foreshortening of each node: bending moves node p along the beam by
                          -1/2 eta^T D_p eta (D_p = sum over the elements between the root and p
                          of Phi_e^T G_e Phi_e, G_e the element geometric stiffness per unit
                          axial force; docs/formulation.md §4b)
    Mx0, MPt (N, 3), (N, 3, nm)  a body with a consistent mass (a solid): Ms x0 and Ms Phi_t, the
                          mass-weighted fields its invariants are summed from (`invariants.mass_sums`;
                          m is then Ms 1); empty (0, 3), (0, 3, nm) for a lumped body
    S_solid (ns, 6, nm)   a solid's modal stresses at its stress points (`point_stress_rows`), Voigt
                          [xx, yy, zz, yz, zx, xy], Pa per unit modal coordinate; (0, 6, nm) for a beam

A solid (`solid_body`) is held the same way: its nodes are the mesh's, after one node per
interface (its reference point: no mass, its motion the interface's, node 0 the frame's), with
three translational DOFs (rotation rows and J zero), no foreshortening (D zero), `length` its
largest extent; docs/fe.md, Solids. A frame (`frame_body`: a mesh of bar elements) is held as a
beam is, six DOFs and lumped masses and rotary inertias (full 3 x 3) at its nodes, after one node
per interface as a solid's; docs/fe.md, Frames.

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

import dataclasses
import functools
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from flexmbd import version
from flexmbd.core.errors import InputError
from flexmbd.fe import assembly, element, frame, meshfile, modes, section, solid, stress
from flexmbd.fe import mesh as fe_mesh
from flexmbd.core.files import atomic_write


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
    D: np.ndarray
    Mx0: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 3)))
    MPt: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 3, 0)))
    S_solid: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 6, 0)))

    @property
    def n_nodes(self) -> int:
        return self.x0.shape[0]

    @property
    def n_modes(self) -> int:
        return self.Phi.shape[2]

    def node_at(self, x: float) -> int:
        """Index of the node nearest to position `x` along the beam (m), by `node_index`."""
        return node_index(self.length, self.n_nodes - 1, x)


def modal_field(P: np.ndarray, eta) -> np.ndarray:
    """(n, N, k) = sum_m P[p, i, m] eta[t, m]: the shapes P (N, k, nm) (a slice of Phi, or modal
    stresses) at the modal coordinates eta (n, nm) of n samples, as one matrix product (ten times
    faster than the same einsum on a beam's 101 nodes and 4000 samples)."""
    N, k, nm = P.shape
    return (eta @ P.reshape(N * k, nm).T).reshape(len(eta), N, k)


def axial_free(fb: FlexBody) -> bool:
    """True when no retained mode is axial: the beam's axial force is then recovered
    quasi-statically (docs/formulation.md §7)."""
    return not any(str(label).startswith("axial") for label in fb.labels)


def node_index(length: float, elements: int, x: float) -> int:
    """The node nearest to position x (m) along a beam meshed in `elements` equal elements: the
    one snapping rule of every solver (half-way between two nodes goes to the root side)."""
    return int(min(max(np.ceil(x * elements / length - 0.5), 0), elements))


def snapped(length: float, elements: int, x: float) -> float:
    """Position x (m) along a beam snapped to its nearest node (`node_index`), m."""
    return node_index(length, elements, x) * length / elements


def beam_section(beam) -> section.Section:
    """The FE section of a case beam (`cases.Beam`): `section_of` its section."""
    s = beam.section
    return section_of(s.shape, s.b, s.h, s.d, s.h_axis)


def section_of(shape: str, b=None, h=None, d=None, h_axis: str = "y") -> section.Section:
    """The FE section of a case's section table (m); FE convention: extent h along y, b along z."""
    if shape == "circle":
        return section.circle(d)
    if h_axis == "y":
        return section.rectangle(b=b, h=h)
    return section.rectangle(b=h, h=b)


def shear_modulus(material) -> float:
    """G = E / (2 (1 + nu)) of a `cases.Material`, Pa."""
    return material.E / (2.0 * (1.0 + material.nu))


def fe_model(beam):
    """Mesh and assembled matrices of a case beam (`cases.Beam`): (nodes, elements, sec, K, M, M_lumped)."""
    sec, material = beam_section(beam), beam.material
    nodes, elements = assembly.beam_mesh(beam.length, beam.elements)
    E, G, rho = material.E, shear_modulus(material), material.rho
    K, M = assembly.beam_matrices(nodes, elements, E, G, rho, sec, mass=beam.mass, shear=beam.shear)
    if beam.mass == "lumped":
        M_lumped = M
    else:
        _, M_lumped = assembly.beam_matrices(nodes, elements, E, G, rho, sec, mass="lumped")
    return nodes, elements, sec, K, M, M_lumped


def mode_set(beam, K, M, M_lumped, nodes: np.ndarray):
    """The reduced body's modes (6N, nm), orthonormal in the lumped mass, and their frequencies (Hz).

    The case's mass matrix M chooses the modes: the lowest `count` elastic modes of the boundary
    conditions whose kind is one of `modes.kinds` (any when not given: `of_kinds`), free-free and
    Craig-Bampton ones made to hold the reference node (`reference_node`). Unless they already are
    (lumped M, clamped-free or hinged-hinged), the retained modes are then re-orthonormalized
    within their span in the lumped mass (`in_node_masses`).
    """
    m = beam.modes
    if m.boundary in ("clamped-free", "hinged-hinged"):
        fixed = modes.boundary_dofs(m.boundary, nodes.shape[0])
        freq, Phi = of_kinds(lambda n: modes.normal_modes(K, M, fixed, n), m.count, m.kinds, K.shape[0] - fixed.size)
        if m.static:
            at = [node_index(beam.length, beam.elements, x) for x in m.static]
            freq_s, Psi = static_correction(K, M, fixed, Phi, at, m.kinds)
            freq, Phi = np.concatenate([freq, freq_s]), np.hstack([Phi, Psi])
        if M is M_lumped:
            return freq, Phi
    else:
        Phi = reference_node(K, M, nodes, floating_modes(beam, K, M))[:, : m.count]
    return in_node_masses(K, M_lumped, Phi)


def static_correction(K, M, fixed, Phi: np.ndarray, at, kinds=None):
    """(freq (k,), Psi (6N, k)): static correction modes at the nodes `at` (docs/formulation.md
    §7d): the static deflections under a unit load on each free DOF of those nodes of the kinds
    (`fe.modes.FAMILIES`; None: every kind), the supports `fixed` holding the beam, made
    M-orthogonal to the retained normal modes Phi (6N, nm; M-orthonormal) and then M-orthonormal
    and K-diagonal among themselves. Phi^T K Psi = 0 follows (K Phi = M Phi Lambda), so the normal
    modes and their frequencies are kept exactly; a load at those nodes is then represented
    statically exactly by the combined set."""
    kinds = kinds or tuple(modes.FAMILIES)
    dofs = sorted(set(6 * p + k for p in at for kind in kinds for k in modes.FAMILIES[kind]) - set(fixed))
    Psi = modes.static_modes(K, fixed, dofs)
    Psi = Psi - Phi @ (Phi.T @ (M @ Psi))
    return modes.orthonormalize(K, M, Psi)


def mode_labels(beam, Phi_fe: np.ndarray) -> list:
    """The label of each retained mode (`fe.modes.mode_labels`): the last ones, as many as a beam's
    static correction adds (above every retained normal mode in frequency), are labelled by family
    as 'bending xy static 1'."""
    n_static = Phi_fe.shape[1] - beam.modes.count
    labels = modes.mode_labels(Phi_fe[:, : beam.modes.count])
    if n_static > 0:
        tail = modes.mode_labels(Phi_fe[:, beam.modes.count:])
        labels += [" static ".join(t.rpartition(" ")[::2]) for t in tail]
    return labels


def of_kinds(lowest, count: int, kinds, most: int):
    """(freq (count,), Phi (6N, count)): the lowest `count` modes whose kind (`fe.modes.mode_families`,
    the family a mode's label names) is one of `kinds` (None: any), from `lowest(n)`, the (freq,
    Phi) of the n lowest modes of a basis independent of n (normal modes); n grows until they hold
    `count` modes of the kinds, at most to `most` (the case's check, `fe.modes.modes_per_family`,
    makes sure that there are that many)."""
    if kinds is None:
        return lowest(count)
    n = count
    while True:
        freq, Phi = lowest(n)
        keep = [j for j, kind in enumerate(modes.mode_families(Phi)) if kind in kinds][:count]
        if len(keep) == count or n >= most:
            break
        n = min(max(2 * n, n + 6), most)
    if len(keep) < count:
        raise ValueError(f"{count} modes of kinds {', '.join(kinds)} requested, the mesh has {len(keep)}")
    return freq[keep], Phi[:, keep]


def floating_modes(beam, K, M) -> np.ndarray:
    """Elastic modes (6N, k), M-orthonormal, of a free-free or Craig-Bampton beam (node 0 moves in
    them), of the kinds `modes.kinds` (`of_kinds`; the families of a straight beam are uncoupled):
    the lowest `count` free-free modes, or every elastic direction of the Craig-Bampton basis: the
    constraint modes of the interface nodes' DOFs of the kinds (the others held) and fixed-interface
    normal modes of the kinds, as many as make `count` with the rigid-body directions of the kinds
    (one per axial or torsion family, two per bending one: a family's DOFs at a node) added."""
    m = beam.modes
    n_dof = K.shape[0]
    if m.boundary == "free-free":
        return of_kinds(lambda n: modes.normal_modes(K, M, [], n), m.count, m.kinds, n_dof - 6)[1]
    kinds = m.kinds or tuple(modes.FAMILIES)
    held = sorted({node_index(beam.length, beam.elements, x) for x in m.interfaces})
    dofs = {kind: [6 * p + k for p in held for k in modes.FAMILIES[kind]] for kind in modes.FAMILIES}
    iface = np.array(sorted(d for kind in kinds for d in dofs[kind]), dtype=int)
    others = np.array(sorted(d for kind in modes.FAMILIES if kind not in kinds for d in dofs[kind]), dtype=int)
    every = np.union1d(iface, others)
    n_normal = min(max(m.count - iface.size, 0) + sum(len(modes.FAMILIES[k]) for k in kinds), n_dof - every.size)
    _, normal = of_kinds(lambda n: modes.normal_modes(K, M, every, n), n_normal, m.kinds, n_dof - every.size)
    freq, Phi = modes.orthonormalize(K, M, np.hstack([normal, modes.constraint_modes(K, others, iface)]))
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


def build(beam, stress_points=()) -> FlexBody:
    """Reduce a case beam (`cases.Beam`) to a FlexBody. `stress_points`: positions x along the
    beam (m) of the sections whose strains the channels need."""
    nodes, elements, sec, K, M, M_lumped = fe_model(beam)
    freq, Phi_fe = mode_set(beam, K, M, M_lumped, nodes)

    # lumped node masses and rotary inertias, from the lumped diagonal
    d = M_lumped.diagonal().reshape(-1, 6)
    m = d[:, 0].copy()
    J = np.zeros((nodes.shape[0], 3, 3))
    J[:, [0, 1, 2], [0, 1, 2]] = d[:, 3:6]

    # constant modal stiffness and damping
    Km = modal_stiffness(K, Phi_fe)
    omega = 2.0 * np.pi * np.asarray(freq)
    Cm = np.diag(2.0 * beam.damping_ratio * omega) + beam.stiffness_damping * Km   # modal, and material (C = beta K)

    # modal strain recovery
    E, G = beam.material.E, shear_modulus(beam.material)
    xs = [float(x) for x in stress_points]
    S = [stress.strain_rows(nodes, elements, E, G, sec, x, shear=beam.shear) @ Phi_fe for x in xs]
    nm = Phi_fe.shape[1]
    return FlexBody(
        name=beam.name, length=beam.length, x0=nodes, m=m, J=J, Phi=spatial_blocks(Phi_fe),
        freq_hz=np.asarray(freq), labels=np.array(mode_labels(beam, Phi_fe) if nm else [], dtype=str), Km=Km, Cm=Cm,
        boundary=beam.modes.boundary, stress_x=np.array(xs, dtype=float),
        S_strain=np.array(S).reshape(len(xs), 4, nm), D=foreshortening(nodes, elements, Phi_fe))


def foreshortening(nodes, elements, Phi_fe) -> np.ndarray:
    """(N, nm, nm) D_p = sum_{e < p} Phi_e^T G_e Phi_e, accumulated from the root (node 0) along the
    elements in order (G_e: `fe.element.geometric_stiffness`; Phi_e the element's rows of the FE
    mode matrix (6N, nm)). D_p is also the modal geometric stiffness of a unit axial force at p."""
    nm = Phi_fe.shape[1]
    D = np.zeros((nodes.shape[0], nm, nm))
    for e, dofs in enumerate(assembly.element_dofs(elements)):
        P = Phi_fe[dofs]
        l = assembly.element_lengths(nodes, elements[e:e + 1])[0]
        D[elements[e, 1]] = D[elements[e, 0]] + P.T @ element.geometric_stiffness(l) @ P
    return 0.5 * (D + D.transpose(0, 2, 1))


def for_case(case) -> dict:
    """Every flexible beam of a (resolved) case, reduced, by body name (`cases.Resolved.flexible`)."""
    return case.flexible()


def reduce(name: str, beam, stress_points=()) -> FlexBody:
    """`build`, once per content: the reduction is cached by everything it depends on (the beam
    `cases.Beam` with its material, and the stress points) but the beam's name, so equal beams (the
    segments of a split beam) and the solver, the report, the command line and every adapter share
    one computation per process. Its arrays are read-only; `name` names the body returned. A case
    solid (`cases.Solid`, stress points (3,) in its frame) reduces by `solid_body`."""
    if beam.type == "solid":
        points = tuple(tuple(float(v) for v in p) for p in stress_points)
    else:
        points = tuple(float(x) for x in stress_points)
    return _named(name, dataclasses.replace(beam, name=""), points)


@functools.lru_cache(maxsize=256)
def _named(name: str, beam, points: tuple) -> FlexBody:
    """The reduction of `beam` (named "") under `name`: one object per name and content, sharing
    the arrays of the one reduction per content (`_reduced`)."""
    return dataclasses.replace(_reduced(beam, points), name=name)


def undeformed(name: str, beam) -> FlexBody:
    """A beam declared rigid: its node masses and positions, no modes (`reduce` with count 0)."""
    return reduce(name, dataclasses.replace(beam, modes=dataclasses.replace(beam.modes, count=0)))


@functools.lru_cache(maxsize=64)
def _reduced(beam, points: tuple) -> FlexBody:
    """`build` with one thread of linear algebra: its last bits do not depend on the process that
    first asks (a command's own, with every core, or a worker's), so a worker forked from one
    that holds it (`executor.Worker`) has the bits it would have computed itself."""
    with threadpool_limits(limits=1):
        fb = solid_body(beam, points) if beam.type == "solid" else build(beam, points)
    for f in fields(fb):
        a = getattr(fb, f.name)
        if isinstance(a, np.ndarray):
            a.flags.writeable = False
    return fb


def save(fb: FlexBody, path) -> None:
    """Write the body to one .npz file (atomically: `files.atomic_write`)."""
    atomic_write(path, lambda f: np.savez(f, **{f_.name: np.asarray(getattr(fb, f_.name)) for f_ in fields(fb)}))


def load(path) -> FlexBody:
    """Read a body written by `save`."""
    with np.load(path, allow_pickle=False) as z:
        kw = {f.name: z[f.name] for f in fields(FlexBody)}
    kw["name"], kw["boundary"] = str(kw["name"]), str(kw["boundary"])
    kw["length"] = float(kw["length"])
    return FlexBody(**kw)


# ---------------------------------------------------------------------------------------------
# solids (docs/fe.md, Solids)

def solid_mesh(file=None, units="m", box=None, divisions=None, element="hex20", stiffness=None,
               mass=None) -> fe_mesh.Mesh:
    """The mesh of a case solid's `mesh` table (validated: `file` absolute), read or built once
    per content (an import error is an InputError naming the file and line), less the nodes on
    no element (`fe.mesh.without_orphans`)."""
    if file is not None:
        return _mesh_file(str(file), units, digest(file))
    return _mesh_box(tuple(box), tuple(int(n) for n in divisions), element)


def digest(path) -> str:
    """SHA-256 (hex) of a file's bytes ('' when it cannot be read: its reader says why): what a
    cached reading of it is keyed by, so that an edited file is read again."""
    try:
        return version.cache_key(Path(path).read_bytes())
    except OSError:
        return ""


@functools.lru_cache(maxsize=8)
def _mesh_file(path: str, units: str, sha256: str) -> fe_mesh.Mesh:
    return fe_mesh.without_orphans(meshfile.read(path, units))


@functools.lru_cache(maxsize=8)
def _mesh_box(box: tuple, n: tuple, kind: str) -> fe_mesh.Mesh:
    return fe_mesh.box(*box, n, kind)


def solid_matrices(body) -> tuple:
    """(K (3N, 3N), Ms (N, N)) of a case solid: its mesh's own assembly (`fe.solid`), or the
    matrices of its Abaqus matrix files where the case names them (`matrix_file`); once per content."""
    spec = body.mesh
    files = tuple(digest(f) if f else "" for f in (spec.file, spec.stiffness, spec.mass))
    return _solid_matrices(spec, body.material.E, body.material.nu, body.material.rho, files)


@functools.lru_cache(maxsize=8)
def _solid_matrices(spec, E: float, nu: float, rho: float, files: tuple) -> tuple:
    mesh = solid_mesh(**dataclasses.asdict(spec))
    ids = tuple(mesh.node_ids)
    K = matrix_file(spec.stiffness, spec.units, ids, "stiffness") if spec.stiffness else solid.stiffness(mesh, E, nu)
    Ms = matrix_file(spec.mass, spec.units, ids, "mass") if spec.mass else solid.scalar_mass(mesh, rho)
    return K, Ms


def matrix_file(path: str, units: str, node_ids: tuple, what: str):
    """`_matrix_file`, cached by the file's content."""
    return _matrix_file(path, units, node_ids, what, digest(path))


@functools.lru_cache(maxsize=8)
def _matrix_file(path: str, units: str, node_ids: tuple, what: str, sha256: str):
    """A solid's matrix from an Abaqus matrix file (`fe.meshfile.read_mtx`, over the mesh's nodes):
    the stiffness K (3N, 3N) as it is; the mass as its scalar Ms (N, N), the file's M having to be
    Ms (x) I3 (an isotropic solid's consistent mass) to 1e-9 of its largest entry: an InputError
    naming the file otherwise."""
    A = meshfile.read_mtx(path, np.asarray(node_ids), units)
    if what == "stiffness":
        return A
    Ms = A[0::3, 0::3].tocsr()
    gap = abs(A - solid.vector_mass(Ms)).max() if A.nnz else 0.0
    if gap > 1e-9 * abs(A).max():
        raise InputError(f"{path}: not a solid's consistent mass (M = Ms (x) I3, the same on x, y and z and no "
                         f"coupling between them): it differs from that form by {gap:.3g} (largest entry "
                         f"{abs(A).max():.3g})")
    return Ms


def reference_point(mesh: fe_mesh.Mesh, node_set: str, point=None) -> np.ndarray:
    """(3,) an interface's reference point, mesh coordinates (m): its `point`, or the centroid of
    its node set."""
    if point is not None:
        return np.asarray(point, dtype=float)
    return mesh.nodes[mesh.node_sets[node_set]].mean(axis=0)


def element_at(mesh: fe_mesh.Mesh, x) -> tuple | None:
    """(kind, row) of the element that contains point x (3,), mesh coordinates (m): of the
    elements whose centres are nearest, the first whose corner box holds x (round-off allowed);
    None when no element does."""
    kinds, rows, c = solid.centres(mesh)
    x = np.asarray(x, dtype=float)
    for k in np.argsort(np.linalg.norm(c - x, axis=1))[:16]:
        X = mesh.nodes[mesh.cells[kinds[k]][rows[k]]]
        lo, hi = X.min(axis=0), X.max(axis=0)
        slack = 1e-9 * float(np.max(hi - lo))
        if np.all(x >= lo - slack) and np.all(x <= hi + slack):
            return str(kinds[k]), int(rows[k])
    return None


@functools.lru_cache(maxsize=256)
def point_place(body, p: tuple) -> str:
    """Where a case solid's stress point p (3,), body frame, m, lies: 'inside', 'on the +y face',
    'on the +x+y edge', 'on the +x+y-z corner' (the body axes along which a step of 1e-6 of the
    mesh's extent leaves every element, `element_at`), or 'outside'; '' on a frame (bar elements:
    its points are fibres of a section)."""
    mesh = solid_mesh(**dataclasses.asdict(body.mesh))
    if mesh.is_frame:
        return ""
    f = body.interfaces[body.frame]
    x = np.asarray(p, dtype=float) + reference_point(mesh, f.set, f.point)
    if element_at(mesh, x) is None:
        return "outside"
    h = 1e-6 * float(np.ptp(mesh.nodes, axis=0).max())
    out = [f"{sign}{'xyz'[a]}" for a in range(3) for sign, d in (("+", h), ("-", -h))
           if element_at(mesh, x + d * np.eye(3)[a]) is None]
    return "inside" if not out else f"on the {''.join(out)} {('face', 'edge', 'corner')[min(len(out), 3) - 1]}"


def point_stress_rows(mesh: fe_mesh.Mesh, E: float, nu: float, x) -> tuple:
    """(S (6, 3nn), dofs (3nn,)): the stress at point x (3,), mesh coordinates, as rows on the DOFs
    of the element that holds it (`element_at`), from that element's displacement gradient at the
    point's natural coordinates (`solid.natural`): the stress at the point asked for, a surface
    point's included, not at the element's centre (checked against scikit-fem and beam theory in
    tests/fe/test_fe_solid.py)."""
    kind, row = element_at(mesh, x)
    xi = solid.natural(kind, mesh.nodes[mesh.cells[kind][row]], np.asarray(x, dtype=float))
    return solid.stress_rows(mesh, E, nu, kind, row, xi=xi)


def solid_labels(m: np.ndarray, Pt: np.ndarray) -> np.ndarray:
    """(nm,) a solid's mode labels: 'mode k' and the body axes its motion mostly lies along (each
    axis's share of sum m_p |Phi_t,p|^2 with the node masses m (N,); every axis above a quarter,
    largest first), e.g. 'mode 1 (z)', 'mode 7 (y+z)' for a torsion mode of a beam-like solid."""
    share = np.einsum("p,pak->ka", m, Pt ** 2)
    share = share / np.maximum(share.sum(axis=1, keepdims=True), 1e-300)
    out = []
    for k, row in enumerate(share):
        axes = [a for a in np.argsort(-row) if row[a] > 0.25]
        out.append(f"mode {k + 1} ({'+'.join('xyz'[a] for a in axes)})")
    return np.array(out, dtype=str)


def solid_length(spec) -> float:
    """The largest extent of a case solid's mesh (`cases.MeshSpec`), m."""
    return float(np.ptp(solid_mesh(**dataclasses.asdict(spec)).nodes, axis=0).max())


def interface_offset(body, interface: str) -> np.ndarray:
    """(3,) an interface's reference point in a case solid's body frame, m."""
    mesh = solid_mesh(**dataclasses.asdict(body.mesh))
    f, o = body.interfaces[interface], body.interfaces[body.frame]
    return reference_point(mesh, f.set, f.point) - reference_point(mesh, o.set, o.point)


def solid_order(body) -> list:
    """The interfaces of a case solid in node order: the frame's (node 0), then the others in
    file order (node k)."""
    return [body.frame] + [n for n in body.interfaces if n != body.frame]


def solid_modes(body, mesh, K, Ms, ref: dict) -> tuple:
    """A case solid's mode set (`fe.solid.interface_modes`, its `modes.boundary`): (Hz (nm,),
    Phi (3N, nm)); ref: each interface's reference point, mesh coordinates."""
    faces, sets = body.interfaces, mesh.node_sets
    frame = faces[body.frame]
    held = sets[frame.set] if body.modes.boundary != "free-free" else ()
    rigid = [(sets[f.set], ref[n]) for n, f in faces.items() if f.kind == "rigid" and n != body.frame]
    avg = [(sets[f.set], ref[n]) for n, f in faces.items() if f.kind == "averaging" and n != body.frame]
    return solid.interface_modes(K, Ms, mesh.nodes, body.modes.boundary, body.modes.count, held=held, rigid=rigid,
                                 averaged=avg, frame=(sets[frame.set], ref[body.frame]))


def solid_body(body, stress_points=()) -> FlexBody:
    """Reduce a case solid (`cases.Solid`) to a FlexBody: its mode set (`solid_modes`), orthonormal
    in the consistent mass; `stress_points` (k, 3): body-frame points whose stresses the channels
    need (`point_stress_rows`). A frame's mesh (bar elements) reduces by `frame_body`."""
    mesh, mat = solid_mesh(**dataclasses.asdict(body.mesh)), body.material
    if mesh.is_frame:
        return frame_body(body, stress_points)
    K, Ms = solid_matrices(body)
    faces = {n: body.interfaces[n] for n in solid_order(body)}
    ref = {n: reference_point(mesh, f.set, f.point) for n, f in faces.items()}
    origin = ref[body.frame]
    nm, N = body.modes.count, mesh.n_nodes
    freq, Phi3 = solid_modes(body, mesh, K, Ms, ref) if nm else (np.zeros(0), np.zeros((3 * N, 0)))
    Pt = Phi3.reshape(N, 3, nm)
    k = len(faces)
    Phi = np.zeros((k + N, 6, nm))
    Phi[k:, 3:, :] = Pt
    for i, (name, face) in enumerate(faces.items()):
        if i:                                           # any other interface: its nodes' rigid fit (a rigid one's: exact)
            nodes = mesh.node_sets[face.set]
            A = solid.averaging(mesh.nodes[nodes], ref[name])
            Phi[i] = A @ Phi3[solid.node_dofs(nodes)]
    x = mesh.nodes - origin
    x0 = np.vstack([[ref[n] - origin for n in faces], x])
    pad = lambda a: np.concatenate([np.zeros((k,) + a.shape[1:]), a])
    m = pad(np.asarray(Ms.sum(axis=1)).ravel())
    S = []
    for p in stress_points:
        rows, dofs = point_stress_rows(mesh, mat.E, mat.nu, np.asarray(p, dtype=float) + origin)
        S.append(rows @ Phi3[dofs])
    Km = modal_stiffness(K, Phi3)
    return FlexBody(
        name=body.name, length=solid_length(body.mesh), x0=x0, m=m, J=np.zeros((k + N, 3, 3)),
        Phi=Phi, freq_hz=freq, labels=solid_labels(m[k:], Pt), Km=Km,
        Cm=np.diag(2.0 * body.damping_ratio * 2.0 * np.pi * freq), boundary=body.modes.boundary,
        stress_x=np.zeros(0), S_strain=np.zeros((0, 4, nm)), D=np.zeros((k + N, nm, nm)),
        Mx0=pad(Ms @ x), MPt=pad((Ms @ Pt.reshape(N, -1)).reshape(N, 3, nm)),
        S_solid=np.array(S).reshape(len(S), 6, nm))


def surface_stress_modes(body, fb: FlexBody) -> tuple:
    """(faces, owners, S): a case solid's boundary faces (`fe.solid.boundary_faces`, corner node
    indices of its mesh), the element of each, and the modal stresses S (ne, 6, nm) at the centres
    of those elements (`owners` indexes S's rows through `np.unique`'s inverse), Pa per unit modal
    coordinate of the reduced body fb: what the case page's von Mises field is drawn from."""
    mesh = solid_mesh(**dataclasses.asdict(body.mesh))
    faces, owners = solid.boundary_faces(mesh)
    elements, inverse = np.unique(owners, return_inverse=True)
    k = len(body.interfaces)
    Phi3 = fb.Phi[k:, 3:, :].reshape(-1, fb.n_modes)
    S = [rows @ Phi3[dofs] for rows, dofs in solid.centre_stress_rows(mesh, body.material.E, body.material.nu, elements)]
    return faces, inverse, np.array(S).reshape(len(elements), 6, fb.n_modes)


# ---------------------------------------------------------------------------------------------
# frames: a mesh of bar elements (docs/fe.md, Frames)

def frame_matrices(body) -> tuple:
    """(K, M) (6N, 6N) of a case solid whose mesh is a frame (`fe.frame.matrices`: stiffness and
    lumped mass, from its cards; `cases.validate` refuses matrix files for a frame)."""
    mesh = solid_mesh(**dataclasses.asdict(body.mesh))
    return frame.matrices(mesh, body.material.E, body.material.nu, body.material.rho)


def frame_node(body, mesh: fe_mesh.Mesh, interface: str) -> int:
    """The mesh node (row) of a frame's interface: its set's one node (`cases.validate` checks)."""
    return int(mesh.node_sets[body.interfaces[interface].set][0])


def in_frame(mesh: fe_mesh.Mesh, x) -> bool:
    """Whether point x (3,), mesh coordinates (m), lies in a frame's bars: within twice the radius
    of gyration sqrt((I1 + I2) / A) of its nearest element's section from that element's axis."""
    row, _, offset = frame.nearest(mesh, np.asarray(x, dtype=float))
    A, I1, I2 = mesh.bars[row, :3]
    return bool(np.linalg.norm(offset) <= 2.0 * np.sqrt((I1 + I2) / A))


def frame_modes(body, mesh: fe_mesh.Mesh, K, M, nodes: dict) -> tuple:
    """A frame's mode set, (Hz (nm,), Phi (6N, nm)) M-orthonormal and K-diagonal, the frame
    interface's node held in each: clamped-interface normal modes; Craig-Bampton (the other
    interfaces' nodes' six constraint modes each and the lowest normal modes with every interface
    held, as many as make `count`: the whole set, as a solid's); free-free normal modes less the
    frame node's rigid motion."""
    count, boundary = body.modes.count, body.modes.boundary
    p0 = nodes[body.frame]
    held = np.arange(6 * p0, 6 * p0 + 6)
    if boundary == "clamped-interface":
        return modes.normal_modes(K, M, held, count)
    if boundary == "craig-bampton":
        iface = np.array([6 * p + k for n, p in nodes.items() if n != body.frame for k in range(6)], dtype=int)
        Phi = modes.craig_bampton(K, M, held, iface, count - iface.size)
    else:
        Phi = modes.hold_node(modes.normal_modes(K, M, [], count)[1], mesh.nodes, p0)
    freq, Phi = modes.orthonormalize(K, M, Phi)
    return freq[:count], Phi[:, :count]


def frame_body(body, stress_points=()) -> FlexBody:
    """Reduce a case solid whose mesh is a frame (bar elements, `fe.frame`) to a FlexBody: nodes
    with six DOFs, like a beam's, but anywhere in the body frame. The interfaces come first (node
    k: interface k of `solid_order`, no mass, its node's block), then the mesh's nodes with their
    lumped masses and rotary inertias (full 3 x 3 in mesh axes); its invariants are the lumped
    node sums, as a beam's. `stress_points` (k, 3): body-frame points of the bars' volume whose
    stress the channels need (`fe.frame.fibre_rows`)."""
    mesh, mat = solid_mesh(**dataclasses.asdict(body.mesh)), body.material
    K, M = frame_matrices(body)
    order = solid_order(body)
    nodes = {n: frame_node(body, mesh, n) for n in order}
    N, nm, k = mesh.n_nodes, body.modes.count, len(order)
    freq, Phi6 = frame_modes(body, mesh, K, M, nodes) if nm else (np.zeros(0), np.zeros((6 * N, 0)))
    blocks = spatial_blocks(Phi6)
    origin = mesh.nodes[nodes[body.frame]]
    x = mesh.nodes - origin
    d = M.diagonal().reshape(N, 6)
    J = np.zeros((k + N, 3, 3))
    c = M.tocoo()                                       # each node's rotational block of M
    on = (c.row // 6 == c.col // 6) & (c.row % 6 >= 3) & (c.col % 6 >= 3)
    np.add.at(J, (k + c.row[on] // 6, c.row[on] % 6 - 3, c.col[on] % 6 - 3), c.data[on])
    S = []
    for point in stress_points:
        rows, dofs = frame.fibre_rows(mesh, mat.E, mat.nu, np.asarray(point, dtype=float) + origin)
        S.append(rows @ Phi6[dofs])
    m = np.concatenate([np.zeros(k), d[:, 0]])
    at = [nodes[n] for n in order]                      # the interfaces' nodes, then every node
    return FlexBody(
        name=body.name, length=solid_length(body.mesh), x0=np.vstack([x[at], x]), m=m, J=J,
        Phi=np.concatenate([blocks[at], blocks]), freq_hz=np.asarray(freq),
        labels=solid_labels(m[k:], blocks[:, 3:, :]), Km=modal_stiffness(K, Phi6),
        Cm=np.diag(2.0 * body.damping_ratio * 2.0 * np.pi * np.asarray(freq)), boundary=body.modes.boundary,
        stress_x=np.zeros(0), S_strain=np.zeros((0, 4, nm)), D=np.zeros((k + N, nm, nm)),
        S_solid=np.array(S).reshape(len(S), 6, nm))
