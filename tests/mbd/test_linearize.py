"""The linearized system against closed forms: a clamped beam's system modes are its mode set's,
and the hinged pendulum vibrates at the pinned-free frequency of the Euler-Bernoulli beam."""

import numpy as np
import pytest

from flexmbd import cases
from flexmbd.fe import flexbody
from flexmbd.solvers import linearize
from flexmbd.core.errors import InputError
from flexmbd.mbd.compiled import entry

pytestmark = pytest.mark.heavy(5)       # seconds, measured with both cores busy (tests/conftest.py)


def test_fixed_base_system_modes_are_the_mode_set():
    case = cases.load("cantilever_step")
    fb = flexbody.for_case(case)["beam"]
    f = [m.freq_hz for m in linearize.for_case(case)]
    np.testing.assert_allclose(f, np.sort(fb.freq_hz), rtol=1e-6)


def test_pendulum_vibrates_at_the_pinned_free_frequency():
    """Released horizontal at rest: no axial load at t = 0, so the first in-plane bending mode of
    the system (joint + clamped-free modes) is the pinned-free beam's, (beta L)^2 sqrt(EI / rho A L^4)
    with beta L = 3.9266 (tan = tanh), within 0.1 %."""
    case = cases.load("pendulum")
    body, mat = case.bodies["beam"], case.materials["steel"]
    sec, L = flexbody.beam_section(body), body.length
    exact = 3.926602 ** 2 * np.sqrt(mat.E * sec.Iz / (mat.rho * sec.A * L ** 4)) / (2 * np.pi)
    inplane = [m for m in linearize.for_case(case) if "xy" in m.label or "joint" in m.label]
    assert inplane[0].freq_hz == pytest.approx(exact, rel=1e-3)
    assert abs(inplane[0].damping) < 1e-9


def test_pendulum_equilibrium_hangs_down_and_swings_at_the_compound_rate():
    """About the hanging equilibrium the rigid swing appears: sqrt(m g d / I_O) of the beam about
    its pivot (d = L/2, I_O = m L^2 / 3), within 1 % (the beam is flexible and has a section)."""
    case = cases.load("pendulum")
    model = linearize.model_of(case)
    q = linearize.equilibrium(model, model.q0)
    assert q[0] == pytest.approx(-np.pi / 2, abs=1e-3)
    L, g = case.bodies["beam"].length, 9.81
    swing = np.sqrt(1.5 * g / L) / (2 * np.pi)
    modes = linearize.system_modes(model, q, np.zeros(model.nv))
    assert modes[0].label == "joint pivot" and modes[0].freq_hz == pytest.approx(swing, rel=0.01)


def test_pendulum_bending_modes_are_named_after_the_beam_not_the_hinge():
    """Released horizontal, the pendulum's in-plane modes are the pinned-free beam's: the hinge
    turns the beam while its clamped-free modes bend it back, so the diagonal energies
    x_i^2 M_ii of hinge and modes are about half each (once labelled 'joint pivot, 49-50 %'),
    while the hinge's momentum is nil and its row share of the kinetic energy 1e-8: every mode is
    the beam's, to 1e-6, numbered in frequency order within its family."""
    modes = linearize.for_case(cases.load("pendulum"))
    inplane = [m for m in modes if "xy" in m.label]
    assert [round(m.freq_hz, 1) for m in inplane] == [24.2, 78.5, 163.9, 281.5, 700.3]
    assert [m.label for m in inplane] == [f"beam: bending xy {k}" for k in range(1, 6)]
    assert [m.label for m in modes if "xz" in m.label] == [f"beam: bending xz {k}" for k in range(1, 8)]
    assert len(modes) == 12 and all(m.share == pytest.approx(1.0, abs=1e-6) for m in modes)


