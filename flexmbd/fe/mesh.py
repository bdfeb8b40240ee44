"""A solid finite-element mesh as plain arrays, and the box mesher of the built-in cases.

    nodes      (N, 3)       node positions, m
    cells      {kind: (ne, nn) int}   element connectivity, 0-based rows of `nodes`; kinds and node
                            orders below (Abaqus' order, which is also VTK's and meshio's)
    node_sets  {name: (k,) int}        sorted, unique node indices
    elem_sets  {name: {kind: (k,) int}} rows of cells[kind]
    materials  {name: (E Pa, nu, rho kg/m^3)}  the file's materials, SI
    source     str          where the mesh came from (a file name, or "box"), for messages
    node_ids   (N,) int     the file's number of each node (messages, sets); box: 1..N
    elem_ids   {kind: (ne,) int}       the file's number of each element; box: 1..ne
    masses     (k, 5)       a frame's point masses (NASTRAN CONM2): [node row, m kg, Ixx, Iyy, Izz kg m^2]
                            (mesh axes, about the node); (0, 5) without
    bars       (ne, 9)      a frame's elements (kind "bar2", `fe.frame`): [A m^2, I1, I2, J m^4, shear
                            factors K1, K2 (0: none), orientation vector v (3,)] of each row of
                            cells["bar2"]; (0, 9) for a solid

Kinds and node orders (corner nodes first, then the mid-edge nodes of the quadratic elements):

    bar2   end nodes a, b (a frame's straight beam element, `fe.frame`)
    tet4   corners 0-3 (right-handed: (x1-x0) x (x2-x0) . (x3-x0) > 0)
    tet10  corners, then mid-edge nodes of edges 01 12 20 03 13 23
    hex8   bottom face 0-3 counter-clockwise seen from the top face, top face 4-7 above 0-3
    hex20  corners, then mid-edge nodes of 01 12 23 30, 45 56 67 74, 04 15 26 37
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

NODES_PER = {"tet4": 4, "tet10": 10, "hex8": 8, "hex20": 20, "bar2": 2}

# mid-edge node k of a quadratic element lies between corners EDGES[kind][k]
EDGES = {
    "tet10": ((0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)),
    "hex20": ((0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4),
              (0, 4), (1, 5), (2, 6), (3, 7)),
}


class Mesh(NamedTuple):
    nodes: np.ndarray
    cells: dict
    node_sets: dict
    elem_sets: dict
    materials: dict
    source: str
    node_ids: np.ndarray
    elem_ids: dict
    bars: np.ndarray = np.zeros((0, 9))
    masses: np.ndarray = np.zeros((0, 5))

    @property
    def n_nodes(self) -> int:
        return self.nodes.shape[0]

    @property
    def is_frame(self) -> bool:
        """True for a frame (bar elements, six DOFs a node: `fe.frame`), False for a solid."""
        return "bar2" in self.cells


def without_orphans(mesh: Mesh) -> Mesh:
    """The mesh less its nodes on no element (a NASTRAN file's RBE reference grids, a bar's G0
    orientation grid): with no stiffness and no mass of their own they would make a body's
    matrices singular. Node sets keep their other nodes (a set of orphans alone comes out empty);
    the mesh itself when every node is on an element."""
    used = np.unique(np.concatenate([c.ravel() for c in mesh.cells.values()]))
    if used.size == mesh.n_nodes:
        return mesh
    row = np.full(mesh.n_nodes, -1)
    row[used] = np.arange(used.size)
    masses = mesh.masses.copy()
    masses[:, 0] = row[masses[:, 0].astype(int)]       # on nodes of elements (`fe.meshfiles.convert` checks)
    return mesh._replace(nodes=mesh.nodes[used], cells={k: row[c] for k, c in mesh.cells.items()},
                         node_sets={k: row[v][row[v] >= 0] for k, v in mesh.node_sets.items()},
                         node_ids=mesh.node_ids[used], masses=masses)


def box(L: float, h: float, b: float, n: tuple, kind: str = "hex8") -> Mesh:
    """A structured mesh of the box [0, L] x [-h/2, h/2] x [-b/2, b/2] (m) with n = (nx, ny, nz)
    divisions, of `kind` elements (tetrahedra: six per hexahedral cell, Kuhn's split, conforming).

    Node sets: "x0" and "xL" (the end faces x = 0 and x = L), "all". No materials.
    """
    nx, ny, nz = n
    xs, ys, zs = np.linspace(0.0, L, nx + 1), np.linspace(-h / 2, h / 2, ny + 1), np.linspace(-b / 2, b / 2, nz + 1)
    X = np.stack(np.meshgrid(xs, ys, zs, indexing="ij"), axis=-1).reshape(-1, 3)
    idx = np.arange(X.shape[0]).reshape(nx + 1, ny + 1, nz + 1)
    i, j, k = (a.ravel() for a in np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij"))
    # the cell's corners, hex8 order: bottom z = z_k (counter-clockwise about +z), then top
    c = np.stack([idx[i, j, k], idx[i + 1, j, k], idx[i + 1, j + 1, k], idx[i, j + 1, k],
                  idx[i, j, k + 1], idx[i + 1, j, k + 1], idx[i + 1, j + 1, k + 1], idx[i, j + 1, k + 1]], axis=1)
    linear = "tet4" if kind.startswith("tet") else "hex8"
    cells = c if linear == "hex8" else right_handed(X, _kuhn(c))
    nodes = X
    if kind in EDGES:
        nodes, cells = with_midnodes(X, cells, EDGES[kind])
    on = lambda mask: np.flatnonzero(mask)
    sets = {"x0": on(np.isclose(nodes[:, 0], 0.0)), "xL": on(np.isclose(nodes[:, 0], L)),
            "all": np.arange(nodes.shape[0])}
    return Mesh(nodes=nodes, cells={kind: cells}, node_sets=sets, elem_sets={"all": {kind: np.arange(cells.shape[0])}},
                materials={}, source="box", node_ids=np.arange(1, nodes.shape[0] + 1),
                elem_ids={kind: np.arange(1, cells.shape[0] + 1)})


def _kuhn(c: np.ndarray) -> np.ndarray:
    """Six right-handed tetrahedra (6 ne, 4) per hexahedron (ne, 8), all sharing the diagonal 0-6:
    neighbouring cells split their common faces alike, so the mesh conforms."""
    paths = ((1, 2), (2, 3), (3, 7), (7, 4), (4, 5), (5, 1))     # around the diagonal, each a face pair
    return np.concatenate([np.stack([c[:, 0], c[:, a], c[:, b], c[:, 6]], axis=1) for a, b in paths], axis=0)


def right_handed(nodes: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Linear tetrahedra (ne, 4) with nodes 1 and 2 swapped where the signed volume is negative."""
    x = nodes[tets]
    neg = np.einsum("ni,ni->n", np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), x[:, 3] - x[:, 0]) < 0
    out = tets.copy()
    out[neg, 1], out[neg, 2] = tets[neg, 2], tets[neg, 1]
    return out


def with_midnodes(nodes: np.ndarray, cells: np.ndarray, edges) -> tuple:
    """Add a node at the midpoint of every element edge (shared between the elements that share
    the edge): (nodes (N + n_edges, 3), cells (ne, corners + len(edges)))."""
    pairs = np.stack([np.sort(cells[:, list(e)], axis=1) for e in edges], axis=1)    # (ne, n_e, 2)
    unique, inv = np.unique(pairs.reshape(-1, 2), axis=0, return_inverse=True)
    mid = 0.5 * (nodes[unique[:, 0]] + nodes[unique[:, 1]])
    extra = nodes.shape[0] + inv.reshape(cells.shape[0], len(edges))
    return np.vstack([nodes, mid]), np.hstack([cells, extra])
