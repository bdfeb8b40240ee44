"""A beam split into segments: the split tree of the case, the whole beam's channels from its
segments, and the split against the unsplit beam and the closed form."""


import numpy as np
import pytest

from flexmbd import cases
from flexmbd.harness import channels, registry
from flexmbd.solvers import inhouse
from flexmbd.core.errors import InputError
from flexmbd.solvers.build import from_case
from flexmbd.mbd.compiled.entry import forward_dynamics
from flexmbd.mbd.model import make_data
from flexmbd.mbd.spatial import expm_so3



def craig_bampton(n, length=1.5):
    """Overrides for Craig-Bampton modes with interfaces at both ends of each of n segments."""
    return ['bodies.beam.modes.boundary="craig-bampton"', f"bodies.beam.modes.interfaces=[0.0, {length / n}]"]


# ---------------------------------------------------------------------------------------------
# the split tree


def test_a_case_without_segments_models_its_own_tree():
    for name in ("cantilever_step", "pendulum", "double_pendulum"):
        case = cases.load(name)
        assert case.split is None and case.modelled is case.resolved and not case.segments
    one = cases.load("pendulum", ["bodies.beam.segments=1"])
    assert one.split is None and one.modelled is one.resolved


def test_the_split_tree_of_the_double_pendulum():
    """Segments named, sized and joined in order; the beam's joint on segment 1; a joint, a load
    and channels on the beam moved to the segment holding their position, at the position along it."""
    case = cases.load("double_pendulum", ["bodies.beam1.segments=4", "bodies.beam2.segments=2",
                                          "joints.pivot2.at=0.75",
                                          'loads.push={type = "point_force", body = "beam2", at = 1.5, force = [0.0, 1.0, 0.0]}'])
    seg = case.split
    assert case.modelled is seg
    assert case.segments == {"beam1": ("beam1:1", "beam1:2", "beam1:3", "beam1:4"),
                             "beam2": ("beam2:1", "beam2:2")}
    assert seg.order == ["beam1:1", "beam1:2", "beam1:3", "beam1:4", "beam2:1", "beam2:2"]
    assert not seg.segments and seg.split is None and seg.modelled is seg
    for b in seg.bodies.values():
        assert b.segments == 1 and b.modes == case.bodies["beam1" if b.length == 0.375 else "beam2"].modes
    assert [(b.length, b.elements) for b in seg.bodies.values()] == [(0.375, 25)] * 4 + [(0.75, 50)] * 2
    j = seg.joints
    assert (j["pivot1"].parent, j["pivot1"].child) == ("ground", "beam1:1")
    assert (j["pivot2"].parent, j["pivot2"].point.x, j["pivot2"].child) == ("beam1:3", 0.0, "beam2:1")
    assert [(j[f"beam1:{k}-{k + 1}"].type, j[f"beam1:{k}-{k + 1}"].parent, j[f"beam1:{k}-{k + 1}"].point.x)
            for k in (1, 2, 3)] == [("fixed", f"beam1:{k}", 0.375) for k in (1, 2, 3)]
    assert (seg.loads["push"].body, seg.loads["push"].point.x) == ("beam2:2", 0.75)
    c = seg.channels
    assert (c["midspan_deflection_1"].body, c["midspan_deflection_1"].at) == ("beam1:3", 0.0)
    assert (c["tip_deflection_2"].body, c["tip_deflection_2"].at) == ("beam2:2", 0.75)
    assert (c["stress_vm_1"].body, c["stress_vm_1"].at) == ("beam1:1", 0.03)
    assert seg.reduced("beam1:1").stress_x.tolist() == [0.03]
    m = from_case(seg)
    assert (seg.nq, seg.nv) == (m.nq, m.nv) == (2 + 6 * 12, 2 + 6 * 12)
    assert case.order == ["beam1", "beam2"]          # the whole beams stay in the case


def test_a_point_on_a_boundary_belongs_to_the_segment_that_starts_there():
    assert [cases.segment_of(1.5, 4, x) for x in (0.0, 0.3, 0.375, 0.75, 1.125, 1.5)] == \
        [(0, 0.0), (0, 0.3), (1, 0.0), (2, 0.0), (3, 0.0), (3, 0.375)]
    assert cases.segment_of(1.0, 3, 2.0 / 3.0) == (2, 0.0)     # within round-off of the boundary
    assert cases.segment_of(1.0, 3, 0.6666) == (1, pytest.approx(0.6666 - 1.0 / 3.0))


