"""The system's small vibrations: the assembled equations of a Model (joint and modal coordinates,
geometric stiffening included, as the integrators take them) linearized about a state, and their
eigenvalues. These are the frequencies a run's spectra show, unlike the mode set's own
boundary-condition frequencies (`flexmbd modes`): a hinged pendulum vibrates at its pinned-free
frequency, not at the clamped-free one of its modes (docs/formulation.md §10).

Coordinates: the free ones, in v's order (`dynamics.free_velocities`); prescribed joints follow
their profile at the linearization time. A state perturbation dq is taken along the joints'
velocity map, q + h qdot(q, e_i), so quaternion joints need no special case. A tree closed by cut
joints (`constraints.Loops`) is linearized on its independent coordinates: the dependent ones
(`Loops.partition`) follow every perturbed state by the loops' closure, at position and velocity
level, and the accelerations are the constrained ones."""

from __future__ import annotations

import re
from typing import NamedTuple

import numpy as np
from scipy import linalg, optimize

from flexmbd.mbd import constraints, dynamics, joints
from flexmbd.mbd.compiled import entry
from flexmbd.mbd.compiled.entry import forward_dynamics
from flexmbd.mbd.model import Model, make_data


class NotLinearized(ValueError):
    """A state the linearization cannot be taken about, or a loop that cannot close at a perturbed
    state: args[0] says which and why, in one line."""


STEP = 1e-6          # central-difference step on q and v (coordinates are O(1) rad or mass-normalized)


class SystemMode(NamedTuple):
    freq_hz: float     # damped frequency |Im lambda| / 2 pi
    damping: float     # ratio -Re lambda / |lambda|; 0 within its resolution
    label: str         # what leads the mode: 'joint pivot', 'beam: bending xy 2' (`labelled`)
    share: float       # that joint's or body family's share of the mode's kinetic energy
    damping_resolution: float   # the smallest |damping| its eigenvalue resolves (`damping_resolution`)
    shape: object = None        # (nf,) its displacement over the free coordinates (`dynamics.free_velocities`;
                                # a loop's dependent ones closed), real at its largest entry, unit norm



def coordinates(model: Model, loops: constraints.Loops | None) -> np.ndarray:
    """Indices into v of the coordinates linearized on: the free ones less a loop's dependent ones."""
    free = dynamics.free_velocities(model)
    return free if loops is None else np.setdiff1d(free, loops.dep)


def accelerations(model: Model, loops: constraints.Loops | None, t: float):
    """qdd(q, v) (nv,) at time t: the tree's forward dynamics, or with loops the constrained
    accelerations at the state closed on its dependent coordinates."""
    data = make_data(model)
    if loops is None:
        return lambda q, v: forward_dynamics(model, data, q, v, t=t)

    def qdd(q, v):
        try:
            q, v = loops.close(t, q, v)
        except constraints.NotClosed as e:          # a perturbed state the dependent coordinates cannot close
            raise NotLinearized(f"joints.{e.args[0]}: the loop cannot close at a state perturbed for the "
                                f"linearization (residual {e.args[1]:.3g})") from None
        return loops.rates(t, q, v)[0][model.nq:]
    return qdd


def perturbed(model: Model, q, i: int, h: float) -> np.ndarray:
    """q moved by h along velocity coordinate i (q + h qdot(q, e_i))."""
    e = np.zeros(model.nv)
    e[i] = 1.0
    return q + h * joints.qdot(model.arrays, q, e, np.zeros(model.nq))


def state_matrix(model: Model, q, v, t: float = 0.0, bar=None, loops: constraints.Loops | None = None) -> np.ndarray:
    """A (2n, 2n) of d/dt [dq; dv] = A [dq; dv] over the n free (with loops: independent)
    coordinates, by central differences of forward dynamics: A = [[0, I], [d qdd/dq, d qdd/dv]].
    `bar` (progress.Progress over the n coordinates), when given, is told each coordinate done."""
    free, acc = coordinates(model, loops), accelerations(model, loops, t)

    def qdd(q, v):
        return acc(q, v)[free]

    n = free.size
    Jq = np.empty((n, n))
    Jv = np.empty((n, n))
    for c, i in enumerate(free):
        Jq[:, c] = (qdd(perturbed(model, q, i, STEP), v) - qdd(perturbed(model, q, i, -STEP), v)) / (2 * STEP)
        dv = np.zeros(model.nv)
        dv[i] = STEP
        Jv[:, c] = (qdd(q, v + dv) - qdd(q, v - dv)) / (2 * STEP)
        if bar:
            bar.update(c + 1)
    return np.block([[np.zeros((n, n)), np.eye(n)], [Jq, Jv]])


