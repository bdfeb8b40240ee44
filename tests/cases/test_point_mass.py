"""Point masses (`type = "point_mass"`): a mass at its frame origin without rotational inertia,
fixed to its parent. flexmbd takes it as the rigid body it is (no inertia); the peers build it as
their users would (Pinocchio's `pin.Inertia` with a zero rotational part, MuJoCo's welded body with
diaginertia 0, Exudyn's mass points on a pin or spherical joint, the rod's vertex mass, the full
model's node mass). Each is held to flexmbd, to a tip body of negligible inertia and to the closed
form of a cantilever with a tip mass; bad input is refused naming its key."""

import io
import json
from contextlib import redirect_stdout
from pathlib import Path

import numpy as np
import pytest

from flexmbd import cases, cli
from flexmbd.harness import cost, registry
from flexmbd.core.errors import InputError
from flexmbd.solvers import mujoco_rod

DATA = Path(__file__).resolve().parents[1] / "data"
PENDULUM = DATA / "point_mass_pendulum.toml"     # rigid link on a hinge, 0.5 kg point mass at its tip
TIP = DATA / "tip_point_mass.toml"               # cantilever, 0.2 kg point mass at its tip, 10 N tip force

BOB = 'bodies.bob={type = "point_mass", mass = 0.5}'
# the same bob as a rigid body of negligible inertia: 1e-12 kg m^2 against the pendulum's 0.83 kg m^2
# about its pivot (0.75 kg m^2 of the beam pendulum), a relative change of 1.2e-12
TINY = 'bodies.bob={type = "rigid", mass = 0.5, inertia = [1e-12, 1e-12, 1e-12, 0.0, 0.0, 0.0]}'
ON_BEAM = ['joints.bob_mount={type = "fixed", parent = "beam", child = "bob", at = 1.5}', "duration = 0.3"]


def tip_mass_frequency(EI, rhoA, L, M):
    """First bending frequency (Hz) of a clamped Euler-Bernoulli beam with a tip mass M and no
    rotary inertia (tests/solvers/test_tip_mass.py, which holds its classical roots)."""
    from tests.solvers.test_tip_mass import tip_mass_frequency as closed
    return closed(EI, rhoA, L, M, 0.0)


def rms(a, b) -> float:
    return float(np.sqrt(np.mean((np.asarray(a) - np.asarray(b)) ** 2)))


def test_a_point_mass_resolves_as_a_rigid_body_without_inertia():
    case = cases.load(str(PENDULUM))
    bob = case.bodies["bob"]
    assert isinstance(bob, cases.PointMass) and isinstance(bob, cases.Rigid) and bob.type == "point_mass"
    assert bob.mass == 0.5 and bob.com == (0.0, 0.0, 0.0) and bob.inertia == (0.0,) * 6
    assert case.link("bob").kind == "rigid" and case.nq == case.nv == 1


# what two flexmbd runs of models differing in the last bits may differ by, per channel kind: the
# adams integrator's error control (rtol 1e-8, atol 1e-10) chooses other steps. Measured (rigid link;
# flexible beam): angle 1.8e-12; 7.6e-10 rad; tip deflection -; 3.4e-7 of its largest; stress at
# 0.03 m, which carries the beam's modes up to 700 Hz, -; 1.5e-5 (von Mises and the signed normal
# stress, the same bending); energy 5.9e-14; 2.3e-11 J; the mount's force 1.3e-12 of its largest
SAME = {"joint_angle": (1e-8, False), "deflection": (1e-5, True), "stress_vm": (1e-4, True),
        "stress_normal": (1e-4, True), "energy": (1e-9, False), "reaction_force": (1e-9, True)}


@pytest.mark.parametrize("carrier", ["rigid link", "flexible beam"])
def test_point_mass_is_a_tip_body_of_negligible_inertia(carrier):
    """flexmbd: a point mass at the tip of a rigid link (released horizontal, 1 s) or of the paper's
    flexible pendulum (0.3 s) moves as a rigid body of the same mass with 1e-12 kg m^2 of inertia
    (which changes the pendulum's inertia about its pivot by 1.2e-12 of itself), to the bounds SAME
    (absolute, or relative to the channel's largest value); the bob as a 3.5 cm cube of 1e-4 kg m^2
    instead moves the rigid link's angle by more than 1e-5 rad."""
    if carrier == "rigid link":
        point, tiny = cases.load(str(PENDULUM)), cases.load(str(PENDULUM), [TINY])
    else:
        point, tiny = (cases.load("pendulum", [over] + ON_BEAM) for over in (BOB, TINY))
    a, b = registry.run(point, "flexmbd"), registry.run(tiny, "flexmbd")
    assert a.ok and b.ok, (a.status, b.status)
    assert np.array_equal(a.t, b.t) and set(a.channels) == set(b.channels)
    for ch, y in a.channels.items():
        tol, relative = SAME[point.channels[ch].kind]
        assert np.abs(y - b.channels[ch]).max() <= tol * (np.abs(y).max() if relative else 1.0), ch
    if carrier == "flexible beam":
        assert np.abs(a.channels["tip_deflection"]).max() > 1e-3       # the beam does bend
    else:
        cube = registry.run(cases.load(str(PENDULUM), [TINY.replace("1e-12", "1e-4")]), "flexmbd")
        assert abs(a.channels["angle"][-1] - cube.channels["angle"][-1]) > 1e-5


