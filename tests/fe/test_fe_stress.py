"""Stress recovery coefficients against statically determinate beam stresses."""

import dataclasses

import numpy as np
import pytest

from flexmbd.fe import assembly, modes, section, stress

pytestmark = pytest.mark.kernel_free

# reference beam (paper section 7.1): steel, 1.5 m, 10 mm (z) x 15 mm (y)
L, B, H = 1.5, 0.01, 0.015
E, NU, RHO = 2.06e11, 0.29, 7820.0
G = E / (2.0 * (1.0 + NU))
SEC = section.rectangle(B, H)
N_EL = 100
TIP = 6 * N_EL


def tip_response(sec, shear=False):
    """Mesh and the static responses (6N, 6) to unit tip loads along each DOF."""
    nodes, elements = assembly.beam_mesh(L, N_EL)
    K, _ = assembly.beam_matrices(nodes, elements, E, G, RHO, sec, shear=shear)
    fixed = modes.boundary_dofs("clamped-free", nodes.shape[0])
    return nodes, elements, modes.static_modes(K, fixed, TIP + np.arange(6))


@pytest.fixture(scope="module")
def rect():
    return tip_response(SEC)


@pytest.fixture(scope="module")
def rect_shear():
    return tip_response(SEC, shear=True)


@pytest.mark.parametrize("x", [0.03, 0.0314, 0.75, L])
def test_bending_stress_tip_load_along_minus_y(rect, x):
    nodes, elements, U = rect
    u = -12.0 * U[:, 1]
    c_sigma, c_tau = stress.stress_coefficients(nodes, elements, E, G, SEC, x, fibre=(H / 2, 0.0))
    # hogging cantilever: the +y fibre is in tension, M c / I
    expected = 12.0 * (L - x) * (H / 2) / SEC.Iz
    assert c_sigma @ u == pytest.approx(expected, rel=1e-6, abs=1e-6 * 47.04e6)
    assert c_tau @ u == 0.0


def test_paper_stress_value(rect):
    nodes, elements, U = rect
    # default fibre (cy, 0)
    c_sigma, _ = stress.stress_coefficients(nodes, elements, E, G, SEC, 0.03)
    assert c_sigma @ (-12.0 * U[:, 1]) == pytest.approx(47.04e6, rel=1e-6)


def test_bending_stress_tip_load_along_minus_z(rect):
    nodes, elements, U = rect
    u = -12.0 * U[:, 2]
    x = 0.03
    c_sigma, _ = stress.stress_coefficients(nodes, elements, E, G, SEC, x, fibre=(0.0, B / 2))
    # +z fibre in tension: 12 * 1.47 * 0.005 / 1.25e-9 = 70.56 MPa
    assert c_sigma @ u == pytest.approx(12.0 * (L - x) * (B / 2) / SEC.Iy, rel=1e-6)
    assert c_sigma @ u == pytest.approx(70.56e6, rel=1e-6)
    c_other, _ = stress.stress_coefficients(nodes, elements, E, G, SEC, x, fibre=(H / 2, 0.0))
    assert abs(c_other @ u) < 1e-6 * 70.56e6


def test_axial_stress(rect):
    nodes, elements, U = rect
    c_sigma, _ = stress.stress_coefficients(nodes, elements, E, G, SEC, 0.4, fibre=(-H / 2, B / 2))
    assert c_sigma @ (1000.0 * U[:, 0]) == pytest.approx(1000.0 / SEC.A, rel=1e-9)


def test_timoshenko_stress_matches_statics(rect_shear):
    nodes, elements, U = rect_shear
    u = -12.0 * U[:, 1] + 7.0 * U[:, 2]
    y, z, x = 0.004, -0.003, 0.0314
    c_sigma, _ = stress.stress_coefficients(nodes, elements, E, G, SEC, x, fibre=(y, z), shear=True)
    expected = 12.0 * (L - x) * y / SEC.Iz - 7.0 * (L - x) * z / SEC.Iy
    assert c_sigma @ u == pytest.approx(expected, rel=1e-6)


def test_timoshenko_coefficients_tend_to_hermite():
    # shear-rigid limit: the end-moment curvature equals the Hermite curvature
    stiff = dataclasses.replace(SEC, ky=1e9, kz=1e9)
    nodes, elements = assembly.beam_mesh(L, 10)
    args = (nodes, elements, E, G, stiff, 0.52)
    c_eb, _ = stress.stress_coefficients(*args, fibre=(0.004, -0.003))
    c_t, _ = stress.stress_coefficients(*args, fibre=(0.004, -0.003), shear=True)
    assert np.abs(c_t - c_eb).max() < 1e-7 * np.abs(c_eb).max()


