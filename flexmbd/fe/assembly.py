"""Mesh of a straight beam and sparse assembly of its global matrices.

Global DOF numbering: node ``p`` (0..N-1) owns DOFs ``6 p + k`` with
``k = 0..5 = [ux, uy, uz, rx, ry, rz]`` (m and rad).
"""

import numpy as np
import scipy.sparse as sp

from flexmbd.fe import element

__all__ = ["beam_mesh", "element_lengths", "element_dofs", "assemble", "beam_matrices"]


def beam_mesh(length, n_el):
    """Equally spaced nodes of a straight beam along local x, from x = 0 to x = length.

    Parameters
    ----------
    length : float
        Beam length L, m.
    n_el : int
        Number of elements (>= 1).

    Returns
    -------
    nodes : (N, 3) float ndarray
        Node positions, m, N = n_el + 1 (y = z = 0).
    elements : (n_el, 2) int ndarray
        Node indices of each element, first node nearer x = 0.
    """
    if int(n_el) != n_el or n_el < 1:
        raise ValueError(f"n_el must be a positive integer, got {n_el!r}")
    if not (np.isfinite(length) and length > 0):
        raise ValueError(f"length must be positive, got {length!r}")
    n_el = int(n_el)
    nodes = np.zeros((n_el + 1, 3))
    nodes[:, 0] = np.linspace(0.0, length, n_el + 1)
    elements = np.column_stack([np.arange(n_el), np.arange(1, n_el + 1)])
    return nodes, elements


def element_lengths(nodes, elements):
    """Element lengths (n_el,), m; raise ValueError unless every element runs along +x.

    The element matrices are written in the beam frame without a rotation, so
    elements must be aligned with local +x (second node at larger x).
    """
    d = nodes[elements[:, 1]] - nodes[elements[:, 0]]
    l = d[:, 0]
    if np.any(l <= 0) or np.any(np.abs(d[:, 1:]) > 1e-12 * l[:, None]):
        raise ValueError("every element must run along +x (straight beam in its body frame)")
    return l


def element_dofs(elements):
    """Global DOF indices of each element (n_el, 12), in the local element order."""
    return (6 * elements[:, :, None] + np.arange(6)).reshape(-1, 12)


def assemble(nodes, elements, element_matrix):
    """Assemble a global matrix from element matrices.

    Parameters
    ----------
    nodes : (N, 3) ndarray
        Node positions, m.
    elements : (n_el, 2) int ndarray
        Element connectivity.
    element_matrix : callable
        ``element_matrix(l) -> (12, 12)`` for an element of length l (m).

    Returns
    -------
    scipy.sparse.csr_matrix, shape (6N, 6N)
        Duplicate entries summed.
    """
    # element matrices and their global DOFs
    lengths = element_lengths(nodes, elements)
    blocks = np.array([element_matrix(l) for l in lengths])
    dofs = element_dofs(elements)

    # scatter in coordinate format, duplicates summed on conversion
    rows = np.repeat(dofs, 12, axis=1).ravel()
    cols = np.tile(dofs, (1, 12)).ravel()
    n = 6 * nodes.shape[0]
    return sp.coo_matrix((blocks.ravel(), (rows, cols)), shape=(n, n)).tocsr()


def beam_matrices(nodes, elements, E, G, rho, sec, mass="lumped", shear=False):
    """Global stiffness and mass matrices of a beam.

    Parameters
    ----------
    nodes, elements : ndarray
        Mesh from :func:`beam_mesh`.
    E, G : float
        Young's and shear moduli, Pa.
    rho : float
        Density, kg/m^3.
    sec : Section
    mass : {"lumped", "consistent"}
        Element mass (see :mod:`flexmbd.fe.element`).
    shear : bool
        Timoshenko (True) or Euler-Bernoulli (False) stiffness.

    Returns
    -------
    K, M : scipy.sparse.csr_matrix, shape (6N, 6N)
    """
    mass_fns = {"lumped": element.mass_lumped, "consistent": element.mass_consistent}
    if mass not in mass_fns:
        raise ValueError(f"mass must be 'lumped' or 'consistent', got {mass!r}")
    K = assemble(nodes, elements, lambda l: element.stiffness(E, G, sec, l, shear=shear))
    M = assemble(nodes, elements, lambda l: mass_fns[mass](rho, sec, l))
    return K, M
