"""Frames (fe.frame) and their NASTRAN cards (fe.meshfile): a straight CBAR cantilever assembles to
the beam's own matrices; turned anywhere it keeps its frequencies; an L-frame and a tip-loaded
cantilever deflect and stress as the closed forms of Euler-Bernoulli beams (nodally exact for end
loads); the cards' fields and every refusal."""

import numpy as np
import pytest
import scipy.linalg as sl
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from flexmbd.fe import assembly, frame, meshfile, modes, section, solid
from flexmbd.fe.mesh import Mesh
from tests.fe.test_fe_meshfile import refused       # one line naming the file and line

EPS = np.finfo(float).eps
E, NU, RHO = 2.1e11, 0.3, 7850.0
G = E / (2.0 * (1.0 + NU))
SEC = section.rectangle(b=0.015, h=0.01)        # h along element y (plane 1), b along element z
TURN = Rotation.from_rotvec([0.3, -0.7, 1.1]).as_matrix()


def bdf(path, nodes, bars, v=(0.0, 1.0, 0.0), sec=SEC, extra="", shear=None) -> str:
    """A NASTRAN file of GRIDs at `nodes` (N, 3), CBARs `bars` [(a, b)] (0-based) with orientation
    vector v, one PBAR of `sec` (I1 = Iz, I2 = Iy; shear factors K1, K2 = `shear` when given) and
    steel."""
    r = lambda x: repr(float(x))                        # every digit, free field
    lines = ["BEGIN BULK"] + [f"GRID,{i + 1},,{r(x)},{r(y)},{r(z)}" for i, (x, y, z) in enumerate(np.asarray(nodes))]
    lines += [f"CBAR,{e + 1},7,{a + 1},{b + 1},{r(v[0])},{r(v[1])},{r(v[2])}" for e, (a, b) in enumerate(bars)]
    lines += [f"PBAR,7,3,{r(sec.A)},{r(sec.Iz)},{r(sec.Iy)},{r(sec.J)}"]
    lines += [",,,,,,,,", f",{r(shear[0])},{r(shear[1])}"] if shear else []
    lines += [f"MAT1,3,{r(E)},,{r(NU)},{r(RHO)}", extra, "ENDDATA"]
    path.write_text("\n".join(lines) + "\n")
    return str(path)


def straight(n=10, length=1.5):
    X = np.c_[np.linspace(0.0, length, n + 1), np.zeros(n + 1), np.zeros(n + 1)]
    return X, [(i, i + 1) for i in range(n)]


def test_a_straight_frame_assembles_to_the_beams_own_matrices(tmp_path):
    X, bars = straight()
    mesh = meshfile.read(bdf(tmp_path / "c.bdf", X, bars))
    K, M = frame.matrices(mesh, E, NU, RHO)
    Kb, Mb = assembly.beam_matrices(X, np.array(bars), E, G, RHO, SEC)
    # element x, y, z are the mesh's: the turn is the identity, so the sums are the same numbers
    assert abs(K - Kb).max() <= 4 * EPS * abs(Kb).max()
    assert abs(M - Mb).max() <= 4 * EPS * abs(Mb).max()


def test_a_turned_frame_keeps_its_frequencies(tmp_path):
    X, bars = straight()
    a = meshfile.read(bdf(tmp_path / "a.bdf", X, bars))
    b = meshfile.read(bdf(tmp_path / "b.bdf", X @ TURN.T + [0.2, 0.1, -0.3], bars, v=TURN @ [0.0, 1.0, 0.0]))
    free = np.arange(6, 6 * len(X))
    lam = []
    for m in (a, b):
        K, M = (A.toarray()[np.ix_(free, free)] for A in frame.matrices(m, E, NU, RHO))
        lam.append(sl.eigh(K, M, eigvals_only=True))
    # a symmetric perturbation of relative size eps moves eigenvalue k by about eps lam_max, so
    # the lowest ones agree to eps lam_max / lam_k; margin 100 (the turned coordinates are
    # rounded to 17 digits, the turn itself to a few eps)
    tol = 100 * EPS * lam[0][-1] / lam[0][:8]
    assert np.all(np.abs(lam[1][:8] / lam[0][:8] - 1.0) <= tol)


