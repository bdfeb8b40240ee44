"""Writes cases/meshes/brick.inp, the mesh cases/brick_pendulum.toml reads: a 0.3 x 0.01 x 0.04 m
aluminium block (x from 0 to 0.3, y and z centred) of 20 x 1 x 3 cells, each split into six
quadratic tetrahedra (C3D10; flexmbd.fe.mesh.box), with the node sets "hinge" (the face x = 0)
and "tip" (the face x = 0.3) and the material "aluminium" (E = 70 GPa, nu = 0.33,
rho = 2700 kg/m^3). SI units. Run from the repository root:

    .venv/bin/python cases/meshes/make_brick.py
"""

from pathlib import Path

import numpy as np

from flexmbd.fe import mesh

HERE = Path(__file__).resolve().parent


def lines(numbers, per=8) -> list:
    """Comma-separated data lines of at most `per` numbers each."""
    numbers = [str(int(n)) for n in numbers]
    return [", ".join(numbers[k:k + per]) for k in range(0, len(numbers), per)]


def main(path=HERE / "brick.inp") -> None:
    m = mesh.box(0.3, 0.01, 0.04, (20, 1, 3), "tet10")
    out = ["*HEADING", "brick_pendulum: 0.3 x 0.01 x 0.04 m aluminium block, C3D10, SI (cases/meshes/make_brick.py)",
           "*NODE"]
    out += [f"{i + 1}, {x:.17g}, {y:.17g}, {z:.17g}" for i, (x, y, z) in enumerate(m.nodes)]
    out.append("*ELEMENT, TYPE=C3D10, ELSET=BLOCK")
    out += [", ".join(str(int(n) + 1) for n in [e, *row]) for e, row in enumerate(m.cells["tet10"])]
    for name, rows in (("hinge", m.node_sets["x0"]), ("tip", m.node_sets["xL"])):
        out.append(f"*NSET, NSET={name}")
        out += lines(rows + 1)
    out += ["*MATERIAL, NAME=aluminium", "*ELASTIC", "70e9, 0.33", "*DENSITY", "2700."]
    path.write_text("\n".join(out) + "\n")


if __name__ == "__main__":
    main()
