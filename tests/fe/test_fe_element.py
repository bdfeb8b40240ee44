"""Sections, element matrices, assembly and static (nodally exact) deflections."""

import dataclasses

import numpy as np
import pytest

from flexmbd.fe import assembly, element, modes, section

pytestmark = pytest.mark.kernel_free

# reference beam (paper section 7.1): steel, 1.5 m, 10 mm (z) x 15 mm (y)
L, B, H = 1.5, 0.01, 0.015
E, NU, RHO = 2.06e11, 0.29, 7820.0
G = E / (2.0 * (1.0 + NU))
SEC = section.rectangle(B, H)


def rigid_vectors(x):
    """Six rigid-body displacement fields (6N, 6) of nodes at positions x along the beam axis."""
    R = np.zeros((x.size, 6, 6))
    for k in range(6):
        R[:, k, k] = 1.0           # unit translations and rotation components
    R[:, 1, 5] = x                 # rotation about z: uy = +x theta_z
    R[:, 2, 4] = -x                # rotation about y: uz = -x theta_y
    return R.reshape(-1, 6)


# sections

def test_rectangle_constants():
    assert SEC.A == pytest.approx(1.5e-4, rel=1e-14)
    assert SEC.Iz == pytest.approx(B * H**3 / 12, rel=1e-14)   # 2.8125e-9, bending in x-y
    assert SEC.Iy == pytest.approx(H * B**3 / 12, rel=1e-14)   # 1.25e-9, bending in x-z
    assert SEC.Iz == pytest.approx(2.8125e-9, rel=1e-12)
    assert SEC.Ip == pytest.approx(SEC.Iy + SEC.Iz, rel=1e-14)
    assert (SEC.cy, SEC.cz) == (H / 2, B / 2)
    assert SEC.ky == SEC.kz == pytest.approx(5 / 6)
    assert SEC.tau_factor == pytest.approx(B / SEC.J, rel=1e-14)
    assert SEC.shape == "rectangle"


@pytest.mark.parametrize("ratio, beta", [(1.0, 0.1406), (1.5, 0.1958), (2.0, 0.229),
                                         (3.0, 0.263), (5.0, 0.291), (10.0, 0.312)])
def test_rectangle_torsion_constant_matches_table(ratio, beta):
    # J = beta a t^3, beta from the series solution (Timoshenko & Goodier)
    J = section.rectangle(1.0, ratio).J
    assert J / (ratio * 1.0**3) == pytest.approx(beta, rel=5e-3)
    assert section.rectangle(ratio, 1.0).J == J


def test_rectangle_swaps_axes():
    s = section.rectangle(H, B)
    assert (s.Iy, s.Iz, s.cy, s.cz) == pytest.approx((SEC.Iz, SEC.Iy, SEC.cz, SEC.cy), rel=1e-14)


def test_circle_constants():
    d = 0.02
    s = section.circle(d)
    J = np.pi * d**4 / 32
    assert s.J == pytest.approx(J, rel=1e-14) and s.Ip == pytest.approx(J, rel=1e-14)
    assert s.Iy == s.Iz == pytest.approx(J / 2, rel=1e-14)
    assert s.tau_factor == pytest.approx((d / 2) / J, rel=1e-14)
    assert s.ky == s.kz == pytest.approx(6 / 7)


@pytest.mark.parametrize("make", [lambda: section.rectangle(0.0, 0.01),
                                  lambda: section.rectangle(0.01, -1.0),
                                  lambda: section.circle(float("nan"))])
def test_bad_section_sizes_raise(make):
    with pytest.raises(ValueError):
        make()


def test_section_is_frozen():
    with pytest.raises(AttributeError):
        SEC.A = 1.0


# element matrices

@pytest.mark.parametrize("shear", [False, True])
def test_stiffness_symmetric_with_six_rigid_modes(shear):
    l = 0.1
    k = element.stiffness(E, G, SEC, l, shear=shear)
    assert np.array_equal(k, k.T)
    w = np.linalg.eigvalsh(k)
    assert np.sum(np.abs(w) < 1e-12 * w.max()) == 6
    assert np.all(w > -1e-12 * w.max())
    # the exact rigid-body fields (rz = +duy/dx, ry = -duz/dx) are in the null space
    R = rigid_vectors(np.array([0.0, l]))
    assert np.abs(k @ R).max() < 1e-9 * np.abs(k).max()


def test_stiffness_bending_planes_sign_convention():
    # pure end rotation rz2 = +1 bends uy the same way as ry2 = -1 bends uz (Iy = Iz here)
    s = section.circle(0.02)
    k = element.stiffness(E, G, s, 0.2)
    u_xy, u_xz = np.zeros(12), np.zeros(12)
    u_xy[11], u_xz[10] = 1.0, -1.0
    f_xy, f_xz = k @ u_xy, k @ u_xz
    assert f_xy[[1, 7]] == pytest.approx(f_xz[[2, 8]], rel=1e-14)
    assert f_xy[[5, 11]] == pytest.approx(-f_xz[[4, 10]], rel=1e-14)


def test_timoshenko_tends_to_euler_bernoulli():
    l = 0.05
    # shear-rigid section (huge shear correction factors): phi -> 0
    k_eb = element.stiffness(E, G, SEC, l)
    k_t = element.stiffness(E, G, dataclasses.replace(SEC, ky=1e9, kz=1e9), l, shear=True)
    assert np.abs(k_t - k_eb).max() < 1e-7 * np.abs(k_eb).max()
    k_shear = element.stiffness(E, G, SEC, l, shear=True)
    assert np.abs(k_shear - k_eb).max() > 1e-3 * np.abs(k_eb).max()
    phi_y, phi_z = element.shear_parameters(E, G, SEC, l)
    assert phi_y == pytest.approx(12 * E * SEC.Iz / (5 / 6 * G * SEC.A * l**2), rel=1e-14)
    assert phi_z / phi_y == pytest.approx(SEC.Iy / SEC.Iz, rel=1e-14)


