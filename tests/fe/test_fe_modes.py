"""Normal modes, boundary conditions, convergence, Craig-Bampton sets and labels."""

import numpy as np
import pytest

from flexmbd.fe import assembly, modes, section

pytestmark = pytest.mark.kernel_free

# reference beam (paper section 7.1): steel, 1.5 m, 10 mm (z) x 15 mm (y)
L, B, H = 1.5, 0.01, 0.015
E, NU, RHO = 2.06e11, 0.29, 7820.0
G = E / (2.0 * (1.0 + NU))
SEC = section.rectangle(B, H)

# beta_n L of the clamped-free and free-free Euler-Bernoulli beam
BETA_CF = [1.8751040687, 4.6940911330, 7.8547574382, 10.9955407349]
BETA_FF = [4.7300407449, 7.8532046241]


def eb_hz(beta_l, I, sec=SEC):
    """Euler-Bernoulli frequency (Hz) for a root beta_n L and second moment I."""
    return beta_l**2 / L**2 * np.sqrt(E * I / (RHO * sec.A)) / (2 * np.pi)


def family(freq, labels, name):
    """Frequencies of the modes labelled ``name 1``, ``name 2``, ... in order."""
    return np.array([f for f, s in zip(freq, labels) if s.rsplit(" ", 1)[0] == name])


def model(n_el, mass="lumped", sec=SEC):
    nodes, elements = assembly.beam_mesh(L, n_el)
    K, M = assembly.beam_matrices(nodes, elements, E, G, RHO, sec, mass=mass)
    return nodes.shape[0], K, M


def orthonormality_error(Phi, M):
    return np.abs(Phi.T @ (M @ Phi) - np.eye(Phi.shape[1])).max()


@pytest.fixture(scope="module")
def ref100():
    return model(100)


@pytest.fixture(scope="module")
def clamped12(ref100):
    N, K, M = ref100
    return modes.normal_modes(K, M, modes.boundary_dofs("clamped-free", N), 12)


# boundary conditions

def test_boundary_dofs():
    assert modes.boundary_dofs("clamped-free", 5).tolist() == [0, 1, 2, 3, 4, 5]
    assert modes.boundary_dofs("hinged-hinged", 5).tolist() == [0, 1, 2, 3, 25, 26]
    assert modes.boundary_dofs("free-free", 5).size == 0
    with pytest.raises(ValueError):
        modes.boundary_dofs("clamped-clamped", 5)


# clamped-free

def test_clamped_free_frequencies(clamped12, ref100):
    freq, Phi = clamped12
    # paper values
    paper = [3.685, 5.527, 23.09, 34.64, 64.66, 96.99]
    assert np.all(np.abs(freq[:6] / paper - 1) < 3e-3)
    # Euler-Bernoulli closed form, planes alternating (Iy < Iz: x-z first)
    closed = [eb_hz(BETA_CF[n], I) for n in range(3) for I in (SEC.Iy, SEC.Iz)]
    assert np.all(np.abs(freq[:6] / closed - 1) < 1e-3)
    assert orthonormality_error(Phi, ref100[2]) < 1e-10
    assert np.all(Phi[:6] == 0)


def test_clamped_free_labels(clamped12, ref100):
    freq, Phi = clamped12
    expected = ["bending xz 1", "bending xy 1", "bending xz 2", "bending xy 2",
                "bending xz 3", "bending xy 3", "bending xz 4", "bending xy 4",
                "bending xz 5", "bending xz 6", "bending xy 5", "bending xz 7"]
    assert modes.mode_labels(Phi, ref100[2]) == expected
    assert modes.mode_labels(Phi) == expected
    assert freq[0] == pytest.approx(3.685, rel=1e-3) and freq[1] == pytest.approx(5.527, rel=1e-3)


def test_torsion_and_axial_labels():
    # a short stubby beam: torsion and axial modes among the lowest
    N, K, M = model(20, sec=section.rectangle(0.2, 0.3))
    freq, Phi = modes.normal_modes(K, M, modes.boundary_dofs("clamped-free", N), 8)
    labels = modes.mode_labels(Phi, M)
    assert "torsion 1" in labels and "axial 1" in labels
    # fixed-free torsion and axial closed forms (J from the Roark formula)
    s = section.rectangle(0.2, 0.3)
    f_t = np.sqrt(G * s.J / (RHO * s.Ip)) / (4 * L)
    f_a = np.sqrt(E / RHO) / (4 * L)
    assert family(freq, labels, "torsion")[0] == pytest.approx(f_t, rel=2e-3)
    assert family(freq, labels, "axial")[0] == pytest.approx(f_a, rel=2e-3)