def equilibrium(model: Model, q0) -> np.ndarray:
    """The static equilibrium nearest q0 reached by descending the potential energy (gravity and
    strain) over the free coordinates, at rest. Refused with prescribed joints (their reference
    moves: linearize about the initial state) and for joints with quaternions."""
    if model.jnt_prescribed[1:].any() or model.nq != model.nv:
        raise NotLinearized("modes --system --about equilibrium: needs a tree without prescribed joints "
                            "or spherical/free joints; use --about initial")
    free, data, zero = dynamics.free_velocities(model), make_data(model), np.zeros(model.nv)

    def V(x):
        q = np.array(q0, dtype=float)
        q[free] = x
        return entry.energy(model, data, q, zero)[1]

    x = optimize.minimize(V, np.asarray(q0, dtype=float)[free], method="BFGS", options={"gtol": 1e-10}).x
    q = np.array(q0, dtype=float)
    q[free] = x
    return q


def mass_matrix(model: Model, q, t: float = 0.0) -> np.ndarray:
    """M (n, n) over the free coordinates (`dynamics.free_velocities`) at q: the inverse of forward
    dynamics' response to unit generalized forces, column c of M^-1 = (qdd(s e_c) - qdd(0)) / s.
    The response is linear in the force, so the large s (1e6 over the coordinate's unit) keeps
    qdd(0)'s round-off out of the difference; n + 1 evaluations where polarization
    (`entry.mass_matrix_system`) takes n^2 / 2."""
    free, data = dynamics.free_velocities(model), make_data(model)
    v, s = np.zeros(model.nv), 1e6
    qdd0 = forward_dynamics(model, data, q, v, t=t)[free]
    Minv = np.empty((free.size, free.size))
    for c, i in enumerate(free):
        tau = np.zeros(model.nv)
        tau[i] = s
        Minv[:, c] = (forward_dynamics(model, data, q, v, tau, t=t)[free] - qdd0) / s
    M = np.linalg.inv(Minv)
    return 0.5 * (M + M.T)


def family(label: str) -> str:
    """A retained mode's family: a beam's label less its number ('bending xy 2' -> 'bending xy');
    a solid's label is its own ('mode 3 (z)')."""
    return re.sub(r" \d+$", "", label)


def coordinate_groups(model: Model) -> list:
    """[(group, family, numbered, indices into v)]: what each velocity coordinate moves. A joint's
    coordinates are the group 'joint NAME' (family ''); a flexible body's modal coordinates are
    grouped by case body (a split beam's segments 'rod:k' together, as 'rod') and by the family of
    their retained mode (`family`), `numbered` where the mode set numbers its families (a beam's)."""
    out = {}
    for i in range(1, model.nb + 1):
        k, nv = model.jnt_vadr[i], model.jnt_nv[i]
        if nv:
            out.setdefault((f"joint {model.jnt_names[i]}", "", False), []).extend(range(k, k + nv))
        a, fb = model.body_madr[i], model.bodies.get(model.names[i])
        for c in range(model.body_nm[i]):
            f = family(str(fb.labels[c]))
            out.setdefault((model.names[i].partition(":")[0], f, f != fb.labels[c]), []).append(a + c)
    return [(g, f, n, np.array(idx)) for (g, f, n), idx in out.items()]


