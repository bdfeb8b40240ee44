"""Channels measured geometrically from the deformed nodes; joint reactions from the momentum;
each channel kind computed in one place."""

import ast
import dataclasses
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import flexmbd
from flexmbd import cases
from flexmbd.harness import channels
from flexmbd.fe import flexbody
from flexmbd.solvers import inhouse
from flexmbd.solvers.build import from_case
from flexmbd.mbd.compiled.entry import forward_dynamics
from flexmbd.mbd.model import make_data


def deflection(fb, p, axis, eta):
    """channels.deflection of node p from one state's modal coordinates eta (nm,)."""
    x = float(fb.x0[p, 0])
    points, x0 = channels.modal_points(fb, [0.0, fb.length, x], eta[None, :])
    beam = channels.Beam(length=fb.length, points=points, x0=x0, root=channels.modal_root(fb, eta[None, :]))
    return float(channels.deflection(beam, x, axis)[0])


def moving_body(boundary, seed):
    """A 10-element beam whose 4 random modes move every node, node 0 included, by decimetres and
    tenths of a radian at unit amplitude (ends kept in the x-y plane for hinged-hinged)."""
    case = cases.load("cantilever_step", ["bodies.beam.elements=10", "bodies.beam.modes.count=4"])
    fb = flexbody.for_case(case)["beam"]
    Phi = np.random.default_rng(seed).normal(size=fb.Phi.shape) * 0.1
    if boundary == "hinged-hinged":
        Phi[[0, -1], 5] = 0.0
    return dataclasses.replace(fb, Phi=Phi, boundary=boundary)


def with_rigid_motion(fb, eta, Q, d):
    """(body, eta) with one more mode, at amplitude 1, carrying every node from its place at eta
    through rotation Q and translation d (node 0's rotation vector becomes that of Q R_0)."""
    r = fb.x0 + fb.Phi[:, 3:] @ eta
    theta0 = fb.Phi[0, :3] @ eta
    col = np.zeros((fb.n_nodes, 6, 1))
    col[:, 3:, 0] = r @ Q.T + d - r
    col[0, :3, 0] = Rotation.from_matrix(Q @ Rotation.from_rotvec(theta0).as_matrix()).as_rotvec() - theta0
    return dataclasses.replace(fb, Phi=np.concatenate([fb.Phi, col], axis=2)), np.r_[eta, 1.0]


def test_deflection_is_measured_in_the_deformed_root_node_frame():
    """Deflection against r_p - r_0 in node 0's rotated frame (scipy), and its rigid-motion invariance."""
    fb = moving_body("clamped-free", 0)
    eta = np.random.default_rng(1).normal(size=fb.n_modes)
    r = fb.x0 + fb.Phi[:, 3:] @ eta
    R0 = Rotation.from_rotvec(fb.Phi[0, :3] @ eta).as_matrix()
    assert np.linalg.norm(fb.Phi[0, :3] @ eta) > 0.1 and np.abs(r[0]).max() > 0.05
    Q, d = Rotation.from_rotvec([0.4, -0.7, 0.2]).as_matrix(), np.array([0.3, -1.0, 2.0])
    moved, eta_moved = with_rigid_motion(fb, eta, Q, d)
    rigid, eta_rigid = with_rigid_motion(fb, np.zeros(fb.n_modes), Q, d)
    for p in (3, 7, 10):
        for axis in range(3):
            ref = R0[:, axis] @ (r[p] - r[0]) - (fb.x0[p] - fb.x0[0])[axis]
            assert deflection(fb, p, axis, eta) == pytest.approx(ref, rel=1e-12, abs=1e-15)
            assert deflection(moved, p, axis, eta_moved) == pytest.approx(ref, rel=1e-10, abs=1e-13)
            assert abs(deflection(rigid, p, axis, eta_rigid)) <= 1e-13


