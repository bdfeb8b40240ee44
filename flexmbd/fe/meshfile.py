"""Solid meshes from Abaqus (.inp), NASTRAN bulk data (.bdf, .nas, .dat) and Gmsh (.msh) files, and
frames (bar elements) from NASTRAN files: the entry, which picks the reader by the file's suffix.

    mesh = meshfile.read("arm.inp", units="mm")                  # Mesh (fe.mesh), always SI
    clamp = meshfile.node_set(mesh, "clamp")                      # (k,) node rows
    K = meshfile.read_mtx("arm_STIF2.mtx", mesh.node_ids, "mm")   # csr (3N, 3N), SI

Units: `units="m"` reads the file as SI (m, N, kg, s, Pa); `units="mm"` as the consistent mm-t-s
system (mm, N, t, s, MPa). The Mesh is always SI: nodes in m, E in Pa, rho in kg/m^3. After the
conversion every material's wave speed sqrt(E/rho) must lie within 10 to 20000 m/s, else the
numbers do not match the units and the file is refused (`meshfiles.convert`).

Element kinds (node orders: fe.mesh; flexmbd integrates every element fully, so the reduced (R),
hybrid (H), modified (M) and incompatible-mode (I) variants are read as the plain element's
geometry):

    tet4   Abaqus C3D4                       NASTRAN CTETRA, 4 grids    Gmsh tetra (4)
    tet10  Abaqus C3D10, C3D10M, C3D10H      NASTRAN CTETRA, 10 grids   Gmsh tetra10 (11)
    hex8   Abaqus C3D8, C3D8R, C3D8H, C3D8I  NASTRAN CHEXA, 8 grids     Gmsh hexahedron (5)
    hex20  Abaqus C3D20, C3D20R, C3D20H      NASTRAN CHEXA, 20 grids    Gmsh hexahedron20 (17)

What each format's reader reads: the package `meshfiles` (`abaqus`, `nastran`, `gmsh`, and `matrix`
for `read_mtx`), whose modules each fill one record (`meshfiles.records.Parsed`) that
`meshfiles.convert` checks and converts. Bad input raises InputError with a one-line message
"FILE:LINE: what" (or "FILE: what").
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from flexmbd.core.errors import InputError
from flexmbd.fe.mesh import Mesh
from flexmbd.fe.meshfiles import abaqus, convert, gmsh, nastran
from flexmbd.fe.meshfiles.common import UNITS, check_units
from flexmbd.fe.meshfiles.matrix import read_mtx

__all__ = ["read", "read_mtx", "node_set", "UNITS"]

# a file's suffix (lower case) -> the reader of its format: source -> records.Parsed
READERS = {".inp": abaqus.parse, ".bdf": nastran.parse, ".nas": nastran.parse, ".dat": nastran.parse,
           ".msh": gmsh.parse}


def read(path, units: str = "m") -> Mesh:
    """The mesh of an Abaqus (.inp), NASTRAN (.bdf, .nas, .dat) or Gmsh (.msh) file, in SI.

    `units` is the file's unit system: "m" (m, N, kg, s, Pa) or "mm" (mm, N, t, s, MPa).
    Raises InputError for a file that cannot be read or is not a valid solid mesh or frame.
    """
    source = str(path)
    check_units(source, units)
    suffix = Path(source).suffix.lower()
    if suffix not in READERS:
        raise InputError(f"{source}: unknown mesh file type {suffix or '(no suffix)'!r} (supported: .inp Abaqus, "
                         ".bdf/.nas/.dat NASTRAN bulk data, .msh Gmsh)")
    return convert.mesh(READERS[suffix](source), units)


def node_set(mesh: Mesh, name: str) -> np.ndarray:
    """The rows (k,) of the mesh's node set `name`; InputError naming the sets there are if none."""
    if name not in mesh.node_sets:
        have = ", ".join(sorted(mesh.node_sets)) or "no node sets"
        raise InputError(f"{mesh.source}: node set {name!r} not found (it has: {have})")
    return mesh.node_sets[name]
