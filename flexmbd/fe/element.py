"""Matrices of the 2-node, 12-DOF straight 3-D beam element (local frame, SI units).

Element DOF order: ``[ux1, uy1, uz1, rx1, ry1, rz1, ux2, uy2, uz2, rx2, ry2, rz2]``
(translations then rotations, node 1 then node 2); the element runs along local x.

Bending sign convention (right-handed small rotations):

- x-y plane: ``rz = +duy/dx``, DOFs ``(uy1, rz1, uy2, rz2) = (1, 5, 7, 11)``, stiffness ``E Iz``;
- x-z plane: ``ry = -duz/dx``, DOFs ``(uz1, ry1, uz2, ry2) = (2, 4, 8, 10)``, stiffness ``E Iy``.

Both planes use the same 4x4 blocks, written for the x-y convention; the x-z block is the
same block with the rotation rows and columns negated (``S B S``, ``S = diag(1, -1, 1, -1)``).
"""

import numpy as np

__all__ = ["AXIAL", "TORSION", "BENDING_XY", "BENDING_XZ", "shear_parameters",
           "stiffness", "mass_lumped", "mass_consistent", "geometric_stiffness"]

# local DOF index sets of the four uncoupled families
AXIAL = np.array([0, 6])
TORSION = np.array([3, 9])
BENDING_XY = np.array([1, 5, 7, 11])
BENDING_XZ = np.array([2, 4, 8, 10])

# sign flip mapping the x-y bending block onto the x-z plane (ry = -duz/dx)
_S_XZ = np.diag([1.0, -1.0, 1.0, -1.0])


def _bar(c):
    """2x2 block ``c [[1, -1], [-1, 1]]`` of a linear bar (axial or torsion stiffness)."""
    return c * np.array([[1.0, -1.0], [-1.0, 1.0]])


def _bar_mass(c):
    """2x2 consistent mass block ``c / 6 [[2, 1], [1, 2]]`` of a linear bar."""
    return c / 6.0 * np.array([[2.0, 1.0], [1.0, 2.0]])


def _bending_stiffness(EI, l, phi):
    """4x4 bending block, x-y convention, DOFs (v1, theta1, v2, theta2).

    Timoshenko closed form (Przemieniecki) with shear parameter ``phi``;
    ``phi = 0`` gives the Euler-Bernoulli (cubic Hermite) element.
    """
    a, b, c = (4.0 + phi) * l**2, (2.0 - phi) * l**2, 6.0 * l
    B = np.array([[12.0, c, -12.0, c],
                  [c, a, -c, b],
                  [-12.0, -c, 12.0, -c],
                  [c, b, -c, a]])
    return EI / ((1.0 + phi) * l**3) * B


def _hermite_mass(m, l):
    """4x4 consistent mass block of the cubic Hermite element, x-y convention; ``m`` in kg/m."""
    B = np.array([[156.0, 22.0 * l, 54.0, -13.0 * l],
                  [22.0 * l, 4.0 * l**2, 13.0 * l, -3.0 * l**2],
                  [54.0, 13.0 * l, 156.0, -22.0 * l],
                  [-13.0 * l, -3.0 * l**2, -22.0 * l, 4.0 * l**2]])
    return m * l / 420.0 * B


def _place(axial, torsion, xy, xz):
    """Scatter the four family blocks into one (12, 12) element matrix."""
    k = np.zeros((12, 12))
    for dofs, block in ((AXIAL, axial), (TORSION, torsion), (BENDING_XY, xy), (BENDING_XZ, xz)):
        k[np.ix_(dofs, dofs)] = block
    return k


def shear_parameters(E, G, sec, l):
    """Timoshenko shear parameters of an element of length ``l`` (m).

    Returns
    -------
    phi_y, phi_z : float
        ``phi_y = 12 E Iz / (ky G A l^2)`` (x-y bending, shear along y) and
        ``phi_z = 12 E Iy / (kz G A l^2)`` (x-z bending, shear along z); dimensionless.
    """
    phi_y = 12.0 * E * sec.Iz / (sec.ky * G * sec.A * l**2)
    phi_z = 12.0 * E * sec.Iy / (sec.kz * G * sec.A * l**2)
    return phi_y, phi_z


