"""Mesh-file import (fe.meshfile): the block written as Abaqus, NASTRAN and Gmsh files reads to one
mesh; each format's features; every refusal names its file and line; units; the node orders of the
quadratic elements on a distorted mesh; Abaqus matrix files against Exudyn's reader.

The data files are written by tests/data/make_block.py (regenerate with
`.venv/bin/python tests/data/make_block.py`); the first test checks that they are its output."""

import importlib.util
import re
from pathlib import Path

import numpy as np
import pytest

from flexmbd.core.errors import InputError
from flexmbd.fe import meshfile
from flexmbd.fe.mesh import EDGES, box, without_orphans

pytestmark = pytest.mark.kernel_free

DATA = Path(__file__).parents[1] / "data"
_spec = importlib.util.spec_from_file_location("make_block", DATA / "make_block.py")
make_block = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(make_block)

# per format: the node sets holding the block's clamp, tip and body nodes, and the material's name
NAMES = {"inp": ("clamp", "tip", "body", "steel"), "bdf": ("spc1", "set2", "set3", "mat1"),
         "msh": ("clamp", "tip", "body", None)}
STEEL = (2.1e11, 0.3, 7850.0)


def write(tmp_path, name, text) -> str:
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def refused(path, fragment, line=None, **kw) -> str:
    """The InputError message of reading `path`, checked to be one line naming the file (and line)
    and containing `fragment`."""
    with pytest.raises(InputError) as e:
        meshfile.read(path, **kw)
    msg = str(e.value)
    assert "\n" not in msg
    assert msg.startswith(f"{path}:{line}: " if line else f"{path}: "), msg
    assert fragment in msg, msg
    return msg


def line_of(text, content) -> int:
    """The 1-based number of the line of `text` that is `content`."""
    return text.splitlines().index(content) + 1


def test_data_files_are_the_generators_output(tmp_path):
    for path in make_block.main(tmp_path):
        assert path.read_bytes() == (DATA / path.name).read_bytes(), f"regenerate {path.name}: make_block.py"


# ---------------------------------------------------------------------------------------------
# the block in three formats


@pytest.mark.parametrize("stem, kind", [("block", "hex20"), ("block_tet", "tet10")])
def test_the_three_block_files_read_to_one_mesh(stem, kind):
    ref = make_block.block(kind)
    boxed = box(0.1, 0.02, 0.03, (4, 1, 2), kind)
    np.testing.assert_allclose(ref.nodes, boxed.nodes, rtol=0, atol=1e-15)
    for ext, (clamp, tip, body, material) in NAMES.items():
        path = str(DATA / f"{stem}.{ext}")
        m = meshfile.read(path)
        assert m.source == path
        row = {i: r for r, i in enumerate(m.node_ids)}
        rows = np.array([row[i] for i in ref.node_ids])
        np.testing.assert_allclose(m.nodes[rows], ref.nodes, rtol=0, atol=1e-15)
        assert list(m.cells) == [kind]
        np.testing.assert_array_equal(m.node_ids[m.cells[kind]], ref.node_ids[ref.cells[kind]])
        ne = ref.cells[kind].shape[0]
        np.testing.assert_array_equal(m.elem_ids[kind], np.arange(1, ne + 1))
        for name, ref_name in ((clamp, "clamp"), (tip, "tip"), (body, "body")):
            assert set(m.node_ids[meshfile.node_set(m, name)]) == set(ref.node_ids[ref.node_sets[ref_name]])
        np.testing.assert_array_equal(m.node_ids[m.node_sets[clamp]], m.node_ids[boxed.node_sets["x0"]])
        if ext != "bdf":                # NASTRAN has no element sets
            np.testing.assert_array_equal(m.elem_sets["body"][kind], np.arange(ne))
        assert m.materials == ({material: STEEL} if material else {})


def test_node_set_names_the_sets_there_are():
    m = meshfile.read(DATA / "block.msh")
    with pytest.raises(InputError, match=re.escape(f"{DATA / 'block.msh'}: node set 'root' not found "
                                                   "(it has: body, clamp, tip)")):
        meshfile.node_set(m, "root")