@pytest.mark.parametrize("item,words", [
    ("bodies.beam.segments=3", "divisible by 3, got elements = 100"),
    ("bodies.beam.segments=0", "positive"),
    ("bodies.beam.segments=100", "each of the 100 segments"),
])
def test_bad_segments_name_the_key(item, words):
    with pytest.raises(InputError, match=r"bodies\.beam\.(segments|modes\.count): .*" + words):
        cases.load("pendulum", [item])


def test_exudyn_ffrf_declines_a_segmented_beam():
    pytest.importorskip("exudyn")
    st = registry.status_for(cases.load("pendulum", ["bodies.beam.segments=2"]), "exudyn-ffrf")
    assert st.startswith("not applicable") and "segments" in st


# ---------------------------------------------------------------------------------------------
# the whole beam's channels


def test_channels_of_a_split_beam_follow_its_segments_rigidly_joined():
    """Deflections of a pendulum split in 3, at random modal coordinates and joint angle, against
    the chain composed here: segment k+1's frame is segment k's end node (x0 + Phi_t eta, turned by
    exp(Phi_r eta)); stresses are segment 1's modal stresses."""
    case = cases.load("pendulum", ["bodies.beam.elements=30", "bodies.beam.segments=3", "bodies.beam.modes.count=4",
                                   "bodies.beam.stiffening=false",             # the chain below is linear
                                   "bodies.beam.stress=modes",                 # the segment's modal strains
                                   "channels.mid_deflection={kind = 'deflection', body = 'beam', at = 0.75}",
                                   "channels.mid_x={kind = 'deflection', body = 'beam', at = 0.75, component = 'x'}"])
    m = from_case(case.modelled)
    rng = np.random.default_rng(3)
    q = np.zeros(m.nq)
    q[0] = 0.7
    q[1:] = 0.02 * rng.standard_normal(m.nq - 1)
    out = channels.channels(case, inhouse.trajectory(case, m, np.zeros(1), q[None], np.zeros((1, m.nv))))

    R, r, pts = expm_so3(np.array([0.0, 0.0, 0.7])), np.zeros(3), {}
    for k, name in enumerate(case.segments["beam"]):
        fb, i = m.bodies[name], m.index(name)
        eta = q[m.body_madr[i]:m.body_madr[i] + m.body_nm[i]]
        for p in range(fb.n_nodes):
            pts.setdefault(round(k * 0.5 + fb.x0[p, 0], 9), r + R @ (fb.x0[p] + fb.Phi[p, 3:] @ eta))
        r, R = r + R @ (fb.x0[-1] + fb.Phi[-1, 3:] @ eta), R @ expm_so3(fb.Phi[-1, :3] @ eta)
    R0 = expm_so3(np.array([0.0, 0.0, 0.7]))                   # clamped-free: segment 1's root node is its frame
    local = lambda x: R0.T @ (pts[x] - pts[0.0]) - [x, 0.0, 0.0]
    assert out["tip_deflection"][0] == pytest.approx(local(1.5)[1], abs=1e-12)
    assert out["mid_deflection"][0] == pytest.approx(local(0.75)[1], abs=1e-12)
    assert out["mid_x"][0] == pytest.approx(local(0.75)[0], abs=1e-12)
    assert out["joint_angle"][0] == 0.7

    first = m.index("beam:1")
    eta1 = q[m.body_madr[first]:m.body_madr[first] + m.body_nm[first]]
    own = channels.modal_strains(m.bodies["beam:1"], eta1[None])[0.03]
    whole = inhouse.trajectory(case, m, np.zeros(1), q[None], np.zeros((1, m.nv))).beams["beam"].strains[0.03]
    assert whole[0, 1:] == pytest.approx(own[0, 1:], abs=1e-15)         # curvatures and twist of segment 1


# ---------------------------------------------------------------------------------------------
# against the unsplit beam and the closed form


def test_one_segment_changes_nothing():
    """segments = 1 gives the unsplit pendulum's channels bit for bit."""
    one = registry.run(cases.load("pendulum", ["bodies.beam.segments=1"]), "flexmbd", 0.5)
    plain = registry.run(cases.load("pendulum"), "flexmbd", 0.5)
    assert one.channels.keys() == plain.channels.keys()
    assert all(np.array_equal(one.channels[k], plain.channels[k]) for k in plain.channels)