def test_hinged_hinged_deflection_is_measured_from_the_chord():
    """Deflection against r_p - r_0 along a planar chord's axes, and its invariance under in-plane motions."""
    fb = moving_body("hinged-hinged", 2)
    eta = np.random.default_rng(3).normal(size=fb.n_modes)
    r = fb.x0 + fb.Phi[:, 3:] @ eta
    e = (r[-1] - r[0]) / np.linalg.norm(r[-1] - r[0])
    assert abs(np.arctan2(e[1], e[0])) > 0.05
    axes = np.array([e, [-e[1], e[0], 0.0], [0.0, 0.0, 1.0]])
    Q, d = Rotation.from_rotvec([0.0, 0.0, 0.6]).as_matrix(), np.array([0.3, -1.0, 2.0])
    moved, eta_moved = with_rigid_motion(fb, eta, Q, d)
    rigid, eta_rigid = with_rigid_motion(fb, np.zeros(fb.n_modes), Q, d)
    for p in (3, 7):
        for axis in range(3):
            ref = axes[axis] @ (r[p] - r[0]) - (fb.x0[p] - fb.x0[0])[axis]
            assert deflection(fb, p, axis, eta) == pytest.approx(ref, rel=1e-12, abs=1e-15)
            assert deflection(moved, p, axis, eta_moved) == pytest.approx(ref, rel=1e-10, abs=1e-13)
            assert abs(deflection(rigid, p, axis, eta_rigid)) <= 1e-13


@pytest.mark.parametrize("boundary", ["clamped-free", "hinged-hinged"])
def test_modal_reach_bounds_every_displacement(boundary):
    """`channels.modal_reach` (what lets the divergence watch skip a sample) is never below the
    largest displacement of the points it covers, from small motions to turns of a radian, node 0
    moving as well; finite while the beam is not torn apart (a hinged-hinged chord's tip moved by
    less than L), inf for coordinates that are not finite. It bounds by a strict inequality, with
    a 1e-9 margin for the Beam's own rounding, so the check is exact: d <= reach."""
    fb = moving_body(boundary, 4)
    nodes = {float(fb.x0[p, 0]): p for p in (0, 3, 7, fb.n_nodes - 1)}
    reach, rng, finite = channels.modal_reach(fb, nodes), np.random.default_rng(5), 0
    for scale in (1e-6, 1e-3, 0.1, 1.0, 3.0):
        for _ in range(50):
            eta = rng.normal(size=fb.n_modes) * scale
            points, x0 = channels.modal_points(fb, list(nodes), eta[None, :], nodes)
            beam = channels.Beam(length=fb.length, points=points, x0=x0, root=channels.modal_root(fb, eta[None, :]))
            d = max(np.linalg.norm(channels.displacement(beam, x)[0]) for x in nodes)
            assert d <= reach(eta)
            finite += np.isfinite(reach(eta))
    assert finite >= 100                                   # the small motions at least get a finite bound
    assert reach(np.full(fb.n_modes, np.nan)) == np.inf


def test_chord_frame_turns_x_onto_the_chord():
    e = np.array([[0.6, 0.8, 0.0], [3.0, 0.0, 0.0], [-2.0, 0.0, 0.0], [1.0, -2.0, 2.0]])
    R = channels.chord_frames(e)
    u = e / np.linalg.norm(e, axis=1)[:, None]
    assert np.allclose(R[[0, 1, 3]] @ [1, 0, 0], u[[0, 1, 3]])
    assert np.allclose(np.einsum("nji,njk->nik", R, R), np.eye(3))
    assert np.allclose(R[0] @ [0, 0, 1], [0, 0, 1])         # a planar chord keeps z
    assert np.array_equal(R[2], np.eye(3))                  # along -x: no smallest turn, the identity
    # the smallest turn: about the axis x ~ u, by the angle between them (Rodrigues' exp, apart)
    k = np.cross([1.0, 0.0, 0.0], u[3])
    angle = np.arctan2(np.linalg.norm(k), u[3, 0])
    assert np.allclose(R[3], Rotation.from_rotvec(k / np.linalg.norm(k) * angle).as_matrix(), atol=1e-14)  # O(1) entries


