"""Small dense linear algebra as plain compiled loops (part of the kernel: it exists for numba).

The recursion works on matrices of size 6 to 6+nm (nm ~ 12). For these numba's `@` and
`np.linalg` go through BLAS/LAPACK, whose call overhead and result allocation cost more than the
arithmetic; these loops do not. Each returns a new array; the `_into` forms write into `out`.
"""

from __future__ import annotations

import numpy as np

from flexmbd.mbd.compiled.jit import njit


@njit(inline="always")
def mm_into(A, B, out):
    """out = A B: (m, k) (k, n) -> out (m, n); out must not overlap A or B."""
    m, k = A.shape
    n = B.shape[1]
    for i in range(m):
        for j in range(n):
            s = 0.0
            for l in range(k):
                s += A[i, l] * B[l, j]
            out[i, j] = s


@njit(inline="always")
def mm_add_into(A, B, out):
    """out += A B: (m, k) (k, n) -> out (m, n); out must not overlap A or B."""
    m, k = A.shape
    n = B.shape[1]
    for i in range(m):
        for j in range(n):
            s = 0.0
            for l in range(k):
                s += A[i, l] * B[l, j]
            out[i, j] += s


@njit(inline="always")
def mv_into(A, x, out):
    """out = A x: (m, k) (k,) -> out (m,)."""
    m, k = A.shape
    for i in range(m):
        s = 0.0
        for l in range(k):
            s += A[i, l] * x[l]
        out[i] = s


@njit(inline="always")
def mv_add_into(A, x, out):
    """out += A x."""
    m, k = A.shape
    for i in range(m):
        s = 0.0
        for l in range(k):
            s += A[i, l] * x[l]
        out[i] += s


@njit
def mm(A, B):
    """A B: (m, k) (k, n) -> (m, n)."""
    C = np.empty((A.shape[0], B.shape[1]))
    mm_into(A, B, C)
    return C


@njit
def mtm(A, B):
    """A^T B: (k, m) (k, n) -> (m, n)."""
    return mm(A.T, B)


@njit
def mv(A, x):
    """A x: (m, k) (k,) -> (m,)."""
    y = np.empty(A.shape[0])
    mv_into(A, x, y)
    return y


@njit
def mtv(A, x):
    """A^T x: (k, m) (k,) -> (m,)."""
    return mv(A.T, x)


@njit(inline="always")
def mtv_add_into(A, x, out):
    """out += A^T x: (k, m) (k,) -> out (m,)."""
    mv_add_into(A.T, x, out)


@njit(inline="always")
def congruence_add_into(G, I, out, IG):
    """out += G^T I G for I (6, 6) symmetric and G (6, n): the projection of an articulated
    inertia onto the parent's coordinates. IG (6, n): workspace."""
    n = G.shape[1]
    mm_into(I, G, IG)
    for i in range(n):
        for j in range(i, n):
            s = 0.0
            for l in range(6):
                s += G[l, i] * IG[l, j]
            out[i, j] += s
            if j != i:
                out[j, i] += s


@njit
def cholesky(A):
    """Lower-triangular L (n, n) with L L^T = A, A symmetric positive definite (otherwise L
    holds nan or inf, which the integrators report as a non-finite state)."""
    n = A.shape[0]
    L = np.zeros((n, n))
    for j in range(n):
        s = A[j, j]
        for k in range(j):
            s -= L[j, k] * L[j, k]
        d = np.sqrt(s)
        L[j, j] = d
        for i in range(j + 1, n):
            s = A[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            L[i, j] = s / d
    return L


@njit
def forward_subst(L, B):
    """L^-1 B (n, k) for lower-triangular L (n, n) and B (n, k)."""
    n, k = B.shape
    Y = np.empty((n, k))
    for j in range(k):
        for r in range(n):
            s = B[r, j]
            for c in range(r):
                s -= L[r, c] * Y[c, j]
            Y[r, j] = s / L[r, r]
    return Y


@njit
def back_subst_vec(L, y):
    """L^-T y (n,) for lower-triangular L (n, n)."""
    n = y.size
    x = np.empty(n)
    for r in range(n - 1, -1, -1):
        s = y[r]
        for c in range(r + 1, n):
            s -= L[c, r] * x[c]
        x[r] = s / L[r, r]
    return x


@njit
def chol_solve(L, B):
    """Solve (L L^T) X = B for X (n, k), L lower triangular (n, n): L^-T (L^-1 B) column by column."""
    Y = forward_subst(L, B)
    for j in range(Y.shape[1]):
        Y[:, j] = back_subst_vec(L, Y[:, j])
    return Y


@njit
def inv_spd(A):
    """A^-1 (n, n) of a symmetric positive definite A, through its Cholesky factor."""
    return chol_solve(cholesky(A), np.eye(A.shape[0]))


@njit
def eig_sym(A):
    """Eigenvalues w (n,) and eigenvectors V (n, n) (columns, orthonormal) of a symmetric A (n, n)
    by cyclic Jacobi rotations, until the off-diagonal part is below round-off of the whole."""
    n = A.shape[0]
    a, V = A.copy(), np.eye(n)
    for _ in range(50):
        off, total = 0.0, 0.0
        for i in range(n):
            for j in range(n):
                total += a[i, j] * a[i, j]
                if i != j:
                    off += a[i, j] * a[i, j]
        if off <= 1e-32 * total:
            break
        for p in range(n - 1):
            for q in range(p + 1, n):
                if a[p, q] == 0.0:
                    continue
                theta = (a[q, q] - a[p, p]) / (2.0 * a[p, q])
                t = (1.0 if theta >= 0.0 else -1.0) / (abs(theta) + np.sqrt(theta * theta + 1.0))
                c = 1.0 / np.sqrt(t * t + 1.0)
                s = t * c
                for k in range(n):                     # a <- a J, then J^T a; V <- V J
                    akp, akq = a[k, p], a[k, q]
                    a[k, p], a[k, q] = c * akp - s * akq, s * akp + c * akq
                for k in range(n):
                    apk, aqk = a[p, k], a[q, k]
                    a[p, k], a[q, k] = c * apk - s * aqk, s * apk + c * aqk
                for k in range(n):
                    vkp, vkq = V[k, p], V[k, q]
                    V[k, p], V[k, q] = c * vkp - s * vkq, s * vkp + c * vkq
    w = np.empty(n)
    for i in range(n):
        w[i] = a[i, i]
    return w, V


@njit
def sym_lstsq(A, b, rcond):
    """The least-squares, least-norm x (n,) of A x = b for a symmetric A (n, n) (its symmetric
    part taken), eigenvalues of magnitude below rcond times the largest dropped: numpy's lstsq
    with that rcond, whose singular values these magnitudes are. nan where A or b is not finite."""
    n = b.size
    x = np.zeros(n)
    if not (np.all(np.isfinite(A)) and np.all(np.isfinite(b))):
        x[:] = np.nan
        return x
    w, V = eig_sym(0.5 * (A + A.T))
    cut = rcond * np.abs(w).max()
    for i in range(n):
        if abs(w[i]) > cut:
            c = 0.0
            for k in range(n):
                c += V[k, i] * b[k]
            c /= w[i]
            for k in range(n):
                x[k] += c * V[k, i]
    return x