def static(mesh, held: int, node: int, load) -> np.ndarray:
    """Displacements (N, 6) of the frame held at `held` under `load` (6,) at `node`, and cond(K)."""
    K, _ = frame.matrices(mesh, E, NU, RHO)
    free = np.setdiff1d(np.arange(K.shape[0]), np.arange(6 * held, 6 * held + 6))
    f = np.zeros(K.shape[0])
    f[6 * node:6 * node + 6] = load
    Kf = K.toarray()[np.ix_(free, free)]
    u = np.zeros(K.shape[0])
    u[free] = np.linalg.solve(Kf, f[free])
    return u.reshape(-1, 6), np.linalg.cond(Kf)


def test_an_l_frame_deflects_as_the_closed_form(tmp_path):
    """Legs a along x and b along y, clamped at the origin, v = z for both (plane 1 the legs'
    out-of-plane bending: I1), loads P at the far end. Out of plane (z): both legs bend and the
    first twists under P b: w = P a^3 / 3EI1 + P b^3 / 3EI1 + P a b^2 / GJ. In plane (x): the
    second leg bends, the first stretches and bends under P b: u = P b^3 / 3EI2 + P a / EA +
    P a b^2 / EI2. Cubic elements are nodally exact under end loads."""
    a, b, n, P = 0.8, 0.5, 8, 10.0
    legs = np.r_[np.c_[np.linspace(0, a, n + 1), np.zeros(n + 1)], np.c_[np.full(n, a), np.linspace(0, b, n + 1)[1:]]]
    X = np.c_[legs, np.zeros(2 * n + 1)]
    mesh = meshfile.read(bdf(tmp_path / "l.bdf", X, [(i, i + 1) for i in range(2 * n)], v=(0.0, 0.0, 1.0)))
    tip = 2 * n
    u, cond = static(mesh, 0, tip, [0.0, 0.0, P, 0.0, 0.0, 0.0])
    w = P * a ** 3 / (3 * E * SEC.Iz) + P * b ** 3 / (3 * E * SEC.Iz) + P * a * b ** 2 / (G * SEC.J)
    assert abs(u[tip, 2] / w - 1.0) <= 10 * EPS * cond        # the solve's relative error bound, margin 10
    u, cond = static(mesh, 0, tip, [P, 0.0, 0.0, 0.0, 0.0, 0.0])
    ux = P * b ** 3 / (3 * E * SEC.Iy) + P * a / (E * SEC.A) + P * a * b ** 2 / (E * SEC.Iy)
    assert abs(u[tip, 0] / ux - 1.0) <= 10 * EPS * cond


@pytest.mark.parametrize("turn", [np.eye(3), TURN])
def test_fibre_stress_of_a_tip_loaded_cantilever_is_the_beam_formula(tmp_path, turn):
    """A cantilever of length L along element x, a tip force P along element z: at station x the
    fibre (y0, z0) carries sigma = -P (L - x) z0 / I2 (the moment bends it about element y), a tip
    force along y gives -P (L - x) y0 / I1, and a tip torque T on a circular bar the shear
    T r / J; the Voigt tensor's von Mises is then |sigma| and sqrt(3) tau."""
    X, bars = straight(6, 1.2)
    mesh = meshfile.read(bdf(tmp_path / "c.bdf", X @ turn.T, bars, v=turn @ [0.0, 1.0, 0.0]))
    x, y0, z0, P = 0.3, 0.004, -0.006, 7.0
    point = turn @ [x, y0, z0]
    rows, dofs = frame.fibre_rows(mesh, E, NU, point)
    for load, want in (([0.0, 0.0, P], -P * (1.2 - x) * z0 / SEC.Iy), ([0.0, P, 0.0], -P * (1.2 - x) * y0 / SEC.Iz)):
        u, cond = static(mesh, 0, 6, np.r_[turn @ load, 0.0, 0.0, 0.0])
        s = rows @ u.ravel()[dofs]
        assert abs(solid.von_mises(s[None])[0] / abs(want) - 1.0) <= 10 * EPS * cond
        sigma = turn.T @ np.array([[s[0], s[5], s[4]], [s[5], s[1], s[3]], [s[4], s[3], s[2]]]) @ turn
        assert abs(sigma[0, 0] / want - 1.0) <= 10 * EPS * cond       # the axial stress, in element axes
    disc = section.circle(0.02)
    mesh = meshfile.read(bdf(tmp_path / "d.bdf", X @ turn.T, bars, v=turn @ [0.0, 1.0, 0.0], sec=disc))
    rows, dofs = frame.fibre_rows(mesh, E, NU, turn @ [x, 0.006, 0.008])
    T = 3.0
    u, cond = static(mesh, 0, 6, np.r_[0.0, 0.0, 0.0, turn @ [T, 0.0, 0.0]])
    vm = solid.von_mises((rows @ u.ravel()[dofs])[None])[0]
    assert abs(vm / (np.sqrt(3.0) * T * 0.01 / disc.J) - 1.0) <= 10 * EPS * cond


