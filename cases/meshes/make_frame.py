"""Writes cases/meshes/l_frame.bdf, the mesh cases/l_frame.toml reads: an L-shaped steel frame in
the x-y plane, a = 1.0 m along x from the origin to the corner, then b = 0.6 m along y, of solid
circular bars d = 20 mm (CBAR, PBAR: A = pi d^2 / 4, I1 = I2 = pi d^4 / 64, J = pi d^4 / 32), 20
and 12 elements, orientation vector +z for both legs (plane 1, I1, the legs' out-of-plane
bending), steel (E = 210 GPa, nu = 0.3, rho = 7850 kg/m^3), and a 0.5 kg point mass at the corner
(CONM2 on grid 21, with 1e-4 kg m^2 about each axis). SET1 1 is the clamped root (grid 1), SET1 2
the free tip (grid 33). NASTRAN free fields, SI units. Run from the repository root:

    .venv/bin/python cases/meshes/make_frame.py
"""

import math
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
A, B, D, NA, NB = 1.0, 0.6, 0.02, 20, 12


def main(path=HERE / "l_frame.bdf") -> None:
    x = np.r_[np.c_[np.linspace(0.0, A, NA + 1), np.zeros(NA + 1)], np.c_[np.full(NB, A), np.linspace(0.0, B, NB + 1)[1:]]]
    area, inertia = math.pi * D ** 2 / 4, math.pi * D ** 4 / 64
    out = ["$ l_frame: L-shaped steel frame of d = 20 mm bars, SI (cases/meshes/make_frame.py)", "BEGIN BULK"]
    out += [f"GRID,{i + 1},,{p:.17g},{q:.17g},0." for i, (p, q) in enumerate(x)]
    out += [f"CBAR,{e + 1},1,{e + 1},{e + 2},0.,0.,1." for e in range(NA + NB)]
    out += [f"PBAR,1,1,{area:.17g},{inertia:.17g},{inertia:.17g},{2 * inertia:.17g}", "MAT1,1,2.1+11,,0.3,7850.",
            f"CONM2,100,{NA + 1},,0.5\n,1.-4,,1.-4,,,1.-4", "SET1,1,1", f"SET1,2,{NA + NB + 1}", "ENDDATA"]
    path.write_text("\n".join(out) + "\n")


if __name__ == "__main__":
    main()