def test_clamp_reactions_are_the_rate_of_momentum_less_the_applied_loads():
    """Clamp reactions against Newton-Euler over the nodes (node accelerations, gravity, tip load at t)."""
    case = cases.load("cantilever_step", ["gravity=[0.0, -9.81, 2.0]", 'loads.tip_force.profile={type="step", t0=0.5}',
                                          "bodies.beam.stiffening=false"])     # node sums of the linear kinematics
    m = from_case(case)
    fb, i = m.bodies["beam"], m.index("beam")
    a, n = m.body_madr[i], m.body_nm[i]
    rng = np.random.default_rng(5)
    t = np.array([0.0, 0.3, 1.1])
    Q, V = rng.normal(size=(3, m.nq)) * 1e-3, rng.normal(size=(3, m.nv)) * 1e-2
    f = inhouse.reactions(m, t, Q, V)
    g, F = np.array(case.gravity), np.array([0.0, -12.0, 0.0]) * (t >= 0.5)[:, None]
    for k in range(3):
        eta_dd = forward_dynamics(m, make_data(m), Q[k], V[k], t=t[k])[a:a + n]
        r = fb.x0 + fb.Phi[:, 3:] @ Q[k, a:a + n]
        ma = fb.m[:, None] * (fb.Phi[:, 3:] @ eta_dd - g)                   # m_p (a_p - g)
        force = ma.sum(axis=0) - F[k]
        rotary = np.einsum("pab,pb->a", fb.J, fb.Phi[:, :3] @ eta_dd)          # J_p Phi_r,p eta_dd
        moment = np.cross(r, ma).sum(axis=0) + rotary - np.cross(r[-1], F[k])
        assert np.abs(f[k, i, 3:] - force).max() <= 1e-11 * np.abs(force).max()
        assert np.abs(f[k, i, :3] - moment).max() <= 1e-11 * np.abs(moment).max()
    assert not np.allclose(f[0], f[2])


def test_no_adapter_computes_a_channel_itself():
    """Adapters produce trajectories: none defines a channel function or forms stresses or chords."""
    own = {"deflection", "stress", "stress_vm", "chord_frames", "von_mises", "channels"}
    for path in (Path(flexmbd.__file__).parent / "adapters").glob("*.py"):
        tree = ast.parse(path.read_text())
        defined = {n.name for n in ast.walk(tree) if isinstance(n, ast.FunctionDef)}
        used = {n.attr if isinstance(n, ast.Attribute) else n.id for n in ast.walk(tree)
                if isinstance(n, (ast.Attribute, ast.Name))}
        assert not defined & own, (path.name, defined & own)
        assert not used & {"von_mises", "section_stresses", "chord_frames", "stress_coefficients"}, path.name


def test_stress_vm_at_a_section_point():
    """sigma = E (eps - y kappa_z + z kappa_y), tau = G r twist on a circle, von Mises of both."""
    from flexmbd.fe import section
    sec = section.circle(0.02)
    s = np.array([[1e-4, 2e-3, -3e-3, 0.05]])
    y, z = 0.006, -0.004
    sigma = 2e11 * (1e-4 - y * -3e-3 + z * 2e-3)
    tau = 8e10 * np.hypot(y, z) * 0.05
    assert channels.stress_vm(s, 2e11, 8e10, sec, (y, z))[0] == pytest.approx(np.sqrt(sigma ** 2 + 3 * tau ** 2), rel=1e-14)


# ---------------------------------------------------------------------------------------------
# quasi-static axial stress (no retained mode is axial)


def root_stress(overrides, t, angle, rate):
    """stress_vm at the pendulum's stress section (x = 0.03 m) in the state joint angle, joint
    rate, modes at rest."""
    case = cases.load("pendulum", overrides)
    m = from_case(case)
    q, v = np.zeros(m.nq), np.zeros(m.nv)
    q[0], v[0] = angle, rate
    out = channels.channels(case, inhouse.trajectory(case, m, np.array([t]), q[None], v[None]))
    return float(out["stress_vm"][0])


def test_a_hanging_beam_carries_its_own_weight():
    """At rest hanging down, sigma(x) = rho g (L - x), the weight below the section over the area."""
    s = root_stress([], 0.0, -np.pi / 2, 0.0)
    assert s == pytest.approx(7820.0 * 9.81 * (1.5 - 0.03), rel=1e-9)


def test_a_spinning_beam_carries_its_centrifugal_force():
    """Prescribed constant rate W about the pivot, no gravity: sigma(x) = rho W^2 (L^2 - x^2) / 2."""
    W = 6.0
    s = root_stress(["gravity=[0.0, 0.0, 0.0]", f'joints.pivot.motion={{type="constant_rate", rate={W}}}'],
                    0.5, W * 0.5, W)
    assert s == pytest.approx(7820.0 * W ** 2 * (1.5 ** 2 - 0.03 ** 2) / 2, rel=1e-3)


def test_axial_force_sums_the_outer_nodes():
    x0 = np.c_[np.linspace(0.0, 1.0, 5), np.zeros((5, 2))]
    F = np.zeros((1, 5, 3))
    F[0, :, 0] = [1.0, 2.0, 4.0, 8.0, 16.0]
    assert channels.axial_force(x0, F, 0.25)[0] == 0.5 * 2.0 + 4.0 + 8.0 + 16.0
    assert channels.axial_force(x0, F, 0.3)[0] == 28.0


