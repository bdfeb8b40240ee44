"""Exponential Adams predictor-corrector (PECE, order 3) on a refreshed linearization, fixed
step, compiled (`exp_adams`), driven and re-linearized from Python (`_exp_adams`)."""

from __future__ import annotations

import numpy as np

from flexmbd.mbd.compiled.bound import bind
from flexmbd.mbd.compiled.entry import handle, rhs
from flexmbd.mbd.compiled.jit import njit
from flexmbd.mbd.integrate.base import NONFINITE, OK, WHY, _in_chunks, failed, state_code
from flexmbd.mbd.model import make_data


# ---------------------------------------------------------------------------------------------
# Exponential Adams (predictor-corrector) on a refreshed linearization, fixed step, compiled

EXP_ORDER = 3       # nodes of the predictor's and the corrector's polynomials (order 3 each)
EXP_REFRESH = 25    # steps between two linearizations (`exp_linearize`) unless the case sets integrator.refresh
EXP_FULL = 8        # every EXP_FULL-th of them in full (Jacobian, eigenbasis), between only the fast eigenvalues,
EXP_TURN = 0.02     # unless a fast eigenvector has turned by more than this (|J v - lam v| / |lam v|)
NOT_DIAGONAL, STALE = 5, 6      # status codes: the linearization has no eigenbasis; it is due again


@njit
def jacobian_columns(ev, nq, t, y, m):
    """The first m columns of df/dy (n, m) of the right-hand side at (t, y) by forward
    differences (m + 1 evaluations)."""
    f0 = rhs(ev, t, y, nq)
    J = np.empty((y.size, m))
    for k in range(m):
        yp = y.copy()
        d = 1e-7 * max(abs(y[k]), 1.0)
        yp[k] += d
        J[:, k] = (rhs(ev, t, yp, nq) - f0) / d
    return J


@njit
def jacobian(ev, nq, t, y):
    """df/dy (n, n) of the right-hand side at (t, y) (n + 1 evaluations)."""
    return jacobian_columns(ev, nq, t, y, y.size)


@njit
def position_jacobian(ev, nq, t, y):
    """A = d(qdd)/dq (nq, nq) at (t, y) (nq + 1 evaluations): the lower-left block of the
    Jacobian of y = [q; v] when dq/dt = v."""
    return np.ascontiguousarray(jacobian_columns(ev, nq, t, y, nq)[nq:])


@njit
def phi_functions(z, kmax):
    """phi_0..phi_kmax (kmax+1, n) of the complex numbers z (n,): phi_0 = exp, phi_j(z) =
    (phi_{j-1}(z) - 1/(j-1)!) / z, phi_j(0) = 1/j!; the Taylor series where |z| < 1/2."""
    out = np.empty((kmax + 1, z.size), dtype=np.complex128)
    for i in range(z.size):
        x = z[i]
        if abs(x) < 0.5:
            for j in range(kmax + 1):
                term = 1.0 + 0.0j
                for m in range(1, j + 1):
                    term /= m
                s = 0.0 + 0.0j
                for m in range(25):
                    s += term
                    term = term * x / (j + m + 1)
                out[j, i] = s
        else:
            out[0, i] = np.exp(x)
            fact = 1.0
            for j in range(1, kmax + 1):
                out[j, i] = (out[j - 1, i] - 1.0 / fact) / x
                fact *= j
    return out


@njit
def exp_weights(lam, h, nodes, frac):
    """The exponential Adams formula from a step's start to frac h (0 < frac <= 1), in the
    eigenbasis of the linear part (eigenvalues lam (n,)): w(frac h) = E w + Σ_j W[j] Nw_j, where
    Nw_j (n,) is the remainder f - L y at the node nodes[j] h (in eigen-coordinates) and the
    remainder between nodes is their interpolating polynomial. Returns E (n,), W (k, n), complex:
    W[j] = frac h Σ_m m! phi_{m+1}(frac h lam) a[m, j], a the monomial coefficients (in units of
    frac h) of the Lagrange basis polynomial of node j."""
    k = nodes.size
    V = np.empty((k, k))
    for i in range(k):
        for m in range(k):
            V[i, m] = (nodes[i] / frac) ** m
    A = np.linalg.inv(V)                    # A[m, j]: coefficient of s^m in node j's basis polynomial
    P = phi_functions(frac * h * lam, k)
    W = np.zeros((k, lam.size), dtype=np.complex128)
    for j in range(k):
        fact = 1.0
        for m in range(k):
            W[j] += fact * A[m, j] * P[m + 1]
            fact *= m + 1
        W[j] *= frac * h
    return P[0].copy(), W


