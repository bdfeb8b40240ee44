"""A reader's record (`records.Parsed`) checked and converted into an SI Mesh: node and element
numbers unique, every reference defined, coordinates finite, volumes positive, bars straight with
an orientation vector off their axis, point masses on a frame's nodes, and every material's wave
speed sqrt(E/rho) within WAVE_SPEED after the conversion of units (else the numbers do not match
the units and the file is refused)."""

from __future__ import annotations

import numpy as np

from flexmbd.core.errors import InputError
from flexmbd.fe.mesh import NODES_PER, Mesh
from flexmbd.fe.meshfiles.common import UNITS, lookup, place
from flexmbd.fe.meshfiles.records import Parsed

# m/s: the plausible range of sqrt(E/rho) for a solid. A soft elastomer or foam has 10-50 m/s (a
# rubber of E = 1 MPa, rho = 1000 kg/m^3: 31.6 m/s), steel 5200 and beryllium 12500, while a file
# read in the other unit system is off by a factor of 1000 (E 1e6 times, rho 1e12): steel in mm-t-s
# read as SI gives 5.2e6 m/s and in SI read as mm-t-s 5.2 m/s, both outside
WAVE_SPEED = (10.0, 20000.0)

# corner o and its three neighbours a, b, c with (xa - xo) x (xb - xo) . (xc - xo) > 0
CORNERS = {"tet": ((0, 1, 2, 3),),
           "hex": ((0, 1, 3, 4), (1, 2, 0, 5), (2, 3, 1, 6), (3, 0, 2, 7),
                   (4, 7, 5, 0), (5, 4, 6, 1), (6, 5, 7, 2), (7, 6, 4, 3))}


class Cells:
    """The elements as rows of the nodes: cells, numbers and lines by kind."""

    def __init__(self, parsed: Parsed, rows_of):
        source = parsed.source
        self.cells, self.ids, self.lines = {}, {}, {}
        for kind, (numbers, conn, lines) in parsed.elements.items():
            numbers = np.asarray(numbers, dtype=np.int64)
            conn = np.asarray(conn, dtype=np.int64).reshape(numbers.size, NODES_PER[kind])
            lines = np.asarray(lines, dtype=np.int64)
            rows = rows_of(conn)
            bad = np.argwhere(rows < 0)
            if bad.size:
                e, j = bad[0]
                raise InputError(f"{place(source, lines[e])}: element {numbers[e]} refers to node {conn[e, j]}, "
                                 "which is not defined")
            self.cells[kind], self.ids[kind], self.lines[kind] = rows, numbers, lines
        self.kinds = list(self.cells)
        self.all_ids = np.concatenate([self.ids[k] for k in self.kinds])
        _unique(source, "element", self.all_ids, np.concatenate([self.lines[k] for k in self.kinds]))


def mesh(parsed: Parsed, units) -> Mesh:
    """The SI Mesh of a file's record in `units` (common.UNITS); InputError at the first fault."""
    source = parsed.source
    ids = np.asarray(parsed.node_ids, dtype=np.int64).reshape(-1)
    xyz = np.asarray(parsed.xyz, dtype=float).reshape(-1, 3)
    node_lines = np.asarray(parsed.node_lines, dtype=np.int64).reshape(-1)
    if not parsed.elements:
        raise InputError(f"{source}: no elements (tetrahedra, hexahedra, or bars in a NASTRAN file) in the file")
    if "bar2" in parsed.elements and len(parsed.elements) > 1:
        raise InputError(f"{source}: both bar and solid elements: a body is either a solid or a frame")
    _unique(source, "node", ids, node_lines)
    bad = np.flatnonzero(~np.isfinite(xyz).all(axis=1))
    if bad.size:
        raise InputError(f"{place(source, node_lines[bad[0]])}: node {ids[bad[0]]} has a coordinate that is not "
                         "a finite number")
    rows_of = lookup(ids)
    cells = Cells(parsed, rows_of)

    length, to_pa, to_kgm3 = UNITS[units]
    nodes = xyz * length
    for kind in cells.kinds:
        if kind != "bar2":
            _positive_volumes(source, kind, nodes, cells.cells[kind], cells.ids[kind], cells.lines[kind], ids)
    frame = np.zeros((0, 9))
    if "bar2" in cells.cells:
        columns = np.array([(*b[:6], *b.v) for b in parsed.bars], dtype=float).reshape(-1, 9)
        frame = columns * np.array([length ** 2] + [length ** 4] * 3 + [1.0] * 5)
        _straight(source, nodes, cells.cells["bar2"], frame[:, 6:], cells.ids["bar2"], cells.lines["bar2"])
    node_sets = _node_sets(source, parsed.node_sets, rows_of)
    elem_sets = _elem_sets(source, parsed.elem_sets, cells)
    masses = _masses(source, parsed.masses, cells.cells, rows_of, length, to_kgm3)
    mats = {name: _material(source, units, name, m, to_pa, to_kgm3) for name, m in parsed.materials.items()}
    return Mesh(nodes=nodes, cells=cells.cells, node_sets=node_sets, elem_sets=elem_sets, materials=mats,
                source=source, node_ids=ids, elem_ids=cells.ids, bars=frame, masses=masses)