# ---------------------------------------------------------------------------------------------
# node orders of the quadratic elements


def test_hex20_and_tet10_node_orders_agree_on_a_distorted_mesh():
    """NASTRAN's CHEXA and Gmsh's hexahedron20 / tetra10 (as meshio gives them) come out in the
    Abaqus order of the same elements, and in that order every mid-edge node is the one nearest
    to the midpoint of its edge in fe.mesh's list."""
    ref = make_block.distorted()
    read = {ext: meshfile.read(DATA / f"distorted.{ext}") for ext in ("inp", "bdf", "msh")}
    for kind in ("hex20", "tet10"):
        x = read["inp"].nodes[read["inp"].cells[kind]][0]
        np.testing.assert_array_equal(x, ref.nodes[ref.cells[kind]][0])
        for ext in ("bdf", "msh"):
            np.testing.assert_array_equal(read[ext].nodes[read[ext].cells[kind]][0], x)
        n = 8 if kind == "hex20" else 4
        midpoints = np.array([0.5 * (x[a] + x[b]) for a, b in EDGES[kind]])
        distance = np.linalg.norm(x[n:, None] - midpoints[None], axis=2)
        np.testing.assert_array_equal(distance.argmin(axis=1), np.arange(len(EDGES[kind])))
    np.testing.assert_array_equal(read["bdf"].node_ids, ref.node_ids)
    np.testing.assert_array_equal(read["msh"].node_ids, np.arange(1, 31))        # Gmsh's numbers are lost
    # the Gmsh file is in Gmsh's order, not fe.mesh's: meshio reordered it
    text = (DATA / "distorted.msh").read_text().splitlines()
    hex_line = next(line for line in text if line.split()[1:2] == ["17"])
    assert [int(v) - 1 for v in hex_line.split()[-20:]] != list(read["msh"].cells["hex20"][0])


# ---------------------------------------------------------------------------------------------
# Abaqus


def nodes_inp(ids, xyz) -> str:
    return "".join(f"{i}, {float(x)!r}, {float(y)!r}, {float(z)!r}\n" for i, (x, y, z) in zip(ids, xyz))


UNIT_HEX = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float)
TET = "*NODE\n1, 0., 0., 0.\n2, 1., 0., 0.\n3, 0., 1., 0.\n4, 0., 0., 1.\n"