def stiffness(E, G, sec, l, shear=False):
    """Element stiffness matrix.

    Parameters
    ----------
    E, G : float
        Young's and shear moduli, Pa.
    sec : Section
        Cross-section constants.
    l : float
        Element length, m.
    shear : bool
        False: Euler-Bernoulli bending. True: shear-flexible Timoshenko element
        (exact-interpolation closed form, nodally exact for end loads).

    Returns
    -------
    (12, 12) ndarray
        Stiffness in N/m, N, N m/rad (translations m, rotations rad).
    """
    # shear parameters (zero for Euler-Bernoulli)
    phi_y, phi_z = shear_parameters(E, G, sec, l) if shear else (0.0, 0.0)

    # the four uncoupled families
    xy = _bending_stiffness(E * sec.Iz, l, phi_y)
    xz = _S_XZ @ _bending_stiffness(E * sec.Iy, l, phi_z) @ _S_XZ
    return _place(_bar(E * sec.A / l), _bar(G * sec.J / l), xy, xz)


def mass_lumped(rho, sec, l):
    """Diagonal lumped mass matrix (the default mass).

    Each node receives half the element: ``rho A l / 2`` on ux, uy, uz and the slice's
    own rotary inertia ``rho Ip l / 2`` on rx, ``rho Iy l / 2`` on ry, ``rho Iz l / 2`` on rz,
    so the matrix is positive definite.

    Parameters
    ----------
    rho : float
        Density, kg/m^3.
    sec : Section
    l : float
        Element length, m.

    Returns
    -------
    (12, 12) ndarray
        Diagonal, kg and kg m^2.
    """
    node = 0.5 * rho * l * np.array([sec.A, sec.A, sec.A, sec.Ip, sec.Iy, sec.Iz])
    return np.diag(np.tile(node, 2))


def mass_consistent(rho, sec, l):
    """Consistent mass matrix of the Euler-Bernoulli element.

    Includes the linear-interpolation axial mass (``rho A``), torsional mass (``rho Ip``)
    and the cubic-Hermite translational bending mass (``rho A``) in both planes.
    The bending rotary inertia (``rho I``, Rayleigh terms) is *not* included: the
    matrix is the classic Euler-Bernoulli one and is positive definite without it.

    Parameters
    ----------
    rho : float
        Density, kg/m^3.
    sec : Section
    l : float
        Element length, m.

    Returns
    -------
    (12, 12) ndarray
        Symmetric positive definite, kg, kg m, kg m^2.
    """
    m = rho * sec.A
    xy = _hermite_mass(m, l)
    xz = _S_XZ @ _hermite_mass(m, l) @ _S_XZ
    return _place(_bar_mass(m * l), _bar_mass(rho * sec.Ip * l), xy, xz)


def geometric_stiffness(l):
    """(12, 12) geometric stiffness of the element per unit axial force (tension positive), 1/m:
    the Hessian of 1/2 int (uy'^2 + uz'^2) dx over the element DOFs with the cubic Hermite
    interpolation of the transverse displacements (both planes; axial and torsion rows zero).
    With a constant axial force N the element's geometric stiffness is N times this."""
    B = np.array([[36.0, 3.0 * l, -36.0, 3.0 * l],
                  [3.0 * l, 4.0 * l**2, -3.0 * l, -l**2],
                  [-36.0, -3.0 * l, 36.0, -3.0 * l],
                  [3.0 * l, -l**2, -3.0 * l, 4.0 * l**2]]) / (30.0 * l)
    z = np.zeros((2, 2))
    return _place(z, z, B, _S_XZ @ B @ _S_XZ)
