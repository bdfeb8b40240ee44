"""Modes chosen by kind (`modes.kinds`): a beam keeps the lowest `count` modes whose family (the
kind its label names: bending xy, bending xz, torsion, axial) is listed; without `kinds` the
lowest `count` of every kind, as before. Checked against the unfiltered mode sets, against the
closed forms of each family, in a run, and on bad input."""

import io
import json
from contextlib import redirect_stdout

import numpy as np
import pytest
from threadpoolctl import threadpool_limits

from flexmbd import cases, cli
from flexmbd.fe import flexbody
from flexmbd.harness import registry
from flexmbd.core.errors import InputError
from flexmbd.fe import modes

XY = 'bodies.beam.modes.kinds=["bending xy"]'
# clamped-free Euler-Bernoulli roots beta_k L of the first five bending modes
BETA_L = np.array([1.8751040687, 4.6940911330, 7.8547574382, 10.9955407349, 14.1371683910])


def beam_of(count: int, *overrides: str, boundary: str = "clamped-free"):
    """The paper pendulum's beam (1.5 m, 10 x 15 mm steel, h along y, 100 elements) reduced."""
    case = cases.load("pendulum", [f"bodies.beam.modes.count={count}", f'bodies.beam.modes.boundary="{boundary}"',
                                   *overrides])
    return case, case.reduced("beam")


def test_in_plane_bending_modes_are_the_closed_forms():
    """kinds = ["bending xy"], count 5: the five lowest bending modes in the x-y plane (E Iz, the
    stiff one here), none of the x-z plane's lower ones, at the Euler-Bernoulli frequencies of that
    plane within the 100-element lumped mesh's error, which grows as (beta_k L / n)^2 (measured
    -6.5e-5 to -1.4e-3, 0.07 to 0.19 times that; bound 0.25 times it, 3.5e-5 .. 5e-3, every one low);
    and the same for the x-z plane with E Iy: each plane its own frequencies (1.5 apart)."""
    for kind, inertia in (("bending xy", "Iz"), ("bending xz", "Iy")):
        case, fb = beam_of(5, f'bodies.beam.modes.kinds=["{kind}"]')
        b = case.bodies["beam"]
        assert fb.labels.tolist() == [f"{kind} {k}" for k in range(1, 6)]
        EI, rhoA = b.material.E * getattr(b.geometry, inertia), b.material.rho * b.geometry.A
        exact = BETA_L ** 2 / (2 * np.pi * b.length ** 2) * np.sqrt(EI / rhoA)
        err = fb.freq_hz / exact - 1.0
        assert np.all(err < 0) and np.all(-err < 0.25 * (BETA_L / b.elements) ** 2), (kind, err)


def test_torsion_and_axial_modes_are_the_closed_forms():
    """kinds = ["torsion"] and ["axial"]: clamped-free rods, f_k = (2k - 1) / (4 L) sqrt(G J / (rho Ip))
    and sqrt(E / rho); the lumped mesh of linear elements gives f sin(theta / 2) / (theta / 2),
    theta = (2k - 1) pi / (2 n): -theta^2 / 24, 1e-5 for the first (bound 1.5 theta^2 / 24)."""
    for kind in ("torsion", "axial"):
        case, fb = beam_of(3, f'bodies.beam.modes.kinds=["{kind}"]')
        b, k = case.bodies["beam"], np.arange(1, 4)
        mat, sec = b.material, b.geometry
        speed = np.sqrt(mat.G * sec.J / (mat.rho * sec.Ip)) if kind == "torsion" else np.sqrt(mat.E / mat.rho)
        exact = (2 * k - 1) / (4 * b.length) * speed
        theta = (2 * k - 1) * np.pi / (2 * b.elements)
        assert fb.labels.tolist() == [f"{kind} {i}" for i in k]
        assert np.all(np.abs(fb.freq_hz / exact - 1.0) < 1.5 * theta ** 2 / 24), kind


@pytest.mark.parametrize("boundary", ["clamped-free", "hinged-hinged", "free-free"])
def test_kinds_keep_the_modes_of_the_full_set(boundary):
    """The modes kept by kind are those of the same kind in an unfiltered set that holds them: for
    normal modes the same eigenpairs (to the eigensolver's 1e-9), for free-free ones the same Ritz
    values of the held set (the families are uncoupled, so holding the reference node keeps them
    apart): the first unfiltered count whose set holds five x-y modes."""
    _, kept = beam_of(5, XY, boundary=boundary)
    for count in range(5, 40):
        _, full = beam_of(count, boundary=boundary)
        inplane = [k for k, lab in enumerate(full.labels) if lab.startswith("bending xy")]
        if len(inplane) == 5:
            break
    assert kept.labels.tolist() == full.labels[inplane].tolist()
    np.testing.assert_allclose(kept.freq_hz, full.freq_hz[inplane], rtol=1e-8)
    # the same shapes up to sign, node by node
    P, Q = kept.Phi.reshape(-1, 5), full.Phi[:, :, inplane].reshape(-1, 5)
    np.testing.assert_allclose(np.abs(np.sum(P * Q, axis=0) / np.linalg.norm(P, axis=0) / np.linalg.norm(Q, axis=0)),
                               1.0, rtol=1e-7)