# ---------------------------------------------------------------------------------------------
# linear validity


def test_validity_names_the_largest_geometric_excess_before_the_axial_load():
    t = np.array([0.0, 0.5, 1.0])
    beam = lambda **m: channels.Beam(length=1.0, points={}, x0={}, root=None, extent={k: np.array(v) for k, v in m.items()})
    traj = channels.Trajectory(t=t, beams={"b": beam(deflection=[0.0, 1.61, 0.5], rotation=[0.0, 0.3, 0.0],
                                                     strain=[0, 0, 0], axial_load=[0.0, 500.0, 0.0])})
    summary, (why, at) = channels.validity(traj)
    assert why == "deflection 161 % of length" and at == 0.5 and summary["b"]["axial_load"] == 500.0
    traj.beams["b"] = beam(deflection=[0.0, 0.01, 0.0], axial_load=[0.0, 0.01, 0.153])
    assert channels.validity(traj)[1] == ("axial load 15 % of the buckling load", 1.0)
    traj.beams["b"] = beam(deflection=[0.0, 0.09, 0.0], rotation=[0.0, 0.099, 0.0], axial_load=[0.0, 0.019, 0.0])
    assert channels.validity(traj)[1] is None


def test_modal_extent_of_a_bent_beam():
    """A beam bent into a circular arc of curvature k (modes set to that shape): deflection,
    rotation and strain against the arc's closed forms (small k)."""
    case = cases.load("cantilever_step", ["bodies.beam.elements=20", "bodies.beam.modes.count=1"])
    fb = flexbody.for_case(case)["beam"]
    k, x = 1e-3, fb.x0[:, 0]
    Phi = np.zeros_like(fb.Phi)
    Phi[:, 4, 0], Phi[:, 2, 0] = k * x ** 2 / 2, k * x            # u_y = k x^2 / 2, theta_z = k x
    sec = flexbody.beam_section(case.bodies["beam"])
    e = channels.modal_extent(dataclasses.replace(fb, Phi=Phi), np.ones((1, 1)), sec)
    assert e["deflection"][0] == pytest.approx(k * 1.5 ** 2 / 2 / 1.5, rel=1e-12)
    assert e["rotation"][0] == pytest.approx(k * 1.5, rel=1e-12)
    assert e["strain"][0] == pytest.approx(k * sec.cy, rel=1e-12)


# ---------------------------------------------------------------------------------------------
# deformed-shape snapshots


def test_shape_points_follow_the_root_tip_and_channel_points():
    """Root and tip first, then the deflection channels' points, then the evenly spaced shape
    points not already listed (one within 1e-9 L of a listed point is that point)."""
    case = cases.load("cantilever_step", ["report.shape_points=5", "channels.tip_deflection.at=0.7500000000001"])
    assert channels.points_needed(case, "beam") == [0.0, 1.5, 0.7500000000001, 0.375, 1.125]
    assert channels.shape_positions(case, "beam") == [0.0, 0.375, 0.7500000000001, 1.125, 1.5]
    assert channels.shape_positions(cases.load("cantilever_step", ["report.shape_points=0"]), "beam") == []
    assert channels.shape_positions(cases.load("cantilever_step"), "beam")[3] == 0.45     # L k / (n - 1)


@pytest.mark.parametrize("chord", [False, True])
def test_shapes_of_a_known_motion_are_its_displacements(chord):
    """A beam carried through a rigid motion (root position r0(t), rotation Q(t)) while its points
    move by u(x, t) in the carried frame: the snapshots are u at the samples nearest the instants,
    an instant the run did not reach is left out, and each component is the deflection channel's.
    chord = True: no root rotation (hinged-hinged modes), the frame is the chord's; the tip stays
    on the carried x axis and the motion is planar, so that the chord frame is Q."""
    case = cases.load("cantilever_step", ["report.shape_points=5", "integrator.output_dt=0.1",
                                          "report.snapshots=[0.0, 0.26, 0.9, 2.0]"])
    t = np.linspace(0.0, 1.0, 11)                                    # a run that ended at t = 1 s
    xs, L = channels.points_needed(case, "beam"), 1.5
    u = lambda x: np.column_stack([1e-3 * x * t, 0.02 * x * (L - x) * t, -0.01 * x * (L - x) * t ** 2 * (not chord)])
    turn = np.column_stack([0.0 * t, 0.0 * t, 0.5 * t]) if chord else np.column_stack([0.3 * t, -0.2 * t, 0.5 * t])
    Q = Rotation.from_rotvec(turn).as_matrix()
    r0 = np.column_stack([t, 2.0 * t, -t])
    points = {x: r0 + np.einsum("nij,nj->ni", Q, np.array([x, 0.0, 0.0]) + u(x)) for x in xs}
    beam = channels.Beam(length=L, points=points, x0={x: np.array([x, 0.0, 0.0]) for x in xs},
                         root=None if chord else Q)
    shapes = channels.shapes(case, channels.Trajectory(t=t, beams={"beam": beam}), case.report.snapshots)
    s = shapes["beam"]
    assert s["x"] == [0.0, 0.375, 0.75, 1.125, 1.5] and s["t"] == pytest.approx([0.0, 0.3, 0.9])
    picks = [0, 3, 9]
    got, want = np.array(s["u"]), np.stack([u(x)[picks] for x in s["x"]], axis=1)
    assert got.shape == (3, 5, 3) and np.abs(want).max() > 0.01
    assert np.abs(got - want).max() <= 1e-15
    for j, x in enumerate(s["x"]):
        for axis in range(3):
            assert np.array_equal(got[:, j, axis], channels.deflection(beam, x, axis)[picks])


