"""Flexible solids end to end (flexmbd/fe/flexbody.py `solid_body`, cases, channels, fe-linear's
full-order solid, the command line): one reduced body from any of the three mesh formats, the
frequencies of an imported tetrahedral mesh against scikit-fem's own reading and assembly, the
modal solid against the full-order one, and import errors as one line with exit status 2."""

import dataclasses
from pathlib import Path

import meshio
import numpy as np
import pytest
import scipy.sparse.linalg as spla

from flexmbd import cases
from flexmbd.harness import registry
from flexmbd.mbd import invariants
from flexmbd.cli import main

DATA = Path(__file__).resolve().parents[1] / "data"

CASE = """title = "solid"
duration = {duration}
gravity = [0.0, -9.81, 0.0]
[materials.steel]
E = 2.1e11
nu = 0.3
rho = 7850.0
[bodies.block]
type = "solid"
material = "steel"
mesh = {{ {mesh} }}
frame = "clamp"
modes = {{ count = {count} }}
[bodies.block.interfaces.clamp]
set = "{clamp}"
kind = "rigid"
[bodies.block.interfaces.tip]
set = "{tip}"
[joints.fix]
type = "{joint}"
parent = "ground"
child = "block"
[loads.push]
type = "point_force"
body = "block"
at = "tip"
force = [0.0, -50.0, 20.0]
profile = {{ type = "step" }}
[channels.tip_y]
kind = "deflection"
body = "block"
at = "tip"
component = "y"
[channels.stress]
kind = "stress_vm"
body = "block"
point = [0.0125, 0.0099, 0.007]
[integrator]
output_dt = 1e-4
"""

# the block's interface sets in each format (NASTRAN has no names: SPC1 1 and SET1 2)
SETS = {"inp": ("clamp", "tip"), "bdf": ("spc1", "set2"), "msh": ("clamp", "tip")}


def case_file(tmp_path, mesh: str, clamp="clamp", tip="tip", count=6, joint="fixed", duration=0.01, name="solid"):
    path = tmp_path / f"{name}.toml"
    path.write_text(CASE.format(mesh=mesh, clamp=clamp, tip=tip, count=count, joint=joint, duration=duration))
    return path


@pytest.mark.parametrize("stem", ["block", "block_tet"])
def test_one_reduced_body_from_abaqus_nastran_and_gmsh(tmp_path, stem):
    """The same mesh written in the three formats (tests/data/make_block.py) reduces to the same
    body: frequencies and every invariant to 1e-12 relative (the files hold the same numbers, so
    only the readers' node numbering could differ, and it would show far above round-off)."""
    bodies = {}
    for ext, (clamp, tip) in SETS.items():
        path = case_file(tmp_path, f'file = "{DATA / f"{stem}.{ext}"}"', clamp, tip, name=ext)
        bodies[ext] = cases.load(str(path)).reduced("block")
    ref = bodies["inp"]
    for ext, fb in bodies.items():
        assert np.allclose(fb.freq_hz, ref.freq_hz, rtol=1e-12, atol=0), ext
        a, b = invariants.invariants(fb), invariants.invariants(ref)
        for name in a._fields:
            x, y = getattr(a, name), getattr(b, name)
            scale = max(np.abs(y).max(), 1e-300)
            # mode signs follow each column's largest entry: equal bodies have equal signs
            assert np.abs(x - y).max() <= 1e-12 * scale, (ext, name)