def test_nastran_bar_cards(tmp_path):
    """G0 for the orientation, PBEAM (a constant section given at a second station with YESA, its
    shear factors NASTRAN's default 1.0) and PBAR (none: Euler-Bernoulli), large fields and
    continuations, mm units: one mesh."""
    text = "\n".join([
        "BEGIN BULK",
        "GRID*   1                               0.              0.",
        "*       0.",
        "GRID,2,,500.,0.,0.", "GRID,3,,1000.,0.,0.", "GRID,9,,0.,300.,0.",
        "CBEAM,1,4,1,2,9", "CBAR,2,5,2,3,0.,1.,0.",
        "PBEAM,4,1,150.,1.25+3,2.8125+3,0.,2.9+3,0.", ",,,,,,,,", ",YESA,1.",
        "PBAR,5,1,150.,1250.,2812.5,2900.", "MAT1,1,210000.,,0.3,7.85-9", "SET1,1,1", "ENDDATA"])
    path = tmp_path / "mm.bdf"
    path.write_text(text + "\n")
    mesh = meshfile.read(str(path), units="mm")
    assert mesh.is_frame and mesh.cells["bar2"].tolist() == [[0, 1], [1, 2]]
    np.testing.assert_allclose(mesh.nodes[:3, 0], [0.0, 0.5, 1.0], rtol=0, atol=1e-15)
    want = [1.5e-4, 1.25e-9, 2.8125e-9, 2.9e-9]
    np.testing.assert_allclose(mesh.bars[:, :4], [want, want], rtol=1e-14)
    assert mesh.bars[:, 4:6].tolist() == [[1.0, 1.0], [0.0, 0.0]]             # PBEAM: K1 = K2 = 1; PBAR: none
    np.testing.assert_allclose(mesh.bars[0, 6:], [0.0, 300.0, 0.0])          # G0 9: x_G0 - x_GA, file units
    assert mesh.materials["mat1"] == pytest.approx((2.1e11, 0.3, 7850.0), rel=1e-14)


def test_shear_factors_make_timoshenko_bars(tmp_path):
    """K1, K2 on a PBAR (and a PBEAM's default 1.0): a tip force on a cantilever moves it by
    P L^3 / 3EI + P L / (K G A) in each plane, which the Timoshenko element gives at its nodes; the
    fibre stress is still the moment's (the element's moment is linear: exact under end loads)."""
    X, bars = straight(4, 0.3)
    k1, k2 = 5.0 / 6.0, 0.7
    mesh = meshfile.read(bdf(tmp_path / "t.bdf", X, bars, shear=(k1, k2)))
    assert np.all(mesh.bars[:, 4:6] == [k1, k2])
    P, L = 3.0e3, 0.3
    for load, I, k in (([0.0, P, 0.0], SEC.Iz, k1), ([0.0, 0.0, P], SEC.Iy, k2)):
        u, cond = static(mesh, 0, 4, np.r_[load, 0.0, 0.0, 0.0])
        want = P * L ** 3 / (3 * E * I) + P * L / (k * G * SEC.A)
        assert abs(np.linalg.norm(u[4, :3]) / want - 1.0) <= 10 * EPS * cond
    rows, dofs = frame.fibre_rows(mesh, E, NU, [0.1, 0.0, 0.006])
    u, cond = static(mesh, 0, 4, [0.0, 0.0, P, 0.0, 0.0, 0.0])
    assert abs((rows @ u.ravel()[dofs])[0] / (-P * (L - 0.1) * 0.006 / SEC.Iy) - 1.0) <= 10 * EPS * cond