def eigenbasis(J):
    """J = V diag(lam) V^-1: (lam (n,), V, Vi (n, n)), complex, or None when J has no eigenbasis
    that reproduces it (`reproduces`) or is not finite."""
    try:
        lam, V = np.linalg.eig(J)
        Vi = np.linalg.inv(V)
    except np.linalg.LinAlgError:
        return None
    x = np.linspace(1.0, 2.0, J.shape[0])
    return reproduces(J @ x, np.abs(J).max(), x, lam.astype(np.complex128), V.astype(np.complex128),
                      Vi.astype(np.complex128))


def second_order_basis(A):
    """The eigenbasis of L = [[0, I], [A, 0]] (2m, 2m) from that of A = X diag(mu) X^-1 (m, m):
    L [x; s x] = s [x; s x] for s^2 = mu, so lam = [s; -s] (s = sqrt(mu)), V = [[X, X], [X S, -X S]]
    and Vi = 1/2 [[X^-1, S^-1 X^-1], [X^-1, -S^-1 X^-1]] (S = diag(s)): an m x m eigenproblem
    for the 2m x 2m one. None as `eigenbasis` (mu = 0, a coordinate with no restoring force,
    makes L's block [[0, 1], [0, 0]] defective)."""
    m = A.shape[0]
    try:
        mu, X = np.linalg.eig(A)
        Xi = np.linalg.inv(X)
    except np.linalg.LinAlgError:
        return None
    sq = np.sqrt(mu.astype(np.complex128))
    if not np.all(sq != 0.0):
        return None
    X, Xi = X.astype(np.complex128), Xi.astype(np.complex128)
    XS, SXi = X * sq, Xi / sq[:, None]
    V = np.empty((2 * m, 2 * m), dtype=np.complex128)
    V[:m, :m] = V[:m, m:] = X
    V[m:, :m], V[m:, m:] = XS, -XS
    Vi = np.empty_like(V)
    Vi[:m, :m] = Vi[m:, :m] = 0.5 * Xi
    Vi[:m, m:], Vi[m:, m:] = 0.5 * SXi, -0.5 * SXi
    x = np.linspace(1.0, 2.0, 2 * m)
    return reproduces(np.concatenate([x[m:], A @ x[:m]]), max(np.abs(A).max(), 1.0), x,
                      np.concatenate([sq, -sq]), V, Vi)


def reproduces(Jx, size, x, lam, V, Vi):
    """(lam, V, Vi) if they are finite and V diag(lam) Vi x is Jx, J's product with the test
    vector x, to 1e-6 of |J| |x| (size: |J|, the largest magnitude of its entries), else None (a
    defective or nearly defective J has no eigenbasis that does)."""
    if not np.all(np.isfinite(Vi)) or \
            np.linalg.norm(V @ (lam * (Vi @ x)) - Jx) > 1e-6 * size * np.linalg.norm(x):
        return None
    return lam, V, Vi


@njit
def cmv_real(V, w, out, half=0):
    """out (n,) = Re(V w), V (n, n) and w (n,) complex. half = m > 0: V is `second_order_basis`'
    [[X, X], [X S, -X S]] (n = 2m), taken through its blocks: Re([X (w1 + w2); X S (w1 - w2)]),
    half the products."""
    n = w.size
    if half:
        c, d = w[:half] + w[half:], w[:half] - w[half:]
        for i in range(half):
            s, sd = 0.0, 0.0
            for k in range(half):
                s += V[i, k].real * c[k].real - V[i, k].imag * c[k].imag
                sd += V[half + i, k].real * d[k].real - V[half + i, k].imag * d[k].imag
            out[i], out[half + i] = s, sd
        return
    for i in range(n):
        s = 0.0
        for m in range(n):
            s += V[i, m].real * w[m].real - V[i, m].imag * w[m].imag
        out[i] = s


