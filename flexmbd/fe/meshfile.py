"""Solid meshes from Abaqus (.inp), NASTRAN bulk data (.bdf, .nas, .dat) and Gmsh (.msh) files, and
frames (bar elements) from NASTRAN files.

    mesh = meshfile.read("arm.inp", units="mm")                  # Mesh (fe.mesh), always SI
    clamp = meshfile.node_set(mesh, "clamp")                      # (k,) node rows
    K = meshfile.read_mtx("arm_STIF2.mtx", mesh.node_ids, "mm")   # csr (3N, 3N), SI

Units: `units="m"` reads the file as SI (m, N, kg, s, Pa); `units="mm"` as the consistent mm-t-s
system (mm, N, t, s, MPa). The Mesh is always SI: nodes in m, E in Pa, rho in kg/m^3. After the
conversion every material's wave speed sqrt(E/rho) must lie within 10 to 20000 m/s, else the
numbers do not match the units and the file is refused.

Element kinds (node orders: fe.mesh; flexmbd integrates every element fully, so the reduced (R),
hybrid (H), modified (M) and incompatible-mode (I) variants are read as the plain element's
geometry):

    tet4   Abaqus C3D4                       NASTRAN CTETRA, 4 grids    Gmsh tetra (4)
    tet10  Abaqus C3D10, C3D10M, C3D10H      NASTRAN CTETRA, 10 grids   Gmsh tetra10 (11)
    hex8   Abaqus C3D8, C3D8R, C3D8H, C3D8I  NASTRAN CHEXA, 8 grids     Gmsh hexahedron (5)
    hex20  Abaqus C3D20, C3D20R, C3D20H      NASTRAN CHEXA, 20 grids    Gmsh hexahedron20 (17)

Abaqus (own parser): *NODE (NSET=), *ELEMENT (TYPE=, ELSET=), *NSET and *ELSET (GENERATE, or
numbers and names of earlier sets), *MATERIAL with *ELASTIC (isotropic E, nu) and *DENSITY;
keywords are case-insensitive, set and material names keep their case and are matched without it.
Part/assembly structure is ignored, so the file must be flat: one *PART at most (one part per
body); *INSTANCE positioning data is not applied. *INCLUDE is refused; any other keyword is skipped.
`read_mtx` reads the matrices of *MATRIX GENERATE / *MATRIX OUTPUT.

NASTRAN (own parser): small (8-character), large (GRID*, 16-character) and free (comma) fields,
continuation lines (first field blank, '+...' or '*...'), '$' comments, BEGIN BULK / ENDDATA when
present. GRID (the basic coordinate system for positions; a displacement system CD only on grids
that orient no bar by X1-X3), CTETRA, CHEXA (the 20-grid mid-edge order 12 23 34 41, 15 26 37 48,
56 67 78 85 is reordered to fe.mesh's), MAT1 (two of E, G, NU give the third; RHO needed), PSOLID
(the elements of one body use one material), and as node sets: SPC/SPC1 "spc<SID>", SET1
"set<SID>", RBE2 "rbe2_<EID>" (dependent grids), RBE3 "rbe3_<EID>" (the weighted grids; the
weights are not kept), each with its reference grid in "rbe2_<EID>_ref"/"rbe3_<EID>_ref".
Materials are named "mat<MID>". CBAR and CBEAM with PBAR and PBEAM make a frame ("bar2" cells and
`Mesh.bars`, with the shear factors K1, K2: a PBAR's blank 0, a PBEAM's NASTRAN's 1.0; docs/fe.md,
Frames; a file holds bars or 3-D elements, not both), with CONM2 point masses on its nodes
(`Mesh.masses`: no offset, basic axes, no products of inertia). Other element cards are refused;
other cards are skipped.

Gmsh (through meshio, MSH 2.2 and 4.1): the 3-D cells, and every physical group as a node set (the
nodes of its cells, facets included) and, for volume groups, an element set. meshio does not keep
Gmsh's node and element numbers: node_ids are the rows + 1 and the 3-D elements are numbered 1, 2, ...
in the file's order. meshio already gives hexahedron20 and tetra10 in VTK's order, which is fe.mesh's,
so no reordering is needed here (tests/test_fe_meshfile.py checks it against a file in Gmsh's order).

Bad input raises InputError with a one-line message "FILE:LINE: what" (or "FILE: what").
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from flexmbd.errors import InputError
from flexmbd.fe.mesh import EDGES, NODES_PER, Mesh

__all__ = ["read", "read_mtx", "node_set", "UNITS"]

# file units -> (length to m, E to Pa, rho to kg/m^3)
UNITS = {"m": (1.0, 1.0, 1.0), "mm": (1e-3, 1e6, 1e12)}

# m/s: the plausible range of sqrt(E/rho) for a solid. A soft elastomer or foam has 10-50 m/s (a
# rubber of E = 1 MPa, rho = 1000 kg/m^3: 31.6 m/s), steel 5200 and beryllium 12500, while a file
# read in the other unit system is off by a factor of 1000 (E 1e6 times, rho 1e12): steel in mm-t-s
# read as SI gives 5.2e6 m/s and in SI read as mm-t-s 5.2 m/s, both outside
WAVE_SPEED = (10.0, 20000.0)

# the largest node, element, property or set number read (the numbers are kept as int64)
NUMBER_MAX = int(np.iinfo(np.int64).max)

# a range of set members (THRU, GENERATE) longer than the file has lines lists numbers the file
# cannot define, and is refused before it is expanded; one of up to this many members is expanded
# anyway, so that the member that is not defined is named
RANGE_EXPANDED = 100_000

ABAQUS_KINDS = {"C3D4": "tet4", "C3D10": "tet10", "C3D10M": "tet10", "C3D10H": "tet10",
                "C3D8": "hex8", "C3D8R": "hex8", "C3D8H": "hex8", "C3D8I": "hex8",
                "C3D20": "hex20", "C3D20R": "hex20", "C3D20H": "hex20"}
GMSH_KINDS = {"tetra": "tet4", "tetra10": "tet10", "hexahedron": "hex8", "hexahedron20": "hex20"}

# NASTRAN's CHEXA with 20 grids lists the mid-edge nodes 12 23 34 41, 15 26 37 48, 56 67 78 85;
# fe.mesh's order has the top face's edges before the vertical ones (the permutation is its own inverse)
NASTRAN_HEX20 = np.r_[0:12, 16:20, 12:16]

# NASTRAN cards that define elements: only CTETRA and CHEXA are read, the others are refused
NASTRAN_ELEMENTS = {
    "CBAR", "CBEAM", "CBEND", "CBUSH", "CBUSH1D", "CBUSH2D", "CROD", "CONROD", "CTUBE", "CVISC",
    "CELAS1", "CELAS2", "CELAS3", "CELAS4", "CDAMP1", "CDAMP2", "CDAMP3", "CDAMP4", "CDAMP5",
    "CGAP", "CMASS1", "CMASS2", "CMASS3", "CMASS4", "CONM1", "CONM2", "CSHEAR", "CQUAD", "CQUAD4",
    "CQUAD8", "CQUADR", "CQUADX", "CTRIA3", "CTRIA6", "CTRIAR", "CTRIAX", "CTRIAX6", "CPENTA",
    "CPYRAM", "CWELD", "CFAST", "CSEAM", "CHACAB", "CHACBR", "CRAC2D", "CRAC3D"}

# corner o and its three neighbours a, b, c with (xa - xo) x (xb - xo) . (xc - xo) > 0
CORNERS = {"tet": ((0, 1, 2, 3),),
           "hex": ((0, 1, 3, 4), (1, 2, 0, 5), (2, 3, 1, 6), (3, 0, 2, 7),
                   (4, 7, 5, 0), (5, 4, 6, 1), (6, 5, 7, 2), (7, 6, 4, 3))}


def read(path, units: str = "m") -> Mesh:
    """The mesh of an Abaqus (.inp), NASTRAN (.bdf, .nas, .dat) or Gmsh (.msh) file, in SI.

    `units` is the file's unit system: "m" (m, N, kg, s, Pa) or "mm" (mm, N, t, s, MPa).
    Raises InputError for a file that cannot be read or is not a valid solid mesh or frame.
    """
    source = str(path)
    if units not in UNITS:
        raise InputError(f"{source}: units {units!r} unknown (use one of: {', '.join(UNITS)})")
    suffix = Path(source).suffix.lower()
    if suffix == ".inp":
        parts = _abaqus(source, _text(source))
    elif suffix in (".bdf", ".nas", ".dat"):
        parts = _nastran(source, _text(source))
    elif suffix == ".msh":
        parts = _gmsh(source)
    else:
        raise InputError(f"{source}: unknown mesh file type {suffix or '(no suffix)'!r} (supported: .inp Abaqus, "
                         ".bdf/.nas/.dat NASTRAN bulk data, .msh Gmsh)")
    return _build(source, units, *parts)


def node_set(mesh: Mesh, name: str) -> np.ndarray:
    """The rows (k,) of the mesh's node set `name`; InputError naming the sets there are if none."""
    if name not in mesh.node_sets:
        have = ", ".join(sorted(mesh.node_sets)) or "no node sets"
        raise InputError(f"{mesh.source}: node set {name!r} not found (it has: {have})")
    return mesh.node_sets[name]