def test_modes_of_an_imported_tetrahedral_mesh_match_scikit_fem(tmp_path, capsys):
    """`flexmbd modes` of the tet10 block clamped at one face against scikit-fem reading the same
    Gmsh file with meshio and assembling it itself (P2 elements, its own quadrature) to 1e-6."""
    path = case_file(tmp_path, f'file = "{DATA / "block_tet.msh"}"', count=6)
    assert main(["modes", str(path), "--json"]) == 0
    import json
    out = json.loads(capsys.readouterr().out)
    ours = np.array([m["freq_hz"] for m in out["bodies"]["block"]["modes"]])

    from skfem import Basis, BilinearForm, ElementTetP2, ElementVector, asm
    from skfem.helpers import dot
    from skfem.io.meshio import from_meshio
    from skfem.models.elasticity import lame_parameters, linear_elasticity
    m = meshio.read(DATA / "block_tet.msh")
    sk = from_meshio(meshio.Mesh(m.points, [("tetra", m.cells_dict["tetra10"][:, :4])]))
    E, nu, rho = 2.1e11, 0.3, 7850.0
    basis = Basis(sk, ElementVector(ElementTetP2()), intorder=4)
    K = asm(linear_elasticity(*lame_parameters(E, nu)), basis)
    M = asm(BilinearForm(lambda u, v, w: rho * dot(u, v)), basis)
    free = basis.complement_dofs(basis.get_dofs(lambda x: np.isclose(x[0], 0.0)).all())
    lam = spla.eigsh(K[free][:, free].tocsc(), k=6, M=M[free][:, free].tocsc(), sigma=0.0, which="LM")[0]
    theirs = np.sqrt(np.sort(lam)) / (2 * np.pi)
    assert np.abs(ours / theirs - 1).max() < 1e-6           # seen: ~1e-12


def test_modal_solid_against_the_full_order_solid(tmp_path):
    """A stubby hex20 box clamped at one face under a step load and gravity: flexmbd's modal solid
    against fe-linear's whole mesh (Newmark at 2.5e-7 s: the step excites the block's kHz modes,
    whose Newmark phase error at 1e-6 s alone made 3 % of the stress difference), over 5 ms. The
    difference falls as modes are added: it is the truncation."""
    mesh = 'box = [0.1, 0.02, 0.03], divisions = [4, 1, 2], element = "hex20"'
    errors = {}
    for count in (3, 24):
        path = case_file(tmp_path, mesh, "x0", "xL", count=count, name=f"m{count}", duration=0.005)
        case = cases.load(str(path), ["solvers.fe-linear.dt=2.5e-7"])
        a, b = registry.run(case, "flexmbd"), registry.run(case, "fe-linear")
        assert a.status.ok and b.status.ok
        errors[count] = {c: np.sqrt(np.mean((a.channels[c] - b.channels[c]) ** 2)) / np.abs(b.channels[c]).max()
                         for c in ("tip_y", "stress")}
    print(errors)
    assert errors[24]["tip_y"] < 0.01 and errors[24]["stress"] < 0.03        # the case's tolerances
    assert errors[24]["tip_y"] < errors[3]["tip_y"] and errors[24]["stress"] < errors[3]["stress"]