@pytest.fixture(scope="module")
def cantilever_runs(cantilever_run):
    """The shipped cantilever_step and its runs by flexmbd and fe-linear (the session's: conftest.py)."""
    return cases.load("cantilever_step"), {s: cantilever_run(s) for s in ("flexmbd", "fe-linear")}


def test_cantilever_shapes_of_flexmbd_and_fe_linear_agree(cantilever_runs):
    """cantilever_step, at every snapshot: flexmbd's shape within 2 % of fe-linear's largest tip
    deflection (measured: 2e-4), its tip at the final instant within 2 % of fe-linear's there
    (measured: 0.3 % of -1.96 mm, near a zero crossing), and each shape's tip point is the
    tip_deflection channel at that sample."""
    case, runs = cantilever_runs
    ref = runs["fe-linear"]
    scale = np.abs(ref.channels["tip_deflection"]).max()
    s, sr = runs["flexmbd"].extra["shapes"]["beam"], ref.extra["shapes"]["beam"]
    assert s["x"] == sr["x"] and s["t"] == sr["t"] == list(case.report.snapshots) == [0.5, 1.0, 1.5, 2.0]
    u, ur = np.array(s["u"]), np.array(sr["u"])
    assert np.abs(u[:, :, 1] - ur[:, :, 1]).max() <= 0.02 * scale
    assert abs(u[-1, -1, 1] - ur[-1, -1, 1]) <= 0.02 * abs(ur[-1, -1, 1])
    for r in runs.values():
        sh = r.extra["shapes"]["beam"]
        k = [int(np.argmin(np.abs(r.t - ti))) for ti in sh["t"]]
        assert sh["x"][-1] == 1.5 and np.array_equal(np.array(sh["u"])[:, -1, 1], r.channels["tip_deflection"][k])


def test_rigid_solvers_store_no_shapes_and_a_short_run_those_it_reached():
    from flexmbd.harness import registry
    case = cases.load("pendulum", ["report.snapshots=[0.0, 0.02, 1.0]"])
    assert "shapes" not in registry.run(case, "pinocchio", 0.02).extra
    s = registry.run(case, "flexmbd", 0.02).extra["shapes"]["beam"]
    assert s["t"] == [0.0, 0.02] and len(s["x"]) == 11 and np.abs(s["u"][0]).max() == 0.0 < np.abs(s["u"][1]).max()


def test_the_axial_load_is_measured_against_the_euler_load_of_the_beam_s_own_ends():
    """A hinged-hinged beam buckles at pi^2 E I / L^2, four times the load of one clamped at its
    root (pi^2 E I / (4 L^2)); the measure follows the modes' boundary condition."""
    from types import SimpleNamespace
    sec = SimpleNamespace(Iy=2.0e-9, Iz=4.5e-11)
    E, L = 2.0e11, 0.45
    euler = np.pi ** 2 * E * 4.5e-11 / L ** 2                       # 438.6 N: the four-bar's coupler
    N = np.array([0.5 * euler, -euler])
    assert np.allclose(channels.axial_load(N, E, sec, L, "hinged-hinged"), [0.5, 1.0], rtol=1e-14)
    assert np.allclose(channels.axial_load(N, E, sec, L, "clamped-free"), [2.0, 4.0], rtol=1e-14)