def test_abaqus_keywords_sets_materials_and_continuations(tmp_path):
    two = box(0.2, 0.1, 0.1, (2, 1, 1), "hex8")                      # 12 nodes, 2 elements
    one = box(0.1, 0.1, 0.1, (1, 1, 1), "hex20")                     # 20 nodes
    tet = box(0.1, 0.1, 0.1, (1, 1, 1), "tet10")
    c20 = (one.cells["hex20"][0] + 101).tolist()
    c10 = list(range(201, 211))
    text = ("** a comment\n*HEADING\nheading text, 1, 2\n"
            f"*node, nset=ALLN\n{nodes_inp(np.arange(1, 13), two.nodes)}"
            f"*Node\n{nodes_inp(np.arange(101, 121), one.nodes + [1, 0, 0])}"
            f"*NODE\n{nodes_inp(np.arange(201, 211), tet.nodes[tet.cells['tet10'][0]] + [2, 0, 0])}"
            "*Element, Type=C3D8I, Elset=left\n1, " + ", ".join(map(str, two.cells["hex8"][0] + 1)) + "\n"
            "*ELEMENT, TYPE=c3d8h\n2, " + ", ".join(map(str, two.cells["hex8"][1] + 1)) + "\n"
            "*Element, type=C3D20H\n"
            f"5, {', '.join(map(str, c20[:7]))},\n  {', '.join(map(str, c20[7:15]))},\n"
            f"{', '.join(map(str, c20[15:]))}\n"
            "*Element, type=C3D10M, elset=tets\n"
            f"9, {', '.join(map(str, c10))}\n"
            "*Elset, elset=LEFT\n2\n*Elset, elset=solid, generate\n1, 9, 4\n"
            "*Nset, Nset=face0, Generate\n1, 7, 2\n*nset, nset=both\nface0, 12\n*NSET, NSET=ontet, ELSET=tets\n"
            "*Boundary\nface0, 1, 3\n"
            "*Material, Name=Alu\n*Elastic\n70e9, 0.33\n*Plastic\n100e6, 0.0\n*Density\n2700,\n")
    m = meshfile.read(write(tmp_path, "mixed.inp", text))
    assert list(m.cells) == ["hex8", "hex20", "tet10"]
    np.testing.assert_array_equal(m.node_ids[m.cells["hex8"]], two.cells["hex8"] + 1)
    np.testing.assert_array_equal(m.node_ids[m.cells["hex20"]][0], c20)
    np.testing.assert_array_equal(m.node_ids[m.cells["tet10"]][0], c10)
    assert {k: v.tolist() for k, v in m.elem_ids.items()} == {"hex8": [1, 2], "hex20": [5], "tet10": [9]}
    assert {k: {kk: vv.tolist() for kk, vv in v.items()} for k, v in m.elem_sets.items()} == {
        "left": {"hex8": [0, 1]}, "tets": {"tet10": [0]}, "solid": {"hex8": [0], "hex20": [0], "tet10": [0]}}
    assert m.node_ids[m.node_sets["face0"]].tolist() == [1, 3, 5, 7]
    assert m.node_ids[m.node_sets["both"]].tolist() == [1, 3, 5, 7, 12]
    assert m.node_ids[m.node_sets["ALLN"]].tolist() == list(range(1, 13))
    assert m.node_ids[m.node_sets["ontet"]].tolist() == c10
    assert m.materials == {"Alu": (70e9, 0.33, 2700.0)}


# ---------------------------------------------------------------------------------------------
# NASTRAN


def test_nastran_fields_continuations_and_cards(tmp_path):
    two = box(0.2, 0.1, 0.1, (2, 1, 1), "hex8")
    grids = []
    for i, (x, y, z) in enumerate(two.nodes.tolist(), 1):
        if i % 3 == 0:
            grids.append(f"GRID,{i},,{x!r},{y!r},{z!r}")                        # free
        elif i % 3 == 1:
            grids += [f"GRID*   {i:>16}{'':16}{x!r:>16}{y!r:>16}*G{i}", f"*G{i}    {z!r:>16}"]    # large
        else:
            grids.append(f"GRID    {i:>8}{'':8}{x!r:>8}{y!r:>8}{z!r:>8}")      # small
    c = two.cells["hex8"] + 1
    text = "\n".join([
        "$ executive and case control", "SOL 103", "CEND", "TITLE = a test", "BEGIN BULK",
        *grids, "GRID,100,0,0.3,0.,0.,5", "$ solids",
        "CHEXA,1,7," + ",".join(map(str, c[0][:6])) + ",+", "+," + ",".join(map(str, c[0][6:])),
        "CHEXA   2       7       " + "".join(f"{g:<8}" for g in c[1][:6]) + "+C2",
        "+C2     " + "".join(f"{g:<8}" for g in c[1][6:]),
        "PSOLID  7       3", "MAT1,3,2.1+11,8.076923+10,,7.85+3", "MAT1,4,,8.+10,.25,2.7D3",
        "SPC,11,1,123,0.,12,123,0.", "SPC1    11      123456  3       THRU    5", "SET1,21,1,2,THRU,4,9",
        "RBE2    31      100     123456  7       8       9       10      11      +",
        "+       12      1.-5", "RBE3,41,,100,123456,1.0,123,1,2,+", "+,3,0.5,123,4,UM,100,456",
        "PARAM,POST,-1", "EIGRL,10,,,12", "ENDDATA", "CBAR after ENDDATA is not read"]) + "\n"
    m = meshfile.read(write(tmp_path, "cards.bdf", text))
    np.testing.assert_array_equal(m.node_ids, list(range(1, 13)) + [100])
    np.testing.assert_array_equal(m.nodes[:12], two.nodes)
    np.testing.assert_array_equal(m.node_ids[m.cells["hex8"]], c)
    sets = {k: m.node_ids[v].tolist() for k, v in m.node_sets.items()}
    assert sets == {"spc11": [1, 3, 4, 5, 12], "set21": [1, 2, 3, 4, 9], "rbe2_31": [7, 8, 9, 10, 11, 12],
                    "rbe2_31_ref": [100], "rbe3_41": [1, 2, 3, 4], "rbe3_41_ref": [100]}
    E, nu, rho = m.materials["mat3"]
    assert (E, rho) == (2.1e11, 7850.0) and nu == pytest.approx(0.3, rel=1e-6)
    assert m.materials["mat4"] == (2 * 8e10 * 1.25, 0.25, 2700.0)
    # a body's mesh drops the reference grid 100, on no element: its sets lose it
    b = without_orphans(m)
    np.testing.assert_array_equal(b.node_ids, range(1, 13))
    np.testing.assert_array_equal(b.node_ids[b.cells["hex8"]], c)
    assert {k: b.node_ids[v].tolist() for k, v in b.node_sets.items()} == {**sets, "rbe2_31_ref": [], "rbe3_41_ref": []}
    assert without_orphans(b) is b


