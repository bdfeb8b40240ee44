"""exudyn-ffrf on flexible solids (docs/exudyn.md, Solids): the FlexBody of the solid with the
mesh's consistent mass in Exudyn's ObjectFFRFreducedOrder, against flexmbd's reduced body and runs."""

import numpy as np
import pytest

pytest.importorskip("exudyn")

from flexmbd import cases
from flexmbd.fe import flexbody
from flexmbd.harness import registry
from flexmbd.mbd import invariants  # noqa: E402
from flexmbd.solvers import exudyn_ffrf  # noqa: E402


def rel_rms(a, b):
    """RMS difference over the first signal's maximum magnitude."""
    return np.sqrt(np.mean((np.asarray(a) - np.asarray(b)) ** 2)) / np.abs(a).max()


def brick():
    case = cases.load("brick_pendulum")
    return case, flexbody.for_case(case)


def test_solid_mass_is_the_flexbodys():
    """The adapter's rebuilt consistent mass (zero rows for the two interface nodes, then the mesh's
    Ms) gives flexmbd's m = Ms 1, Mx0 = Ms x0 and MPt = Ms Phi_t to round-off."""
    case, fbs = brick()
    fb, body = fbs["block"], case.bodies["block"]
    Ms = exudyn_ffrf.padded_scalar_mass(body, fb)
    assert Ms.shape == (fb.n_nodes, fb.n_nodes) and fb.n_nodes == 2 + 861
    assert Ms[:2].nnz == 0 and Ms[:, :2].nnz == 0
    np.testing.assert_allclose(Ms @ np.ones(fb.n_nodes), fb.m, rtol=0, atol=1e-15)        # node masses ~1e-4 kg
    np.testing.assert_allclose(Ms @ fb.x0, fb.Mx0, rtol=0, atol=1e-15)
    np.testing.assert_allclose((Ms @ fb.Phi[:, 3:, :].reshape(fb.n_nodes, -1)).reshape(fb.MPt.shape), fb.MPt,
                               rtol=0, atol=1e-14)                                          # entries up to ~0.5
    M = exudyn_ffrf.solid_mass(body, fb)
    assert (M - exudyn_ffrf.sp.kron(Ms, exudyn_ffrf.sp.identity(3))).nnz == 0


def test_solid_invariants_in_exudyn_are_flexmbds():
    """What the ObjectFFRFreducedOrder in the built system holds (read back from Exudyn), computed
    by Exudyn's interface from the consistent mass, equals flexmbd's invariants I1..I9 of the same
    FlexBody to round-off (the largest entries are ~1: tolerance 1e-13 of each invariant's scale)."""
    case, fbs = brick()
    fb = fbs["block"]
    inv = invariants.invariants(fb)
    nm, N = fb.n_modes, fb.n_nodes
    SC, mbs, items, S, joints = exudyn_ffrf.build(case, fbs, True)
    o = mbs.GetObject(items["block"]["obj"])

    def close(a, b):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-13 * max(np.abs(b).max(), 1e-300))
    assert o["mass"] == pytest.approx(inv.I8[0], rel=1e-14)
    close(o["mass"] * np.asarray(o["centerOfMass"]), inv.I4[0])
    close(np.asarray(o["inertia"]), inv.I1[0])
    close(np.asarray(o["massMatrixReduced"].GetPythonObject()), inv.I9[0])
    close(np.asarray(o["massMatrixReduced"].GetPythonObject()), np.eye(nm))          # mass-orthonormal modes
    close(np.asarray(o["stiffnessMatrixReduced"].GetPythonObject()), fb.Km)
    close(np.asarray(o["mPhitTPsi"]), inv.I5[0])
    close(-np.asarray(o["mXRefTildePsi"]), inv.I6[0])
    close(np.asarray(o["mPsiTildePsi"]).reshape(nm, 3, nm), -inv.I7[0])
    close(np.asarray(o["mPsiTildePsiTilde"]).reshape(nm, 3, nm, 3).transpose(0, 2, 1, 3), inv.I3[0])
    C = np.asarray(o["mXRefTildePsiTilde"]).reshape(3, nm, 3).transpose(1, 0, 2)
    close(C + C.transpose(0, 2, 1), inv.I2[0])
    # the FlexBody's nodes and modes as they are, then the centre-of-mass node that carries gravity
    x, Phi = np.asarray(o["referencePositions"]).reshape(-1, 3), np.asarray(o["modeBasis"]).reshape(-1, 3, nm)
    assert x.shape[0] == N + 1
    np.testing.assert_array_equal(x[:N], fb.x0)
    np.testing.assert_array_equal(Phi[:N], fb.Phi[:, 3:, :])
    close(x[N], inv.I4[0] / inv.I8[0])
    close(Phi[N], inv.I5[0] / inv.I8[0])


