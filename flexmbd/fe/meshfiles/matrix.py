"""Abaqus matrix files (*MATRIX GENERATE, *MATRIX OUTPUT): a solid's stiffness or mass over the
nodes of its mesh, in either layout Abaqus writes (`read_mtx`)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from flexmbd.core.errors import InputError
from flexmbd.fe.meshfiles import common
from flexmbd.fe.meshfiles.common import is_real, lookup


def read_mtx(path, node_ids, units: str = "m") -> sp.csr_matrix:
    """A symmetric (3N, 3N) matrix from an Abaqus matrix file (*MATRIX GENERATE, *MATRIX OUTPUT),
    DOF 3 row + (dof - 1) for the translations dof = 1..3 of the node in row `row` of `node_ids`
    (N,) (the mesh's file node numbers). Either layout Abaqus writes:

        FORMAT=MATRIX INPUT (the default)  "row node, row dof, column node, column dof, value"
        FORMAT=COORDINATE                  "row column value", 1-based equation numbers

    The equation numbers of the coordinate layout are taken to run node by node in the order of
    `node_ids`, three per node (what Exudyn's FEM reader assumes too): true when every node carries
    the three translations only. One triangle is mirrored; a full matrix must be symmetric.
    `units` as in `fe.meshfile.read`: "mm" (N/mm, t, N s/mm) scales by 1e3 to SI (N/m, kg, N s/m).
    """
    source = str(path)
    common.check_units(source, units)
    node_ids = np.asarray(node_ids, dtype=np.int64)
    n = 3 * node_ids.size
    lines, table = _entries(source)
    if table.shape[1] == 5:
        rows, cols = (_dofs(source, lines, table[:, k], table[:, k + 1], node_ids) for k in (0, 2))
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


def _entries(source) -> tuple:
    """(lines (k,), numbers (k, 3 or 5)) of the file's data lines, all of one width."""
    lines, numbers = [], []
    for no, line in enumerate(common.text(source).splitlines(), 1):
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
        no = next(no for no, row in zip(lines, numbers) if not all(is_real(t) for t in row))
        raise InputError(f"{source}:{no}: not a number in a matrix entry") from None
    return np.asarray(lines), table


def _dofs(source, lines, node, dof, node_ids) -> np.ndarray:
    """DOF indices 3 row + dof - 1 of the (node number, dof) columns of a matrix-input file."""
    node, dof = node.astype(np.int64), dof.astype(np.int64)
    rows = lookup(node_ids)(node)
    bad = np.flatnonzero(rows < 0)
    if bad.size:
        raise InputError(f"{source}:{lines[bad[0]]}: node {node[bad[0]]} is not a node of the mesh "
                         "(negative numbers are Abaqus' internal nodes, e.g. of constraints)")
    bad = np.flatnonzero((dof < 1) | (dof > 3))
    if bad.size:
        raise InputError(f"{source}:{lines[bad[0]]}: dof {dof[bad[0]]}: a solid's nodes have dofs 1 to 3 only")
    return 3 * rows + dof - 1
