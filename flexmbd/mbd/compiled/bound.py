"""A Model's arrays and one Data as a single object for compiled code (`Bound`), and the
intrinsics that pass it and the kernel's entry by address.

numba passes a Bound in about 1.7 us, where the two NamedTuples (some 70 arrays) take about
17 us; inside, both are structrefs with the NamedTuples' fields, so the algorithms read
`model.parent` or `data.Xup` the same way in compiled and in plain Python code. The arrays inside
are borrowed (`borrowed`: no meminfo), so reading a field touches no reference count; the Python
Bound keeps their owners, the Model's arrays and the Data, alive (`bind`).
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np
from llvmlite import ir
from numba.core import cgutils, types
from numba.experimental import structref
from numba.extending import intrinsic

from flexmbd.mbd.invariants import stack
from flexmbd.mbd.compiled.jit import PURE_PYTHON, njit
from flexmbd.mbd.model import Arrays, Data, Model, empty_arrays, empty_data, empty_loads


@structref.register
class ArraysType(types.StructRef):
    """numba type of `ArraysRef`."""


@structref.register
class DataType(types.StructRef):
    """numba type of `DataRef`."""


@structref.register
class BoundType(types.StructRef):
    """numba type of `Bound`."""


class ArraysRef(structref.StructRefProxy):
    """The fields of `model.Arrays` behind one pointer. Reading one field in compiled code touches
    that array only, where a NamedTuple read out of a structref takes a reference to every member."""


class DataRef(structref.StructRefProxy):
    """The fields of `model.Data` behind one pointer (see ArraysRef)."""


class Bound(structref.StructRefProxy):
    """A Model's arrays (field model, an ArraysRef) and one Data (field data, a DataRef) as a
    single object for compiled code. Made by `bind`; the arrays are shared, not copied.

    `address` (int) is where its data lives. numba's dispatcher types an int in C but a structref
    in Python (about 0.8 us more), so the cheap call from Python passes the address, and the
    compiled code takes the Bound back with `bound_at`, while the Python object keeps it alive
    for the call."""

    @classmethod
    def _numba_box_(cls, ty, mi):
        b = super()._numba_box_(ty, mi)
        b.address = _address(b)
        return b


structref.define_proxy(ArraysRef, ArraysType, Arrays._fields)
structref.define_proxy(DataRef, DataType, Data._fields)
structref.define_boxing(BoundType, Bound)


def _bound_type() -> BoundType:
    A = Arrays(**empty_arrays(0, 0), inv=stack([None], 0), **empty_loads(0, 0), gravity=np.zeros(3))
    D = empty_data(0, 0, 0, 0)
    return BoundType([("model", ArraysType(list(zip(Arrays._fields, numba.typeof(A).types)))),
                      ("data", DataType(list(zip(Data._fields, numba.typeof(D).types))))])


BOUND_T = _bound_type()


@intrinsic
def address_of(typingctx, b):
    """The address (intp) of a Bound's data (its meminfo)."""
    def codegen(context, builder, sig, args):
        st = cgutils.create_struct_proxy(BOUND_T)(context, builder, value=args[0])
        return builder.ptrtoint(st.meminfo, context.get_value_type(types.intp))
    return types.intp(BOUND_T), codegen


@intrinsic
def bound_at(typingctx, address):
    """The Bound at `address` (`Bound.address`), as a new reference. The caller guarantees that
    a Bound there is alive for the call."""
    def codegen(context, builder, sig, args):
        st = cgutils.create_struct_proxy(BOUND_T)(context, builder)
        st.meminfo = builder.inttoptr(args[0], st.meminfo.type)
        context.nrt.incref(builder, BOUND_T, st._getvalue())
        return st._getvalue()
    return BOUND_T(types.intp), codegen


@intrinsic
def call_entry(typingctx, fn, address, t, q, v, tau, out, want_qdot):
    """Call the kernel's entry (`entry.evaluate`, a C function at address fn) for the Bound at
    `address`: the arrays q, v, tau, out (C-contiguous float64) go by their data pointers."""
    f64p = types.CPointer(types.float64)

    def codegen(context, builder, sig, args):
        fnp, addr, tt, qa, va, taua, outa, flag = args
        ptrs = [context.make_array(ty)(context, builder, value=a).data
                for ty, a in zip(sig.args[3:7], (qa, va, taua, outa))]
        intp, dbl, p = context.get_value_type(types.intp), context.get_value_type(types.float64), \
            context.get_value_type(f64p)
        fnty = ir.FunctionType(
            context.get_value_type(types.void), [intp, dbl, p, p, p, p, intp, intp, intp])
        callee = builder.inttoptr(fnp, fnty.as_pointer())
        nq = context.make_array(sig.args[3])(context, builder, value=qa).nitems
        nv = context.make_array(sig.args[4])(context, builder, value=va).nitems
        builder.call(callee, [addr, tt, *ptrs, nq, nv, flag])
        return context.get_dummy_value()
    return types.void(fn, address, t, q, v, tau, out, want_qdot), codegen


@njit
def _address(b):
    return address_of(b)


def _borrow(builder, ty, value):
    """`value` of type ty (an array, or a tuple of them, nested) with every array's meminfo set to
    null: the same data, shape and parent, no reference count."""
    if isinstance(ty, types.Array):
        return builder.insert_value(value, ir.Constant(value.type.elements[0], None), 0)   # field 0: meminfo
    if isinstance(ty, types.BaseTuple):
        for k, member in enumerate(ty.types):
            value = builder.insert_value(value, _borrow(builder, member, builder.extract_value(value, k)), k)
    return value


@intrinsic
def borrowed(typingctx, arrays):
    """The arrays of a (nested) tuple as borrowed references: their meminfo null, so that neither
    reading nor dropping one touches a reference count (an atomic add). Whoever holds them must
    keep the owners alive: `bind` keeps the NamedTuples on the Bound."""
    def codegen(context, builder, sig, args):
        return _borrow(builder, sig.args[0], args[0])
    return arrays(arrays), codegen


@njit
def _bind(arrays, data):
    b = structref.new(BOUND_T)
    b.model = ArraysRef(*borrowed(arrays))
    b.data = DataRef(*borrowed(data))
    return b


class PlainBound(NamedTuple):
    """The uncompiled stand-in for a Bound (numba's JIT disabled, `jit.PURE_PYTHON`): the same
    fields model and data, the NamedTuples themselves."""

    model: Arrays
    data: Data


def bind(model: Model, data: Data) -> Bound:
    """The Model's arrays and `data` as one `Bound`; a PlainBound when numba's JIT is disabled."""
    if PURE_PYTHON:
        return PlainBound(model.arrays, data)
    b = _bind(model.arrays, data)
    b.owners = (model.arrays, data)                     # the Bound's arrays are borrowed from these
    return b