@njit
def cmv(Vi, x, half=0):
    """Vi x (n,) complex for x (n,) real. half = m > 0: Vi is `second_order_basis`'
    1/2 [[X^-1, S^-1 X^-1], [X^-1, -S^-1 X^-1]] (n = 2m), taken through its blocks: with
    a = Vi[:m, :m] x1 and b = Vi[:m, m:] x2, [a + b; a - b], half the products."""
    n = x.size
    out = np.empty(n, dtype=np.complex128)
    if half:
        for i in range(half):
            a, b = 0.0 + 0.0j, 0.0 + 0.0j
            for k in range(half):
                a += Vi[i, k] * x[k]
                b += Vi[i, half + k] * x[half + k]
            out[i], out[half + i] = a + b, a - b
        return out
    for i in range(n):
        s = 0.0 + 0.0j
        for m in range(n):
            s += Vi[i, m] * x[m]
        out[i] = s
    return out


@njit
def inside(Ed, Wd, wz, Nw, V, Y, k, m, half):
    """The output instants inside one step, Y[k + j] for 0 < j < m, from the corrector's formula at
    the fractions j/m (`exp_weights`): Ed (m - 1, n), Wd (m - 1, K, n) its weights, wz the last
    state's coordinates in the eigenbasis, Nw (kc, n) the remainders at the corrector's nodes."""
    for j in range(1, m):
        wd = Ed[j - 1] * wz
        for i in range(Nw.shape[0]):
            wd += Wd[j - 1, i] * Nw[i]
        cmv_real(V, wd, Y[k + j], half)


@njit
def remember(Yh, Fh, Wz, G, y1, f1, Vi, half):
    """The history one step on, newest first: y1 and its right-hand side f1, and their coordinates
    in the eigenbasis (Vi = V^-1) in Wz and G."""
    for j in range(Yh.shape[0] - 1, 0, -1):
        Yh[j], Fh[j], Wz[j], G[j] = Yh[j - 1], Fh[j - 1], Wz[j - 1], G[j - 1]
    Yh[0], Fh[0], Wz[0], G[0] = y1, f1, cmv(Vi, y1, half), cmv(Vi, f1, half)    # the real state's coordinates


@njit
def exp_adams(ev, nq, Yh, Fh, basis, Wz, G, t_out, Y, h, m, p, st, clock, counts):
    """Exponential Adams, predictor-corrector (PECE), fixed step h, from t_out[0] through the
    instants t_out, writing Y[1:]. f(y) = L y + N(y) with L a finite-difference linearization
    (`exp_linearize`) taken every st[3] steps; L is integrated exactly through its eigenbasis and N by the
    polynomial through its last values (EXP_ORDER nodes: the predictor at 0, -h, -2h, the
    corrector at h, 0, -h), so each step costs two evaluations whatever the frequencies of L.

    Steps of h = m output intervals (m >= 1, the instants between from the corrector's formula at
    fractions j/m) or 1/p of one (p >= 1). Yh, Fh (EXP_ORDER, n): the last states and their
    right-hand sides, newest first; basis (2n+1, n) complex: [lam; V; Vi] of the last
    linearization, Wz and G (EXP_ORDER, n) complex: V^-1 Yh and V^-1 Fh; st (int64): [steps
    taken, history length, the step of the last linearization (-1: none), steps between two
    linearizations]; clock (1,): the time
    of Yh[0] (between two instants when p > 1). Returns (k, status,
    t) as `dopri5`, status STALE when the linearization is due (`exp_linearize`, then call
    again from instant k); counts (3,) += steps, evaluations."""
    K = EXP_ORDER
    n = Yh.shape[1]
    half = nq if 2 * nq == n else 0                     # the second-order basis: its products by blocks
    t = clock[0]
    y1 = np.empty(n)
    lam, V, Vi = basis[0], basis[1:n + 1], basis[n + 1:]
    Ep = Ec = np.zeros(n, dtype=np.complex128)
    Wp = Wc = np.zeros((K, n), dtype=np.complex128)
    Ed = np.zeros((max(m - 1, 1), n), dtype=np.complex128)
    Wd = np.zeros((max(m - 1, 1), K, n), dtype=np.complex128)
    order = -1
    k = 0
    while k < t_out.size - 1:
        if st[2] < 0 or st[0] - st[2] >= st[3]:
            clock[0] = t
            return k, STALE, t
        kp = min(st[1], K)                              # the order ramps up over the first steps
        if kp != order:
            order = kp
            Ep, Wp = exp_weights(lam, h, -np.arange(kp).astype(np.float64), 1.0)
            cn = 1.0 - np.arange(min(kp + 1, K)).astype(np.float64)
            Ec, Wc = exp_weights(lam, h, cn, 1.0)
            for j in range(1, m):
                Ej, Wj = exp_weights(lam, h, cn, j / m)
                Ed[j - 1], Wd[j - 1, :cn.size] = Ej, Wj
        kc = min(kp + 1, K)
        Nw = np.empty((kc, n), dtype=np.complex128)     # remainders at the corrector's nodes
        for j in range(kc - 1):
            Nw[j + 1] = G[j] - lam * Wz[j]
        wp = Ep * Wz[0]
        for j in range(kp):
            wp += Wp[j] * (G[j] - lam * Wz[j])
        cmv_real(V, wp, y1, half)
        gp = cmv(Vi, rhs(ev, t + h, y1, nq), half)
        Nw[0] = gp - lam * wp
        w1 = Ec * Wz[0]
        for j in range(kc):
            w1 += Wc[j] * Nw[j]
        inside(Ed, Wd, Wz[0], Nw, V, Y, k, min(m, t_out.size - k), half)
        cmv_real(V, w1, y1, half)
        f1 = rhs(ev, t + h, y1, nq)
        counts[2] += 2
        remember(Yh, Fh, Wz, G, y1, f1, Vi, half)
        st[0] += 1
        st[1] = min(st[1] + 1, K)
        counts[0] += 1
        t = t + h
        code = state_code(y1, nq)
        if code == OK and not np.all(np.isfinite(f1)):
            code = NONFINITE
        clock[0] = t
        if code != OK:
            return k, code, t
        if st[0] % p == 0:
            if k + m <= t_out.size - 1:
                k += m
                Y[k] = y1
            else:                                       # the last step overran the last instant
                k = t_out.size - 1
            t = clock[0] = t_out[k]
    return t_out.size - 1, OK, t


