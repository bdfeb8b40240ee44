"""Linear stress recovery: maps from the nodal displacement vector to section stresses.

Sign conventions (beam along local x, section point (y, z), m):

- normal stress ``sigma_xx = E du_x/dx - E y d2u_y/dx2 - E z d2u_z/dx2``, i.e.
  ``E eps - E y kappa_z + E z kappa_y`` with ``kappa_z = d rz/dx = d2uy/dx2`` and
  ``kappa_y = d ry/dx = -d2uz/dx2`` (``rz = duy/dx``, ``ry = -duz/dx``). A positive
  curvature d2uy/dx2 puts the +y fibre in compression; a cantilever loaded along -y
  has its +y fibre in tension at the root.
- torsional shear at the section point, ``tau = G r(y, z) d rx/dx`` (sign follows the twist):
  r is the distance from the axis on a circle, twice the distance from the mid-plane across the
  thickness on a rectangle (thin-wall membrane analogy; :func:`flexmbd.fe.section.torsion_lever`).
"""

import numpy as np

from flexmbd.fe import element
from flexmbd.fe.assembly import element_dofs, element_lengths

__all__ = ["locate", "strain_rows", "section_stresses", "stress_coefficients", "von_mises"]


def locate(nodes, elements, x):
    """Element containing the position ``x`` (m) along the beam, and the local coordinate there.

    A position exactly on a node belongs to the element on the side away from x = 0
    (the element starting at that node); x = L belongs to the last element.

    Returns
    -------
    e : int
        Element index.
    xi : float
        ``(x - x_start) / l`` in [0, 1].
    l : float
        Element length, m.
    """
    x0, x1 = nodes[elements[:, 0], 0], nodes[elements[:, 1], 0]
    if not (x0.min() <= x <= x1.max()):
        raise ValueError(f"stress point x = {x} m lies outside the beam [{x0.min()}, {x1.max()}]")
    inside = np.flatnonzero((x0 <= x) & (x < x1))
    e = int(inside[0]) if inside.size else int(np.argmax(x1))
    l = element_lengths(nodes, elements[e:e + 1])[0]
    return e, (x - x0[e]) / l, l


def _hermite_dd(xi, l):
    """Second x-derivatives (4,) of the cubic Hermite shape functions, x-y convention.

    ``v(x) = N1 v1 + N2 theta1 + N3 v2 + N4 theta2`` with ``theta = dv/dx``; units 1/m^2, 1/m.
    """
    return np.array([(12.0 * xi - 6.0) / l**2, (6.0 * xi - 4.0) / l,
                     (6.0 - 12.0 * xi) / l**2, (6.0 * xi - 2.0) / l])


def _curvatures_hermite(xi, l):
    """Rows (12,) mapping element DOFs to kappa_z = d2uy/dx2 and kappa_y = -d2uz/dx2 (1/m)."""
    dd = _hermite_dd(xi, l)
    kz, ky = np.zeros(12), np.zeros(12)
    kz[element.BENDING_XY] = dd
    ky[element.BENDING_XZ] = -dd * np.array([1.0, -1.0, 1.0, -1.0])
    return kz, ky


def _curvatures_from_moments(E, G, sec, xi, l):
    """Curvature rows (12,) of the Timoshenko element, from its end moments.

    Without distributed load the bending moment is linear along the element, so
    ``E I kappa(xi) = -(1 - xi) f_1 + xi f_2`` with ``f = k_e u_e`` the nodal end moments.
    For the Euler-Bernoulli element this equals the Hermite curvature.
    """
    k = element.stiffness(E, G, sec, l, shear=True)
    kz = (-(1.0 - xi) * k[5] + xi * k[11]) / (E * sec.Iz)
    ky = (-(1.0 - xi) * k[4] + xi * k[10]) / (E * sec.Iy)
    return kz, ky


def curvature_rows(E, G, sec, xi, l, shear=False):
    """(kappa_z, kappa_y) rows (12,) on an element's local DOFs at station xi in [0, 1] of an
    element of length l: the Hermite curvatures, or with `shear` the Timoshenko element's, from
    its end moments (the two agree for an Euler-Bernoulli section)."""
    return _curvatures_from_moments(E, G, sec, xi, l) if shear else _curvatures_hermite(xi, l)


def strain_rows(nodes, elements, E, G, sec, x, shear=False):
    """Linear maps (4, 6N) from the nodal displacements u (6N,) to the section strains at ``x``:
    rows [eps, kappa_y, kappa_z, twist rate] (1, 1/m, 1/m, rad/m).

    Evaluated in the element containing ``x`` (see :func:`locate`) with its shape functions:
    linear for axial strain and twist rate, cubic Hermite for the curvatures (which vary
    linearly within the element). With ``shear=True`` the curvatures are those of the
    Timoshenko element (bending moment from its end forces, also linear).
    """
    e, xi, l = locate(nodes, elements, x)
    rows = np.zeros((4, 12))
    rows[0, element.AXIAL] = np.array([-1.0, 1.0]) / l
    rows[3, element.TORSION] = np.array([-1.0, 1.0]) / l
    kz, ky = curvature_rows(E, G, sec, xi, l, shear)
    rows[1], rows[2] = ky, kz
    out = np.zeros((4, 6 * nodes.shape[0]))
    out[:, element_dofs(elements[e:e + 1])[0]] = rows
    return out


def section_stresses(strains, E, G, sec, fibre=None):
    """Normal and torsional shear stress (sigma, tau), Pa, at the section point ``fibre`` = (y, z)
    (default ``(sec.cy, 0)``) from section strains (..., 4) [eps, kappa_y, kappa_z, twist rate]:
    ``sigma = E (eps - y kappa_z + z kappa_y)``, ``tau = G twist r(y, z)`` (see
    :func:`flexmbd.fe.section.torsion_lever`)."""
    from flexmbd.fe.section import torsion_lever
    y, z = (sec.cy, 0.0) if fibre is None else (float(fibre[0]), float(fibre[1]))
    s = np.asarray(strains)
    sigma = E * (s[..., 0] - y * s[..., 2] + z * s[..., 1])
    tau = G * torsion_lever(sec, y, z) * s[..., 3]
    return sigma, tau


def stress_coefficients(nodes, elements, E, G, sec, x, fibre=None, shear=False):
    """Linear maps (6N,) from the nodal displacements u to (sigma, tau) at the section point
    ``fibre`` of the section at ``x``: :func:`section_stresses` of :func:`strain_rows`.

    Returns
    -------
    c_sigma : (6N,) ndarray
        ``sigma_xx = c_sigma @ u``, Pa per (m or rad).
    c_tau : (6N,) ndarray
        Torsional shear at the point, ``tau = c_tau @ u``, Pa per rad.
    """
    rows = strain_rows(nodes, elements, E, G, sec, x, shear)
    return section_stresses(rows.T, E, G, sec, fibre)


def von_mises(sigma, tau):
    """Von Mises equivalent stress ``sqrt(sigma^2 + 3 tau^2)`` (Pa), elementwise on arrays."""
    return np.sqrt(np.square(sigma) + 3.0 * np.square(tau))
