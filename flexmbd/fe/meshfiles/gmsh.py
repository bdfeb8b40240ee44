"""Gmsh (.msh, MSH 2.2 and 4.1), through meshio: the 3-D cells, and every physical group as a node
set (the nodes of its cells, facets included) and, for volume groups, an element set. meshio does
not keep Gmsh's node and element numbers: node_ids are the rows + 1 and the 3-D elements are
numbered 1, 2, ... in the file's order. meshio already gives hexahedron20 and tetra10 in VTK's
order, which is fe.mesh's, so no reordering is needed here (tests/fe/test_fe_meshfile.py checks it
against a file in Gmsh's order). No line numbers: a message names the file only."""

from __future__ import annotations

import numpy as np

from flexmbd.core.errors import InputError
from flexmbd.fe.meshfiles import common
from flexmbd.fe.meshfiles.records import Elements, Members, Parsed

KINDS = {"tetra": "tet4", "tetra10": "tet10", "hexahedron": "hex8", "hexahedron20": "hex20"}


def parse(source) -> Parsed:
    """The record of a Gmsh file."""
    m = _meshio(source)
    if np.asarray(m.points).ndim != 2 or not len(m.points):
        raise InputError(f"{source}: the Gmsh file defines no nodes")
    for block in m.cells:
        if block.dim == 3 and block.type not in KINDS:
            raise InputError(f"{source}: Gmsh element type {block.type} is not supported "
                             f"(supported: {', '.join(KINDS)})")
    elements, blocks = _elements(m)
    node_sets, elem_sets = {}, {}
    for name, members in _physical_groups(m).items():
        nodes = np.unique(np.concatenate([np.asarray(m.cells[k].data)[idx].ravel() for k, idx in members])) + 1
        node_sets[name] = Members(nodes, np.zeros(nodes.size, dtype=np.int64))
        solid = [blocks[k][idx] for k, idx in members if k in blocks]
        if solid:
            numbers = np.concatenate(solid)
            elem_sets[name] = Members(numbers, np.zeros(numbers.size, dtype=np.int64))
    n = len(m.points)
    return Parsed(source, node_ids=np.arange(1, n + 1), xyz=np.asarray(m.points, dtype=float)[:, :3],
                  node_lines=np.zeros(n, dtype=np.int64), elements=elements, node_sets=node_sets,
                  elem_sets=elem_sets)


def _meshio(source):
    """meshio's mesh of the file; InputError when it cannot be read."""
    import meshio                       # here: only Gmsh files need it

    common.readable(source)             # a missing or unreadable file: the same message as the others
    try:                                # not meshio.read: it ends the process on a ReadError
        return meshio.gmsh.read(source)
    except Exception as e:              # meshio's ReadError, and whatever a malformed file makes it raise
        why = f"{type(e).__name__}: {e}" if str(e) else type(e).__name__
        raise InputError(f"{source}: not a readable Gmsh file ({why})") from None


def _elements(m) -> tuple:
    """({kind: Elements}, {block index: its element numbers}) of the 3-D cells, numbered 1, 2, ... in
    the file's order and gathered by kind."""
    number, blocks = 0, {}
    gathered = {}
    for k, block in enumerate(m.cells):
        if block.type in KINDS:
            numbers = np.arange(number + 1, number + len(block.data) + 1)
            number += len(block.data)
            blocks[k] = numbers
            el = gathered.setdefault(KINDS[block.type], ([], []))
            el[0].append(numbers)
            el[1].append(np.asarray(block.data, dtype=np.int64) + 1)
    elements = {kind: Elements(np.concatenate(e[0]), np.concatenate(e[1]),
                               np.zeros(sum(map(len, e[0])), dtype=np.int64)) for kind, e in gathered.items()}
    return elements, blocks


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