# ---------------------------------------------------------------------------------------------
# refusals: every one names the file, and the line where there is one


def test_unknown_element_type_names_the_supported_ones(tmp_path):
    text = TET + "*ELEMENT, TYPE=S4R\n1, 1, 2, 3, 4\n"
    msg = refused(write(tmp_path, "a.inp", text), "element type 'S4R' is not supported", line=6)
    assert "C3D4, C3D10, C3D10M" in msg and "C3D20H" in msg


@pytest.mark.parametrize("case, text, at, fragment", [
    ("undefined node", TET + "*ELEMENT, TYPE=C3D4\n1, 1, 2, 3, 5\n", "1, 1, 2, 3, 5",
     "element 1 refers to node 5, which is not defined"),
    ("duplicate node", TET + "2, 1., 1., 1.\n*ELEMENT, TYPE=C3D4\n1, 1, 2, 3, 4\n", "2, 1., 1., 1.",
     "node 2 is defined twice (first on line 3)"),
    ("duplicate element", TET + "5, 1., 1., 1.\n*ELEMENT, TYPE=C3D4\n1, 1, 2, 3, 4\n*ELEMENT, TYPE=C3D4\n"
     "1, 2, 5, 3, 4\n", "1, 2, 5, 3, 4", "element 1 is defined twice (first on line 8)"),
    ("node set member", TET + "*ELEMENT, TYPE=C3D4\n1, 1, 2, 3, 4\n*NSET, NSET=fix\n1, 9\n", "1, 9",
     "node set 'fix' lists node 9, which is not defined"),
    ("element set member", TET + "*ELEMENT, TYPE=C3D4\n1, 1, 2, 3, 4\n*ELSET, ELSET=grip, GENERATE\n1, 3\n",
     "1, 3", "element set 'grip' lists element 2, which is not a defined solid element"),
    ("unknown set name", TET + "*ELEMENT, TYPE=C3D4\n1, 1, 2, 3, 4\n*NSET, NSET=fix\nfaces\n", "faces",
     "'faces' is neither a number nor a set defined before"),
    ("inverted tetrahedron", TET + "*ELEMENT, TYPE=C3D4\n1, 1, 3, 2, 4\n", "1, 1, 3, 2, 4",
     "element 1 (tet4) has a non-positive volume"),
    ("inverted hexahedron", "*NODE\n" + nodes_inp(range(1, 9), UNIT_HEX) + "*ELEMENT, TYPE=C3D8R\n"
     "7, 5, 6, 7, 8, 1, 2, 3, 4\n", "7, 5, 6, 7, 8, 1, 2, 3, 4",
     "element 7 (hex8) has a non-positive volume at corner node 5"),
    ("collapsed hexahedron", "*NODE\n" + nodes_inp(range(1, 9), UNIT_HEX * [1, 1, 0]) + "*ELEMENT, TYPE=C3D8\n"
     "7, 1, 2, 3, 4, 5, 6, 7, 8\n", "7, 1, 2, 3, 4, 5, 6, 7, 8",
     "element 7 (hex8) has a non-positive volume at corner node 1"),
    ("second part", "*Part, name=a\n" + TET + "*End Part\n*Part, name=b\n*End Part\n", "*Part, name=b",
     "a second *PART: flexmbd reads one part per body"),
    ("short element", TET + "*ELEMENT, TYPE=C3D10\n1, 1, 2, 3, 4, 5, 6, 7, 8, 9\n*NSET, NSET=a\n1\n",
     "1, 1, 2, 3, 4, 5, 6, 7, 8, 9", "element 1 (C3D10) needs 10 nodes, got 9"),
    ("include", TET + "*INCLUDE, INPUT=more.inp\n", "*INCLUDE, INPUT=more.inp", "*INCLUDE is not supported"),
    ("cylindrical", "*NODE, SYSTEM=C\n1, 1., 0., 0.\n", "*NODE, SYSTEM=C", "only rectangular coordinates"),
    ("nodes of no set", TET + "*ELEMENT, TYPE=C3D4\n1, 1, 2, 3, 4\n*NSET, NSET=a, ELSET=b\n",
     "*NSET, NSET=a, ELSET=b", "the file has no element set 'b'"),
])
def test_abaqus_refusals(tmp_path, case, text, at, fragment):
    refused(write(tmp_path, "bad.inp", text), fragment, line=line_of(text, at))