@njit
def directional(ev, nq, t, y, f0, U):
    """J U (n, r) by forward differences of the right-hand side along the columns of U (n, r)
    at (t, y), f0 = rhs(t, y): r evaluations."""
    out = np.empty(U.shape)
    for c in range(U.shape[1]):
        d = 1e-7 * max(np.abs(y).max(), 1.0) / max(np.abs(U[:, c]).max(), 1e-300)
        out[:, c] = (rhs(ev, t, y + d * U[:, c], nq) - f0) / d
    return out


def exp_linearize(ev, nq, t, h, Yh, Fh, basis, Wz, G, st, counts, made) -> bool:
    """A new linear part L for `exp_adams` at (t, Yh[0]) (its eigenbasis into basis, the history
    into it: Wz, G).

    Where every coordinate's rate is its velocity (dq/dt = v: no quaternion, so 2 nq = n), L =
    [[0, I], [A, 0]] with A = d(qdd)/dq (`position_jacobian`, nq + 1 evaluations) and its eigenbasis
    from A's (`second_order_basis`), each time: the velocity coupling d(qdd)/dv (gyroscopic and
    Coriolis terms, proportional to the slow motion's rates) is left to the remainder N, which
    follows it as it follows any slow term. A with a zero eigenvalue gets the stiffness below.

    Otherwise every EXP_FULL-th time (and the first) the finite-difference Jacobian J and
    its eigenbasis; between, only the fast eigenvalues move (|lam h| > 1, where the remainder
    polynomial cannot follow a change of L): lam_i = w_i J v_i from two evaluations along the
    real and imaginary parts of each such eigenvector v_i (w_i its row of V^-1), the eigenvectors
    kept, unless one of them has turned (|J v_i - lam_i v_i| > EXP_TURN |lam_i v_i|): then in full.
    A J with no eigenbasis (`eigenbasis`: a defective one, as [[0, 1], [0, 0]] of a coordinate
    with no restoring force) gets a stiffness (0.01 / h)^2 on every coordinate (q and v aligned),
    which the remainder N = f - L y takes back; False when that has none either. made (1,):
    linearizations so far.
    counts (3,) += -, linearizations, evaluations."""
    n = Yh.shape[1]
    lam, V, Vi = basis[0], basis[1:n + 1], basis[n + 1:]
    if 2 * nq == n:
        A = position_jacobian(ev, nq, t, Yh[0])
        counts[2] += nq + 1
        e = second_order_basis(A)
        if e is None:                                   # the stiffness (0.01 / h)^2, as below
            e = second_order_basis(A - (0.01 / h) ** 2 * np.eye(nq))
        if e is None:
            return False
        lam[:], V[:], Vi[:] = e
        return _relinearized(Yh, Fh, Vi, Wz, G, st, counts, made)
    full = made[0] % EXP_FULL == 0
    if not full:
        fast = np.flatnonzero((np.abs(lam * h) > 1.0) & (lam.imag > 0.0))     # one of each conjugate pair
        if fast.size:
            JU = directional(ev, nq, t, Yh[0], Fh[0], np.ascontiguousarray(
                np.concatenate([V[:, fast].real, V[:, fast].imag], axis=1)))
            counts[2] += 2 * fast.size
            Jv = JU[:, :fast.size] + 1j * JU[:, fast.size:]
            new = np.einsum("ij,ji->i", Vi[fast], Jv)
            turned = np.linalg.norm(Jv - V[:, fast] * new, axis=0) / (np.abs(new) * np.linalg.norm(V[:, fast], axis=0))
            full = turned.max() > EXP_TURN     # the eigenvectors have turned: linearize in full
            if not full:
                old = lam[fast]
                lam[fast] = new
                for i, o in zip(fast, old):             # its conjugate partner
                    lam[np.argmin(np.abs(lam - np.conj(o)))] = np.conj(lam[i])
    if full:
        J = jacobian(ev, nq, t, Yh[0])
        counts[2] += n + 1
        e = eigenbasis(J)
        if e is None and 2 * nq == n:                  # a coordinate with no restoring force: give
            J[nq:, :nq] -= (0.01 / h) ** 2 * np.eye(nq)  # L one at w h = 0.01 (N takes it back)
            e = eigenbasis(J)
        if e is None:
            return False
        lam[:], V[:], Vi[:] = e
    return _relinearized(Yh, Fh, Vi, Wz, G, st, counts, made)


