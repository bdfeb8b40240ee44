"""Everything that exists only for numba, behind `entry.forward(model, data, t, q, v, tau)` and
the integrators' `entry.rhs`:

    jit     njit and cfunc with the on-disk cache keyed by the compiled sources; the pure-Python mode
    dense   small dense linear algebra as plain loops (no BLAS call overhead at sizes 6 to 6+nm)
    bound   the Model's arrays and a Data as one object (structrefs), passed by address
    entry   the one compiled entry (profiles, coordinate rates, `dynamics.aba`) and the calls into it

The algorithms themselves (`dynamics`, `joints`, `invariants`) are plain functions of the Model
arrays and a Data, compiled with `jit.njit` and readable without any of this.
"""