def refined(A, lam: complex, x) -> np.ndarray:
    """(n,) the displacement part x of A's eigenvector at root lam, refined by two steps of inverse
    iteration on the n coordinates, (J_q + lam J_v - lam^2 (1 + 1e-12)) y = x, to a residual of
    1e-14 from eig's 1e-3 (`momenta`). The shift keeps an exactly diagonal system (a clamped
    beam's) from a zero pivot and is 1e-6 of any gap between distinct roots."""
    n = A.shape[0] // 2
    B = A[n:, :n] + lam * A[n:, n:] - lam ** 2 * (1 + 1e-12) * np.eye(n)
    for _ in range(2):
        x = np.linalg.solve(B, x)
        x = x / np.linalg.norm(x)
    return x


def momenta(A, M, lam: complex, x, closure=None) -> tuple[np.ndarray, np.ndarray]:
    """(x, p) over the free coordinates: a mode's velocities and their generalized momenta M x, from
    the displacement part x of A's eigenvector at root lam (the velocities are lam x: the same
    shape). `np.linalg.eig`'s x of the (2n, 2n) A, whose blocks differ by lam^2 (1e7 at 500 Hz),
    has an error of 1e-3 relative, which M x carries into a momentum that cancels (a hinge whose
    beam bends about it: its momentum is 1e-3 of its parts, and M x gave it a share of up to 70 %).
    On a tree p is therefore taken from the linearized equations, M x = M (J_q + lam J_v) x / lam^2,
    which on the hinge's row is its stiffness's (nil): as accurate as the refined vector, to 1e-10
    in the shares, at n^2 per mode. With loops, whose constraint forces the equations also hold,
    x is refined (`refined`: n^3 per mode) and closed onto the dependent coordinates
    (`closure`: (independent,) -> (free,) velocities), and p = M x."""
    n = A.shape[0] // 2
    if closure is None:
        return x, M @ (A[n:, :n] @ x + lam * (A[n:, n:] @ x)) / lam ** 2
    x = closure(refined(A, lam, x))
    return x, M @ x


def energy_shares(x, p) -> np.ndarray:
    """(n,) each coordinate's share of a mode's kinetic energy: with the mode's velocities x (n,),
    complex, and their momenta p = M x, coordinate i holds 1/2 Re(conj(x_i) p_i), its velocity
    times its generalized momentum; the shares sum to 1. A coordinate that only carries others
    along (a hinge whose beam bends about it: its momentum is nil) holds nothing, however far it
    turns."""
    e = np.real(np.conj(x) * p)
    return e / e.sum()


def lead(groups: list, share) -> tuple[str, str, bool, float]:
    """(group, family, numbered, share) that leads a mode whose coordinates hold `share` (nv,) of
    its energy (`coordinate_groups`): the joint or body with the largest share, and of a body its
    family with the largest share."""
    total = {}
    for g, _, _, idx in groups:
        total[g] = total.get(g, 0.0) + share[idx].sum()
    g = max(total, key=total.get)
    return max(((g, f, n, float(share[idx].sum())) for h, f, n, idx in groups if h == g), key=lambda x: x[3])


def labelled(leads: list) -> list:
    """A label per mode from its (group, family, numbered) (`lead`), in frequency order: 'joint
    pivot'; a beam's family numbered in the order of the system modes it leads, 'beam: bending
    xy 2' (the system's second in-plane bending mode, whatever retained modes make it up); a
    solid's retained mode as its mode set names it, 'block: mode 1 (y)'."""
    count, out = {}, []
    for g, f, numbered in leads:
        count[g, f] = count.get((g, f), 0) + 1
        out.append(g if not f else f"{g}: {f} {count[g, f]}" if numbered else f"{g}: {f}")
    return out


def closing(model: Model, loops: constraints.Loops, t: float, q, v):
    """The map from velocities x (independent,) to the free coordinates' (free,): the dependent
    ones by the loops' velocity rows, G v = 0 (prescribed joints at rest)."""
    free, ind, dep = dynamics.free_velocities(model), coordinates(model, loops), loops.dep
    G = loops.state(t, q, v)[2]

    def closure(x):
        full = np.zeros(model.nv, dtype=complex)
        full[ind] = x
        full[dep] = -np.linalg.lstsq(G[:, dep], G[:, ind] @ x, rcond=None)[0]
        return full[free]
    return closure