def settled(case, iterations=8) -> dict:
    """The case's channels at the static equilibrium of its flexmbd Model (Newton on qdd(q) = 0 at
    rest, central-difference Jacobian): the value a damped run settles to."""
    m = from_case(case.modelled)
    data, q, h = make_data(m), m.q0.copy(), 1e-6
    qdd = lambda q: forward_dynamics(m, data, q, np.zeros(m.nv), t=1.0)
    for _ in range(iterations):
        J = np.array([(qdd(q + h * e) - qdd(q - h * e)) / (2 * h) for e in np.eye(m.nq)]).T
        q = q - np.linalg.solve(J, qdd(q))
    assert np.abs(qdd(q)).max() < 1e-8
    out = channels.channels(case, inhouse.trajectory(case, m, np.array([1.0]), q[None], np.zeros((1, m.nv))))
    return {k: float(v[0]) for k, v in out.items()}


EB_TIP = 12.0 * 1.5 ** 3 / (3 * 2.06e11 * 0.01 * 0.015 ** 3 / 12)     # P L^3 / (3 E I) = 23.30 mm
EB_ROOT_STRESS = 12.0 * (1.5 - 0.03) * 0.0075 / (0.01 * 0.015 ** 3 / 12)  # M c / I at x = 0.03 m


@pytest.mark.parametrize("n", [1, 2, 4])
def test_a_split_cantilever_settles_to_the_closed_form(n):
    """Craig-Bampton modes with interfaces at both ends of each segment hold the static response of
    a segment to the force and moment at its end, so the split beam's static tip deflection is the
    FE one, which for cubic beam elements is P L^3 / (3 E I): what is left is the chain's
    second-order geometry (tip slope 0.023 rad, its square 5e-4), within 1e-3."""
    out = settled(cases.load("cantilever_step", [f"bodies.beam.segments={n}"] + craig_bampton(n)))
    assert -out["tip_deflection"] == pytest.approx(EB_TIP, rel=1e-3)
    assert out["stress_vm"] == pytest.approx(EB_ROOT_STRESS, rel=1e-3)


def test_a_split_cantilever_with_clamped_free_modes_converges_in_the_mode_count():
    """Clamped-free modes of a segment miss part of its static response to the moment at its end
    (the slope under an end moment converges as 1/count): 2 and 4 segments with 12 modes each are
    3 % and 7 % stiff, with 48 modes each within 1.5 % of P L^3 / (3 E I)."""
    err = {(n, c): -settled(cases.load("cantilever_step", [f"bodies.beam.segments={n}",
                                                           f"bodies.beam.modes.count={c}"]))["tip_deflection"] / EB_TIP - 1
           for n in (2, 4) for c in (12, 48)}
    assert abs(err[2, 48]) < abs(err[2, 12]) < 0.05 and abs(err[4, 48]) < abs(err[4, 12]) < 0.08
    assert abs(err[2, 48]) < 0.015 and abs(err[4, 48]) < 0.015


def tip_positions(r, L: float) -> np.ndarray:
    """(n, 2) global tip position in the plane of swing, from the joint angle and the tip's
    deflections in the root node's frame: Rz(angle) [L + dx, dy]."""
    th, x, y = r.channels["joint_angle"], L + r.channels["tip_deflection_x"], r.channels["tip_deflection"]
    return np.c_[np.cos(th) * x - np.sin(th) * y, np.sin(th) * x + np.cos(th) * y]


@pytest.mark.slow
def test_flexible_pendulum_case_follows_the_exact_beam():
    """Sonneville's very flexible pendulum as shipped (20 segments): the tip stays within 2 % of L
    of the converged geometrically exact beam (exudyn-beam, 256 elements, 1e-5 s) over 1 s
    (measured 1.22 %; docs/formulation.md §9)."""
    case = cases.load("flexible_pendulum")
    ref = registry.run(cases.load("flexible_pendulum", ["solvers.exudyn-beam.elements=256",
                                                       "solvers.exudyn-beam.dt=1e-5"]), "exudyn-beam")
    r = registry.run(case, "flexmbd")
    assert ref.ok and r.status.outside, (ref.status, r.status)
    d = np.linalg.norm(tip_positions(r, 1.0) - tip_positions(ref, 1.0), axis=1)
    assert d.max() < 0.02, d.max()
