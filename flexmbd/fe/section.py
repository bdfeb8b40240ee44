"""Beam cross-section properties (SI units).

Section axes are the local y and z axes of the beam (the beam runs along local x).
For a rectangle, ``h`` is the extent along y and ``b`` the extent along z, so
``Iz = b h^3 / 12`` governs bending in the x-y plane (displacement uy, rotation rz)
and ``Iy = h b^3 / 12`` bending in the x-z plane (displacement uz, rotation ry).
"""

from dataclasses import dataclass

import numpy as np

__all__ = ["Section", "rectangle", "circle", "torsion_lever"]

# shear correction factors (Timoshenko): 5/6 for a solid rectangle, 6/7 for a solid
# circle (Cowper's 6(1+nu)/(7+6nu) at nu = 0; 0.857, vs 0.886 at nu = 0.3)
K_SHEAR_RECTANGLE = 5.0 / 6.0
K_SHEAR_CIRCLE = 6.0 / 7.0


@dataclass(frozen=True)
class Section:
    """Cross-section constants of a straight prismatic beam.

    Attributes
    ----------
    A : float
        Area, m^2.
    Iy, Iz : float
        Second moments of area about the local y and z axes, m^4
        (``Iz`` for bending in x-y, ``Iy`` for bending in x-z).
    J : float
        St Venant torsion constant, m^4 (torsional stiffness G J).
    Ip : float
        Polar second moment ``Iy + Iz``, m^4 (torsional rotary inertia rho Ip).
    ky, kz : float
        Shear correction factors for shear along y and z (5/6 rectangle, 6/7 circle).
    cy, cz : float
        Outer-fibre distances along y and z, m.
    tau_factor : float
        Outer-fibre torsional shear stress per unit torque, 1/m^3: ``tau = T * tau_factor``.
    shape : str
        ``"rectangle"`` or ``"circle"``.
    """

    A: float
    Iy: float
    Iz: float
    J: float
    Ip: float
    ky: float
    kz: float
    cy: float
    cz: float
    tau_factor: float
    shape: str


def _positive(**sizes):
    """Raise ValueError unless every given size is a finite positive number."""
    for name, v in sizes.items():
        if not (np.isfinite(v) and v > 0):
            raise ValueError(f"section size {name} must be positive and finite, got {v!r}")


def rectangle_torsion_constant(b, h):
    """St Venant torsion constant of a solid b x h rectangle, m^4.

    ``J = a t^3 (1/3 - 0.21 (t/a) (1 - t^4 / (12 a^4)))`` with ``a = max(b, h)``,
    ``t = min(b, h)`` (Roark; within about 0.5 % of the series solution).
    """
    a, t = max(b, h), min(b, h)
    return a * t**3 * (1.0 / 3.0 - 0.21 * (t / a) * (1.0 - t**4 / (12.0 * a**4)))


def rectangle(b, h):
    """Solid rectangle, width ``b`` along z and height ``h`` along y (m).

    Parameters
    ----------
    b, h : float
        Extent along local z and local y, m.

    Returns
    -------
    Section
        ``tau_factor = t / J`` (t = smaller side): exact for thin rectangles,
        conservative for thick ones (over-predicts the peak torsional shear by
        about 18 % at b/h = 2/3 and 48 % for a square).
    """
    _positive(b=b, h=h)
    Iy, Iz = h * b**3 / 12.0, b * h**3 / 12.0
    J = rectangle_torsion_constant(b, h)
    return Section(A=b * h, Iy=Iy, Iz=Iz, J=J, Ip=Iy + Iz,
                   ky=K_SHEAR_RECTANGLE, kz=K_SHEAR_RECTANGLE,
                   cy=h / 2.0, cz=b / 2.0, tau_factor=min(b, h) / J, shape="rectangle")


def circle(d):
    """Solid circle of diameter ``d`` (m): ``J = Ip = pi d^4 / 32``, ``tau_factor = (d/2) / J``."""
    _positive(d=d)
    I = np.pi * d**4 / 64.0
    J = 2.0 * I
    return Section(A=np.pi * d**2 / 4.0, Iy=I, Iz=I, J=J, Ip=J,
                   ky=K_SHEAR_CIRCLE, kz=K_SHEAR_CIRCLE,
                   cy=d / 2.0, cz=d / 2.0, tau_factor=(d / 2.0) / J, shape="circle")


def torsion_lever(sec: Section, y: float, z: float, terms: int = 400) -> float:
    """Saint-Venant torsional shear per unit G * twist rate at the section point (y, z), m:
    ``tau = G (d rx/dx) torsion_lever``.

    Circle: the distance from the axis. Rectangle (half-sides a <= b, u across the thickness,
    w along the long side): the gradient of Prandtl's stress function (Timoshenko & Goodier,
    Theory of Elasticity, section 109),
    ``phi / (G twist) = (32 a^2 / pi^3) sum_n odd (-1)^((n-1)/2) / n^3
    (1 - cosh(n pi w / 2a) / cosh(n pi b / 2a)) cos(n pi u / 2a)``; at the middle of a long side
    it is 2a (1 - sum 8 / (pi^2 n^2 cosh(n pi b / 2a))), 2a for a thin rectangle."""
    if sec.shape == "circle":
        return float(np.hypot(y, z))
    u, w, a, b = (y, z, sec.cy, sec.cz) if sec.cy <= sec.cz else (z, y, sec.cz, sec.cy)
    n = np.arange(1, 2 * terms, 2, dtype=float)
    k = n * np.pi / (2.0 * a)
    sign = np.where((n - 1) % 4 == 0, 1.0, -1.0)
    ch = np.exp(k * (abs(w) - b)) * (1.0 + np.exp(-2.0 * k * abs(w))) / (1.0 + np.exp(-2.0 * k * b))  # cosh ratio
    sh = np.sign(w) * np.exp(k * (abs(w) - b)) * (1.0 - np.exp(-2.0 * k * abs(w))) / (1.0 + np.exp(-2.0 * k * b))
    c = 16.0 * a / np.pi ** 2 * sign / n ** 2
    d_du = -2.0 * u + np.sum(c * ch * np.sin(k * u))       # -2u: the thin strip's series, summed
    d_dw = -np.sum(c * sh * np.cos(k * u))
    return float(np.hypot(d_du, d_dw))