GRIDS = "GRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\nGRID,3,,0.,1.,0.\nGRID,4,,0.,0.,1.\n"


@pytest.mark.parametrize("case, text, at, fragment", [

    ("shell", GRIDS + "CQUAD4  2       1       1       2       3       4\n",
     "CQUAD4  2       1       1       2       3       4", "CQUAD4 elements are not supported"),
    ("coordinate system", GRIDS + "GRID,5,3,1.,1.,1.\nCTETRA,1,1,1,2,3,4\n", "GRID,5,3,1.,1.,1.",
     "GRID 5 has coordinate system CP=3: only the basic system (CP blank or 0) is supported"),
    ("point mass", GRIDS + "CTETRA,1,1,1,2,3,4\nCONM2,9,1,,1.5\n", "CONM2,9,1,,1.5",
     "CONM2 9: its grid 1 is on a solid (a point mass sits on a frame's node)"),
    ("undefined grid", GRIDS + "CTETRA,1,1,1,2,3,6\n", "CTETRA,1,1,1,2,3,6",
     "element 1 refers to node 6, which is not defined"),
    ("duplicate grid", GRIDS + "GRID,3,,1.,1.,1.\nCTETRA,1,1,1,2,3,4\n", "GRID,3,,1.,1.,1.",
     "node 3 is defined twice (first on line 3)"),
    ("grid count", GRIDS + "CTETRA,1,1,1,2,3,4,1,2\n", "CTETRA,1,1,1,2,3,4,1,2",
     "CTETRA 1 has 6 grids (flexmbd reads 4 or 10)"),
    ("set member", GRIDS + "CTETRA,1,1,1,2,3,4\nSET1,5,1,THRU,7\n", "SET1,5,1,THRU,7",
     "node set 'set5' lists node 5, which is not defined"),
    ("two materials", GRIDS + "GRID,5,,1.,1.,1.\nCTETRA,1,1,1,2,3,4\nCTETRA,2,2,2,5,3,4\nPSOLID,1,1\n"
     "PSOLID,2,2\nMAT1,1,2.1+11,,.3,7850.\nMAT1,2,7.+10,,.33,2700.\n", "CTETRA,2,2,2,5,3,4",
     "element 2 has material mat2 (property 2) but element 1 mat1 (property 1): the elements of one body "
     "must use one material"),
    ("material elastic", GRIDS + "CTETRA,1,1,1,2,3,4\nMAT1,1,2.1+11,,,7850.\n", "MAT1,1,2.1+11,,,7850.",
     "MAT1 1: two of E, G, NU are needed"),
    ("material density", GRIDS + "CTETRA,1,1,1,2,3,4\nMAT1,1,2.1+11,,.3\n", "MAT1,1,2.1+11,,.3",
     "material mat1: no density"),
    ("number", GRIDS + "GRID,5,,1.,x,1.\nCTETRA,1,1,1,2,3,4\n", "GRID,5,,1.,x,1.", "GRID X: 'x' is not a number"),
    ("inverted", GRIDS + "CTETRA,1,1,1,3,2,4\n", "CTETRA,1,1,1,3,2,4", "element 1 (tet4) has a non-positive volume"),
])
def test_nastran_refusals(tmp_path, case, text, at, fragment):
    refused(write(tmp_path, "bad.bdf", text), fragment, line=line_of(text, at))