def test_lumped_mass_diagonal():
    l = 0.02
    m = element.mass_lumped(RHO, SEC, l)
    half = RHO * l / 2
    node = half * np.array([SEC.A, SEC.A, SEC.A, SEC.Ip, SEC.Iy, SEC.Iz])
    assert np.array_equal(m, np.diag(np.diag(m)))
    assert np.diag(m) == pytest.approx(np.tile(node, 2), rel=1e-14)


def test_consistent_mass_rigid_body_inertia():
    l = 0.3
    m = element.mass_consistent(RHO, SEC, l)
    assert np.array_equal(m, m.T)
    assert np.linalg.eigvalsh(m).min() > 0
    R = rigid_vectors(np.array([0.0, l]))
    inertia = R.T @ m @ R
    # translations: total mass; twist: rho Ip l; rotations about y, z about the first node:
    # rho A l^3 / 3 (translational inertia only: no bending rotary inertia in this matrix)
    expected = RHO * l * np.array([SEC.A, SEC.A, SEC.A, SEC.Ip, SEC.A * l**2 / 3, SEC.A * l**2 / 3])
    assert np.diag(inertia) == pytest.approx(expected, rel=1e-12)
    # the y-translation / z-rotation coupling has the sign of uy = +x theta_z, and uz = -x theta_y
    assert inertia[1, 5] == pytest.approx(RHO * SEC.A * l**2 / 2, rel=1e-12)
    assert inertia[2, 4] == pytest.approx(-RHO * SEC.A * l**2 / 2, rel=1e-12)


# assembly

def test_beam_mesh():
    nodes, elements = assembly.beam_mesh(L, 4)
    assert nodes.shape == (5, 3) and elements.shape == (4, 2)
    assert nodes[:, 0] == pytest.approx([0, 0.375, 0.75, 1.125, 1.5])
    assert np.array_equal(elements, [[0, 1], [1, 2], [2, 3], [3, 4]])
    assert elements.dtype.kind == "i"
    with pytest.raises(ValueError):
        assembly.beam_mesh(L, 0)


@pytest.mark.parametrize("mass", ["lumped", "consistent"])
def test_assembled_matrices(mass):
    nodes, elements = assembly.beam_mesh(L, 10)
    K, M = assembly.beam_matrices(nodes, elements, E, G, RHO, SEC, mass=mass)
    assert K.shape == M.shape == (66, 66) and K.format == M.format == "csr"
    assert abs(K - K.T).max() == 0 and abs(M - M.T).max() == 0
    R = rigid_vectors(nodes[:, 0])
    assert np.abs(K @ R).max() < 1e-9 * abs(K).max()
    inertia = R.T @ (M @ R)
    assert inertia[0, 0] == pytest.approx(RHO * SEC.A * L, rel=1e-12)
    assert inertia[3, 3] == pytest.approx(RHO * SEC.Ip * L, rel=1e-12)


def test_assembly_rejects_misaligned_elements():
    nodes, elements = assembly.beam_mesh(L, 3)
    nodes[2, 1] = 0.01
    with pytest.raises(ValueError):
        assembly.assemble(nodes, elements, lambda l: np.eye(12))
    with pytest.raises(ValueError):
        assembly.beam_matrices(*assembly.beam_mesh(L, 3), E, G, RHO, SEC, mass="diagonal")


# static deflection: Hermite and exact-interpolation Timoshenko elements are nodally exact

@pytest.fixture(scope="module")
def cantilever():
    nodes, elements = assembly.beam_mesh(L, 100)
    fixed = modes.boundary_dofs("clamped-free", nodes.shape[0])
    tip = 6 * (nodes.shape[0] - 1)
    return nodes, elements, fixed, tip


@pytest.mark.parametrize("shear", [False, True])
def test_tip_deflection(cantilever, shear):
    nodes, elements, fixed, tip = cantilever
    K, _ = assembly.beam_matrices(nodes, elements, E, G, RHO, SEC, shear=shear)
    U = modes.static_modes(K, fixed, [tip + 1, tip + 2])
    P = 12.0
    uy, uz = -P * U[tip + 1, 0], P * U[tip + 2, 1]     # 12 N along -y, then along +z
    shear_y = P * L / (SEC.ky * G * SEC.A) if shear else 0.0
    shear_z = P * L / (SEC.kz * G * SEC.A) if shear else 0.0
    assert uy == pytest.approx(-(P * L**3 / (3 * E * SEC.Iz) + shear_y), rel=1e-6)
    assert uz == pytest.approx(P * L**3 / (3 * E * SEC.Iy) + shear_z, rel=1e-6)
    if not shear:
        assert uy == pytest.approx(-23.30e-3, rel=1e-3)
        assert uz == pytest.approx(52.43e-3, rel=1e-3)
    # the Timoshenko result really is larger by the shear term (5e-5 relative here)
    assert (uz - P * L**3 / (3 * E * SEC.Iy) > 1e-7) == shear
    # the tip rotation of the x-z plane is ry = -duz/dx < 0 for a load along +z
    assert U[tip + 4, 1] < 0 < U[tip + 5, 0]