def test_craig_bampton_kinds_are_the_basis_of_those_kinds():
    """Craig-Bampton with interfaces at both ends and kinds = ["bending xy"]: the x-y constraint
    modes of the two nodes (2 each) and the x-y fixed-interface normal modes, less the x-y plane's two
    rigid directions, held at the root: every mode in the plane, and spanning the static response
    to a transverse tip force (which the constraint modes hold exactly)."""
    case, fb = beam_of(6, XY, "bodies.beam.modes.interfaces=[0.0, 1.5]", boundary="craig-bampton")
    assert all(lab.startswith("bending xy") for lab in fb.labels) and fb.n_modes == 6
    b = case.bodies["beam"]
    nodes, _, _, K, M, _ = flexbody.fe_model(b)
    tip = 6 * (nodes.shape[0] - 1) + 1                              # uy of the tip node
    static = modes.static_modes(K, modes.boundary_dofs("clamped-free", nodes.shape[0]), [tip])[:, 0]
    Phi = fb.Phi[:, [3, 4, 5, 0, 1, 2], :].reshape(-1, fb.n_modes)   # back to the FE DOF order
    fit = Phi @ np.linalg.lstsq(Phi, static, rcond=None)[0]
    assert np.linalg.norm(fit - static) < 1e-8 * np.linalg.norm(static)


def test_without_kinds_the_lowest_modes_of_every_kind():
    """No kinds: the lowest `count` normal modes, whatever their kind (the pendulum's 12: x-z and
    x-y bending); every kind listed: the same set, bit for bit."""
    case, default = beam_of(12)
    nodes, _, _, K, M, _ = flexbody.fe_model(case.bodies["beam"])
    with threadpool_limits(limits=1):                   # as the reduction runs (`flexbody._reduced`)
        freq, _ = modes.normal_modes(K, M, modes.boundary_dofs("clamped-free", nodes.shape[0]), 12)
    assert np.array_equal(default.freq_hz, freq)
    assert {lab.rsplit(" ", 1)[0] for lab in default.labels} == {"bending xy", "bending xz"}
    _, every = beam_of(12, f"bodies.beam.modes.kinds={json.dumps(list(modes.FAMILIES))}")
    assert np.array_equal(every.freq_hz, default.freq_hz) and np.array_equal(every.Phi, default.Phi)


def test_a_planar_run_needs_only_the_planar_modes():
    """The pendulum swings in the x-y plane, so its x-z modes stay at rest: five in-plane modes kept
    by kind give the run of the 11 lowest modes (which hold the same five and six of the x-z plane)
    to the integrator's tolerance (rtol 1e-8 on states of other sizes: measured 3.1e-7 of the tip
    deflection, bound 1e-5), while the five lowest modes of any kind (three in-plane) differ by 9 %
    (bound: more than 1e-3)."""
    runs = {name: registry.run(cases.load("pendulum", ["duration=0.3", *over]), "flexmbd")
            for name, over in (("kinds", ["bodies.beam.modes.count=5", XY]), ("all", ["bodies.beam.modes.count=11"]),
                               ("lowest", ["bodies.beam.modes.count=5"]))}
    assert all(r.ok for r in runs.values())
    y = {name: r.channels["tip_deflection"] for name, r in runs.items()}
    scale = np.abs(y["all"]).max()
    assert np.abs(y["kinds"] - y["all"]).max() < 1e-5 * scale
    assert np.abs(y["lowest"] - y["all"]).max() > 1e-3 * scale


def test_flexmbd_modes_prints_the_kept_modes():
    out = io.StringIO()
    with redirect_stdout(out):
        assert cli.main(["modes", "pendulum", "--set", "bodies.beam.modes.count=3", "--set", XY, "--json"]) == 0
    got = json.loads(out.getvalue())["bodies"]["beam"]["modes"]
    assert [m["label"] for m in got] == ["bending xy 1", "bending xy 2", "bending xy 3"]
    assert got[0]["freq_hz"] == pytest.approx(5.527, abs=1e-3)


REFUSED = [
    ('bodies.beam.modes.kinds=["bending-xy"]', "unknown mode kind 'bending-xy' (did you mean 'bending xy'?)"),
    ('bodies.beam.modes.kinds=[]', "expected at least one of"),
    ('bodies.beam.modes.kinds=["torsion", "torsion"]', "listed twice"),
    ('bodies.beam.modes.kinds="torsion"', "expected a list of strings"),
    ('bodies.beam.modes.kinds=["axial"]', "101 modes of kinds axial requested but the 100-element mesh has only 100"),
]


@pytest.mark.parametrize("override, why", REFUSED)
def test_bad_kinds_are_refused_naming_the_key(override, why, capsys):
    count = ["bodies.beam.modes.count=101"] if "101" in why else []
    with pytest.raises(InputError) as e:
        cases.load("pendulum", [override, *count])
    assert ": bodies.beam.modes.kinds: " in str(e.value) and why in str(e.value), str(e.value)
    assert cli.main(["modes", "pendulum", "--set", override, *[a for c in count for a in ("--set", c)]]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and ": bodies.beam.modes.kinds: " in err[0], err


def test_modes_per_family_count_the_free_dofs():
    """Per family, every boundary leaves n axial, n torsion and 2n bending modes in each plane of an
    n-element beam (the free DOFs less the rigid motions): their sum is every elastic mode."""
    for boundary in ("clamped-free", "hinged-hinged", "free-free"):
        nodes = 5
        fixed = modes.boundary_dofs(boundary, nodes)
        rigid = 6 if boundary == "free-free" else 0
        assert sum(modes.modes_per_family(nodes - 1).values()) == 6 * nodes - fixed.size - rigid
