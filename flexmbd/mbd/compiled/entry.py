"""The kernel's one compiled entry, `evaluate`, and the calls into it: `forward` and `energy`
from Python, `rhs` and `call` from the compiled integrators and the closed loops' rows.

`evaluate` is a C function (numba cfunc): the profiles at time t, the coordinate rates and the
articulated-body algorithm (`dynamics`) for the Bound at an address. It is compiled once; the
Python call and the integrators call it through its address, so its body, the bulk of the
compiled code, is never linked into (and optimized again inside) each caller.

In the pure-Python mode (NUMBA_DISABLE_JIT=1, `jit.PURE_PYTHON`) the same functions run on the
NamedTuples: `bind` gives a PlainBound and `rhs` and `forward` call `dynamics` directly.
"""

from __future__ import annotations

import numpy as np
from numba import carray, types

from flexmbd.mbd.dynamics import (aba, forward_kinematics, kinetic_energy, pass1, passes23, potential_energy,
                                  prescribed, response)
from flexmbd.mbd.compiled.jit import PURE_PYTHON, cfunc, njit
from flexmbd.mbd.joints import qdot
from flexmbd.mbd.compiled.bound import Bound, bind, bound_at, call_entry
from flexmbd.mbd.model import Data, Model

_P = types.CPointer(types.float64)
SIGNATURE = types.void(types.intp, types.float64, _P, _P, _P, _P, types.intp, types.intp, types.intp)


ACCELERATIONS, RATES, ENERGY, RESPONSE, KINEMATICS = 0, 1, 2, 3, 4     # what `evaluate` computes (its last argument)


def evaluate(address, t, q_ptr, v_ptr, tau_ptr, out_ptr, nq, nv, mode):
    """For the Bound at `address`, at time t, state q (nq,), v (nv,) and generalized forces tau (nv,):
    the accelerations into its data.qdd (mode ACCELERATIONS) and [dq/dt; qdd] into out (nq+nv,)
    (RATES), or the kinetic and potential energy of the state as it is, no profile applied, into
    out (2,) (ENERGY). The energy is here, after `aba`'s first pass (the bodies' mass matrices
    M_i(eta) included), so that it is compiled with the rest, not as a second copy of the
    kinematics and the mass matrix in a function of its own (16 s of a first run's compilation).
    RESPONSE: M^-1 tau at the state of the last ACCELERATIONS or RATES evaluation into out (nv,)
    (`dynamics.response`; t, q and v are not read). KINEMATICS: the profiles and the kinematics
    of pass 1 alone (`dynamics.forward_kinematics`: transforms, velocities, velocity products),
    nothing into out."""
    b = bound_at(address)
    model, data = b.model, b.data
    q, v, tau = carray(q_ptr, nq), carray(v_ptr, nv), carray(tau_ptr, nv)
    if mode == RESPONSE:
        carray(out_ptr, nv)[:] = response(model, data, tau)
        return
    if mode != ENERGY:
        q, v = prescribed(model, data, t, q, v)
    if mode == KINEMATICS:
        forward_kinematics(model, data, q, v)
        return
    pass1(model, data, q, v, tau)                       # `aba`'s first pass, shared
    if mode == ENERGY:
        out = carray(out_ptr, 2)
        out[0], out[1] = kinetic_energy(model, data, v), potential_energy(model, data, q)
        return
    qdd = passes23(model, data, tau)
    if mode == RATES:
        out = carray(out_ptr, nq + nv)
        qdot(model, q, v, out[:nq])
        out[nq:] = qdd


_entry = []


def entry_address() -> int:
    """The address of the compiled `evaluate` (compiled, or loaded from the cache, on first use)."""
    if not _entry:
        _entry.append(cfunc(SIGNATURE, evaluate).address)
    return _entry[0]


def handle(b: Bound):
    """What the compiled integrators pass to `rhs` for the Bound b (which the caller keeps alive):
    (entry address, b.address); b itself in the pure-Python mode."""
    return b if PURE_PYTHON else (entry_address(), b.address)


@njit
def rhs(k, t, y, nq):
    """dy/dt (nq+nv,) for y = [q; v] at time t, through the entry `k` (`handle`); prescribed
    joints follow their profiles, no joint forces."""
    out = np.empty(y.size)
    call_entry(k[0], k[1], t, y[:nq], y[nq:], np.zeros(y.size - nq), out, RATES)
    return out


@njit
def call(k, t, q, v, tau, out, mode):
    """One call of the entry `k` (`handle`) from compiled code: `evaluate`'s mode at time t for
    q (nq,), v (nv,), tau (nv,), out; each C-contiguous (they go by their data pointers)."""
    call_entry(k[0], k[1], t, q, v, tau, out, mode)


@njit
def bound_of(k):
    """The Bound behind the entry `k` (`handle`), for compiled code that reads its model's arrays
    and the Data an evaluation left (the caller keeps the Bound alive)."""
    return bound_at(k[1])


@njit
def _at(fn, address, t, q, v, tau, out, mode):
    """One call of the entry at fn for the Bound at `address` (`evaluate`'s arguments)."""
    call_entry(fn, address, t, q, v, tau, out, mode)


@njit
def _accelerations(fn, address, t, q, v, tau):
    """`_at` for mode ACCELERATIONS: two arguments fewer for numba's dispatcher to check (about
    25 ns each), the one call a user makes in a loop."""
    call_entry(fn, address, t, q, v, tau, q, ACCELERATIONS)


_bound = {}
_last = (None, None, None, 0, 0)                        # the last (model, data, Bound, entry, Bound.address)