def _relinearized(Yh, Fh, Vi, Wz, G, st, counts, made) -> bool:
    """The history in the new eigen-coordinates (Wz, G) and the linearization counted: True."""
    Wz[:st[1]] = Yh[:st[1]] @ Vi.T
    G[:st[1]] = Fh[:st[1]] @ Vi.T
    made[0] += 1
    counts[1] += 1
    st[2] = st[0]
    return True


def _exp_adams(model, y0, t_out, Y, dt, output_dt, bar, chunk=50, judged=None, refresh=EXP_REFRESH):
    """Drive the compiled `exp_adams` over chunks of whole steps, linearizing between its calls
    every `refresh` steps: steps of m output intervals (m = round(dt / output_dt) when
    dt >= output_dt) or of 1/p of one (p = ceil(output_dt / dt))."""
    b, nq = bind(model, make_data(model)), model.nq
    ev = handle(b)
    f0 = rhs(ev, 0.0, y0, nq)
    if not (np.all(np.isfinite(y0)) and np.all(np.isfinite(f0))):
        return 0, 0, 1, failed("non-finite state", 0.0)
    m, p = (max(int(round(dt / output_dt)), 1), 1) if dt >= output_dt else (1, int(np.ceil(output_dt / dt - 1e-9)))
    h, n = output_dt * m / p, y0.size
    Yh, Fh = np.zeros((EXP_ORDER, n)), np.zeros((EXP_ORDER, n))
    Yh[0], Fh[0] = y0, f0
    basis = np.zeros((2 * n + 1, n), dtype=np.complex128)
    Wz, G = np.zeros((EXP_ORDER, n), dtype=np.complex128), np.zeros((EXP_ORDER, n), dtype=np.complex128)
    st = np.array([0, 1, -1, refresh], dtype=np.int64)
    clock, counts, made = np.zeros(1), np.zeros(3, dtype=np.int64), np.zeros(1, dtype=np.int64)
    counts[2] += 1

    def advance(k, k1):
        j = 0
        while True:
            i, code, t = exp_adams(ev, nq, Yh, Fh, basis, Wz, G, t_out[k + j:k1 + 1], Y[k + j:k1 + 1], h, m, p,
                                   st, clock, counts)
            j += i
            if code != STALE:
                return j, code, t
            if not exp_linearize(ev, nq, t, h, Yh, Fh, basis, Wz, G, st, counts, made):
                return j, NOT_DIAGONAL, t

    return _in_chunks(advance, t_out, counts, bar, m * int(np.ceil(chunk / m)), judged)


WHY[NOT_DIAGONAL] = "exp-adams: the linearization has no eigenbasis (a defective Jacobian)"
