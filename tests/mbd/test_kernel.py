"""The kernel: a Bound shares the Model's arrays and a Data with Python, and the calls into the one
compiled entry leak no reference."""

import numba
import numpy as np

from flexmbd.report import bench
from flexmbd.solvers.build import from_case
from flexmbd.mbd.compiled import bound, entry
from flexmbd.mbd.model import make_data


@numba.njit
def _fields(b):
    return b.model.parent, b.model.inv.I1, b.data.qdd, b.data.X0


@numba.njit
def _at(address):
    return bound.bound_at(address)


def test_bound_shares_the_arrays_of_model_and_data():
    m = from_case(bench.chain_case(2, flexible=True))
    data = make_data(m)
    parent, I1, qdd, X0 = _fields(bound.bind(m, data))
    assert parent is m.parent and I1 is m.inv.I1 and qdd is data.qdd and X0 is data.X0


def test_address_gives_back_the_same_bound_and_calls_leak_no_reference():
    m = from_case(bench.chain_case(2, flexible=False))
    data = make_data(m)
    b = bound.bind(m, data)
    refs = b._meminfo.refcount
    again = _at(b.address)
    assert again.address == b.address and _fields(again)[2] is data.qdd
    assert b._meminfo.refcount == refs + 1
    del again
    assert b._meminfo.refcount == refs
    q, v = np.full(m.nq, 0.2), np.full(m.nv, -0.1)
    ev = entry.handle(b)
    for _ in range(100):
        entry.rhs(ev, 0.0, np.concatenate([q, v]), m.nq)
    assert b._meminfo.refcount == refs


def test_rhs_is_qdot_and_forward():
    """`rhs` (the integrators' call) gives the rates of q and the accelerations of `forward`."""
    m = from_case(bench.chain_case(3, flexible=True, stiffening=False))   # random states, large deflections
    rng = np.random.default_rng(5)
    q, v = rng.normal(size=m.nq) * 0.1, rng.normal(size=m.nv)
    b = bound.bind(m, make_data(m))
    yd = entry.rhs(entry.handle(b), 0.4, np.concatenate([q, v]), m.nq)
    assert np.array_equal(yd[m.nq:], entry.forward_dynamics(m, make_data(m), q, v, t=0.4))
    assert np.array_equal(yd[:m.nq], v)                 # revolute joints and modes: dq/dt = v


def test_forward_is_the_same_evaluation_into_data():
    """`forward` is `forward_dynamics` on a fresh Data, fills data's own arrays and returns
    data.qdd itself."""
    m = from_case(bench.chain_case(3, flexible=True, stiffening=False))
    rng = np.random.default_rng(3)
    q, v, tau = rng.normal(size=m.nq) * 0.1, rng.normal(size=m.nv), rng.normal(size=m.nv)
    data = make_data(m)
    a = entry.forward(m, data, 0.3, q, v, tau)
    assert np.array_equal(a, entry.forward_dynamics(m, make_data(m), q, v, tau, t=0.3))
    assert a is data.qdd and np.abs(data.f[1:]).max() > 0


def test_forward_follows_the_model_and_data_it_is_given():
    """`forward` keeps the last (model, data) bound apart: alternating two Data of one model, and
    two models, each call writes its own Data and gives its own model's accelerations."""
    m2, m3 = (from_case(bench.chain_case(n, flexible=False)) for n in (2, 3))
    d2a, d2b, d3 = make_data(m2), make_data(m2), make_data(m3)
    q2, q2b, q3 = np.array([0.3, -0.2]), np.array([0.1, 0.5]), np.array([0.1, 0.2, 0.3])
    first = entry.forward(m2, d2a, 0.0, q2, np.zeros(2), np.zeros(2)).copy()
    other = entry.forward(m2, d2b, 0.0, q2b, np.zeros(2), np.zeros(2)).copy()
    three = entry.forward(m3, d3, 0.0, q3, np.zeros(3), np.zeros(3)).copy()
    assert np.array_equal(d2a.qdd, first) and np.array_equal(d2b.qdd, other) and np.array_equal(d3.qdd, three)
    assert not np.array_equal(first, other)
    assert np.array_equal(entry.forward(m2, d2a, 0.0, q2b, np.zeros(2), np.zeros(2)), other)