def test_the_mass_matrix_from_forward_dynamics_is_the_polarized_one():
    """`mass_matrix` (n + 1 forward evaluations) against `entry.mass_matrix_system` (the kinetic
    energy by polarization, checked against the Lagrangian oracle), swung away from the release."""
    from flexmbd.mbd.model import make_data
    model = linearize.model_of(cases.load("double_pendulum"))
    q = model.q0.copy()
    q[model.jnt_qadr[1:]] += [-0.7, 0.4]
    q[model.body_madr[1]:model.body_madr[1] + 3] = [1e-3, -2e-3, 5e-4]
    M = entry.mass_matrix_system(model, make_data(model), q)
    np.testing.assert_allclose(linearize.mass_matrix(model, q), M, atol=1e-10 * np.abs(M).max())


def test_energy_shares_split_by_velocity_times_momentum():
    """Two masses on a lever, coordinates (a, b) with M = [[2, 1], [1, 1]]: a mode moving a alone
    carries b along (its momentum (M x)_b = 1), yet b holds nothing: T_b = 1/2 x_b (M x)_b = 0."""
    M = np.array([[2.0, 1.0], [1.0, 1.0]])
    shares = lambda x: linearize.energy_shares(x, M @ x)
    np.testing.assert_allclose(shares(np.array([1.0, 0.0])), [1.0, 0.0])
    np.testing.assert_allclose(shares(np.array([1.0, -1.0])), [1.0, 0.0])
    np.testing.assert_allclose(shares(np.array([1j, 1j])).sum(), 1.0)


def test_a_mode_s_momenta_from_the_equations_are_the_refined_vector_s():
    """The pendulum's 281 Hz mode: eig's vector gives the hinge a share of 0.7 through M x (its
    momentum cancels to 1e-3 of its parts); the momenta from the linearized equations, and M x of
    the vector refined by inverse iteration, give it 1e-7 at most."""
    case = cases.load("pendulum")
    model = linearize.model_of(case)
    A = linearize.state_matrix(model, model.q0, model.v0)
    M, n = linearize.mass_matrix(model, model.q0), A.shape[0] // 2
    lam, vec = np.linalg.eig(A)
    k = int(np.argmin(np.abs(lam - 2j * np.pi * 281.47)))
    x = vec[:n, k]
    assert abs(linearize.energy_shares(x, M @ x)[0]) > 0.1
    assert abs(linearize.energy_shares(*linearize.momenta(A, M, lam[k], x))[0]) < 1e-7
    xr = linearize.refined(A, lam[k], x)
    assert abs(linearize.energy_shares(xr, M @ xr)[0]) < 1e-7


def test_a_solid_s_system_modes_are_named_after_its_own_modes():
    """The hinged block: its mode set's names ('mode 1 (y)'), never a beam's family; its in-plane
    modes (401 and 1890 Hz) mix its clamped modes 1 (y) and 3 (y), and the larger names each."""
    modes = linearize.for_case(cases.load("brick_pendulum"))
    assert [(round(m.freq_hz), m.label) for m in modes] == [
        (363, "block: mode 2 (z)"), (401, "block: mode 1 (y)"), (1227, "block: mode 4 (y)"), (1890, "block: mode 3 (y)")]
    assert [round(m.share, 2) for m in modes] == [1.0, 0.56, 1.0, 0.56]


def test_a_joint_is_named_only_where_its_coordinate_holds_the_energy():
    """The double pendulum released at rest: its hinges have no stiffness there, so no mode is
    theirs (its 849 Hz mode was once 'joint pivot2', 81 % of the diagonal energies); hanging at
    its equilibrium, the pendulum's rigid swing is its hinge's."""
    modes = linearize.for_case(cases.load("double_pendulum"))
    assert not any(m.label.startswith("joint") for m in modes)
    assert modes[-1].label == "beam2: bending xy 5" and modes[-1].freq_hz == pytest.approx(849.4, abs=0.1)
    assert linearize.for_case(cases.load("pendulum"), "equilibrium")[0].label == "joint pivot"


def test_equilibrium_refuses_prescribed_motion():
    with pytest.raises(InputError, match="--about initial"):
        linearize.for_case(cases.load("rotating_cantilever"), "equilibrium")


