"""Bad input in mesh files and solid bodies (fe.meshfile, fe.solid.fits_rigid, the solid's checks in
cases.validate): numbers beyond int64, set ranges too long or descending, RBE3 weights that are not
numbers, large-field cards without their continuation, point masses that are not finite, solid
interfaces that cannot carry a rigid motion, and the wave-speed range that tells the units. Each is
one line naming the file and its line (or the case's key), exit status 2; what is valid reads."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from flexmbd.cli import main
from flexmbd.core.errors import InputError
from flexmbd.fe import meshfile, solid
from tests.fe.test_fe_meshfile import line_of, refused, write
from tests.fe.test_solids import case_file

pytestmark = pytest.mark.kernel_free

DATA = Path(__file__).resolve().parents[1] / "data"

TET = "GRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\nGRID,3,,0.,1.,0.\nGRID,4,,0.,0.,1.\nCTETRA,1,1,1,2,3,4\nPSOLID,1,1\n"
STEEL = "MAT1,1,2.1+11,,.3,7850.\n"
INP = "*NODE\n1, 0., 0., 0.\n2, 1., 0., 0.\n3, 0., 1., 0.\n4, 0., 0., 1.\n*ELEMENT, TYPE=C3D4\n1, 1, 2, 3, 4\n"
BAR = "GRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\nCBAR,1,1,1,2,0.,1.,0.\nPBAR,1,1,1.-4,1.-8,1.-8,2.-8\n" + STEEL


def run_refused(tmp_path, capsys, mesh, solver="flexmbd", clamp="clamp", tip="tip") -> str:
    """The one stderr line of `flexmbd run` of a case of a solid meshed by `mesh`, checked to be
    exit status 2 with nothing written."""
    path = case_file(tmp_path, f'file = "{mesh}"', clamp=clamp, tip=tip, count=4, name="case")
    code = main(["run", str(path), "--solver", solver, "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2 and len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert not (tmp_path / "out").exists()
    return err


# ---------------------------------------------------------------------------------------------
# 1. numbers beyond int64


@pytest.mark.parametrize("name, text, at, fragment", [
    ("grid.bdf", TET + STEEL + "GRID,99999999999999999999,,0.,0.,2.\n", "GRID,99999999999999999999,,0.,0.,2.",
     "GRID ID: 99999999999999999999 is too large"),
    ("element.bdf", TET + STEEL + "CTETRA,99999999999999999999,1,1,2,3,4\n", "CTETRA,99999999999999999999,1,1,2,3,4",
     "CTETRA EID: 99999999999999999999 is too large"),
    ("set.bdf", TET + STEEL + "SET1,1,1,-99999999999999999999\n", "SET1,1,1,-99999999999999999999",
     "SET1 G: -99999999999999999999 is too large"),
    ("node.inp", INP.replace("4, 0., 0., 1.", "99999999999999999999, 0., 0., 1."), "99999999999999999999, 0., 0., 1.",
     "*NODE number: 99999999999999999999 is too large"),
    ("set.inp", INP + "*NSET, NSET=a\n1, 99999999999999999999\n", "1, 99999999999999999999",
     "*NSET: 99999999999999999999 is too large"),
])
def test_a_number_beyond_int64_is_refused_with_its_line(tmp_path, name, text, at, fragment):
    refused(write(tmp_path, name, text), fragment, line=line_of(text, at))


def test_the_largest_numbers_that_fit_are_read(tmp_path):
    big = 2 ** 63 - 1
    m = meshfile.read(write(tmp_path, "big.bdf", TET.replace("GRID,4,", f"GRID,{big},").replace(",3,4\n", f",3,{big}\n")
                            + STEEL + f"SET1,1,99999999,{big}\nGRID,99999999,,1.,1.,1.\n"))
    assert m.node_ids.tolist() == [1, 2, 3, big, 99999999]
    assert m.node_ids[m.node_sets["set1"]].tolist() == [big, 99999999]


# ---------------------------------------------------------------------------------------------
# 2. ranges of set members longer than the file can define: refused before they are expanded


RANGE_READ = """
import resource, sys
resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))   # 2 GB: the range as a list would take 16 GB
from flexmbd.core.errors import InputError
from flexmbd.fe import meshfile
try:
    meshfile.read(sys.argv[1])
except InputError as e:
    print(e)
