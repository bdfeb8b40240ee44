"""Does it matter which copy of the compiled `aba` runs? One evaluation of the 64-link rigid chain
from Python.

    .venv/bin/python benchmarks/load_order.py aba        # aba's own compilation loaded first
    .venv/bin/python benchmarks/load_order.py forward    # a caller of aba loaded first

Every compiled caller of `dynamics.aba` carries its own copy of it in its cached machine code, and
the process runs the copy loaded first. When M and D were NamedTuples inside the Bound, the copies
embedded in callers ran 30-60 % slower than `aba`'s own, and `model.bind` loaded `aba` first;
with M and D as structrefs the two orders measure the same (docs/performance.md, item 4).
Prints the median time of one call, us. Run each variant in a fresh process, with the compile
cache warm (after `make test`).
"""

import sys

import numpy as np
from numba.core import types

from flexmbd import bench, dynamics, integrate
from flexmbd.bench import median_us
from flexmbd.model import BOUND_T, bind, from_case, make_data


def main(first: str) -> None:
    model = from_case(bench.chain_case(64, flexible=False))
    rng = np.random.default_rng(0)
    q, v, tau = rng.normal(size=model.nq) * 0.3, rng.normal(size=model.nv) * 0.3, np.zeros(model.nv)
    y = np.concatenate([q, v])
    b = bind(model, make_data(model))
    if first == "aba":
        dynamics.aba.compile((BOUND_T, *[types.Array(types.float64, 1, "C")] * 3))
    else:
        dynamics.forward(b, 0.0, q, v, tau)
    print(f"{first} loaded first: forward {median_us(lambda: dynamics.forward(b, 0.0, q, v, tau)):.1f} us, "
          f"rhs {median_us(lambda: integrate.rhs(b, 0.0, y, model.nq)):.1f} us, "
          f"aba {median_us(lambda: dynamics.aba(b, q, v, tau)):.1f} us")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "aba")