@pytest.mark.parametrize("name", cases.available())
def test_every_shipped_case_samples_its_system_modes_without_aliasing(name):
    """A shipped case's output interval resolves every retained mode of its system: the highest
    system frequency lies below the Nyquist frequency 1 / (2 output_dt), so its spectra show the
    modes themselves, not aliases."""
    case = cases.load(name)
    top = max((m.freq_hz for m in linearize.for_case(case)), default=0.0)
    assert top < 0.5 / case.integrator.output_dt, f"{name}: {top:.4g} Hz"


def test_a_rigid_mode_without_stiffness_is_not_reported_as_a_slow_vibration():
    """Released horizontal, the pendulum's swing has no stiffness (a double zero root); with 24
    modes the differences' roundoff moved it to about 0.0016 Hz, once reported as a mode."""
    for count in (12, 24):
        modes = linearize.for_case(cases.load("pendulum", [f"bodies.beam.modes.count={count}"]))
        assert min(m.freq_hz for m in modes) == pytest.approx(3.6847, rel=1e-3), count


def test_frozen_linearization_along_a_swing_follows_the_rigid_pendulum():
    """A rigid pendulum (no modes) frozen at angle theta (0 horizontal) at rest: qdd = -(m g d / I_O)
    cos(theta), so omega^2 = (3 g / 2 L) (-sin theta): the compound rate hanging down, less on the
    way up; within 1 % (the section's own inertia)."""
    case = cases.load("pendulum", ["bodies.beam.modes.count=0"])
    L = case.bodies["beam"].length
    t = np.linspace(0.0, 1.0, 11)
    for theta in (-np.pi / 2, -np.pi / 4, -np.pi / 8):
        (at, modes), = linearize.along(case, t, {"pivot": np.full(t.size, theta)}, [0.5])
        assert at == pytest.approx(0.5)
        assert modes[0].freq_hz == pytest.approx(np.sqrt(1.5 * 9.81 / L * -np.sin(theta)) / (2 * np.pi), rel=0.01)


def test_frozen_linearization_needs_every_free_joint_recorded():
    case = cases.load("double_pendulum")
    model = linearize.model_of(case)
    assert linearize.frozen_joints(model, {"pivot1", "pivot2"}) and not linearize.frozen_joints(model, {"pivot1"})
    with pytest.raises(InputError, match="do not fix every free joint"):
        linearize.along(case, np.linspace(0, 1, 5), {"pivot1": np.zeros(5)}, [0.5])


def test_frozen_linearization_of_a_driven_hub_follows_its_profile():
    """The spin-up beam frozen at t = 20 s, after its hub reached 6 rad/s (spin_up profile), has the
    frequencies of the same beam spun at a constant 6 rad/s linearized about its initial state
    (constant_rate): the profile's rate enters, and nothing else of the two cases differs."""
    spun = linearize.along(cases.load("spinup_beam"), np.linspace(0.0, 30.0, 301), {}, [0.0, 20.0])
    steady = linearize.for_case(cases.load("rotating_cantilever", ["joints.hub.motion.rate=6.0"]))
    assert [m.freq_hz for m in spun[0][1]][:3] == pytest.approx([0.0403, 0.2525, 0.6044], rel=1e-3)
    assert [m.freq_hz for m in spun[1][1]] == pytest.approx([m.freq_hz for m in steady], rel=1e-6)


def test_a_closed_loop_is_linearized_on_its_independent_coordinates():
    """The slider-crank at rest (crank held at angle 0): the rod, pinned at both ends in its plane
    by the crank pin (the cut joint) and the slider's pin, vibrates in-plane at the pinned-pinned
    Euler-Bernoulli frequency pi / (2 L^2) sqrt(EI / rho A) = 131.5 Hz (within 0.5 %: the 30-element
    mesh and shear-free section); the loop's dependent coordinates (the slide, the rod's angle, an
    out-of-plane modal coordinate) follow by closure, so the slide adds no spurious mode."""
    case = cases.load("slider_crank", ["joints.crank_pivot.motion.rate=0.0"])
    rod = case.bodies["rod"]
    EI, rhoA = rod.material.E * rod.geometry.Iz, rod.material.rho * rod.geometry.A
    f1 = np.pi / (2 * rod.length ** 2) * np.sqrt(EI / rhoA)
    modes = linearize.for_case(case)
    inplane = [m for m in modes if "xy" in m.label]
    assert inplane[0].freq_hz == pytest.approx(f1, rel=0.005)
    assert all("joint" not in m.label for m in modes)


