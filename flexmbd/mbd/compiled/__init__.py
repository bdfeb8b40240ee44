"""The solver's compiled part, the one place numba appears:

    jit     compiling: numba's njit and cfunc with an on-disk cache keyed by the compiled sources
    dense   small dense loops (6x6-sized products) the algorithms use
    bound   the Model's arrays and a Data as one object (structrefs), passed by address
    entry   the one compiled entry (profiles, coordinate rates, `dynamics.aba`) and the calls into
            it: `entry.forward(model, data, t, q, v, tau)` and the integrators' `entry.rhs`

The algorithms themselves (`dynamics`, `joints`, `invariants`) are plain functions of the Model
arrays and a Data, compiled with `jit.njit`, and readable without any of this.

It imports the solver's own modules only; it is the one place numba and llvmlite are imported.
"""