# hinged-hinged

def test_hinged_hinged_bending(ref100):
    N, K, M = ref100
    freq, Phi = modes.normal_modes(K, M, modes.boundary_dofs("hinged-hinged", N), 10)
    labels = modes.mode_labels(Phi, M)
    n = np.arange(1, 5)
    for name, I in (("bending xy", SEC.Iz), ("bending xz", SEC.Iy)):
        closed = (n * np.pi / L) ** 2 * np.sqrt(E * I / (RHO * SEC.A)) / (2 * np.pi)
        assert np.all(np.abs(family(freq, labels, name)[:4] / closed - 1) < 3e-3)
    assert orthonormality_error(Phi, M) < 1e-10


# convergence of the first clamped-free frequency: h^2 lumped, h^4 consistent

@pytest.mark.parametrize("mass, low, high", [("lumped", 1.8, 2.2), ("consistent", 3.6, 4.4)])
def test_convergence_rate(mass, low, high):
    n_el = np.array([4, 8, 16, 32])
    exact = eb_hz(BETA_CF[0], SEC.Iy)
    err = []
    for n in n_el:
        N, K, M = model(n, mass)
        f, _ = modes.normal_modes(K, M, modes.boundary_dofs("clamped-free", N), 1)
        err.append(abs(f[0] / exact - 1))
    slope = np.polyfit(np.log(L / n_el), np.log(err), 1)[0]
    assert low < slope < high


# free-free and Craig-Bampton

def test_free_free_excludes_rigid_modes(ref100):
    N, K, M = ref100
    freq, Phi = modes.normal_modes(K, M, [], 4)
    closed = [eb_hz(BETA_FF[0], SEC.Iy), eb_hz(BETA_FF[0], SEC.Iz),
              eb_hz(BETA_FF[1], SEC.Iy), eb_hz(BETA_FF[1], SEC.Iz)]
    assert np.all(np.abs(freq / closed - 1) < 1e-3)
    assert orthonormality_error(Phi, M) < 1e-10
    expected = ["bending xz 1", "bending xy 1", "bending xz 2", "bending xy 2"]
    assert modes.mode_labels(Phi, M) == expected


def test_craig_bampton_free_free(ref100):
    N, K, M = ref100
    iface = np.r_[0:6, 6 * (N - 1):6 * N]
    basis = modes.craig_bampton(K, M, [], iface, 20)
    assert basis.shape == (6 * N, 32)
    freq, Phi = modes.orthonormalize(K, M, basis)
    assert Phi.shape == (6 * N, 32)
    assert orthonormality_error(Phi, M) < 1e-10
    Kr = Phi.T @ (K @ Phi)
    assert np.abs(Kr - np.diag(np.diag(Kr))).max() < 1e-10 * np.abs(Kr).max()
    assert np.diag(Kr)[6:] == pytest.approx((2 * np.pi * freq[6:]) ** 2, rel=1e-8)
    # six rigid-body directions at ~0 Hz, then the free-free elastic modes
    assert np.all(freq[:6] < 1e-2) and freq[6] > 1.0
    assert modes.mode_labels(Phi[:, :8], M)[:6] == ["rigid"] * 6
    f_ff, _ = modes.normal_modes(K, M, [], 2)
    assert np.all(np.abs(freq[6:8] / f_ff - 1) < 5e-3)


def test_constraint_modes_are_rigid_for_one_interface_node(ref100):
    # one free-free interface node: the constraint modes are the rigid-body motions about it
    N, K, M = ref100
    x = np.linspace(0, L, N)
    R = np.zeros((N, 6, 6))
    R[:, np.arange(6), np.arange(6)] = 1.0
    R[:, 1, 5] = x                 # rotation about z drags uy = +x
    R[:, 2, 4] = -x                # rotation about y drags uz = -x
    Psi = modes.constraint_modes(K, [], np.arange(6))
    # (K_ff has cond ~ 3e9: static solutions are good to ~1e-8 relative)
    assert np.abs(Psi - R.reshape(-1, 6)).max() < 1e-7 * L