"""


@pytest.mark.parametrize("name, text, at", [
    ("thru.bdf", TET + STEEL + "SET1,1,1,THRU,2000000000\n", "SET1,1,1,THRU,2000000000"),
    ("spc.bdf", TET + STEEL + "SPC1,1,123,1,THRU,2000000000\n", "SPC1,1,123,1,THRU,2000000000"),
    ("nset.inp", INP + "*NSET, NSET=a, GENERATE\n1, 2000000000, 1\n", "1, 2000000000, 1"),
    ("elset.inp", INP + "*ELSET, ELSET=a, GENERATE\n1, 3999999999, 2\n", "1, 3999999999, 2"),
])
def test_a_range_longer_than_the_file_can_define_is_refused_promptly_and_small(tmp_path, name, text, at):
    """In a process limited to 2 GB of address space, where expanding the range fails."""
    path = write(tmp_path, name, text)
    r = subprocess.run([sys.executable, "-c", RANGE_READ, path], capture_output=True, text=True, timeout=60,
                       env={**os.environ, "OPENBLAS_NUM_THREADS": "1"})
    assert r.returncode == 0 and r.stderr == "", r.stderr
    assert r.stdout.startswith(f"{path}:{line_of(text, at)}: "), r.stdout
    assert "holds 2000000000 numbers, more than a file of" in r.stdout, r.stdout


def test_a_range_within_the_file_still_names_its_first_undefined_member(tmp_path):
    text = TET + STEEL + "SET1,1,2,THRU,9\n"
    refused(write(tmp_path, "set.bdf", text), "node set 'set1' lists node 5, which is not defined",
            line=line_of(text, "SET1,1,2,THRU,9"))


# ---------------------------------------------------------------------------------------------
# 3. THRU ranges ascend


def test_a_descending_thru_range_is_refused(tmp_path):
    text = TET + STEEL + "SET1,1,4,THRU,1\n"
    refused(write(tmp_path, "down.bdf", text), "SET1: 4 THRU 1 is not an ascending range",
            line=line_of(text, "SET1,1,4,THRU,1"))
    m = meshfile.read(write(tmp_path, "up.bdf", TET + STEEL + "SET1,1,1,THRU,3\nSET1,2,4,THRU,4\n"))
    assert m.node_ids[m.node_sets["set1"]].tolist() == [1, 2, 3] and m.node_ids[m.node_sets["set2"]].tolist() == [4]


# ---------------------------------------------------------------------------------------------
# 5. RBE3 weights are numbers


def test_an_rbe3_weight_that_is_not_a_number_is_refused(tmp_path):
    text = TET + STEEL + "RBE3, 100,, 4, 123456, abc, 123, 1, 2, 3\n"
    refused(write(tmp_path, "rbe3.bdf", text), "RBE3 WT: 'abc' is not a number",
            line=line_of(text, "RBE3, 100,, 4, 123456, abc, 123, 1, 2, 3"))
    m = meshfile.read(write(tmp_path, "good.bdf", TET + STEEL + "RBE3,100,,4,123456,1.5,123,1,2,+\n+,3\n"))
    assert m.node_ids[m.node_sets["rbe3_100"]].tolist() == [1, 2, 3]


# ---------------------------------------------------------------------------------------------
# 6 (and 4). a solid's interface needs three nodes not on one line


# block.inp with sets of one node, two, and three on one line (x = 0, y = -0.01, z = -0.015 ... 0.015)
FEW = "*NSET, NSET=one\n1\n*NSET, NSET=two\n1, 4\n*NSET, NSET=line\n1, 2, 3\n*NSET, NSET=plane\n1, 2, 4\n"


def block_with_few(tmp_path) -> str:
    return write(tmp_path, "block.inp", (DATA / "block.inp").read_text() + FEW)


@pytest.mark.parametrize("clamp, words", [("one", "has 1 node:"), ("two", "has 2 nodes:"),
                                          ("line", "has 3 nodes on one line:")])
def test_a_solid_clamped_on_too_few_nodes_is_refused(tmp_path, capsys, clamp, words):
    """A rigid interface held in clamped-interface modes: on a node or a line it leaves a rotation free."""
    err = run_refused(tmp_path, capsys, block_with_few(tmp_path), clamp=clamp)
    assert "bodies.block.interfaces.clamp.set" in err and words in err, err
    assert "a solid's interface needs at least 3 nodes not on one line" in err, err


@pytest.mark.parametrize("solver", ["flexmbd", "fe-linear"])
@pytest.mark.parametrize("tip", ["one", "two", "line"])
def test_an_averaging_interface_on_too_few_nodes_is_refused_before_any_solver(tmp_path, capsys, solver, tip):
    err = run_refused(tmp_path, capsys, block_with_few(tmp_path), solver=solver, tip=tip)
    assert "bodies.block.interfaces.tip.set" in err and f"node set {tip!r}" in err, err
    assert "a solid's interface needs at least 3 nodes not on one line" in err, err


def test_fits_rigid_and_the_fit_it_guards(tmp_path):
    x = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    assert not solid.fits_rigid(x[:1]) and not solid.fits_rigid(x[:2]) and not solid.fits_rigid(x[:3])
    assert not solid.fits_rigid(x[:3] + [0.0, 1e-9, 0.0] * np.array([[0], [1], [0]]))   # a line to 1e-9
    assert solid.fits_rigid(x[[0, 1, 3]]) and solid.fits_rigid(x)
    with pytest.raises(np.linalg.LinAlgError):                       # what the check keeps from the solvers
        solid.averaging(x[:3], x[0])
    A = solid.averaging(x[[0, 1, 3]], x[0])                         # three points: their rigid fit
    u = solid.rigid_fields(x[[0, 1, 3]], x[0]) @ np.arange(1.0, 7.0)
    np.testing.assert_allclose(A @ u, np.arange(1.0, 7.0), atol=1e-12)
    m = meshfile.read(block_with_few(tmp_path))
    assert solid.fits_rigid(m.nodes[m.node_sets["plane"]]) and not solid.fits_rigid(m.nodes[m.node_sets["line"]])


# ---------------------------------------------------------------------------------------------
# 7. large-field cards come in pairs of lines


def test_a_large_field_card_without_its_continuation_is_refused(tmp_path):
    grid = f"GRID*   {5:>16}{'':16}{'1.':>16}{'1.':>16}"
    text = TET + STEEL + grid + "\n"
    refused(write(tmp_path, "half.bdf", text), "GRID*: a large-field card's lines come in pairs",
            line=line_of(text, grid))
    m = meshfile.read(write(tmp_path, "whole.bdf", text + f"*       {'2.':>16}\n"))
    np.testing.assert_array_equal(m.nodes[-1], [1.0, 1.0, 2.0])


# ---------------------------------------------------------------------------------------------
# 8. point masses are finite and not negative


@pytest.mark.parametrize("mass, fragment", [("nan", "CONM2 M: 'nan' is not a finite number"),
                                            ("inf", "CONM2 M: 'inf' is not a finite number"),
                                            ("-1.", "CONM2 2: M and I11, I22, I33 must not be negative")])
def test_a_point_mass_that_is_not_finite_or_negative_is_refused(tmp_path, mass, fragment):
    card = f"CONM2,2,2,,{mass}"
    text = BAR + card + "\n"
    refused(write(tmp_path, "frame.bdf", text), fragment, line=line_of(text, card))


def test_a_finite_point_mass_reads(tmp_path):
    m = meshfile.read(write(tmp_path, "frame.bdf", BAR + "CONM2,2,2,,0.5\n"))
    np.testing.assert_array_equal(m.masses, [[1, 0.5, 0, 0, 0]])


# ---------------------------------------------------------------------------------------------
# 9. the wave speed tells the units: rubber reads, steel in the other unit system does not


def test_a_rubber_reads_and_mixed_up_units_are_still_refused(tmp_path):
    rubber = "MAT1,1,1.+6,,.45,1000."                                   # sqrt(E/rho) = 31.6 m/s
    m = meshfile.read(write(tmp_path, "rubber.bdf", TET + rubber + "\n"))
    assert m.materials == {"mat1": (1e6, 0.45, 1000.0)}
    steel_mm = "MAT1,1,210000.,,.3,7.85-9"                              # MPa, t/mm^3: 5.17e6 m/s read as SI
    refused(write(tmp_path, "steel_mm.bdf", TET + steel_mm + "\n"), "sqrt(E/rho) = 5.17e+06 m/s in units 'm'",
            line=line_of(TET + steel_mm, steel_mm))
    steel = STEEL.strip()                                               # SI read as mm-t-s: 5.17 m/s
    refused(write(tmp_path, "steel.bdf", TET + STEEL), "sqrt(E/rho) = 5.17 m/s in units 'mm', outside 10..20000 m/s",
            line=line_of(TET + steel, steel), units="mm")
    rubber_mm = "MAT1,1,1.,,.45,1.-9"                                   # the rubber in MPa, t/mm^3, read as SI
    refused(write(tmp_path, "rubber_mm.bdf", TET + rubber_mm + "\n"), "sqrt(E/rho) = 3.16e+04 m/s in units 'm'",
            line=line_of(TET + rubber_mm, rubber_mm))


# ---------------------------------------------------------------------------------------------
# the command: a bad mesh file is one line naming the file and line, exit status 2


@pytest.mark.parametrize("text, at", [
    (TET + STEEL + "GRID,99999999999999999999,,0.,0.,2.\n", "GRID,99999999999999999999,,0.,0.,2."),
    (TET + STEEL + "SET1,1,4,THRU,1\n", "SET1,1,4,THRU,1"),
    (TET + STEEL + "GRID*   5\n", "GRID*   5"),
])
def test_the_command_refuses_a_bad_mesh_file_with_its_line(tmp_path, capsys, text, at):
    path = write(tmp_path, "bad.bdf", text)
    err = run_refused(tmp_path, capsys, path)
    assert err.startswith(f"flexmbd: {path}:{line_of(text, at)}: "), err


def test_a_gmsh_file_read_without_nodes_is_refused(tmp_path, monkeypatch):
    """meshio can hand back a mesh without points from a damaged file: one line, not an IndexError."""
    from types import SimpleNamespace

    from flexmbd.fe.meshfiles import gmsh
    monkeypatch.setattr(gmsh, "_meshio", lambda source: SimpleNamespace(points=np.zeros(0), cells=[], cell_data={}))
    with pytest.raises(InputError) as e:
        gmsh.parse(tmp_path / "damaged.msh")
    assert "defines no nodes" in str(e.value)
