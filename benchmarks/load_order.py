"""Which copy of the compiled `aba` runs: one evaluation of the 64-link rigid chain from Python.

    .venv/bin/python benchmarks/load_order.py aba        # aba loaded first, as model.bind does
    .venv/bin/python benchmarks/load_order.py forward    # a caller of aba loaded first

Every compiled caller of `dynamics.aba` carries its own copy of it in its cached machine code, and
the process runs the copy loaded first. With "forward" the Bound is made without `model.bind`'s
`load_aba`, so the copy embedded in `forward_at` (behind `dynamics.forward`) arrives first. Prints the median time of one call, us.
Run each variant in a fresh process, with the compile cache warm (after `make test`).
"""

import sys

import numpy as np

from flexmbd import bench, dynamics, integrate
from flexmbd.bench import median_us
from flexmbd.model import _bind, from_case, make_data


def main(first: str) -> None:
    model = from_case(bench.chain_case(64, flexible=False))
    rng = np.random.default_rng(0)
    q, v, tau = rng.normal(size=model.nq) * 0.3, rng.normal(size=model.nv) * 0.3, np.zeros(model.nv)
    y = np.concatenate([q, v])
    b = _bind(model.arrays, make_data(model))
    if first == "aba":
        dynamics.load_aba()
    else:
        dynamics.forward(b, 0.0, q, v, tau)
    print(f"{first} loaded first: forward {median_us(lambda: dynamics.forward(b, 0.0, q, v, tau)):.1f} us, "
          f"rhs {median_us(lambda: integrate.rhs(b, 0.0, y, model.nq)):.1f} us, "
          f"aba {median_us(lambda: dynamics.aba(b, q, v, tau)):.1f} us")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "aba")