def test_a_file_of_both_bars_and_solids_is_refused(tmp_path):
    text = GRIDS + "CTETRA,1,1,1,2,3,4\nCBAR,2,1,1,2,0.,0.,1.\nPBAR,1,1,1.-4,1.-9,1.-9,2.-9\nMAT1,1,2.1+11,,.3,7850.\n"
    refused(write(tmp_path, "mixed.bdf", text), "both bar and solid elements: a body is either a solid or a frame")


def msh22(nodes, elements, names=()) -> str:
    """A Gmsh MSH 2.2 file: elements as (gmsh type, physical tag, node tags)."""
    out = ["$MeshFormat", "2.2 0 8", "$EndMeshFormat"]
    if names:
        out += ["$PhysicalNames", str(len(names))] + [f'{d} {t} "{n}"' for d, t, n in names] + ["$EndPhysicalNames"]
    out += ["$Nodes", str(len(nodes))] + [f"{i} {x} {y} {z}" for i, (x, y, z) in enumerate(nodes, 1)]
    out += ["$EndNodes", "$Elements", str(len(elements))]
    out += [f"{k} {t} 2 {p} {p} " + " ".join(map(str, e)) for k, (t, p, e) in enumerate(elements, 1)]
    return "\n".join(out + ["$EndElements"]) + "\n"


TET_NODES = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 1), (1, 1, 0)]


@pytest.mark.parametrize("case, text, fragment", [
    ("garbage", "this is not a mesh\n", "not a readable Gmsh file"),
    ("truncated", msh22(TET_NODES, [(4, 1, (1, 2, 3, 4))]).split("2 1 0 0")[0], "not a readable Gmsh file (ValueError"),
    ("wedge", msh22(TET_NODES, [(6, 1, (1, 2, 3, 4, 5, 6))]), "Gmsh element type wedge is not supported "
     "(supported: tetra, tetra10, hexahedron, hexahedron20)"),
    ("surfaces only", msh22(TET_NODES, [(2, 1, (1, 2, 3))]), "no elements (tetrahedra, hexahedra"),
    ("inverted", msh22(TET_NODES, [(4, 1, (1, 2, 3, 4)), (4, 1, (1, 3, 2, 4))]),
     "element 2 (tet4) has a non-positive volume"),
])
def test_gmsh_refusals(tmp_path, case, text, fragment):
    refused(write(tmp_path, "bad.msh", text), fragment)