def _node_sets(source, sets, rows_of) -> dict:
    """{name: sorted unique node rows} of the file's node sets, every member defined."""
    return {name: np.unique(_members(source, f"node set {name!r} lists node", numbers, lines, rows_of,
                                     "which is not defined"))
            for name, (numbers, lines) in sets.items()}


def _members(source, says: str, numbers, lines, rows_of, what: str) -> np.ndarray:
    """The rows (`rows_of`) of a set's member numbers; InputError at the first undefined member's
    line: 'SOURCE:LINE: {says} N, {what}'."""
    numbers = np.asarray(numbers, dtype=np.int64)
    rows = rows_of(numbers)
    bad = np.flatnonzero(rows < 0)
    if bad.size:
        raise InputError(f"{place(source, lines[bad[0]])}: {says} {numbers[bad[0]]}, {what}")
    return rows


def _elem_sets(source, sets, cells: Cells) -> dict:
    """{name: {kind: sorted unique rows of cells[kind]}} of the file's element sets, every member defined."""
    kinds = cells.kinds
    kind_of = np.concatenate([np.full(cells.ids[k].size, i) for i, k in enumerate(kinds)])
    row_of = np.concatenate([np.arange(cells.ids[k].size) for k in kinds])
    where = lookup(cells.all_ids)
    elem_sets = {}
    for name, (numbers, lines) in sets.items():
        at = _members(source, f"element set {name!r} lists element", numbers, lines, where,
                      "which is not a defined solid element")
        elem_sets[name] = {k: np.unique(row_of[at][kind_of[at] == i]) for i, k in enumerate(kinds)
                           if (kind_of[at] == i).any()}
    return elem_sets


def _masses(source, point_masses, cells, rows_of, length, to_kgm3) -> np.ndarray:
    """(k, 5) [node row, m, I11, I22, I33] SI of a frame's point masses, each on a node of a bar."""
    masses = np.zeros((len(point_masses), 5))
    on = np.unique(np.concatenate([c.ravel() for c in cells.values()])) if point_masses else ()
    for k, pm in enumerate(point_masses):
        row = int(rows_of(np.array([pm.grid]))[0])
        if "bar2" not in cells or row < 0 or row not in on:
            why = ("is not defined" if row < 0 else "is on no bar") if "bar2" in cells else "is on a solid"
            raise InputError(f"{place(source, pm.line)}: CONM2 {pm.eid}: its grid {pm.grid} {why} (a point mass "
                             "sits on a frame's node)")
        masses[k] = [row, pm.m * to_kgm3 * length ** 3, *(np.array([pm.I11, pm.I22, pm.I33]) * to_kgm3 * length ** 5)]
    return masses


def _straight(source, nodes, cells, v, numbers, lines) -> None:
    """InputError naming the first bar element whose end nodes coincide or whose orientation vector
    v (ne, 3) is (nearly) parallel to its axis."""
    d = nodes[cells[:, 1]] - nodes[cells[:, 0]]
    l, size = np.linalg.norm(d, axis=1), np.ptp(nodes, axis=0).max()
    bad = np.flatnonzero(l <= 1e-9 * size)
    if bad.size:
        raise InputError(f"{place(source, lines[bad[0]])}: element {numbers[bad[0]]} (bar) has coincident end nodes")
    s = np.linalg.norm(np.cross(d, v), axis=1) / np.maximum(l * np.linalg.norm(v, axis=1), 1e-300)
    bad = np.flatnonzero(s < 1e-6)
    if bad.size:
        raise InputError(f"{place(source, lines[bad[0]])}: element {numbers[bad[0]]} (bar) has an orientation "
                         "vector along its axis (or none): plane 1 is undefined")


def _material(source, units, name, m, to_pa, to_kgm3) -> tuple:
    """(E Pa, nu, rho kg/m^3) of a material given in file units, checked."""
    at = place(source, m.line)
    if m.E is None or m.nu is None:
        raise InputError(f"{at}: material {name}: no Young's modulus and Poisson's ratio")
    if m.rho is None:
        raise InputError(f"{at}: material {name}: no density")
    E, nu, rho = m.E * to_pa, m.nu, m.rho * to_kgm3
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
        raise InputError(f"{place(source, lines[e])}: element {numbers[e]} ({kind}) has a non-positive volume"
                         f"{corner} (inverted, misordered or collapsed nodes)")


def _unique(source, what, numbers, lines) -> None:
    """InputError at the second definition of the first number defined twice."""
    order = np.argsort(numbers, kind="stable")
    s = numbers[order]
    dup = np.flatnonzero(s[1:] == s[:-1])
    if dup.size:
        first, again = order[dup[0]], order[dup[0] + 1]
        also = f" (first on line {lines[first]})" if lines[first] else ""
        raise InputError(f"{place(source, lines[again])}: {what} {s[dup[0]]} is defined twice{also}")