BARS = "GRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\nPBAR,7,1,1.-4,1.-9,1.-9,2.-9\nMAT1,1,2.1+11,,.3,7850.\n"


@pytest.mark.parametrize("case, line, fragment", [
    ("offset", "CBAR,1,7,1,2,0.,1.,0.\n,,,0.1", "W1A = 0.1: pin flags and offsets are not supported"),
    ("pin flag", "CBAR,1,7,1,2,0.,1.,0.\n,4", "PA = 4: pin flags and offsets are not supported"),
    ("no orientation", "CBAR,1,7,1,2", "CBAR 1 has no orientation vector (X1-X3 or G0; BAROR is not read)"),
    ("parallel", "CBAR,1,7,1,2,2.,0.,0.", "element 1 (bar) has an orientation vector along its axis"),
    ("coincident", "CBAR,1,7,1,1,0.,1.,0.", "element 1 (bar) has coincident end nodes"),
    ("property", "CBAR,1,8,1,2,0.,1.,0.", "element 1 refers to property 8, which has no PBAR or PBEAM card"),
    ("orientation node", "CBAR,1,7,1,2,5", "element 1 refers to node 5, which is not defined"),
    ("offset type", "CBAR,1,7,1,2,0.,1.,0.,BGG", "OFFT 'BGG': only GGG (the default) is read"),
    ("displacement system", "CBAR,1,7,3,2,0.,1.,0.\nGRID,3,,0.,0.,0.,4",
     "element 1's orientation vector is in the displacement coordinate system CD=4 of its node 3"),
])
def test_bar_refusals(tmp_path, case, line, fragment):
    path = tmp_path / "bad.bdf"
    path.write_text(BARS + line + "\n")
    refused(str(path), fragment, line=5)


@pytest.mark.parametrize("card, fragment", [
    ("PBAR,8,1,1.-4,1.-9,1.-9,2.-9,0.5", "PBAR 8: NSM = 0.5: only sections without non-structural mass"),
    ("PBAR,8,1,1.-4,1.-9,1.-9,2.-9\n,,,,,,,,\n,,,1.-10", "PBAR 8: I12 = 1.-10"),
    ("PBAR,8,1,1.-4,0.,1.-9,2.-9", "PBAR 8: A, I1, I2 and J must be positive"),
    ("PBEAM,8,1,1.-4,1.-9,1.-9,0.,2.-9\n,,,,,,,,\n,YES,1.,2.-4,1.-9,1.-9,0.,2.-9",
     "PBEAM 8: a tapered beam (its stations' sections differ): only a constant section is read"),
    ("PBAR,7,1,1.-4,1.-9,1.-9,2.-9", "PBAR 7 is defined twice (first on line 3)"),
])
def test_bar_property_refusals(tmp_path, card, fragment):
    path = tmp_path / "bad.bdf"
    path.write_text(BARS + "CBAR,1,8,1,2,0.,1.,0.\n" + card + "\n")
    refused(str(path), fragment, line=6)