@pytest.mark.parametrize("text, expected", [
    ("*NODE\n1, 0, 0, 0\n*ELEMENT, TYPE=C3D4\n1, 1, 2, 3, 4\n", "bad.inp:4: "),
    ("*NODE\n1, 0, 0, 0\n2, 1, 0, 0\n3, 0, 1, 0\n4, 0, 0, 1\n*ELEMENT, TYPE=C3D6\n1, 1, 2, 3, 4\n", "bad.inp:6: "),
    ("*NODE\n1, 0, 0, 0\n2, 1, 0, 0\n3, 0, 1, 0\n4, 0, 0, -1\n*ELEMENT, TYPE=C3D4\n1, 1, 2, 3, 4\n", "bad.inp"),
])
def test_an_import_error_is_one_line_exit_2_and_nothing_written(tmp_path, capsys, text, expected):
    (tmp_path / "bad.inp").write_text(text + "*MATERIAL, NAME=steel\n*ELASTIC\n2e11, 0.3\n*DENSITY\n7850.\n"
                                      "*NSET, NSET=clamp\n1\n*NSET, NSET=tip\n2\n")
    path = case_file(tmp_path, 'file = "bad.inp"')
    code = main(["run", str(path), "--solver", "flexmbd", "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1 and expected in err, err
    assert not (tmp_path / "out").exists()


def test_a_missing_set_names_the_file_and_its_sets(tmp_path, capsys):
    path = case_file(tmp_path, f'file = "{DATA / "block.inp"}"', tip="tipp")
    assert main(["run", str(path), "--solver", "flexmbd", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "bodies.block.interfaces.tip.set" in err and "'tipp'" in err and "clamp" in err, err
    assert not (tmp_path / "out").exists()


def test_solvers_without_solids_say_so(tmp_path):
    case = cases.load(str(case_file(tmp_path, f'file = "{DATA / "block.inp"}"')))
    for name in ("pinocchio", "mujoco", "exudyn-beam", "analytic", "mujoco-rod"):
        status = registry.status_for(case, name)
        assert status.startswith(("not applicable", "unavailable")), (name, status)
    assert registry.status_for(case, "flexmbd") == "" and registry.status_for(case, "fe-linear") == ""


def test_craig_bampton_modes_with_a_rigid_tip_against_the_full_order_solid(tmp_path):
    """A rigid (RBE2-like) tip interface and Craig-Bampton modes (its six constraint modes and the
    normal modes with it held): flexmbd against fe-linear's whole mesh under the same constraint
    (`fe.solid.constraint_basis`), as in test_modal_solid_against_the_full_order_solid."""
    mesh = 'box = [0.1, 0.02, 0.03], divisions = [4, 1, 2], element = "hex20"'
    path = case_file(tmp_path, mesh, "x0", "xL", count=30, duration=0.005)
    text = path.read_text().replace('[bodies.block.interfaces.tip]\nset = "xL"',
                                    '[bodies.block.interfaces.tip]\nset = "xL"\nkind = "rigid"')
    path.write_text(text.replace('modes = { count = 30 }', 'modes = { count = 30, boundary = "craig-bampton" }'))
    case = cases.load(str(path), ["solvers.fe-linear.dt=2.5e-7"])
    assert case.reduced("block").boundary == "craig-bampton"
    a, b = registry.run(case, "flexmbd"), registry.run(case, "fe-linear")
    rel = {c: np.sqrt(np.mean((a.channels[c] - b.channels[c]) ** 2)) / np.abs(b.channels[c]).max()
           for c in ("tip_y", "stress")}
    assert rel["tip_y"] < 0.01 and rel["stress"] < 0.03, rel      # the case tolerances (seen 0.09 %, 2.2 %)


def test_free_free_modes_of_a_hinged_block_in_flexmbd_and_exudyn(tmp_path):
    """brick_pendulum with free-free modes (the hinge face's fitted reference point as the frame):
    flexmbd and exudyn-ffrf (its own invariants from the consistent mass) over 0.05 s."""
    pytest.importorskip("exudyn")
    case = cases.load("brick_pendulum", ['bodies.block.modes.boundary="free-free"', "bodies.block.modes.count=6",
                                         'bodies.block.interfaces.hinge.kind="averaging"'])
    a, b = registry.run(case, "flexmbd", 0.05), registry.run(case, "exudyn-ffrf", 0.05)
    assert a.status.ok and b.status.ok
    d = np.sqrt(np.mean((a.channels["tip_deflection"] - b.channels["tip_deflection"]) ** 2))
    assert d < 0.005 * np.abs(b.channels["tip_deflection"]).max()         # the case's tolerance


def write_mtx(path, A, node_ids):
    """A symmetric (3N, 3N) matrix as Abaqus writes it (*MATRIX OUTPUT, the default layout): the
    upper triangle as 'row node, row dof, column node, column dof, value'."""
    U = __import__("scipy.sparse", fromlist=["triu"]).triu(A).tocoo()
    path.write_text("".join(f"{node_ids[r // 3]},{r % 3 + 1}, {node_ids[c // 3]},{c % 3 + 1}, {float(v)!r}\n"
                            for r, c, v in zip(U.row, U.col, U.data)))


def test_matrices_from_abaqus_matrix_files_give_the_same_body(tmp_path, capsys):
    """A mesh file's stiffness and mass given as Abaqus matrix files (`mesh.stiffness`, `mesh.mass`)
    replace the assembly; written from the assembly, they reduce to the same body to 1e-12. A mass
    that is not a solid's (M = Ms (x) I3) is one line naming the file, exit status 2."""
    from flexmbd.fe import flexbody
    from flexmbd.fe import solid
    base = case_file(tmp_path, f'file = "{DATA / "block.inp"}"', name="assembled")
    case = cases.load(str(base))
    mesh = flexbody.solid_mesh(**dataclasses.asdict(case.bodies["block"].mesh))
    K, Ms = flexbody.solid_matrices(case.bodies["block"])
    write_mtx(tmp_path / "K.mtx", K, mesh.node_ids)
    write_mtx(tmp_path / "M.mtx", solid.vector_mass(Ms), mesh.node_ids)
    path = case_file(tmp_path, f'file = "{DATA / "block.inp"}", stiffness = "K.mtx", mass = "M.mtx"', name="files")
    a, b = case.reduced("block"), cases.load(str(path)).reduced("block")
    assert np.allclose(b.freq_hz, a.freq_hz, rtol=1e-12, atol=0)
    assert np.abs(b.Phi - a.Phi).max() <= 1e-10 * np.abs(a.Phi).max()
    M = solid.vector_mass(Ms).tolil()
    M[1, 1] *= 1.01                                                        # y of node 0 heavier than its x
    write_mtx(tmp_path / "M.mtx", M.tocsr(), mesh.node_ids)
    assert main(["run", str(path), "--solver", "flexmbd", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "M.mtx: not a solid's consistent mass" in err, err
    assert not (tmp_path / "out").exists()


def test_cantilever_solid_s_surface_is_read_at_its_point():
    """cantilever_solid (12 N step at the tip): the signed normal stress at its channel's point, the
    top surface 2h from the clamp, has the time mean of the static M c / I = 47.04 MPa within 3 %
    (measured -1.3 %; fe-linear's full order -1.9 %, docs/fe.md: the mesh's own error, the clamp's
    restraint and the undamped step's time-mean bias), and its von Mises channel reads the surface
    (48.8 MPa), not the element's centre (24.4 MPa, where it was read before)."""
    case = cases.load("cantilever_solid", ['channels.top={kind="stress_normal", body="beam", point=[0.03, 0.0075, 0.0]}'])
    r = registry.run(case, "flexmbd")
    assert r.ok, r.status
    assert r.channels["top"].mean() == pytest.approx(47.04e6, rel=0.03)
    assert r.channels["stress_vm"].mean() > 40e6


@pytest.mark.parametrize("point, place", [((0.03, 0.0075, 0.0), "on the +y face"), ((0.03, 0.0, 0.0), "inside"),
                                          ((0.06, 0.0075, 0.005), "on the +y+z edge"),
                                          ((0.0, -0.0075, -0.005), "on the -x-y-z corner")])
def test_a_solid_stress_point_says_where_it_lies(point, place):
    """cantilever_solid's box (x from the clamp 0 to 1.5 m, |y| <= h/2 = 7.5 mm, |z| <= 5 mm): the
    channel's title tells a surface point from an inner one (`flexbody.point_place`)."""
    from flexmbd.fe import flexbody
    from flexmbd.harness import channels
    case = cases.load("cantilever_solid", [f'channels.p={{kind="stress_normal", body="beam", point={list(point)}}}'])
    assert flexbody.point_place(case.bodies["beam"], point) == place
    assert channels.label(case, "p").endswith(f"m, {place} [Pa]")


def test_a_solid_s_normal_stress_along_a_direction_is_the_stress_tensor_s_projection():
    """stress_normal with a direction e: e^T sigma e of the point's stress tensor (Voigt order xx,
    yy, zz, yz, zx, xy): at 45 degrees in x-y, (sigma_xx + sigma_yy) / 2 + sigma_xy; along x,
    sigma_xx; along any other direction the product with the full symmetric matrix (round-off:
    1e-13 of stresses of one order of magnitude); the case's direction is made a unit vector."""
    from flexmbd.harness import channels
    S = np.array([[40e6, -3e6, 1e6, 0.5e6, -2e6, 7e6]])
    e = np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0)
    assert channels.solid_stress("stress_normal", S, tuple(e))[0] == pytest.approx(0.5 * (40e6 - 3e6) + 7e6, rel=1e-14)
    assert channels.solid_stress("stress_normal", S, (1.0, 0.0, 0.0))[0] == channels.solid_stress("stress_normal", S)[0]
    sym = np.array([[40e6, 7e6, -2e6], [7e6, -3e6, 0.5e6], [-2e6, 0.5e6, 1e6]])
    for d in ([0.2, -0.5, 0.84], [0.0, 0.0, 1.0]):
        d = np.array(d) / np.linalg.norm(d)
        assert channels.solid_stress("stress_normal", S, tuple(d))[0] == pytest.approx(d @ sym @ d, rel=1e-13)
    case = cases.load("cantilever_solid", ['channels.d={kind="stress_normal", body="beam", point=[0.03, 0.0075, 0], '
                                           'direction=[2, 0, 0]}'])
    assert case.channels["d"].direction == (1.0, 0.0, 0.0)                  # made a unit vector
