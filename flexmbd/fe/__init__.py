"""Finite-element pre-processor of straight 3-D beams and of solids (SI units).

The chain is a sequence of free functions on plain arrays::

    sec = section.rectangle(b, h)                                     # Section
    nodes, elements = assembly.beam_mesh(L, n_el)                     # (N, 3), (n_el, 2)
    K, M = assembly.beam_matrices(nodes, elements, E, G, rho, sec)    # csr (6N, 6N)
    fixed = modes.boundary_dofs("clamped-free", N)                    # int array
    freq_hz, Phi = modes.normal_modes(K, M, fixed, n)                 # (n,), (6N, n)
    c_sigma, c_tau = stress.stress_coefficients(nodes, elements, E, G, sec, x)

DOF order: node ``p`` owns global DOFs ``6 p + k``, ``k = [ux, uy, uz, rx, ry, rz]``
(translations in m, then rotations in rad); ``rz = +duy/dx`` and ``ry = -duz/dx``.

A solid: `mesh` (the Mesh arrays, the box mesher), `meshfile` (Abaqus, NASTRAN and Gmsh files;
their readers, one module per format, in `meshfiles`),
`solid` (isoparametric elements, assembly, clamped-interface modes, interfaces, stress); docs/fe.md.

It imports the core and the version; nothing of the cases, the harness or the solvers.
"""

from flexmbd.fe import assembly, element, mesh, meshfile, modes, section, solid, stress

__all__ = ["assembly", "element", "mesh", "meshfile", "modes", "section", "solid", "stress"]