def test_a_tip_mass_lowers_the_first_frequency_as_the_closed_form(tmp_path):
    """A CONM2 of the rod's own mass rho A L at the tip of a cantilever: its lowest bending
    frequency is beta^2 sqrt(EI / rho A) / 2 pi with beta L the first root of
    1 + cos cosh + r beta L (cos sinh - sin cosh) = 0, r = 1 (Euler-Bernoulli, a point mass). The
    lumped elements converge to it at O(h^2): the difference falls about fourfold as the elements
    double, and at 80 elements it is below 1e-4 (seen -2.5e-4, -6.4e-5, -1.7e-5 at 20, 40, 80)."""
    from scipy.optimize import brentq
    L = 1.5
    m_tip = RHO * SEC.A * L
    x = brentq(lambda b: 1 + np.cos(b) * np.cosh(b) + b * (np.cos(b) * np.sinh(b) - np.sin(b) * np.cosh(b)), 0.5, 2.0)
    f_exact = (x / L) ** 2 * np.sqrt(E * SEC.Iz / (RHO * SEC.A)) / (2 * np.pi)
    errors = []
    for n in (20, 40, 80):
        X, bars = straight(n, L)
        mesh = meshfile.read(bdf(tmp_path / f"m{n}.bdf", X, bars, extra=f"CONM2,1,{n + 1},,{m_tip!r}"))
        assert mesh.masses.tolist() == [[n, m_tip, 0.0, 0.0, 0.0]]
        K, M = frame.matrices(mesh, E, NU, RHO)
        free = np.arange(6, K.shape[0])
        lam = sl.eigh(K.toarray()[np.ix_(free, free)], M.toarray()[np.ix_(free, free)], eigvals_only=True)
        errors.append(abs(np.sqrt(lam[0]) / (2 * np.pi) / f_exact - 1.0))
    assert 3.0 < errors[0] / errors[1] < 5.0 and 3.0 < errors[1] / errors[2] < 5.0, errors
    assert errors[2] < 1e-4, errors


@pytest.mark.parametrize("card, fragment", [
    ("CONM2,9,2,,1.5,0.1", "CONM2 9: X1 = 0.1: only a mass at its grid"),
    ("CONM2,9,2,3,1.5", "CONM2 9: CID = 3: only the basic system"),
    ("CONM2,9,2,,1.5\n,1.,0.5", "CONM2 9: I21 = 0.5"),
    ("CONM2,9,7,,1.5", "CONM2 9: its grid 7 is not defined"),
    ("CONM2,9,3,,1.5", "CONM2 9: its grid 3 is on no bar"),
])
def test_point_mass_refusals(tmp_path, card, fragment):
    path = tmp_path / "bad.bdf"
    path.write_text(BARS + "GRID,3,,0.,1.,0.\nCBAR,1,7,1,2,0.,1.,0.\n" + card + "\n")
    refused(str(path), fragment, line=7)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), n=st.integers(1, 6))
def test_any_frame_has_exactly_the_six_rigid_motions_free(seed, n):
    """A random connected frame (a chain of n bars in random directions, random orientation
    vectors, random sections): K is symmetric, the six rigid motions of the whole frame are in its
    null space, and nothing else is (the turned elements leave no spurious mechanism and no
    spurious stiffness of rigid motion); M is symmetric positive definite. Tolerances: a rigid
    field's force K r against |K| |r| at round-off (1e-12, the turned sums of 12 x 12 blocks);
    the seventh eigenvalue of K against its largest well above that (a real bending mode)."""
    rng = np.random.default_rng(seed)
    steps = rng.normal(size=(n, 3))
    X = np.vstack([np.zeros(3), np.cumsum(0.2 * steps / np.linalg.norm(steps, axis=1, keepdims=True), axis=0)])
    cells = np.array([(i, i + 1) for i in range(n)])
    v = rng.normal(size=(n, 3))
    bars = np.c_[rng.uniform(1e-4, 2e-4, n), rng.uniform(1e-9, 3e-9, (n, 3)), np.zeros((n, 2)), v]
    mesh = Mesh(nodes=X, cells={"bar2": cells}, node_sets={}, elem_sets={}, materials={}, source="random",
                node_ids=np.arange(1, n + 2), elem_ids={"bar2": np.arange(1, n + 1)}, bars=bars)
    K, M = (A.toarray() for A in frame.matrices(mesh, E, NU, RHO))
    assert np.abs(K - K.T).max() <= 1e-14 * np.abs(K).max() and np.abs(M - M.T).max() <= 1e-14 * np.abs(M).max()
    R = modes.rigid_body_fields(X, 0)
    assert np.abs(K @ R).max() <= 1e-12 * np.abs(K).max() * np.abs(R).max()
    lam = np.linalg.eigvalsh(K)
    assert lam[6] > 1e-8 * lam[-1]
    assert np.linalg.eigvalsh(M)[0] > 0.0