ROUNDOFF = 1e-10    # relative error of the central differences (step 1e-6: roundoff eps / h)


def damping_resolution(B: np.ndarray, lam: np.ndarray, left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """(2n,) the smallest damping ratio each eigenvalue lam_k of B resolves: the eigen-solver's
    round-off of lam_k, kappa_k eps ||B||_F (a backward-stable solver's error; kappa_k =
    1 / |y_k^H x_k| its condition number, y_k and x_k its unit left and right eigenvectors, the
    columns of `left` and `right`), over |lam_k|. B is the balanced state matrix the eigenvalues
    are computed from (`scipy.linalg.matrix_balance`: joint and modal coordinates of very
    different scales make the unbalanced bound 1e4-1e7 times too wide). A ratio -Re lam / |lam|
    below it is round-off."""
    tiny = np.finfo(float).tiny
    with np.errstate(over="ignore"):        # an eigenvalue at 0 or a defective one resolves nothing: inf
        kappa = 1.0 / np.maximum(np.abs(np.einsum("ik,ik->k", left.conj(), right)), tiny)
        return kappa * np.finfo(float).eps * np.linalg.norm(B) / np.maximum(np.abs(lam), tiny)


def system_modes(model: Model, q, v, t: float = 0.0, bar=None, loops: constraints.Loops | None = None) -> list:
    """The oscillating eigenvalues of the linearized system (one per conjugate pair, ascending
    frequency) with damping and label; a damping ratio within its mode's `damping_resolution` is
    0. Non-oscillating roots (rigid-body modes, overdamped or unstable ones) are left out, and so
    are roots within sqrt(ROUNDOFF max|A|) of zero: a rigid mode without stiffness is a double zero
    root, which an error e in A moves by sqrt(e). Each is labelled by the joint or body holding the
    largest share of its kinetic energy (`energy_shares`, `lead`, `labelled`). `bar`: the progress
    of the state matrix (`state_matrix`); `loops`: the case's cut joints, whose dependent
    coordinates `q`, `v` must already satisfy (`constraints.Loops.close`); a mode's dependent
    velocities follow from its independent ones by the loops' velocity rows, G v = 0."""
    free, ind = dynamics.free_velocities(model), coordinates(model, loops)
    A = state_matrix(model, q, v, t, bar, loops)
    B, T = linalg.matrix_balance(A, permute=False)              # B = T^-1 A T, T diagonal
    lam, left, vec = linalg.eig(B, left=True)
    resolution = damping_resolution(B, lam, left, vec)
    vec = T @ vec                                               # A's eigenvectors
    zero = np.sqrt(ROUNDOFF * np.abs(A).max(initial=0.0))       # how far the differences move a double zero root
    M, groups = mass_matrix(model, q, t), coordinate_groups(model)
    closure = None if loops is None else closing(model, loops, t, q, v)
    scale = np.abs(lam).max(initial=1.0)
    found = []
    for k in np.flatnonzero((lam.imag > 1e-9 * scale) & (np.abs(lam) > zero)):
        share = np.zeros(model.nv)
        x, p = momenta(A, M, lam[k], vec[:ind.size, k], closure)
        share[free] = energy_shares(x, p)
        zeta = -lam[k].real / abs(lam[k])
        x = x / x[np.argmax(np.abs(x))]
        found.append((float(lam[k].imag / (2 * np.pi)), float(zeta if abs(zeta) > resolution[k] else 0.0),
                      lead(groups, share), float(resolution[k]), x.real / np.linalg.norm(x.real)))
    found.sort(key=lambda m: m[0])
    labels = labelled([m[2][:3] for m in found])
    return [SystemMode(f, d, lab, led[3], r, x) for (f, d, led, r, x), lab in zip(found, labels)]


def mac(a, b) -> float:
    """The modal assurance criterion of two shapes (n,): (a . b)^2 / (a . a)(b . b), 1 for the same
    shape, 0 for orthogonal ones."""
    return float(np.dot(a, b) ** 2 / (np.dot(a, a) * np.dot(b, b)))