@pytest.mark.parametrize("peer", ["pinocchio", "mujoco"])
def test_rigid_peers_agree_with_flexmbd(peer):
    """The rigid pendulum with a point mass (link inertia as given, so no prism or lumping differs):
    Pinocchio (DOP853 at 1e-12) and MuJoCo (RK4 at 1e-4 s) within 1e-8 rad of flexmbd over the 1 s
    swing (measured 2e-12 rad: the peers' own integration errors on the rigid pendulum are 1e-12 to
    1e-11 rad, docs/peers.md), the energy conserved to 1e-8 J of 7.4 J kinetic. A point mass given an
    inertia of its own would show: 1e-4 kg m^2 (a 3.5 cm cube of 0.5 kg) shifts the angle by 2e-4 rad."""
    case = cases.load(str(PENDULUM))
    ref, r = registry.run(case, "flexmbd"), registry.run(case, peer)
    assert r.ok, r.status
    angle = np.interp(ref.t, r.t, r.channels["angle"])
    assert np.abs(angle - ref.channels["angle"]).max() < 1e-8
    assert abs(ref.channels["angle"][-1]) > 3.0                       # it swung through the bottom
    assert np.abs(r.channels["energy"] - r.channels["energy"][0]).max() < 1e-8


def test_system_mode_is_the_closed_form_of_a_tip_mass():
    """`flexmbd modes --system` on the cantilever with a 0.2 kg tip point mass: its first mode is the
    first bending mode of a cantilever with a tip mass and no rotary inertia (23.428 Hz; with the
    8 cm cube of tests/solvers/test_tip_mass.py, 2e-4 kg m^2, it is 23.378 Hz, 2.1e-3 lower). Bound 3e-4:
    the 40-element lumped mesh is 1.1e-4 low (O(h^2); 100 elements: 1.7e-5 high, where the excess of
    the 8 retained modes' Ritz value shows)."""
    case = cases.load(str(TIP))
    b = case.bodies["beam"]
    f = tip_mass_frequency(b.material.E * b.geometry.Iz, b.material.rho * b.geometry.A, b.length, 0.2)
    assert f == pytest.approx(23.4283, rel=1e-5)
    out = io.StringIO()
    with redirect_stdout(out):
        assert cli.main(["modes", str(TIP), "--system", "--json"]) == 0
    first = json.loads(out.getvalue())["modes"][0]
    assert first["label"] == "beam: bending xy 1"
    assert first["freq_hz"] == pytest.approx(f, rel=3e-4)


def crossing_frequency(t, y) -> float:
    from tests.solvers.test_tip_mass import crossing_frequency as crossing
    return crossing(t, y)


@pytest.mark.parametrize("solver", ["flexmbd", "fe-linear", "exudyn-beam", "exudyn-ffrf", "mujoco-rod"])
def test_cantilever_with_a_tip_point_mass_vibrates_at_the_closed_form(solver):
    """A constant 10 N force at the tip from rest: the tip swings about F L^3 / (3 E I) at the
    closed-form frequency of a cantilever with a tip mass (23.428 Hz). From the zero crossings over
    0.2 s, measured: flexmbd -4.8e-5, exudyn-ffrf -3.6e-5, fe-linear -5.4e-5 (the 40-element mesh),
    exudyn-beam 3.6e-6, mujoco-rod 3.8e-5; bound 2e-4 (a rigid tip body of the test_tip_mass cube is
    2.1e-3 off). The largest deflection is twice the static one within 2e-3 (flexmbd and exudyn-ffrf
    -1.1e-3 with 8 modes, fe-linear -1.1e-4, exudyn-beam 6.6e-5) but for mujoco-rod, whose discrete
    integrator damps (-7.9e-3, bound 1.5e-2)."""
    pytest.importorskip("exudyn" if solver.startswith("exudyn") else "mujoco" if solver == "mujoco-rod" else "numpy")
    case = cases.load(str(TIP))
    b = case.bodies["beam"]
    EI, L = b.material.E * b.geometry.Iz, b.length
    f = tip_mass_frequency(EI, b.material.rho * b.geometry.A, L, 0.2)
    static = case.loads["push"].force[1] * L ** 3 / (3.0 * EI)
    r = registry.run(case, solver)
    assert r.ok, r.status
    y = r.channels["tip_deflection"]
    assert crossing_frequency(r.t, y - static) == pytest.approx(f, rel=2e-4)
    assert y.min() == pytest.approx(2.0 * static, rel=1.5e-2 if solver == "mujoco-rod" else 2e-3)