def test_gmsh_physical_groups_without_names_and_facets(tmp_path):
    text = msh22(TET_NODES, [(2, 7, (1, 2, 3)), (4, 1, (1, 2, 3, 4)), (4, 1, (2, 6, 3, 5))], names=[(3, 1, "solid")])
    m = meshfile.read(write(tmp_path, "groups.msh", text))
    assert m.node_ids[m.node_sets["physical2d_7"]].tolist() == [1, 2, 3]
    assert m.node_ids[m.node_sets["solid"]].tolist() == [1, 2, 3, 4, 5, 6]
    assert {k: v["tet4"].tolist() for k, v in m.elem_sets.items()} == {"solid": [0, 1]}
    assert m.elem_ids["tet4"].tolist() == [1, 2]


@pytest.mark.parametrize("name, text", [("nodes.inp", TET), ("nodes.bdf", GRIDS),
                                        ("nodes.nas", "BEGIN BULK\n" + GRIDS + "ENDDATA\n")])
def test_a_file_without_elements_is_refused(tmp_path, name, text):
    refused(write(tmp_path, name, text), "no elements (tetrahedra, hexahedra, or bars in a NASTRAN file) in the file")


@pytest.mark.parametrize("ext", ["inp", "bdf", "nas", "dat", "msh"])
def test_a_missing_file_is_an_input_error(tmp_path, ext):
    refused(str(tmp_path / f"none.{ext}"), "cannot read the file (No such file or directory)")


def test_unknown_file_type_and_units(tmp_path):
    refused(write(tmp_path, "part.stl", "solid\n"), "unknown mesh file type '.stl' (supported: .inp Abaqus")
    refused(str(DATA / "block.inp"), "units 'inch' unknown (use one of: m, mm)", units="inch")
    with pytest.raises(InputError, match="units 'ft' unknown"):
        meshfile.read_mtx(DATA / "block.inp", [1], units="ft")


# ---------------------------------------------------------------------------------------------
# units


def test_mm_t_s_files_read_to_the_si_mesh(tmp_path):
    si = meshfile.read(DATA / "block.inp")
    ref = make_block.block("hex20")
    mm = ref._replace(nodes=make_block.short(ref.nodes * 1000), materials={"steel": (210000.0, 0.3, 7.85e-9)})
    paths = {"inp": tmp_path / "mm.inp", "bdf": tmp_path / "mm.bdf", "msh": tmp_path / "mm.msh"}
    make_block.write_inp(paths["inp"], mm, "mm-t-s")
    make_block.write_bdf(paths["bdf"], mm, "mm-t-s")
    make_block.write_msh22(paths["msh"], mm, make_block.gmsh_groups(ref))
    assert "MAT1,1,210000.,,0.3,7.85-9" in paths["bdf"].read_text()
    for ext, path in paths.items():
        m = meshfile.read(path, units="mm")
        np.testing.assert_allclose(m.nodes, si.nodes, rtol=1e-15, atol=1e-15)
        for E, nu, rho in m.materials.values():
            assert (E, nu) == (2.1e11, 0.3) and rho == pytest.approx(7850.0, rel=1e-15)
    text = paths["inp"].read_text()
    refused(str(paths["inp"]), "material steel: sqrt(E/rho) = 5.17e+06 m/s in units 'm', outside 10..20000 m/s: "
            "the material's numbers do not match the units", line=line_of(text, "*Material, name=steel"))
    refused(str(paths["bdf"]), "material mat1: sqrt(E/rho) = 5.17e+06 m/s in units 'm'",
            line=line_of(paths["bdf"].read_text(), "MAT1,1,210000.,,0.3,7.85-9"))
    refused(str(DATA / "block.inp"), "material steel: sqrt(E/rho) = 5.17 m/s in units 'mm'",
            line=line_of((DATA / "block.inp").read_text(), "*Material, name=steel"), units="mm")


# ---------------------------------------------------------------------------------------------
# Abaqus matrix files


def symmetric(n, seed=3) -> np.ndarray:
    """A sparse-ish symmetric positive definite (n, n) matrix with a non-zero diagonal."""
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(n, n)) * (rng.random((n, n)) < 0.4)
    return a @ a.T + n * np.eye(n)


