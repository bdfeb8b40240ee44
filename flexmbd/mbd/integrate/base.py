"""What every integrator shares: a run's end (`Ended`, `Stop`), its samples (`Simulation`), the
right-hand side called from Python (`rhs_function`) and from the compiled step loops, of a tree or
of closed loops (`rates`), the divergence rule on a state (`state_code`, its words WHY) and the
chunked driving of a compiled step loop with its checks (`_in_chunks`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from flexmbd.mbd.compiled.bound import bind
from flexmbd.mbd.compiled.entry import handle, rhs
from flexmbd.mbd.compiled.jit import njit
from flexmbd.mbd.constraints import constrained_rates
from flexmbd.mbd.model import Model, make_data


DIVERGED = 1e8      # |v| beyond this (rad/s, m/s, modal units) counts as divergence: the divergence rule's
                    # bound on a velocity state, the same for every solver (`results.first_failure` its others)


class Ended(NamedTuple):
    """How a run of the integrators ended: `ok`, or failed for `why` at `t` (s; None: not known).
    The harness makes it a run's status (`inhouse.run`)."""

    ok: bool = True
    why: str = ""
    t: float | None = None


def failed(why: str, t=None) -> Ended:
    return Ended(False, why, None if t is None else float(t))


class Stop(Exception):
    """Raised inside the right-hand side to end a run that has failed; args[0] is its `Ended`."""


@dataclass
class Simulation:
    t: np.ndarray                   # (n,) output instants, s
    q: np.ndarray                   # (n, nq)
    v: np.ndarray                   # (n, nv)
    status: Ended = field(default_factory=Ended)
    steps: int = 0
    rhs_evals: int = 0
    wall_s: float = 0.0
    settings: dict = field(default_factory=dict)


def rhs_function(model: Model):
    """f(t, y) for y = [q; v] (the compiled `compiled.entry.rhs` behind a Python call), and a counter
    of its evaluations."""
    b, nq = bind(model, make_data(model)), model.nq
    ev = handle(b)
    count = [0]

    def f(t, y):
        count[0] += 1
        yd = rhs(ev, float(t), y, nq)
        if not np.all(np.isfinite(yd)):
            raise Stop(failed(NON_FINITE[1], t))
        return yd

    f.bound = b                 # alive as long as f: the compiled code reaches it by address
    return f, count


@njit
def rates(ev, cuts, t, y, nq):
    """dy/dt (nq+nv,) at (t, y) through the entry `ev` (`compiled.entry.handle`): the tree's
    (cuts None), or the constrained rates of the loops closed by the cuts (`constraints.CutArrays`,
    `constraints.constrained_rates`). None is pruned when compiled: a tree's step loop holds none
    of the loops' code."""
    if cuts is None:
        return rhs(ev, t, y, nq)
    return constrained_rates(ev, cuts, t, y[:nq], y[nq:])[0]


CLOSING = 30        # Newton iterations of a projection onto the loops' constraints (`constraints.project`)


OK, NONFINITE, DIVERGING, TOO_SMALL, NEWTON = 0, 1, 2, 3, 4
NOT_CLOSED = 7      # a closed loop's projection failed (exp-adams has 5 and 6)


@njit
def state_code(y, nq):
    """The divergence rule of every integrator on a state y = [q; v]: NONFINITE when an entry is
    not finite, DIVERGING when a velocity |v_i| exceeds DIVERGED, else OK. The compiled step loops
    call it after every step, the others through `_check` (the message: WHY)."""
    for i in range(y.size):
        if not np.isfinite(y[i]):
            return NONFINITE
    for i in range(nq, y.size):
        if abs(y[i]) > DIVERGED:
            return DIVERGING
    return OK


WHY = {NONFINITE: "non-finite state", DIVERGING: f"diverged (|v| > {DIVERGED:g})", TOO_SMALL: "step size too small",
       NEWTON: "Newton did not converge with a fresh iteration matrix", NOT_CLOSED: "a loop no longer closes"}
NON_FINITE = (WHY[NONFINITE], "non-finite acceleration")     # the whys of a run that ended in non-finite values


def _in_chunks(advance, t_out, counts, bar, chunk, judged=None):
    """Run a compiled integrator, `advance(k, k1) -> (instants done, status code, t)` over
    t_out[k:k1+1], chunk by chunk, with progress and failures in between (the state's, and
    `judged`'s of the chunk's samples: `judge`): (k, steps, evaluations, status)."""
    k = 0
    while k < t_out.size - 1:
        k1 = min(k + chunk, t_out.size - 1)
        j, code, t = advance(k, k1)
        k0, k = k, k + j
        if code != OK:
            return k, int(counts[0]), int(counts[2]), failed(WHY[code], t)
        hit = judged(k0 + 1, k) if judged and k > k0 else None
        if hit is not None:
            return hit[0], int(counts[0]), int(counts[2]), hit[1]
        if bar:
            bar.update(t_out[k])
    return k, int(counts[0]), int(counts[2]), Ended()


def judge(check, t_out, Y, nq, k0, k1):
    """`check` (simulate's) of the output samples k0..k1 (rows of Y): (the first failed sample's
    index, its `Ended`) or None."""
    hit = check(t_out[k0:k1 + 1], Y[k0:k1 + 1, :nq], Y[k0:k1 + 1, nq:])
    return None if hit is None else (k0 + hit[0], failed(hit[1].why, hit[1].t))


def reached(Y) -> int:
    """The last output instant (row of Y, NaN where not reached) with a finite state."""
    ok = np.flatnonzero(np.all(np.isfinite(Y), axis=1))
    return int(ok[-1]) if ok.size else 0


def _check(y, t, nq):
    """Stop a run whose state y = [q; v] breaks the divergence rule (`state_code`)."""
    code = state_code(y, nq)
    if code != OK:
        raise Stop(failed(WHY[code], t))