def read_mtx(path, node_ids, units: str = "m") -> sp.csr_matrix:
    """A symmetric (3N, 3N) matrix from an Abaqus matrix file (*MATRIX GENERATE, *MATRIX OUTPUT),
    DOF 3 row + (dof - 1) for the translations dof = 1..3 of the node in row `row` of `node_ids`
    (N,) (the mesh's file node numbers). Either layout Abaqus writes:

        FORMAT=MATRIX INPUT (the default)  "row node, row dof, column node, column dof, value"
        FORMAT=COORDINATE                  "row column value", 1-based equation numbers

    The equation numbers of the coordinate layout are taken to run node by node in the order of
    `node_ids`, three per node (what Exudyn's FEM reader assumes too): true when every node carries
    the three translations only. One triangle is mirrored; a full matrix must be symmetric.
    `units` as in `read`: "mm" (N/mm, t, N s/mm) scales by 1e3 to SI (N/m, kg, N s/m).
    """
    source = str(path)
    if units not in UNITS:
        raise InputError(f"{source}: units {units!r} unknown (use one of: {', '.join(UNITS)})")
    node_ids = np.asarray(node_ids, dtype=np.int64)
    n = 3 * node_ids.size
    lines, numbers = [], []
    for no, line in enumerate(_text(source).splitlines(), 1):
        s = line.strip()
        if s and not s.startswith("*"):
            lines.append(no)
            numbers.append(s.replace(",", " ").split())
    if not numbers:
        raise InputError(f"{source}: no matrix entries")
    width = len(numbers[0])
    for no, row in zip(lines, numbers):
        if len(row) != width or width not in (3, 5):
            raise InputError(f"{source}:{no}: expected 'row node, row dof, column node, column dof, value' "
                             f"or 'row column value', got {len(row)} numbers")
    try:
        table = np.array(numbers, dtype=float)
    except ValueError:
        no = next(no for no, row in zip(lines, numbers) if not all(_is_real(t) for t in row))
        raise InputError(f"{source}:{no}: not a number in a matrix entry") from None
    lines = np.asarray(lines)
    if width == 5:
        rows, cols = (_mtx_dofs(source, lines, table[:, k], table[:, k + 1], node_ids) for k in (0, 2))
    else:
        eq = table[:, :2].astype(np.int64)
        bad = np.flatnonzero(((eq < 1) | (eq > n)).any(axis=1))
        if bad.size:
            raise InputError(f"{source}:{lines[bad[0]]}: equation {eq[bad[0]].max()} is not one of the mesh's "
                             f"1..{n} (3 per node, {node_ids.size} nodes)")
        rows, cols = eq[:, 0] - 1, eq[:, 1] - 1
    scale = 1e3 if units == "mm" else 1.0          # N/mm, t, N s/mm -> N/m, kg, N s/m
    A = sp.coo_matrix((scale * table[:, -1], (rows, cols)), shape=(n, n)).tocsr()
    # one triangle (of the file's numbering, which need not be the rows' order) or the full matrix
    off = np.unique(rows[rows != cols] * n + cols[rows != cols])
    mirrored = np.isin((off % n) * n + off // n, off)
    if not mirrored.any():
        return (A + sp.triu(A, 1).T + sp.tril(A, -1).T).tocsr()
    if not mirrored.all() or abs(A - A.T).max() > 1e-12 * abs(A).max():
        raise InputError(f"{source}: the matrix is not symmetric (neither one triangle nor a symmetric square)")
    return A


def _mtx_dofs(source, lines, node, dof, node_ids) -> np.ndarray:
    """DOF indices 3 row + dof - 1 of the (node number, dof) columns of a matrix-input file."""
    node, dof = node.astype(np.int64), dof.astype(np.int64)
    rows = _lookup(node_ids)(node)
    bad = np.flatnonzero(rows < 0)
    if bad.size:
        raise InputError(f"{source}:{lines[bad[0]]}: node {node[bad[0]]} is not a node of the mesh "
                         "(negative numbers are Abaqus' internal nodes, e.g. of constraints)")
    bad = np.flatnonzero((dof < 1) | (dof > 3))
    if bad.size:
        raise InputError(f"{source}:{lines[bad[0]]}: dof {dof[bad[0]]}: a solid's nodes have dofs 1 to 3 only")
    return 3 * rows + dof - 1


# ---------------------------------------------------------------------------------------------
# checks and conversion, common to the three formats


def _build(source, units, ids, xyz, node_lines, elems, nsets, esets, materials, bars=None, conm2=()) -> Mesh:
    """Check one file's contents and convert them into an SI Mesh.

    ids (N,) the file's node numbers, xyz (N, 3) in file units, node_lines (N,) the line of each
    (0: none); elems {kind: (numbers (ne,), node numbers (ne, nn), lines (ne,))}; nsets and esets
    {name: (node or element numbers (k,), lines (k,))}; materials {name: (E, nu, rho, line)} in file
    units, None where the file gives no value; bars (ne, 7) the section and orientation vector of
    each element of elems["bar2"] (`fe.mesh`), file units; conm2 [(EID, grid, [M, I11, I22, I33],
    line)] a frame's point masses, file units.
    """
    ids = np.asarray(ids, dtype=np.int64).reshape(-1)
    xyz = np.asarray(xyz, dtype=float).reshape(-1, 3)
    node_lines = np.asarray(node_lines, dtype=np.int64).reshape(-1)
    if not elems:
        raise InputError(f"{source}: no elements (tetrahedra, hexahedra, or bars in a NASTRAN file) in the file")
    if "bar2" in elems and len(elems) > 1:
        raise InputError(f"{source}: both bar and solid elements: a body is either a solid or a frame")
    _unique(source, "node", ids, node_lines)
    bad = np.flatnonzero(~np.isfinite(xyz).all(axis=1))
    if bad.size:
        raise InputError(f"{_at(source, node_lines[bad[0]])}: node {ids[bad[0]]} has a coordinate that is not "
                         "a finite number")
    rows_of = _lookup(ids)

    cells, elem_ids, elem_lines = {}, {}, {}
    for kind, (numbers, conn, lines) in elems.items():
        numbers = np.asarray(numbers, dtype=np.int64)
        conn = np.asarray(conn, dtype=np.int64).reshape(numbers.size, NODES_PER[kind])
        lines = np.asarray(lines, dtype=np.int64)
        rows = rows_of(conn)
        bad = np.argwhere(rows < 0)
        if bad.size:
            e, j = bad[0]
            raise InputError(f"{_at(source, lines[e])}: element {numbers[e]} refers to node {conn[e, j]}, "
                             "which is not defined")
        cells[kind], elem_ids[kind], elem_lines[kind] = rows, numbers, lines
    kinds = list(cells)
    all_ids = np.concatenate([elem_ids[k] for k in kinds])
    all_lines = np.concatenate([elem_lines[k] for k in kinds])
    _unique(source, "element", all_ids, all_lines)

    length, to_pa, to_kgm3 = UNITS[units]
    nodes = xyz * length
    for kind in kinds:
        if kind != "bar2":
            _positive_volumes(source, kind, nodes, cells[kind], elem_ids[kind], elem_lines[kind], ids)
    frame = np.zeros((0, 9))
    if "bar2" in cells:
        frame = np.asarray(bars, dtype=float) * np.array([length ** 2] + [length ** 4] * 3 + [1.0] * 5)
        _straight(source, nodes, cells["bar2"], frame[:, 6:], elem_ids["bar2"], elem_lines["bar2"])

    node_sets = {}
    for name, (numbers, lines) in nsets.items():
        numbers = np.asarray(numbers, dtype=np.int64)
        rows = rows_of(numbers)
        bad = np.flatnonzero(rows < 0)
        if bad.size:
            raise InputError(f"{_at(source, lines[bad[0]])}: node set {name!r} lists node {numbers[bad[0]]}, "
                             "which is not defined")
        node_sets[name] = np.unique(rows)

    kind_of = np.concatenate([np.full(elem_ids[k].size, i) for i, k in enumerate(kinds)])
    row_of = np.concatenate([np.arange(elem_ids[k].size) for k in kinds])
    where = _lookup(all_ids)
    elem_sets = {}
    for name, (numbers, lines) in esets.items():
        numbers = np.asarray(numbers, dtype=np.int64)
        at = where(numbers)
        bad = np.flatnonzero(at < 0)
        if bad.size:
            raise InputError(f"{_at(source, lines[bad[0]])}: element set {name!r} lists element "
                             f"{numbers[bad[0]]}, which is not a defined solid element")
        elem_sets[name] = {k: np.unique(row_of[at][kind_of[at] == i]) for i, k in enumerate(kinds)
                           if (kind_of[at] == i).any()}

    masses = np.zeros((len(conm2), 5))
    on = np.unique(np.concatenate([c.ravel() for c in cells.values()])) if conm2 else ()
    for k, (eid, grid, values, line) in enumerate(conm2):
        row = int(rows_of(np.array([grid]))[0])
        if "bar2" not in cells or row < 0 or row not in on:
            why = ("is not defined" if row < 0 else "is on no bar") if "bar2" in cells else "is on a solid"
            raise InputError(f"{_at(source, line)}: CONM2 {eid}: its grid {grid} {why} (a point mass sits on a "
                             "frame's node)")
        masses[k] = [row, values[0] * to_kgm3 * length ** 3, *(np.array(values[1:]) * to_kgm3 * length ** 5)]

    mats = {}
    for name, (E, nu, rho, line) in materials.items():
        mats[name] = _material(source, units, name, E, nu, rho, line, to_pa, to_kgm3)
    return Mesh(nodes=nodes, cells=cells, node_sets=node_sets, elem_sets=elem_sets, materials=mats,
                source=source, node_ids=ids, elem_ids=elem_ids, bars=frame, masses=masses)


def _straight(source, nodes, cells, v, numbers, lines) -> None:
    """InputError naming the first bar element whose end nodes coincide or whose orientation vector
    v (ne, 3) is (nearly) parallel to its axis."""
    d = nodes[cells[:, 1]] - nodes[cells[:, 0]]
    l, size = np.linalg.norm(d, axis=1), np.ptp(nodes, axis=0).max()
    bad = np.flatnonzero(l <= 1e-9 * size)
    if bad.size:
        raise InputError(f"{_at(source, lines[bad[0]])}: element {numbers[bad[0]]} (bar) has coincident end nodes")
    s = np.linalg.norm(np.cross(d, v), axis=1) / np.maximum(l * np.linalg.norm(v, axis=1), 1e-300)
    bad = np.flatnonzero(s < 1e-6)
    if bad.size:
        raise InputError(f"{_at(source, lines[bad[0]])}: element {numbers[bad[0]]} (bar) has an orientation vector "
                         "along its axis (or none): plane 1 is undefined")


def _material(source, units, name, E, nu, rho, line, to_pa, to_kgm3) -> tuple:
    """(E Pa, nu, rho kg/m^3) of a material given in file units, checked."""
    at = _at(source, line)
    if E is None or nu is None:
        raise InputError(f"{at}: material {name}: no Young's modulus and Poisson's ratio")
    if rho is None:
        raise InputError(f"{at}: material {name}: no density")
    E, rho = E * to_pa, rho * to_kgm3
    if not E > 0 or not rho > 0 or not -1.0 < nu < 0.5:
        raise InputError(f"{at}: material {name}: E = {E:g} Pa, nu = {nu:g}, rho = {rho:g} kg/m^3 "
                         "(E and rho must be positive, -1 < nu < 0.5)")
    c = float(np.sqrt(E / rho))
    if not WAVE_SPEED[0] <= c <= WAVE_SPEED[1]:
        raise InputError(f"{at}: material {name}: sqrt(E/rho) = {c:.3g} m/s in units {units!r}, outside "
                         f"{WAVE_SPEED[0]:g}..{WAVE_SPEED[1]:g} m/s: the material's numbers do not match the units "
                         "(SI files need units = \"m\", mm-t-s files (MPa, t/mm^3) units = \"mm\")")
    return (float(E), float(nu), float(rho))


def _positive_volumes(source, kind, nodes, cells, numbers, lines, ids) -> None:
    """InputError naming the first element whose corner Jacobian (tetrahedra: signed volume of the
    corner tetrahedron; hexahedra: at each corner, from its three edges) is not positive."""
    x = nodes[cells]
    corners = CORNERS[kind[:3]]
    det = np.stack([np.einsum("ij,ij->i", np.cross(x[:, a] - x[:, o], x[:, b] - x[:, o]), x[:, c] - x[:, o])
                    for o, a, b, c in corners], axis=1)
    n = 4 if kind[:3] == "tet" else 8
    size = np.ptp(x[:, :n], axis=1).max(axis=1) ** 3          # negligible against the element's size
    bad = np.argwhere(det <= 1e-12 * size[:, None])
    if bad.size:
        e, k = bad[0]
        corner = "" if kind[:3] == "tet" else f" at corner node {ids[cells[e, corners[k][0]]]}"
        raise InputError(f"{_at(source, lines[e])}: element {numbers[e]} ({kind}) has a non-positive volume{corner} "
                         "(inverted, misordered or collapsed nodes)")


def _unique(source, what, numbers, lines) -> None:
    """InputError at the second definition of the first number defined twice."""
    order = np.argsort(numbers, kind="stable")
    s = numbers[order]
    dup = np.flatnonzero(s[1:] == s[:-1])
    if dup.size:
        first, again = order[dup[0]], order[dup[0] + 1]
        also = f" (first on line {lines[first]})" if lines[first] else ""
        raise InputError(f"{_at(source, lines[again])}: {what} {s[dup[0]]} is defined twice{also}")


def _lookup(numbers):
    """A function mapping file numbers (any shape) to their positions in `numbers`, -1 where absent."""
    numbers = np.asarray(numbers, dtype=np.int64)
    order = np.argsort(numbers, kind="stable")
    s = numbers[order]

    def rows(wanted):
        wanted = np.asarray(wanted, dtype=np.int64)
        if s.size == 0:
            return np.full(wanted.shape, -1, dtype=np.int64)
        pos = np.minimum(np.searchsorted(s, wanted), s.size - 1)
        return np.where(s[pos] == wanted, order[pos], -1)
    return rows


def _at(source, line) -> str:
    return f"{source}:{line}" if line else source


def _text(source) -> str:
    try:
        with open(source, encoding="utf-8", errors="replace") as f:
            return f.read()
    except OSError as e:
        raise InputError(f"{source}: cannot read the file ({e.strerror or e})") from None


def _is_real(token) -> bool:
    try:
        float(token)
        return True
    except ValueError:
        return False


# ---------------------------------------------------------------------------------------------
# Abaqus


def _abaqus(source, text) -> tuple:
    """The parts of `_build` from the text of an Abaqus input file."""
    ids, xyz, node_lines = [], [], []
    elems = {}                                  # kind -> (numbers, node numbers, lines)
    nsets, esets, materials = {}, {}, {}        # name -> ([numbers], [lines]); name -> [E, nu, rho, line]
    of_elements = []                            # (node set, element set, line) of *NSET, ELSET=
    n_lines = len(text.splitlines())
    parts = 0
    state, params, kind, material, pending = None, {}, None, None, None

    def finish():
        if pending is not None:
            no, tokens = pending
            raise InputError(f"{source}:{no}: element {tokens[0]} ({params['TYPE']}) needs "
                             f"{NODES_PER[kind]} nodes, got {len(tokens) - 1}")

    for no, line in enumerate(text.splitlines(), 1):
        s = line.strip()
        if not s or s.startswith("**"):
            continue
        if s.startswith("*"):
            finish()
            state, params = _keyword(s)
            if state == "PART":
                parts += 1
                if parts > 1:
                    raise InputError(f"{source}:{no}: a second *PART: flexmbd reads one part per body (a flat "
                                     "file, or one *PART); write each part to its own file")
            elif state == "INCLUDE":
                raise InputError(f"{source}:{no}: *INCLUDE is not supported: merge the included file in")
            elif state == "NODE" and params.get("SYSTEM", "R").upper() != "R":
                raise InputError(f"{source}:{no}: *NODE, SYSTEM={params['SYSTEM']}: only rectangular coordinates "
                                 "(SYSTEM=R) are supported")
            elif state == "ELEMENT":
                kind = ABAQUS_KINDS.get(params.get("TYPE", "").upper())
                if kind is None:
                    raise InputError(f"{source}:{no}: element type {params.get('TYPE', '(none)')!r} is not supported "
                                     f"(supported: {', '.join(ABAQUS_KINDS)})")
                params["TYPE"] = params["TYPE"].upper()
                elems.setdefault(kind, ([], [], []))
            elif state in ("NSET", "ELSET") and not params.get(state):
                raise InputError(f"{source}:{no}: *{state} without {state}=name")
            elif state == "NSET" and params.get("ELSET"):
                of_elements.append((params["NSET"], params["ELSET"], no))     # the nodes of an element set
            elif state == "MATERIAL":
                if not params.get("NAME"):
                    raise InputError(f"{source}:{no}: *MATERIAL without NAME=")
                material = _named(materials, params["NAME"])
                materials.setdefault(material, [None, None, None, no])
            elif state == "ELASTIC" and params.get("TYPE", "ISOTROPIC").upper() != "ISOTROPIC":
                raise InputError(f"{source}:{no}: *ELASTIC, TYPE={params['TYPE']}: only isotropic elasticity "
                                 "is supported")
            if state in ("NSET", "ELSET"):
                params["name"] = _named(nsets if state == "NSET" else esets, params[state])
            params["first"] = True
            continue

        tokens = [t.strip() for t in s.split(",")]
        if state == "NODE":
            if len(tokens) < 2 or not all(_is_real(t) for t in tokens[1:4] if t) or not _is_int(tokens[0]):
                raise InputError(f"{source}:{no}: *NODE data: expected 'number, x, y, z', got {s!r}")
            ids.append(_int(tokens[0], f"{source}:{no}", "*NODE number"))
            xyz.append([float(t) if t else 0.0 for t in (tokens[1:4] + ["", ""])[:3]])
            node_lines.append(no)
            if params.get("NSET"):
                _add(nsets, params["NSET"], [ids[-1]], no)
        elif state == "ELEMENT":
            if pending is None:
                pending = (no, [])
            pending[1].extend(t for t in tokens if t)
            if len(pending[1]) < NODES_PER[kind] + 1:      # continued on the next line (C3D20: 16 + 5)
                continue
            start, numbers = pending
            pending = None
            if len(numbers) != NODES_PER[kind] + 1 or not all(_is_int(t) for t in numbers):
                raise InputError(f"{source}:{start}: element {numbers[0]} ({params['TYPE']}) needs "
                                 f"{NODES_PER[kind]} node numbers, got {' '.join(numbers[1:])!r}")
            numbers = [_int(t, f"{source}:{start}", f"*ELEMENT, TYPE={params['TYPE']}") for t in numbers]
            el = elems[kind]
            el[0].append(numbers[0])
            el[1].append(numbers[1:])
            el[2].append(start)
            if params.get("ELSET"):
                _add(esets, params["ELSET"], [numbers[0]], start)
        elif state in ("NSET", "ELSET"):
            table = nsets if state == "NSET" else esets
            _add(table, params["name"], _members(source, no, tokens, table, "GENERATE" in params, state, n_lines), no)
        elif state == "SYSTEM":
            raise InputError(f"{source}:{no}: *SYSTEM (nodes in a local coordinate system) is not supported")
        elif state in ("ELASTIC", "DENSITY") and material is not None:
            if not params.pop("first", False):
                raise InputError(f"{source}:{no}: *{state} of material {material}: more than one data line "
                                 "(temperature-dependent data is not supported)")
            values = [t for t in tokens if t]
            need = 2 if state == "ELASTIC" else 1
            if len(values) < need or not all(_is_real(t) for t in values[:need]):
                raise InputError(f"{source}:{no}: *{state}: expected {'E, nu' if need == 2 else 'rho'}, got {s!r}")
            m = materials[material]
            if state == "ELASTIC":
                m[0], m[1] = float(values[0]), float(values[1])
            else:
                m[2] = float(values[0])
    finish()
    if of_elements:
        nodes_of = {e: c for numbers, conn, _ in elems.values() for e, c in zip(numbers, conn)}
        for name, elset, no in of_elements:
            if _named(esets, elset) not in esets:
                raise InputError(f"{source}:{no}: *NSET, ELSET={elset}: the file has no element set {elset!r}")
            numbers = esets[_named(esets, elset)][0]
            missing = [e for e in numbers if e not in nodes_of]
            if missing:
                raise InputError(f"{source}:{no}: element set {elset!r} lists element {missing[0]}, which is "
                                 "not a defined solid element")
            _add(nsets, name, sorted({n for e in numbers for n in nodes_of[e]}), no)
    elems = {k: v for k, v in elems.items() if v[0]}
    return (ids, np.array(xyz, dtype=float).reshape(-1, 3), node_lines, elems,
            {k: (np.array(v[0], dtype=np.int64), v[1]) for k, v in nsets.items()},
            {k: (np.array(v[0], dtype=np.int64), v[1]) for k, v in esets.items()},
            {k: tuple(v) for k, v in materials.items()})


def _keyword(line) -> tuple:
    """('NAME WORDS', {PARAMETER: value}) of an Abaqus keyword line; a parameter without a value
    maps to ''."""
    fields = line[1:].split(",")
    params = {}
    for p in fields[1:]:
        key, _, value = p.partition("=")
        if key.strip():
            params[" ".join(key.upper().split())] = value.strip().strip('"')
    return " ".join(fields[0].upper().split()), params


def _members(source, no, tokens, table, generate, what, n_lines) -> list:
    """The numbers listed on one data line of *NSET or *ELSET of a file of `n_lines` lines: 'first,
    last[, step]' with GENERATE (`_range`), else numbers and the names of sets defined before."""
    tokens = [t for t in tokens if t]
    at = f"{source}:{no}"
    if generate:
        if not 2 <= len(tokens) <= 3 or not all(_is_int(t) for t in tokens):
            raise InputError(f"{at}: *{what}, GENERATE: expected 'first, last[, increment]'")
        first, last, step = (_int(t, at, f"*{what}, GENERATE") for t in (tokens + ["1"])[:3])
        return list(_range(first, last, step, at, f"*{what}, GENERATE: {first}, {last}, {step}", n_lines))
    out = []
    for t in tokens:
        if _is_int(t):
            out.append(_int(t, at, f"*{what}"))
        else:
            name = _named(table, t)
            if name not in table:
                raise InputError(f"{source}:{no}: *{what}: {t!r} is neither a number nor a set defined before")
            out.extend(table[name][0])
    return out


def _add(table, name, numbers, line) -> None:
    """Append numbers (all from one line) to the set `name` (matched without case) of `table`."""
    entry = table.setdefault(_named(table, name), ([], []))
    entry[0].extend(numbers)
    entry[1].extend([line] * len(numbers))


def _named(table, name) -> str:
    """The key of `table` that equals `name` without regard to case, else `name`."""
    low = name.lower()
    return next((k for k in table if k.lower() == low), name)


def _is_int(token) -> bool:
    return re.fullmatch(r"[+-]?\d+", token.strip()) is not None


def _int(field, at, what) -> int:
    """An integer field (of either format): a number of at most NUMBER_MAX in size."""
    if not _is_int(field):
        raise InputError(f"{at}: {what}: {field!r} is not an integer")
    value = int(field)
    if abs(value) > NUMBER_MAX:
        raise InputError(f"{at}: {what}: {field.strip()} is too large (numbers up to {NUMBER_MAX} are read)")
    return value


def _range(first, last, step, at, what, n_lines) -> range:
    """first, first + step, ..., last: the numbers of a range of set members (`what`, as the file
    gives it), ascending; refused before any list of them is made when it holds more numbers than
    the file's `n_lines` lines could define (a node or an element takes a line at least; RANGE_EXPANDED)."""
    if step < 1 or last < first:
        raise InputError(f"{at}: {what} is not an ascending range")
    numbers = range(first, last + 1, step)
    if len(numbers) > max(n_lines, RANGE_EXPANDED):
        raise InputError(f"{at}: {what} holds {len(numbers)} numbers, more than a file of {n_lines} lines can "
                         "define (a node or an element takes a line at least, and a set's members must be defined)")
    return numbers


# ---------------------------------------------------------------------------------------------
# NASTRAN


def _nastran(source, text) -> tuple:
    """The parts of `_build` from the text of a NASTRAN bulk data file."""
    ids, xyz, node_lines = [], [], []
    elems = {}
    nsets = {}
    mat1, psolid, pids = {}, {}, []            # MID -> (E, nu, rho, line); PID -> (MID, line); (EID, PID, line)
    bars, pbar = [], {}                         # (EID, PID, GA, X or G0, line); PID -> (MID, [A .. K2], line)
    local = {}                                  # GRID ID -> its displacement coordinate system CD, where not basic
    conm2 = []                                  # (EID, G, [M, I11, I22, I33], line)
    n_lines = len(text.splitlines())
    for name, f, no in _cards(source, text):
        at = f"{source}:{no}"
        if name == "GRID":
            if f[1] not in ("", "0"):
                raise InputError(f"{at}: GRID {f[0]} has coordinate system CP={f[1]}: only the basic system "
                                 "(CP blank or 0) is supported")
            if f[5] not in ("", "0"):
                local[_int(f[0], at, "GRID ID")] = f[5]
            ids.append(_int(f[0], at, "GRID ID"))
            xyz.append([_real(v, at, "GRID X") if v else 0.0 for v in f[2:5]])
            node_lines.append(no)
        elif name in ("CTETRA", "CHEXA"):
            eid = _int(f[0], at, f"{name} EID")
            grids = [_int(v, at, f"{name} G") for v in f[2:] if v]
            sizes = {"CTETRA": {4: "tet4", 10: "tet10"}, "CHEXA": {8: "hex8", 20: "hex20"}}[name]
            if len(grids) not in sizes:
                raise InputError(f"{at}: {name} {eid} has {len(grids)} grids (flexmbd reads "
                                 f"{' or '.join(map(str, sizes))})")
            kind = sizes[len(grids)]
            if kind == "hex20":
                grids = list(np.asarray(grids)[NASTRAN_HEX20])
            el = elems.setdefault(kind, ([], [], []))
            el[0].append(eid)
            el[1].append(grids)
            el[2].append(no)
            pids.append((eid, _int(f[1], at, f"{name} PID") if f[1] else eid, no))
        elif name in ("CBAR", "CBEAM"):
            eid = _int(f[0], at, f"{name} EID")
            ga, gb = (_int(v, at, f"{name} G{e}") for v, e in zip(f[2:4], "AB"))
            if f[4] and _is_int(f[4]) and not (f[5] or f[6]):
                orient = _int(f[4], at, f"{name} G0")
            elif f[4] or f[5] or f[6]:
                orient = np.array([_real(v, at, f"{name} X{k + 1}") if v else 0.0 for k, v in enumerate(f[4:7])])
            else:
                raise InputError(f"{at}: {name} {eid} has no orientation vector (X1-X3 or G0; BAROR is not read)")
            if f[7] not in ("", "GGG"):
                raise InputError(f"{at}: {name} {eid}: OFFT {f[7]!r}: only GGG (the default) is read")
            for v, w in zip(f[8:16], ("PA", "PB", "W1A", "W2A", "W3A", "W1B", "W2B", "W3B")):
                if v and (_real(v, at, f"{name} {w}") if w[0] == "W" else _int(v, at, f"{name} {w}")) != 0:
                    raise InputError(f"{at}: {name} {eid}: {w} = {v}: pin flags and offsets are not supported")
            el = elems.setdefault("bar2", ([], [], []))
            el[0].append(eid)
            el[1].append([ga, gb])
            el[2].append(no)
            bars.append((eid, _int(f[1], at, f"{name} PID") if f[1] else eid, ga, orient, no))
        elif name in ("PBAR", "PBEAM"):
            pid = _int(f[0], at, f"{name} PID")
            if pid in pbar:
                raise InputError(f"{at}: {name} {pid} is defined twice (first on line {pbar[pid][2]})")
            f = f + [""] * 19                           # the optional fields read as blank
            if name == "PBAR":                          # PID MID A I1 I2 J NSM; C1..F2; K1 K2 I12
                values, nsm, i12, shear = f[2:6], f[6], f[18], (f[16] or "0", f[17] or "0")
            else:                                       # PID MID A I1 I2 I12 J NSM (end A); C1..F2;
                values, nsm, i12 = [f[2], f[3], f[4], f[6]], f[7], f[5]     # stations; K1 K2 ...
                k = 16
                while k < len(f) and f[k].upper() in ("YES", "YESA", "NO"):
                    if f[k].upper() != "YESA" and any(_real(a or "0", at, name) != _real(b or "0", at, name)
                                                      for a, b in zip(f[k + 2:k + 8], f[2:8])):
                        raise InputError(f"{at}: PBEAM {pid}: a tapered beam (its stations' sections differ): "
                                         "only a constant section is read")
                    k += 16
                shear = tuple((f[j] if j < len(f) else "") or "1.0" for j in (k, k + 1))   # NASTRAN's default 1.0
            A, I1, I2, J = (_real(v, at, f"{name} {w}") if v else 0.0 for v, w in zip(values, ("A", "I1", "I2", "J")))
            K1, K2 = (_real(v, at, f"{name} {w}") for v, w in zip(shear, ("K1", "K2")))
            for v, w in ((nsm, "NSM"), (i12, "I12")):
                if v and _real(v, at, f"{name} {w}") != 0:
                    raise InputError(f"{at}: {name} {pid}: {w} = {v}: only sections without non-structural mass "
                                     "and with principal axes along the element's y and z are read")
            if not min(A, I1, I2, J) > 0 or min(K1, K2) < 0:
                raise InputError(f"{at}: {name} {pid}: A, I1, I2 and J must be positive and K1, K2 not negative (got "
                                 f"{A:g}, {I1:g}, {I2:g}, {J:g}, {K1:g}, {K2:g})")
            pbar[pid] = (_int(f[1], at, f"{name} MID"), [A, I1, I2, J, K1, K2], no)
        elif name == "CONM2":                           # EID G CID M X1 X2 X3; I11 I21 I22 I31 I32 I33
            f = f + [""] * 14
            eid = _int(f[0], at, "CONM2 EID")
            if f[2] not in ("", "0"):
                raise InputError(f"{at}: CONM2 {eid}: CID = {f[2]}: only the basic system (blank or 0) is supported")
            for v, w in zip(f[4:7] + [f[9], f[11], f[12]], ("X1", "X2", "X3", "I21", "I31", "I32")):
                if v and _real(v, at, f"CONM2 {w}") != 0:
                    raise InputError(f"{at}: CONM2 {eid}: {w} = {v}: only a mass at its grid with principal axes along "
                                     "the basic ones is read (no offset, no products of inertia)")
            values = [_real(v, at, f"CONM2 {w}") if v else 0.0 for v, w in zip([f[3], f[8], f[10], f[13]],
                                                                             ("M", "I11", "I22", "I33"))]
            if min(values) < 0:
                raise InputError(f"{at}: CONM2 {eid}: M and I11, I22, I33 must not be negative")
            conm2.append((eid, _int(f[1], at, "CONM2 G"), values, no))
        elif name in NASTRAN_ELEMENTS:
            raise InputError(f"{at}: {name} elements are not supported (CTETRA and CHEXA make a solid body, "
                             "CBAR and CBEAM a frame, CONM2 a point mass on a frame)")
        elif name == "MAT1":
            mid = _int(f[0], at, "MAT1 MID")
            if mid in mat1:
                raise InputError(f"{at}: MAT1 {mid} is defined twice (first on line {mat1[mid][3]})")
            E, G, nu, rho = (_real(v, at, "MAT1 " + w) if v else None for v, w in zip(f[1:5], ("E", "G", "NU", "RHO")))
            if E is None and G is not None and nu is not None:
                E = 2.0 * G * (1.0 + nu)
            elif nu is None and E is not None and G is not None:
                nu = E / (2.0 * G) - 1.0
            if E is None or nu is None:
                raise InputError(f"{at}: MAT1 {mid}: two of E, G, NU are needed")
            mat1[mid] = (E, nu, rho, no)
        elif name == "PSOLID":
            psolid[_int(f[0], at, "PSOLID PID")] = (_int(f[1], at, "PSOLID MID"), no)
        elif name in ("SPC", "SPC1", "SET1"):
            sid = _int(f[0], at, f"{name} SID")
            if name == "SPC":
                grids = [_int(v, at, "SPC G") for v in (f[1], f[4]) if v]
            else:
                grids = _thru(f[2 if name == "SPC1" else 1:], at, name, n_lines)
            _add(nsets, f"{'set' if name == 'SET1' else 'spc'}{sid}", grids, no)
        elif name == "RBE2":
            eid = _int(f[0], at, "RBE2 EID")
            dependent = []
            for v in f[3:]:
                if v and not _is_int(v):
                    break                               # ALPHA, a real, ends the grid list
                if v:
                    dependent.append(_int(v, at, "RBE2 GM"))
            _add(nsets, f"rbe2_{eid}", dependent, no)
            _add(nsets, f"rbe2_{eid}_ref", [_int(f[1], at, "RBE2 GN")], no)
        elif name == "RBE3":
            eid = _int(f[0], at, "RBE3 EID")
            weighted, k = [], 4
            while k < len(f) and f[k].upper() not in ("UM", "ALPHA", "TREF", "STRESS"):
                if f[k] and not _is_int(f[k]):
                    _real(f[k], at, "RBE3 WT")          # a weight WTi (not kept), then its components Ci
                    k += 2
                    continue
                if f[k]:
                    weighted.append(_int(f[k], at, "RBE3 G"))
                k += 1
            _add(nsets, f"rbe3_{eid}", weighted, no)
            _add(nsets, f"rbe3_{eid}_ref", [_int(f[2], at, "RBE3 REFGRID")], no)

    materials = {f"mat{mid}": m for mid, m in mat1.items()}
    used = {}                                           # MID -> (EID, PID, line) of its first element
    for eid, pid, no in pids + [b[:2] + b[4:] for b in bars]:
        card, (mid, pline) = ("PSOLID", psolid[pid]) if pid in psolid else ("PBAR", pbar[pid][::2]) if pid in pbar \
            else (None, (None, None))
        if card:
            if mid not in mat1:
                raise InputError(f"{source}:{pline}: {card} {pid} refers to material {mid}, which has no MAT1 card")
            used.setdefault(mid, (eid, pid, no))
    if len(used) > 1:
        (m1, (e1, p1, _)), (m2, (e2, p2, no)) = list(used.items())[:2]
        raise InputError(f"{source}:{no}: element {e2} has material mat{m2} (property {p2}) but element {e1} "
                         f"mat{m1} (property {p1}): the elements of one body must use one material")
    xyz = np.array(xyz, dtype=float).reshape(-1, 3)
    section = np.zeros((len(bars), 9))
    where = dict(zip(ids, range(len(ids))))
    for k, (eid, pid, ga, orient, no) in enumerate(bars):
        if pid not in pbar:
            raise InputError(f"{source}:{no}: element {eid} refers to property {pid}, which has no PBAR or PBEAM card")
        if isinstance(orient, np.ndarray) and ga in local:
            raise InputError(f"{source}:{no}: element {eid}'s orientation vector is in the displacement coordinate "
                             f"system CD={local[ga]} of its node {ga}: only the basic system is supported (or give G0)")
        if not isinstance(orient, np.ndarray):
            if orient not in where or ga not in where:
                raise InputError(f"{source}:{no}: element {eid} refers to node {orient if orient not in where else ga}, "
                                 "which is not defined")
            orient = xyz[where[orient]] - xyz[where[ga]]
        section[k] = pbar[pid][1] + list(orient)
    return (ids, xyz, node_lines, elems,
            {k: (np.array(v[0], dtype=np.int64), v[1]) for k, v in nsets.items()}, {}, materials, section, conm2)


def _cards(source, text):
    """Yield (NAME, data fields, line) of each bulk data card, its continuation lines joined: the
    data fields are the card's fields 2-9, 12-19, ... (continuation markers dropped), stripped."""
    lines = text.splitlines()
    start = next((i + 1 for i, line in enumerate(lines) if re.match(r"\s*BEGIN\s+BULK", line, re.I)), 0)
    card = None
    for i in range(start, len(lines)):
        no = i + 1
        line = lines[i].split("$", 1)[0].rstrip()
        if not line.strip():
            continue
        if re.match(r"\s*ENDDATA", line, re.I):
            break
        if re.match(r"\s*INCLUDE", line, re.I):
            raise InputError(f"{source}:{no}: INCLUDE is not supported: merge the included file in")
        first, data = _fields(source, no, line)
        if not first or first[0] in "+*":
            if card is None:
                raise InputError(f"{source}:{no}: a continuation line with no card before it")
            card[1].extend(data)
        else:
            if card is not None:
                yield _paired(source, card)
            card = (first.upper().rstrip("*"), data, no)
    if card is not None:
        yield _paired(source, card)


def _paired(source, card) -> tuple:
    """The card, refused when it ends in half a line: large-field lines hold four fields each and
    come in pairs (fields 2-5, then 6-9 on a continuation line), every other line eight."""
    name, data, no = card
    if len(data) % 8:
        raise InputError(f"{source}:{no}: {name}*: a large-field card's lines come in pairs (fields 2-5, then "
                         "fields 6-9 on a continuation line starting with '*'): the continuation line is missing")
    return card


def _fields(source, no, line) -> tuple:
    """(first field, data fields) of one physical line: free (commas), large (16 characters: the
    first field ends or starts with '*') or small (8 characters) field format."""
    if "," in line:
        f = [v.strip() for v in line.split(",")]
        if len(f) > 10:
            raise InputError(f"{source}:{no}: a free-field line with more than 10 fields")
        n = 4 if f[0].endswith("*") or f[0].startswith("*") else 8
        return f[0], (f[1:n + 1] + [""] * n)[:n]
    line = line.expandtabs(8)
    first = line[:8].strip()
    if first.endswith("*") or first.startswith("*"):
        return first, [line[8 + 16 * k:24 + 16 * k].strip() for k in range(4)]
    return first, [line[8 + 8 * k:16 + 8 * k].strip() for k in range(8)]


def _thru(fields, at, card, n_lines) -> list:
    """Grid numbers of a list that may use 'G1 THRU G2' (G1 <= G2; `_range` in a file of `n_lines` lines)."""
    out, fields = [], [v for v in fields if v]
    k = 0
    while k < len(fields):
        if fields[k].upper() == "THRU":
            if not out or k + 1 >= len(fields):
                raise InputError(f"{at}: {card}: THRU needs a number on each side")
            last = _int(fields[k + 1], at, card + " G")
            out.extend(_range(out[-1], last, 1, at, f"{card}: {out[-1]} THRU {last}", n_lines)[1:])
            k += 2
        else:
            out.append(_int(fields[k], at, card + " G"))
            k += 1
    return out


def _real(field, at, what) -> float:
    """A NASTRAN real, finite: also '1.5-3' and '2.+5' (exponent without E) and D exponents."""
    s = field.strip().upper().replace("D", "E")
    m = re.fullmatch(r"([+-]?(?:\d+\.?\d*|\.\d+))([+-]\d+)", s)
    if m:
        s = f"{m.group(1)}E{m.group(2)}"
    try:
        value = float(s)
    except ValueError:
        raise InputError(f"{at}: {what}: {field!r} is not a number") from None
    if not np.isfinite(value):
        raise InputError(f"{at}: {what}: {field!r} is not a finite number")
    return value


# ---------------------------------------------------------------------------------------------
# Gmsh


def _gmsh(source) -> tuple:
    """The parts of `_build` from a Gmsh file, through meshio."""
    import meshio                       # here: only Gmsh files need it

    try:                                # a missing or unreadable file: the same message as the others
        open(source, "rb").close()
    except OSError as e:
        raise InputError(f"{source}: cannot read the file ({e.strerror or e})") from None
    try:                                # not meshio.read: it ends the process on a ReadError
        m = meshio.gmsh.read(source)
    except Exception as e:              # meshio's ReadError, and whatever a malformed file makes it raise
        why = f"{type(e).__name__}: {e}" if str(e) else type(e).__name__
        raise InputError(f"{source}: not a readable Gmsh file ({why})") from None
    for block in m.cells:
        if block.dim == 3 and block.type not in GMSH_KINDS:
            raise InputError(f"{source}: Gmsh element type {block.type} is not supported "
                             f"(supported: {', '.join(GMSH_KINDS)})")

    # the 3-D cells: numbered 1, 2, ... in the file's order, gathered by kind
    number, blocks = 0, {}              # block index -> its element numbers
    elems = {}
    for k, block in enumerate(m.cells):
        if block.type in GMSH_KINDS:
            kind = GMSH_KINDS[block.type]
            numbers = np.arange(number + 1, number + len(block.data) + 1)
            number += len(block.data)
            blocks[k] = numbers
            el = elems.setdefault(kind, ([], [], []))
            el[0].append(numbers)
            el[1].append(np.asarray(block.data, dtype=np.int64) + 1)
    elems = {kind: (np.concatenate(e[0]), np.concatenate(e[1]), np.zeros(sum(map(len, e[0])), dtype=np.int64))
             for kind, e in elems.items()}

    nsets, esets = {}, {}
    for name, members in _physical_groups(m).items():
        nodes = np.unique(np.concatenate([np.asarray(m.cells[k].data)[idx].ravel() for k, idx in members])) + 1
        nsets[name] = (nodes, np.zeros(nodes.size, dtype=np.int64))
        solid = [blocks[k][idx] for k, idx in members if k in blocks]
        if solid:
            numbers = np.concatenate(solid)
            esets[name] = (numbers, np.zeros(numbers.size, dtype=np.int64))
    n = len(m.points)
    return (np.arange(1, n + 1), np.asarray(m.points, dtype=float)[:, :3], np.zeros(n, dtype=np.int64),
            elems, nsets, esets, {})


def _physical_groups(m) -> dict:
    """{name: [(block index, cell indices in the block)]} of a meshio mesh read from Gmsh: the
    named groups from meshio's cell sets where it makes them (MSH 4.1, where an entity may be in
    several groups), the others from the 'gmsh:physical' tags (MSH 4.1: an entity's first group
    only) and their names in field_data; a group without a name is 'physical<dim>d_<tag>'."""
    groups = {}
    for name in m.field_data:
        for k, idx in enumerate(m.cell_sets.get(name, [])):
            if idx is not None and len(idx):
                groups.setdefault(name, []).append((k, np.asarray(idx, dtype=np.int64)))
    from_sets = set(groups)
    names = {(int(v[1]), int(v[0])): name for name, v in ((n, np.asarray(v).ravel()) for n, v in m.field_data.items())
             if v.size >= 2}
    for k, (block, tags) in enumerate(zip(m.cells, m.cell_data.get("gmsh:physical", []))):
        tags = np.asarray(tags)
        for tag in np.unique(tags[tags > 0]):
            name = names.get((block.dim, int(tag)), f"physical{block.dim}d_{tag}")
            if name not in from_sets:
                groups.setdefault(name, []).append((k, np.flatnonzero(tags == tag)))
    return groups