def test_solid_pendulum_follows_flexmbd_short():
    """0.2 s of brick_pendulum (its table: Fox-Goodwin at 1.25e-5 s) against flexmbd at its defaults.
    Measured: tip deflection 7.5e-5 RMS / max, hinge angle 6.0e-9 rad. Bounds with a margin of ~3 that
    still catch a wrong body: the lumped row-sum mass gives 5.4e-4 / 4.3e-8 rad, Exudyn's
    LoadMassProportional gravity 7.0e-4 / 1.4e-6 rad, the trapezoidal rule at 2.5e-5 s 5.4e-2."""
    case = cases.load("brick_pendulum")
    ref = registry.run(case, "flexmbd", 0.2)
    r = registry.run(case, "exudyn-ffrf", 0.2)
    assert r.ok, r.status
    assert r.settings["solver"] == "fox-goodwin" and r.settings["dt"] == pytest.approx(1.25e-5)
    np.testing.assert_allclose(r.t, ref.t)
    assert rel_rms(ref.channels["tip_deflection"], r.channels["tip_deflection"]) < 2.5e-4
    assert np.abs(ref.channels["hinge_angle"] - r.channels["hinge_angle"]).max() < 2e-8
    assert np.ptp(r.channels["hinge_angle"]) > 0.9                       # it swings: 0.95 rad by 0.2 s


def test_solid_energy_with_the_consistent_mass():
    """The energy channel on a solid: kinetic 1/2 v' (Ms (x) I3) v from Exudyn's node velocities,
    gravity with m = Ms 1. Released at rest it starts at 0 and stays there: measured 8.9e-11 J over
    0.1 s against m g L = 0.95 J exchanged; bound 1e-8 J."""
    case = cases.load("brick_pendulum", ["channels.energy={kind='energy'}"])
    r = registry.run(case, "exudyn-ffrf", 0.1)
    assert r.ok, r.status
    assert r.channels["energy"][0] == pytest.approx(0.0, abs=1e-15)
    assert np.abs(r.channels["energy"]).max() < 1e-8


def test_solid_stress_channel_and_tip_load():
    """cantilever_solid (hex20 mesh, 12 modes, a step load at the averaging interface 'tip', a
    stress at an element centre from the modal stresses S_solid), 0.05 s at the adapter's defaults:
    measured tip deflection 2.6e-6 and stress 1.2e-4 RMS / max off flexmbd; bounds 10x that."""
    case = cases.load("cantilever_solid")
    ref = registry.run(case, "flexmbd", 0.05)
    r = registry.run(case, "exudyn-ffrf", 0.05)
    assert r.ok, r.status
    assert rel_rms(ref.channels["tip_deflection"], r.channels["tip_deflection"]) < 3e-5
    assert rel_rms(ref.channels["stress_vm"], r.channels["stress_vm"]) < 1.2e-3


WEIGHT = "bodies.weight={type='rigid', mass=0.1, com=[0.0, 0.0, 0.0], inertia=[1e-5, 1e-5, 1e-5, 0.0, 0.0, 0.0]}"


@pytest.mark.parametrize("over", [
    [WEIGHT, "joints.tipjoint={type='spherical', parent='block', child='weight', at='tip'}"],
    ["loads.tipload={type='point_force', body='block', at='tip', force=[0.5, -2.0, 0.0], frame='global', "
     "profile={type='ramp', t1=0.02}}"],
], ids=["spherical-joint-at-tip", "load-at-tip"])
def test_solid_averaging_interface_position(over):
    """A spherical joint or a load at the averaging interface 'tip' act on its reference node, whose
    translation rows are the rigid fit's, as in flexmbd. 0.1 s, measured tip deflection 2.1e-5 /
    2.3e-5 RMS / max off flexmbd, hinge angle 4.3e-9 / 2.8e-9 rad; bounds 1e-4 and 5e-8 rad."""
    case = cases.load("brick_pendulum", over)
    assert exudyn_ffrf.applies(case) == ""
    ref = registry.run(case, "flexmbd", 0.1)
    r = registry.run(case, "exudyn-ffrf", 0.1)
    assert r.ok, r.status
    assert rel_rms(ref.channels["tip_deflection"], r.channels["tip_deflection"]) < 1e-4
    assert np.abs(ref.channels["hinge_angle"] - r.channels["hinge_angle"]).max() < 5e-8


def test_solid_not_applicable_reasons():
    """What the adapter cannot model on a solid is refused in one line, never run."""
    for jt in ("revolute", "fixed"):
        tip = f"joints.tipjoint={{type='{jt}', parent='block', child='weight', at='tip'}}"
        c = cases.load("brick_pendulum", [WEIGHT, tip])
        assert str(registry.status_for(c, "exudyn-ffrf")) == (
            f"not applicable: joint 'tipjoint': a {jt} joint at interface 'tip' of solid 'block' (not its frame's) "
            f"needs the interface's rotation, which Exudyn's super-element marker on its reference node does not "
            f"give (its position only: spherical joints)")
    loop = cases.load("brick_pendulum", [
        WEIGHT, "joints.lj={type='revolute', parent='ground', child='weight', at=[0.3, 0.0, 0.0]}",
        "joints.cut={type='spherical', parent='block', child='weight', at='tip', child_at=[0.0, 0.0, 0.0], loop=true}"])
    assert "the modes of solid 'block' can move its point out of the plane" in exudyn_ffrf.applies(loop)
    none = cases.load("brick_pendulum", ["bodies.block.modes.count=0"])
    assert exudyn_ffrf.applies(none).startswith("body 'block' retains no modes")
    assert exudyn_ffrf.applies(cases.load("brick_pendulum")) == ""
    assert exudyn_ffrf.SOLIDS is True