def test_a_closed_loop_is_linearized_along_a_run():
    """The four-bar frozen at instants of a run that records only its crank and rocker angles:
    the coupler pin (a dependent joint) follows by closure from the last instant's assembly, and
    the coupler's first bending mode stays near its pinned-pinned 34 Hz (within 15 %: the axial
    load and the mechanism's rates move it)."""
    case = cases.load("four_bar_swing")
    t = np.linspace(0.0, 0.2, 201)
    crank = np.pi / 2 + 20.0 * t                                  # about the case's start and rate
    from oracle_four_bar import angles
    rocker = np.array([angles(th, 0.15, 0.45, 0.40, 0.50)[1] for th in crank])
    sweep = linearize.along(case, t, {"crank_pivot": crank, "rocker_pivot": rocker}, [0.0, 0.1, 0.2])
    for at, modes in sweep:
        assert modes[0].label == "coupler: bending xy 1" and modes[0].freq_hz == pytest.approx(34.0, rel=0.15), at


def test_damping_resolution_is_the_eigenvalue_condition_number_times_round_off():
    """On a 2 x 2 triangular B = [[l1, c], [0, l2]] the condition number of l1 is
    sqrt(1 + (c / (l1 - l2))^2); the resolution is that times eps ||B||_F / |l1|."""
    from scipy import linalg
    l1, l2, c = -0.5 + 20.0j, -0.5 - 20.0j, 300.0
    B = np.array([[l1, c], [0.0, l2]])
    lam, left, right = linalg.eig(B, left=True)
    k = int(np.argmin(np.abs(lam - l1)))
    kappa = np.sqrt(1.0 + abs(c / (l1 - l2)) ** 2)
    got = linearize.damping_resolution(B, lam, left, right)[k]
    assert got == pytest.approx(kappa * np.finfo(float).eps * np.linalg.norm(B) / abs(l1), rel=1e-9)


@pytest.mark.parametrize("name", ["pendulum", "flexible_pendulum", "rotating_cantilever"])
def test_an_undamped_systems_damping_is_round_off_within_its_resolution(name):
    """Without damping every oscillating root's ratio -Re lambda / |lambda| is the eigen-solver's
    round-off: within its resolution, which stays far below any physical damping (1e-7), so the
    modes report 0."""
    from scipy import linalg
    case = cases.load(name)
    model = linearize.model_of(case)
    A = linearize.state_matrix(model, model.q0, model.v0)
    B, _ = linalg.matrix_balance(A, permute=False)
    lam, left, right = linalg.eig(B, left=True)
    res = linearize.damping_resolution(B, lam, left, right)
    osc = (lam.imag > 1e-9 * np.abs(lam).max()) & (np.abs(lam) > np.sqrt(linearize.ROUNDOFF * np.abs(A).max()))
    zeta = -lam.real / np.abs(lam)
    assert osc.any() and np.all(np.abs(zeta[osc]) <= res[osc]) and np.all(res[osc] < 1e-7)
    modes = linearize.for_case(case)
    assert len(modes) == osc.sum() and all(m.damping == 0.0 for m in modes)


def test_modal_damping_is_resolved():
    """With 1 % modal damping the pendulum's out-of-plane bending modes (the beam's coordinates
    alone) keep their 0.01, well above their resolution (within 1e-9: the differences' error)."""
    modes = linearize.for_case(cases.load("pendulum", ["bodies.beam.damping_ratio=0.01"]))
    beam = [m for m in modes if "xz" in m.label and m.share > 0.99]
    assert len(beam) >= 5
    for m in beam:
        assert m.damping == pytest.approx(0.01, abs=1e-9) and m.damping_resolution < 1e-9
