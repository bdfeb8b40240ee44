"""The compiled part above the algorithms (in the solver's layer, 1), behind `entry.forward(model, data, t, q, v,
tau)` and the integrators' `entry.rhs`:

    bound   the Model's arrays and a Data as one object (structrefs), passed by address
    entry   the one compiled entry (profiles, coordinate rates, `dynamics.aba`) and the calls into it

The algorithms themselves (`dynamics`, `joints`, `invariants`) are plain functions of the Model
arrays and a Data, compiled with `flexmbd.jit.njit` (small dense loops: `flexmbd.dense`, both at
layer 1, below them) and readable without any of this.
"""
