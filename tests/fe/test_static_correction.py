"""Static correction modes (`modes.static`, fe.flexbody.static_correction, docs/formulation.md
§7d): a beam's normal modes plus the static deflections under unit loads at the listed nodes,
orthogonalised against them. Checked against the closed-form static deflection, against the mode
set without them, and on bad input."""

import numpy as np
import pytest

from flexmbd import cases, cli
from flexmbd.core.errors import InputError
from flexmbd.fe import flexbody

XY = 'bodies.beam.modes.kinds=["bending xy"]'


def mode_set(*overrides: str):
    """The paper pendulum's beam (1.5 m steel, 100 elements, clamped-free, lumped mass): its case
    beam, K, the lumped M and (freq, Phi_fe) of `fe.flexbody.mode_set`."""
    beam = cases.load("pendulum", list(overrides)).bodies["beam"]
    nodes, _, _, K, M, M_lumped = flexbody.fe_model(beam)
    return beam, K, M, flexbody.mode_set(beam, K, M, M_lumped, nodes)


def reduced_static(K, Phi, F):
    """u = Phi (Phi^T K Phi)^-1 Phi^T F: the static response of the reduced body."""
    return Phi @ np.linalg.solve(Phi.T @ (K @ Phi), Phi.T @ F)


@pytest.mark.parametrize("count", [1, 2, 4])
def test_a_tip_load_is_carried_exactly_with_any_number_of_modes(count):
    """A static tip force P on the cantilever: with the tip's static correction the reduced body's
    tip deflection is P L^3 / (3 E I) (cubic elements are exact for it) at any mode count, and so
    is its slope P L^2 / (2 E I), to 1e-7 relative: the basis is orthonormal to about 1e-12 and
    the reduced stiffness's conditioning, (f_max / f_1)^2 = (600 / 5.5)^2 = 1.2e4, amplifies it
    (measured 2e-9; margin 50). Without the correction the normal modes alone miss it by more than
    1e-4: the test can fail."""
    beam, K, _, (_, Phi) = mode_set(f"bodies.beam.modes.count={count}", XY, "bodies.beam.modes.static=[1.5]")
    b = beam.section
    EI = beam.material.E * b.b * b.h ** 3 / 12.0
    F = np.zeros(K.shape[0])
    tip = 6 * beam.elements + 1                     # tip node's u_y
    F[tip] = 1.0
    u = reduced_static(K, Phi, F)
    assert abs(u[tip] / (beam.length ** 3 / (3 * EI)) - 1) < 1e-7
    assert abs(u[tip + 4] / (beam.length ** 2 / (2 * EI)) - 1) < 1e-7          # tip slope theta_z
    _, _, _, (_, normal) = mode_set(f"bodies.beam.modes.count={count}", XY)
    assert abs(reduced_static(K, normal, F)[tip] / (beam.length ** 3 / (3 * EI)) - 1) > 1e-4


def test_the_normal_modes_are_kept_and_the_corrections_labelled_above_them():
    """The correction leaves the retained normal modes and their frequencies as they were (to 1e-12:
    Phi^T K Psi = 0 follows from K Phi = M Phi Lambda), is M-orthonormal to them, K-diagonal, above
    them in frequency, and labelled by family: 'bending xy static 1'."""
    _, K, M, (freq, Phi) = mode_set("bodies.beam.modes.count=4", "bodies.beam.modes.static=[1.5]")
    _, _, _, (freq0, Phi0) = mode_set("bodies.beam.modes.count=4")
    assert np.allclose(freq[:4], freq0, rtol=1e-12) and np.allclose(Phi[:, :4], Phi0, atol=1e-12 * abs(Phi0).max())
    G = Phi.T @ (M @ Phi)
    assert np.allclose(G, np.eye(Phi.shape[1]), atol=1e-10)
    Km = Phi.T @ (K @ Phi)
    assert np.allclose(Km, np.diag(np.diag(Km)), atol=1e-9 * Km.max())
    assert freq[4:].min() > freq[:4].max()
    fb = cases.load("pendulum", ["bodies.beam.modes.count=4", "bodies.beam.modes.static=[1.5]"]).reduced("beam")
    # the tip's six DOFs: axial, two bending planes (force and moment each), torsion
    assert sorted(str(lab) for lab in fb.labels[4:]) == sorted(
        ["axial static 1", "torsion static 1", "bending xy static 1", "bending xy static 2",
         "bending xz static 1", "bending xz static 2"])


def test_kinds_choose_the_corrections_too():
    """With kinds = ["bending xy"] only the in-plane tip force and moment are corrected."""
    fb = cases.load("pendulum", ["bodies.beam.modes.count=3", XY, "bodies.beam.modes.static=[1.5]"]).reduced("beam")
    assert [str(lab) for lab in fb.labels] == ["bending xy 1", "bending xy 2", "bending xy 3",
                                               "bending xy static 1", "bending xy static 2"]


def test_hinged_hinged_corrects_only_the_free_dofs():
    """On a hinged-hinged beam the far end's transverse DOFs are held: its correction is the axial
    force, the torsion and the two bending moments."""
    case = cases.load("double_pendulum", ["bodies.beam1.modes.count=2", "bodies.beam1.modes.static=[1.5]"])
    fams = [str(lab) for lab in case.reduced("beam1").labels[2:]]
    assert sorted(fams) == ["axial static 1", "bending xy static 1", "bending xz static 1", "torsion static 1"]


REFUSED = [
    ('bodies.beam.modes.static=[0.0]', "on its root node"),
    ('bodies.beam.modes.static=[2.0]', "outside the beam"),
    ('bodies.beam.modes.static=[1.5, 1.499]', "the same node"),
    ('bodies.beam.modes.static=[1.5]', "needs boundary"),
]


@pytest.mark.parametrize("override, why", REFUSED)
def test_bad_static_positions_are_refused_naming_the_key(override, why, capsys):
    extra = ['bodies.beam.modes.boundary="free-free"'] if "boundary" in why else []
    with pytest.raises(InputError) as e:
        cases.load("pendulum", [override, *extra])
    assert ": bodies.beam.modes.static: " in str(e.value) and why in str(e.value), str(e.value)
    assert cli.main(["modes", "pendulum", "--set", override, *[a for x in extra for a in ("--set", x)]]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and ": bodies.beam.modes.static: " in err[0], err