def _bound_of(model: Model, data: Data):
    """(model, data, Bound, entry address, Bound address) for (model, data), bound once: kept for
    the last few Data used, the last one also apart, where `forward` finds it in two comparisons."""
    global _last
    hit = _bound.get(id(data))
    if hit is None or hit[0] is not model or hit[1] is not data:
        if len(_bound) >= 16:
            del _bound[next(iter(_bound))]
        b = bind(model, data)
        hit = _bound[id(data)] = (model, data, b, entry_address(), b.address)
    _last = hit
    return hit


def forward(model: Model, data: Data, t: float, q, v, tau) -> np.ndarray:
    """Generalized accelerations (nv,) at time t: profiles applied, then `dynamics.aba`. The cheap
    call from Python: q, v, tau C-contiguous float arrays, t a float. Returns data.qdd itself, as
    Pinocchio's `aba` returns `data.ddq`: copy it to keep it."""
    hit = _last
    if hit[1] is not data or hit[0] is not model:
        hit = _bound_of(model, data)
    _accelerations(hit[3], hit[4], t, q, v, tau)
    return data.qdd


def rates(model: Model, data: Data, t: float, q, v, tau) -> np.ndarray:
    """[dq/dt; qdd] (nq+nv,) at time t: `forward` with the coordinate rates (of the prescribed
    joints' profile values), arguments as there."""
    *_, fn, address = _bound_of(model, data)
    out = np.empty(q.size + v.size)
    _at(fn, address, t, q, v, tau, out, RATES)
    return out


def energy(model: Model, data: Data, q, v) -> tuple[float, float]:
    """(kinetic, potential) energy of the state (q, v) as it is (no profile applied)."""
    *_, fn, address = _bound_of(model, data)
    q, v = np.ascontiguousarray(q, dtype=float), np.ascontiguousarray(v, dtype=float)
    out = np.empty(2)
    _at(fn, address, 0.0, q, v, np.zeros(v.size), out, ENERGY)
    return float(out[0]), float(out[1])


if PURE_PYTHON:                                         # no addresses: the same passes, uncompiled
    def rhs(k, t, y, nq):                               # noqa: F811
        """`rhs` uncompiled: k is a PlainBound."""
        model, data = k.model, k.data
        q, v = prescribed(model, data, t, y[:nq], y[nq:])
        out = np.empty(y.size)
        qdot(model, q, v, out[:nq])
        out[nq:] = aba(model, data, q, v, np.zeros(v.size))
        return out

    def call(k, t, q, v, tau, out, mode):                # noqa: F811
        """`call` uncompiled: `evaluate`'s modes on k, a PlainBound."""
        model, data = k.model, k.data
        if mode == RESPONSE:
            out[:] = response(model, data, tau)
            return
        if mode == ENERGY:
            pass1(model, data, q, v, tau)
            out[0], out[1] = kinetic_energy(model, data, v), potential_energy(model, data, q)
            return
        q, v = prescribed(model, data, t, q, v)
        if mode == KINEMATICS:
            forward_kinematics(model, data, q, v)
            return
        qdd = aba(model, data, q, v, tau)
        if mode == RATES:
            qdot(model, q, v, out[:q.size])
            out[q.size:] = qdd

    def bound_of(k):                                    # noqa: F811
        """`bound_of` uncompiled: k is the PlainBound itself."""
        return k

    def forward(model: Model, data: Data, t: float, q, v, tau) -> np.ndarray:  # noqa: F811
        """`forward` uncompiled: the same passes on the NamedTuples."""
        q, v = prescribed(model.arrays, data, t, q, v)
        return aba(model.arrays, data, q, v, tau)

    def rates(model: Model, data: Data, t: float, q, v, tau) -> np.ndarray:  # noqa: F811
        """`rates` uncompiled."""
        q, v = prescribed(model.arrays, data, t, q, v)
        out = np.empty(q.size + v.size)
        qdot(model.arrays, q, v, out[:q.size])
        out[q.size:] = aba(model.arrays, data, q, v, tau)
        return out

    def energy(model: Model, data: Data, q, v) -> tuple[float, float]:    # noqa: F811
        """`energy` uncompiled."""
        pass1(model.arrays, data, q, v, np.zeros(v.size))
        return kinetic_energy(model.arrays, data, v), potential_energy(model.arrays, data, q)


def forward_dynamics(model: Model, data: Data, q, v, tau=None, t: float = 0.0) -> np.ndarray:
    """Generalized accelerations (nv,) at time t (profiles of loads and prescribed joints applied),
    a copy of data.qdd."""
    tau = np.zeros(model.nv) if tau is None else np.asarray(tau, dtype=float)
    return forward(model, data, float(t), np.ascontiguousarray(q, dtype=float), np.ascontiguousarray(v, dtype=float),
                   np.ascontiguousarray(tau)).copy()


def mass_matrix_system(model: Model, data: Data, q) -> np.ndarray:
    """M(q) (nv, nv) of the whole tree, from the kinetic energy T = 1/2 v^T M v by polarization:
    M_ii = 2 T(e_i), M_ij = T(e_i + e_j) - T(e_i) - T(e_j). For diagnosis and linearization,
    not for time stepping (nv^2 / 2 energy evaluations)."""
    E = np.eye(model.nv)
    T = [energy(model, data, q, E[i])[0] for i in range(model.nv)]
    M = np.diag(2.0 * np.array(T))
    for i in range(model.nv):
        for j in range(i):
            M[i, j] = M[j, i] = energy(model, data, q, E[i] + E[j])[0] - T[i] - T[j]
    return M

