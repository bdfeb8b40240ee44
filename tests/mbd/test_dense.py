"""The small dense solvers of the kernel (flexmbd/mbd/compiled/dense.py) against numpy: the
symmetric eigen-decomposition by Jacobi rotations and the least-squares, least-norm solve of a
symmetric system built on it (the closed loops' multipliers)."""

import numpy as np
import pytest

from flexmbd.mbd.compiled.dense import eig_sym, mm_add_into, sym_lstsq

pytestmark = pytest.mark.kernel_free


def spd(rng, n, rank=None):
    """A random symmetric positive semi-definite (n, n) of the given rank, eigenvalues 1e-3..1e3."""
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    w = np.zeros(n)
    r = n if rank is None else rank
    w[:r] = 10.0 ** rng.uniform(-3, 3, r)
    return Q @ np.diag(w) @ Q.T


@pytest.mark.parametrize("n", [1, 2, 5, 6])
def test_eig_sym_diagonalizes_a_symmetric_matrix(n):
    """V diag(w) V^T = A and V^T V = I to round-off of the largest entry (1e-13: a few hundred
    rotations, each exact to eps)."""
    rng = np.random.default_rng(n)
    A = spd(rng, n) - 2.0 * np.eye(n)                     # indefinite too
    w, V = eig_sym(A)
    assert np.allclose(V @ np.diag(w) @ V.T, A, rtol=0, atol=1e-13 * np.abs(A).max())
    assert np.allclose(V.T @ V, np.eye(n), rtol=0, atol=1e-13)
    assert np.allclose(np.sort(w), np.linalg.eigvalsh(A), rtol=0, atol=1e-13 * np.abs(A).max())


@pytest.mark.parametrize("rank", [5, 3])
def test_sym_lstsq_is_numpys_lstsq_on_a_symmetric_system(rank):
    """Full rank and rank-deficient (an exact null space, as a planar loop's out-of-plane rows
    give): the least-norm solution numpy's lstsq gives with the same rcond, to 1e-9 of its size
    (the condition number, 1e6 over the kept eigenvalues, times round-off)."""
    rng = np.random.default_rng(10 + rank)
    A = spd(rng, 5, rank)
    b = A @ rng.normal(size=5)                            # consistent: in the range of A
    ref = np.linalg.lstsq(A, b, rcond=1e-9)[0]
    got = sym_lstsq(A, b, 1e-9)
    assert np.allclose(got, ref, rtol=0, atol=1e-9 * np.abs(ref).max())


def test_sym_lstsq_takes_the_symmetric_part_and_refuses_what_is_not_finite():
    rng = np.random.default_rng(3)
    A = spd(rng, 4)
    E = 1e-14 * rng.normal(size=(4, 4))                   # round-off off symmetry, as G M^-1 G^T has
    b = rng.normal(size=4)
    x = sym_lstsq(A + 0.5 * (E + E.T), b, 1e-9)
    assert np.allclose(sym_lstsq(A + E, b, 1e-9), x, rtol=0, atol=1e-10 * np.abs(x).max())   # round-off x 1e6
    A[1, 2] = np.nan
    assert np.all(np.isnan(sym_lstsq(A, b, 1e-9)))


def test_mm_add_into_adds_the_product():
    rng = np.random.default_rng(4)
    A, B, C = rng.normal(size=(3, 4)), rng.normal(size=(4, 7)), rng.normal(size=(3, 7))
    out = C.copy()
    mm_add_into(A, B, out)
    assert np.allclose(out, C + A @ B, rtol=0, atol=1e-14)