def test_torsion_circle():
    d, T = 0.02, 5.0
    s = section.circle(d)
    nodes, elements, U = tip_response(s)
    c_sigma, c_tau = stress.stress_coefficients(nodes, elements, E, G, s, 0.2)
    u = T * U[:, 3]
    assert c_tau @ u == pytest.approx(T * (d / 2) / s.J, rel=1e-9)      # 3.18 MPa
    assert c_tau @ u == pytest.approx(3.1831e6, rel=1e-4)
    assert c_sigma @ u == 0.0


def test_torsion_rectangle(rect):
    """Torsional shear at the middle of a long side (the maximum) and of a short side, against
    Saint-Venant's tables (Timoshenko & Goodier, section 109) for h/b = 1.5: tau_max = T /
    (k2 h b^2), k2 = 0.231, with the twist rate T / (G J) of the element's J."""
    nodes, elements, U = rect
    T = 2.0
    theta = T / (G * SEC.J)                                  # twist rate of the FE beam, rad/m
    _, c_long = stress.stress_coefficients(nodes, elements, E, G, SEC, 1.0, fibre=(0.0, SEC.cz))
    _, c_short = stress.stress_coefficients(nodes, elements, E, G, SEC, 1.0, fibre=(SEC.cy, 0.0))
    k1 = SEC.J / (H * B ** 3)                                # 0.196 for h/b = 1.5 (table: 0.196)
    assert k1 == pytest.approx(0.196, abs=2e-3)
    assert c_long @ (T * U[:, 3]) == pytest.approx(G * theta * B * k1 / 0.231, rel=5e-3)
    assert 0.5 < (c_short @ U[:, 3]) / (c_long @ U[:, 3]) < 1.0


def test_torsion_lever_limits():
    """Square: the same shear at the middle of every side (k1/k2 = 0.1406/0.208 side); thin
    strip: 2 x the distance from the mid-plane; zero at the centre and at a corner."""
    sq = section.rectangle(0.02, 0.02)
    assert section.torsion_lever(sq, sq.cy, 0.0) == pytest.approx(0.02 * 0.1406 / 0.2082, rel=2e-3)
    # the series converges slowly on the short sides (|w| = b): 400 terms give 1e-6
    assert section.torsion_lever(sq, 0.0, sq.cz) == pytest.approx(section.torsion_lever(sq, sq.cy, 0.0), rel=1e-5)
    thin = section.rectangle(0.1, 0.001)
    for y in (0.0005, 0.0002, -0.0004):
        assert section.torsion_lever(thin, y, 0.0) == pytest.approx(2 * abs(y), rel=1e-6)
    assert section.torsion_lever(sq, 0.0, 0.0) == 0.0
    assert section.torsion_lever(sq, sq.cy, sq.cz) <= 1e-2 * section.torsion_lever(sq, sq.cy, 0.0)
    assert section.torsion_lever(section.circle(0.02), 0.003, 0.004) == pytest.approx(0.005, rel=1e-15)


def test_node_belongs_to_element_away_from_root():
    nodes, elements = assembly.beam_mesh(L, 10)
    u = np.random.default_rng(0).normal(size=66)
    x_node = nodes[4, 0]
    eps = 1e-9 * (L / 10)
    at = [stress.stress_coefficients(nodes, elements, E, G, SEC, x)[0] @ u
          for x in (x_node - eps, x_node, x_node + eps)]
    # curvature jumps at the node for an arbitrary u; the node value is the right-hand limit
    assert at[1] == pytest.approx(at[2], rel=1e-6)
    assert abs(at[1] - at[0]) > 1e-3 * abs(at[1])
    assert stress.locate(nodes, elements, x_node)[:2] == (4, 0.0)
    assert stress.locate(nodes, elements, L)[:2] == (9, 1.0)


@pytest.mark.parametrize("x", [-1e-9, L + 1e-9, np.nan])
def test_outside_beam_raises(rect, x):
    nodes, elements, _ = rect
    with pytest.raises(ValueError, match="outside"):
        stress.stress_coefficients(nodes, elements, E, G, SEC, x)


def test_von_mises():
    assert stress.von_mises(3.0, 2.0) == pytest.approx(np.sqrt(21.0), rel=1e-15)
    s, t = np.array([1.0, -2.0, 0.0]), np.array([0.0, 1.0, -1.0])
    assert stress.von_mises(s, t) == pytest.approx(np.sqrt([1.0, 7.0, 3.0]), rel=1e-15)