def write_mtx(path, A, node_ids=None, triangle=None) -> None:
    """A in Abaqus' COORDINATE layout ("row column value", node_ids None) or its MATRIX INPUT layout
    ("node, dof, node, dof, value"); `triangle` "lower"/"upper" writes one triangle only."""
    i, j = np.nonzero(A)
    keep = {None: i == i, "lower": i >= j, "upper": i <= j}[triangle]
    with open(path, "w") as f:
        for a, b in zip(i[keep], j[keep]):
            if node_ids is None:
                f.write(f"{a + 1} {b + 1}  {A[a, b]:.16e}\n")
            else:
                f.write(f"{node_ids[a // 3]},{a % 3 + 1}, {node_ids[b // 3]},{b % 3 + 1}, {A[a, b]:.16e}\n")


def test_read_mtx_agrees_with_exudyns_reader(tmp_path):
    fem = pytest.importorskip("exudyn.FEM")
    ids = np.array([10, 20, 30, 40])
    A = symmetric(12)
    write_mtx(tmp_path / "full.mtx", A)
    exudyn = fem.FEMinterface()
    exudyn.ReadStiffnessMatrixFromAbaqus(str(tmp_path / "full.mtx"))
    K = meshfile.read_mtx(tmp_path / "full.mtx", ids)
    assert K.shape == (12, 12)
    np.testing.assert_array_equal(K.toarray(), exudyn.stiffnessMatrix.toarray())
    np.testing.assert_array_equal(K.toarray(), A)
    write_mtx(tmp_path / "upper.mtx", A, triangle="upper")
    np.testing.assert_array_equal(meshfile.read_mtx(tmp_path / "upper.mtx", ids).toarray(), A)
    write_mtx(tmp_path / "lower.mtx", A, ids, triangle="lower")
    np.testing.assert_array_equal(meshfile.read_mtx(tmp_path / "lower.mtx", ids).toarray(), A)
    # the node numbers decide the rows: nodes listed in another order permute the DOFs node by node
    perm = np.array([2, 0, 3, 1])
    P = (3 * perm[:, None] + np.arange(3)).ravel()
    np.testing.assert_array_equal(meshfile.read_mtx(tmp_path / "lower.mtx", ids[perm]).toarray(),
                                  A[np.ix_(P, P)])
    write_mtx(tmp_path / "square.mtx", A, ids)
    np.testing.assert_array_equal(meshfile.read_mtx(tmp_path / "square.mtx", ids, units="mm").toarray(), 1e3 * A)


def test_read_mtx_refusals(tmp_path):
    ids = [10, 20]
    bad = {"node": "10,1, 10,1, 1.0\n10,2, 50,1, 2.0\n", "dof": "10,1, 10,1, 1.0\n20,4, 10,1, 2.0\n",
           "equation": "1 1 1.0\n7 1 2.0\n", "columns": "1 1 1.0\n1 2\n", "number": "1 1 1.0\n1 2 x\n",
           "unsymmetric": "1 1 1.0\n1 2 2.0\n2 1 3.0\n", "empty": "** nothing\n"}
    messages = {}
    for name, text in bad.items():
        with pytest.raises(InputError) as e:
            meshfile.read_mtx(write(tmp_path, f"{name}.mtx", text), ids)
        messages[name] = str(e.value).removeprefix(str(tmp_path) + "/")
    assert messages == {
        "node": "node.mtx:2: node 50 is not a node of the mesh (negative numbers are Abaqus' internal nodes, "
                "e.g. of constraints)",
        "dof": "dof.mtx:2: dof 4: a solid's nodes have dofs 1 to 3 only",
        "equation": "equation.mtx:2: equation 7 is not one of the mesh's 1..6 (3 per node, 2 nodes)",
        "columns": "columns.mtx:2: expected 'row node, row dof, column node, column dof, value' or "
                   "'row column value', got 2 numbers",
        "number": "number.mtx:2: not a number in a matrix entry",
        "unsymmetric": "unsymmetric.mtx: the matrix is not symmetric (neither one triangle nor a symmetric square)",
        "empty": "empty.mtx: no matrix entries"}