def test_hold_node_takes_out_the_nodes_rigid_motion(ref100, clamped12):
    N, K, M = ref100
    nodes = np.c_[np.linspace(0, L, N), np.zeros(N), np.zeros(N)]
    p = 30
    R = modes.rigid_body_fields(nodes, p)
    assert np.array_equal(R[6 * p:6 * p + 6], np.eye(6))
    assert np.abs(K @ R).max() < 1e-14 * np.abs(K).max()
    _, Phi = modes.normal_modes(K, M, [], 4)
    held = modes.hold_node(Phi + R[:, :4], nodes, p)      # rigid parts come out too
    assert not np.any(held[6 * p:6 * p + 6])
    assert np.abs(held - modes.hold_node(Phi, nodes, p)).max() < 1e-12 * np.abs(Phi).max()
    Kr, Kh = Phi.T @ (K @ Phi), held.T @ (K @ held)
    assert np.abs(Kh - Kr).max() < 1e-9 * np.abs(Kr).max()          # (K: cond ~ 3e9)
    # held at the clamped node, clamped modes are unchanged
    assert np.array_equal(modes.hold_node(clamped12[1], nodes, 0), clamped12[1])


def test_constraint_modes_static_condensation(ref100):
    N, K, M = ref100
    iface = np.r_[6 * 50:6 * 51, 6 * (N - 1) + 1]
    Psi = modes.constraint_modes(K, modes.boundary_dofs("clamped-free", N), iface)
    assert np.array_equal(Psi[iface], np.eye(iface.size))
    interior = np.setdiff1d(np.arange(6, 6 * N), iface)
    residual = (K @ Psi)[interior]
    assert np.abs(residual).max() < 1e-6 * np.abs(K @ Psi).max()


def test_orthonormalize_drops_dependent_directions(clamped12, ref100):
    _, Phi = clamped12
    K, M = ref100[1], ref100[2]
    freq, out = modes.orthonormalize(K, M, np.hstack([Phi[:, :3], 2 * Phi[:, :1] - Phi[:, 2:3]]))
    assert out.shape[1] == 3
    assert freq == pytest.approx(clamped12[0][:3], rel=1e-8)


# solver paths and errors

def test_sparse_path_matches_dense(clamped12, ref100):
    N, K, M = ref100
    freq, Phi = modes.normal_modes(K, M, modes.boundary_dofs("clamped-free", N), 12, dense_limit=0)
    # the lowest eigenvalues of this K (cond ~ 3e9) are only determined to ~1e-9 relative
    assert freq == pytest.approx(clamped12[0], rel=1e-8)
    assert np.abs(Phi - clamped12[1]).max() < 1e-8 * np.abs(Phi).max()
    assert orthonormality_error(Phi, M) < 1e-10


def test_too_many_modes_raise():
    N, K, M = model(1)
    with pytest.raises(ValueError, match="free DOFs"):
        modes.normal_modes(K, M, modes.boundary_dofs("clamped-free", N), 7)
    with pytest.raises(ValueError, match="elastic"):
        modes.normal_modes(K, M, [], 7)     # 12 DOFs, 6 of them rigid
    assert modes.normal_modes(K, M, [], 6)[0].size == 6


def test_circle_equal_frequencies_are_split_by_plane():
    s = section.circle(0.02)
    N, K, M = model(40, "consistent", sec=s)
    freq, Phi = modes.normal_modes(K, M, modes.boundary_dofs("clamped-free", N), 4)
    assert freq[0] == pytest.approx(freq[1], rel=1e-10)
    assert freq[0] == pytest.approx(eb_hz(BETA_CF[0], s.Iz, sec=s), rel=1e-6)
    expected = ["bending xy 1", "bending xz 1", "bending xy 2", "bending xz 2"]
    assert modes.mode_labels(Phi, M) == expected
    # each mode lies entirely in one plane
    share_xy = (Phi * (M @ Phi)).reshape(N, 6, 4)[:, [1, 5]].sum(axis=(0, 1))
    assert share_xy == pytest.approx([1, 0, 1, 0], abs=1e-10)
    # also when n cuts through an equal-frequency pair
    _, Phi3 = modes.normal_modes(K, M, modes.boundary_dofs("clamped-free", N), 3)
    assert np.abs(Phi3 - Phi[:, :3]).max() < 1e-8 * np.abs(Phi).max()