def test_every_solver_that_runs_it_has_a_cost_estimate():
    """The command's cost check (before any run) reads the case as its solvers do: a case of one beam
    is that beam and its point masses."""
    for path in (TIP, PENDULUM):
        case = cases.load(str(path))
        runs = [s for s in registry.NAMES if not registry.status_for(case, s)]
        assert {"flexmbd", "exudyn-beam"} <= set(runs)
        cost.check([(case, s) for s in runs])


def test_mujoco_rod_puts_the_point_mass_on_its_nearest_vertex():
    """The rod's tip vertex sits at L: the tip mass joins it; off the rod it is not modelled."""
    pytest.importorskip("mujoco")
    case = cases.load(str(TIP))
    s, _ = mujoco_rod.rod_points(0.5, 40)
    assert mujoco_rod.vertex_masses(case, s) == {40: 0.2}
    assert mujoco_rod.applies(case) == ""
    ground = cases.load(str(TIP), ['joints.tip_mount={type = "fixed", parent = "ground", child = "tip", '
                                   'at = [0.5, 0.0, 0.0]}'])
    assert mujoco_rod.applies(ground).startswith("point mass 'tip': only on the rod")


# ---------------------------------------------------------------------------------------------
# bad input: one line naming the file and key, exit status 2


REFUSED = [
    (['joints.bob_mount.type="revolute"'], "joints.bob_mount.type", "hangs on a fixed joint (it has no rotational"),
    (['joints.bob_mount.type="spherical"'], "joints.bob_mount.type", "hangs on a fixed joint (it has no rotational"),
    (['joints.bob_mount.type="free"'], "joints.bob_mount.type", "hangs on a fixed joint (it has no rotational"),
    (['joints.bob_mount.type="prismatic"'], "joints.bob_mount.type", "hangs on a fixed joint"),
    (['bodies.bob.mass=0.0'], "bodies.bob.mass", "must be positive"),
    (['bodies.bob.inertia=[1.0, 1.0, 1.0, 0.0, 0.0, 0.0]'], "bodies.bob.inertia", "unknown key"),
    (['bodies.bob.type="point"'], "bodies.bob.type", "did you mean 'point_mass'"),
    (['bodies.more={type = "rigid", mass = 1.0, inertia = [1.0, 1.0, 1.0, 0.0, 0.0, 0.0]}',
      'joints.more={type = "fixed", parent = "bob", child = "more"}'], "joints.more.parent", "carries no joint"),
    (['loads.push={type = "point_force", body = "bob", at = [0.0, 0.0, 0.0], force = [1.0, 0.0, 0.0]}'],
     "loads.push.body", "apply the load to its parent"),
    (['joints.tie={type = "fixed", parent = "ground", child = "bob", loop = true, at = [1.0, 0.0, 0.0]}'],
     "joints.tie.child", "no loop joint reaches"),
]


@pytest.mark.parametrize("overrides, key, why", REFUSED)
def test_bad_point_masses_are_refused_naming_the_key(overrides, key, why, capsys):
    with pytest.raises(InputError) as e:
        cases.load(str(PENDULUM), overrides)
    assert f": {key}: " in str(e.value) and why in str(e.value), str(e.value)
    args = ["modes", str(PENDULUM)] + [a for o in overrides for a in ("--set", o)]
    assert cli.main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{PENDULUM}: {key}: " in err[0] and "Traceback" not in err[0], err


def test_deflection_of_a_point_mass_is_refused():
    with pytest.raises(InputError, match=r"channels\.d\.body: deflection needs a beam or a solid, 'bob' is a point "
                                         r"mass"):
        cases.load(str(PENDULUM), ['channels.d={kind = "deflection", body = "bob", at = 0.0}'])
