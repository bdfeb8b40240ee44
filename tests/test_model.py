"""model.Bound: the Model's arrays and a Data behind one pointer, shared with Python, not copied."""

import numba
import numpy as np

from flexmbd import bench, dynamics
from flexmbd import model as M


@numba.njit
def _fields(b):
    return b.M.parent, b.M.inv.I1, b.D.qdd, b.D.X0


@numba.njit
def _at(address):
    return M.bound_at(address)


def test_bound_shares_the_arrays_of_model_and_data():
    m = M.from_case(bench.chain_case(2, flexible=True))
    data = M.make_data(m)
    parent, I1, qdd, X0 = _fields(M.bind(m, data))
    assert parent is m.parent and I1 is m.inv.I1 and qdd is data.qdd and X0 is data.X0


def test_address_gives_back_the_same_bound_and_calls_leak_no_reference():
    m = M.from_case(bench.chain_case(2, flexible=False))
    data = M.make_data(m)
    b = M.bind(m, data)
    refs = b._meminfo.refcount
    again = _at(b.address)
    assert again.address == b.address and _fields(again)[2] is data.qdd
    assert b._meminfo.refcount == refs + 1
    del again
    assert b._meminfo.refcount == refs
    q, v, tau = np.full(m.nq, 0.2), np.full(m.nv, -0.1), np.zeros(m.nv)
    for _ in range(100):
        dynamics.forward(b, 0.0, q, v, tau)
    assert b._meminfo.refcount == refs
