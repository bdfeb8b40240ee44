"""Writes the mesh files that tests/fe/test_fe_meshfile.py reads, each set from one mesh:

    .venv/bin/python tests/data/make_block.py        # rewrites the nine files next to this script

block.inp, block.bdf, block.msh
    A hex20 block 0.1 x 0.02 x 0.03 m (x from 0 to L = 0.1, y and z centred), 4 x 1 x 2 elements
    (flexmbd.fe.mesh.box), steel (E = 2.1e11 Pa, nu = 0.3, rho = 7850 kg/m^3), the node sets
    "clamp" (x = 0), "tip" (x = L) and "body" (every node), and the element set "body".
    Abaqus: the layout Abaqus/CAE writes (part, assembly, instance, sets at assembly level, a step),
    C3D20R elements over two lines. NASTRAN: GRID* in large field, CHEXA in small field with
    continuations, MAT1 and PSOLID in free field; "clamp" is SPC1 1 (so "spc1"), "tip" SET1 2
    ("set2"), "body" SET1 3 with THRU ("set3"); the material is "mat1". Gmsh: MSH 2.2 ASCII in
    Gmsh's own node order, physical surfaces "clamp" and "tip" (quad8 facets), physical volume "body".
block_tet.inp, block_tet.bdf, block_tet.msh
    The same block of tet10 elements (six per hexahedron), as a flat Abaqus file (C3D10); NASTRAN
    GRID in small field, CTETRA in free field; Gmsh MSH 4.1 ASCII (triangle6 facets).
distorted.inp, distorted.bdf, distorted.msh
    One distorted hex20 and one distorted tet10, their mid-edge nodes moved off the edge midpoints
    (each stays nearest to its own edge) and their node numbers scrambled: a wrong node order in any
    reader shows. No sets, no material.

Coordinates are rounded to short decimals, so that every format (NASTRAN's small field has eight
characters) writes them exactly and the three files of a set read to identical numbers. The node
orders of Gmsh and NASTRAN are written here from their documentation, not through meshio.
"""

import sys
from pathlib import Path

import numpy as np

from flexmbd.fe.mesh import EDGES, Mesh, box

HERE = Path(__file__).resolve().parent
L, H, B, N = 0.1, 0.02, 0.03, (4, 1, 2)
STEEL = ("steel", 2.1e11, 0.3, 7850.0)

ABAQUS_TYPE = {"tet4": "C3D4", "tet10": "C3D10", "hex8": "C3D8R", "hex20": "C3D20R"}

# Gmsh's node order from fe.mesh's (Gmsh's manual, "Node ordering"): hexahedron20's mid-edge nodes
# are on 01 03 04 12 15 23 26 37 45 47 56 67, tetra10's on 01 12 20 30 32 31
GMSH_ORDER = {"tet4": np.arange(4), "tet10": np.r_[0:8, 9, 8], "hex8": np.arange(8),
              "hex20": np.r_[0:8, 8, 11, 16, 9, 17, 10, 18, 19, 12, 15, 13, 14]}
GMSH_TYPE = {"tet4": 4, "tet10": 11, "hex8": 5, "hex20": 17}
GMSH_FACET = {"tet4": 2, "tet10": 9, "hex8": 3, "hex20": 16}      # triangle, triangle6, quad, quad8

# NASTRAN CHEXA's 20 grids from fe.mesh's order: mid-edge 12 23 34 41, 15 26 37 48, 56 67 78 85
NASTRAN_HEX20 = np.r_[0:12, 16:20, 12:16]

# element faces by corners, outward (for the facets of the Gmsh files' physical surfaces)
FACES = {"tet": ((0, 2, 1), (0, 1, 3), (1, 2, 3), (0, 3, 2)),
         "hex": ((0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7))}


def short(x) -> np.ndarray:
    """`x` rounded to the double of a short decimal (at most 9 significant digits)."""
    return np.vectorize(lambda v: float(f"{v:.9g}"))(np.asarray(x, dtype=float))


def block(kind: str) -> Mesh:
    """The test block of `kind` elements with its sets clamp, tip, body."""
    m = box(L, H, B, N, kind)
    nodes = short(m.nodes)
    sets = {"clamp": m.node_sets["x0"], "tip": m.node_sets["xL"], "body": np.arange(nodes.shape[0])}
    return m._replace(nodes=nodes, node_sets=sets, elem_sets={"body": {kind: np.arange(m.cells[kind].shape[0])}},
                      materials={STEEL[0]: STEEL[1:]}, source=f"block {kind}")


def distorted() -> Mesh:
    """A hex20 and a tet10, distorted, mid-edge nodes off their edges' midpoints, scrambled numbers."""
    rng = np.random.default_rng(20)
    hex_corners = 0.05 * np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                                   [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], dtype=float)
    hex_corners += rng.uniform(-0.008, 0.008, hex_corners.shape)
    tet_corners = np.array([[0.2, 0, 0], [0.26, 0.01, 0], [0.21, 0.05, 0.005], [0.215, 0.02, 0.06]])
    tet_corners += rng.uniform(-0.005, 0.005, tet_corners.shape)
    blocks = []
    for kind, corners in (("hex20", hex_corners), ("tet10", tet_corners)):
        mid = np.array([0.5 * (corners[a] + corners[b]) for a, b in EDGES[kind]])
        blocks.append(np.vstack([corners, mid + rng.uniform(-0.002, 0.002, mid.shape)]))
    xyz = np.round(np.vstack(blocks), 4)
    rows = rng.permutation(xyz.shape[0])               # file row of each element node
    nodes = np.empty_like(xyz)
    nodes[rows] = xyz
    ids = 101 + 3 * rng.permutation(xyz.shape[0])
    return Mesh(nodes=short(nodes), cells={"hex20": rows[None, :20], "tet10": rows[None, 20:]}, node_sets={},
                elem_sets={}, materials={}, source="distorted", node_ids=ids,
                elem_ids={"hex20": np.array([7]), "tet10": np.array([3])})


def num(v) -> str:
    """The shortest text of a float that reads back to it."""
    return repr(float(v))


def lines_of(items, per=16) -> list:
    """Abaqus data lines of at most `per` comma-separated items."""
    items = [str(i) for i in items]
    return [", ".join(items[k:k + per]) for k in range(0, len(items), per)]


# ---------------------------------------------------------------------------------------------
# Abaqus


def write_inp(path, mesh: Mesh, title: str, cae: bool = False) -> None:
    """An Abaqus input file; `cae`: in Abaqus/CAE's layout (one part, an assembly with one instance,
    the sets at assembly level, a frequency step), else flat."""
    out = ["*Heading", f"** {title}", "** written by tests/data/make_block.py"]
    if cae:
        out += ["*Preprint, echo=NO, model=NO, history=NO, contact=NO", "**", "** PARTS", "**", "*Part, name=block"]
    out.append("*Node")
    out += [f"{i:7d}, {num(x)}, {num(y)}, {num(z)}" for i, (x, y, z) in zip(mesh.node_ids, mesh.nodes)]
    for kind, cells in mesh.cells.items():
        sets = [name for name, members in mesh.elem_sets.items() if kind in members]
        out.append(f"*Element, type={ABAQUS_TYPE[kind]}" + (f", elset={sets[0]}" if sets else ""))
        for e, row in zip(mesh.elem_ids[kind], mesh.node_ids[cells]):
            items = [str(e)] + [str(n) for n in row]
            out += [", ".join(items[:16]) + ("," if len(items) > 16 else "")]
            if len(items) > 16:
                out.append("    " + ", ".join(items[16:]))
    if cae:
        out += ["*Solid Section, elset=body, material=steel", ",", "*End Part", "**", "** ASSEMBLY", "**",
                "*Assembly, name=Assembly", "**", "*Instance, name=block-1, part=block", "*End Instance", "**"]
    inst = ", instance=block-1" if cae else ""
    for name, rows in mesh.node_sets.items():
        ids = mesh.node_ids[rows]
        if ids.size > 2 and (np.diff(ids) == 1).all():
            out += [f"*Nset, nset={name}{inst}, generate", f"{ids[0]}, {ids[-1]}, 1"]
        else:
            out += [f"*Nset, nset={name}{inst}"] + lines_of(ids)
    if cae:
        out += ["*End Assembly", "**", "** MATERIALS", "**"]
    for name, (E, nu, rho) in mesh.materials.items():
        out += [f"*Material, name={name}", "*Density", f"{num(rho)},", "*Elastic", f"{num(E)}, {num(nu)}"]
    if cae:
        out += ["** ----------------------------------------------------------------", "**", "** STEP: modes", "**",
                "*Step, name=modes, nlgeom=NO, perturbation", "*Frequency, eigensolver=Lanczos", "10, , , , ,",
                "*Boundary", "clamp, ENCASTRE", "*End Step"]
    Path(path).write_text("\n".join(out) + "\n")


# ---------------------------------------------------------------------------------------------
# NASTRAN


def small(name, fields) -> list:
    """A card in small field format: 8 data fields a line, '+' continuations."""
    fields = [str(f) for f in fields]
    assert all(len(f) <= 8 for f in fields), fields
    out = []
    for k in range(0, max(len(fields), 1), 8):
        line = f"{name if k == 0 else '+':<8}" + "".join(f"{f:>8}" for f in fields[k:k + 8])
        out.append(f"{line:<72}+" if k + 8 < len(fields) else line.rstrip())
    return out


def free(name, fields) -> list:
    """A card in free field format: 8 data fields a line, '+' continuations."""
    fields = [str(f) for f in fields]
    out = []
    for k in range(0, max(len(fields), 1), 8):
        head = name if k == 0 else "+"
        more = ",+" if k + 8 < len(fields) else ""
        out.append(",".join([head] + fields[k:k + 8]) + more)
    return out


def large_grid(i, x) -> list:
    """A GRID* card in large field format (16-character fields, '*' continuation)."""
    assert all(len(num(v)) <= 16 for v in x)
    return [f"{'GRID*':<8}{i:>16}{'':>16}{num(x[0]):>16}{num(x[1]):>16}*", f"{'*':<8}{num(x[2]):>16}"]


def nastran_real(v) -> str:
    """A real in NASTRAN's short form: the exponent without E (2.1+11, 7.85-9)."""
    mantissa, _, exponent = f"{v:.6g}".partition("e")
    if "." not in mantissa:
        mantissa += "."
    return mantissa + (f"{int(exponent):+d}" if exponent else "")


def write_bdf(path, mesh: Mesh, title: str, grid: str = "small", element: str = "small",
              sets: dict = None) -> None:
    """A NASTRAN bulk data file: GRID in `grid` ('small' or 'large') field, elements in `element`
    ('small' or 'free') field, MAT1/PSOLID (MID = PID = 1) in free field; `sets` {node set: (card,
    SID)} with card SPC1 or SET1."""
    out = [f"$ {title}", "$ written by tests/data/make_block.py", "SOL 103", "CEND", "BEGIN BULK",
           "PARAM,POST,-1", "EIGRL,10,,,12", "$ grids"]
    for i, x in zip(mesh.node_ids, mesh.nodes):
        out += large_grid(i, x) if grid == "large" else small("GRID", [i, "", num(x[0]), num(x[1]), num(x[2])])
    out.append("$ elements")
    write = small if element == "small" else free
    for kind, cells in mesh.cells.items():
        order = NASTRAN_HEX20 if kind == "hex20" else slice(None)
        for e, row in zip(mesh.elem_ids[kind], mesh.node_ids[cells][:, order]):
            out += write("CTETRA" if kind.startswith("tet") else "CHEXA", [e, 1, *row])
    for name, (E, nu, rho) in mesh.materials.items():
        out += [f"$ material {name}", "PSOLID,1,1", f"MAT1,1,{nastran_real(E)},,{num(nu)},{nastran_real(rho)}"]
    for name, (card, sid) in (sets or {}).items():
        ids = mesh.node_ids[mesh.node_sets[name]]
        out.append(f"$ node set {name}")
        if card == "SET1" and ids.size > 2 and (np.diff(ids) == 1).all():
            out += free("SET1", [sid, ids[0], "THRU", ids[-1]])
        elif card == "SET1":
            out += free("SET1", [sid, *ids])
        else:
            out += small("SPC1", [sid, 123456, *ids])
    out.append("ENDDATA")
    Path(path).write_text("\n".join(out) + "\n")


# ---------------------------------------------------------------------------------------------
# Gmsh


def facets(mesh: Mesh, kind: str, on) -> np.ndarray:
    """The element faces (k, 3 | 4 | 6 | 8 rows: corners, then mid-edge nodes in turn) whose nodes
    all satisfy `on` (a bool array over the nodes)."""
    cells = mesh.cells[kind]
    mid = {tuple(sorted(e)): 4 * (kind[:3] == "tet") + 8 * (kind[:3] == "hex") + k
           for k, e in enumerate(EDGES.get(kind, ()))}
    out = []
    for face in FACES[kind[:3]]:
        cols = list(face) + ([mid[tuple(sorted((face[k], face[(k + 1) % len(face)])))] for k in range(len(face))]
                             if kind in EDGES else [])
        rows = cells[:, cols]
        out.append(rows[on[rows].all(axis=1)])
    return np.concatenate(out)


def gmsh_groups(mesh: Mesh) -> list:
    """(dim, tag, name, [(gmsh type, node rows in Gmsh's order)]) of the physical groups clamp and tip
    (their facets) and body (the 3-D cells)."""
    groups = []
    for tag, (name, x) in enumerate((("clamp", 0.0), ("tip", L)), 1):
        on = np.isclose(mesh.nodes[:, 0], x)
        groups.append((2, tag, name, [(GMSH_FACET[k], facets(mesh, k, on)) for k in mesh.cells]))
    groups.append((3, 3, "body", [(GMSH_TYPE[k], c[:, GMSH_ORDER[k]]) for k, c in mesh.cells.items()]))
    return groups


def write_msh22(path, mesh: Mesh, groups: list) -> None:
    """A Gmsh MSH 2.2 ASCII file; node tags are the rows + 1, Gmsh's node order."""
    out = ["$MeshFormat", "2.2 0 8", "$EndMeshFormat"]
    if groups:
        out += ["$PhysicalNames", str(len(groups))]
        out += [f'{d} {t} "{n}"' for d, t, n, _ in groups] + ["$EndPhysicalNames"]
    out += ["$Nodes", str(mesh.n_nodes)]
    out += [f"{i} {num(x)} {num(y)} {num(z)}" for i, (x, y, z) in enumerate(mesh.nodes, 1)]
    out += ["$EndNodes", "$Elements"]
    elements = []
    for dim, tag, name, blocks in groups:
        for gtype, rows in blocks:
            elements += [f"{gtype} 2 {tag} {tag} " + " ".join(str(r + 1) for r in row) for row in rows]
    out += [str(len(elements))] + [f"{k} {e}" for k, e in enumerate(elements, 1)] + ["$EndElements"]
    Path(path).write_text("\n".join(out) + "\n")


def write_msh41(path, mesh: Mesh, groups: list) -> None:
    """A Gmsh MSH 4.1 ASCII file: one entity per physical group (surfaces, volume), every node in the
    volume's entity block; node tags are the rows + 1, Gmsh's node order."""
    lo, hi = mesh.nodes.min(axis=0), mesh.nodes.max(axis=0)
    box_ = " ".join(num(v) for v in (*lo, *hi))
    surfaces = [g for g in groups if g[0] == 2]
    volumes = [g for g in groups if g[0] == 3]
    out = ["$MeshFormat", "4.1 0 8", "$EndMeshFormat",
           "$PhysicalNames", str(len(groups))] + [f'{d} {t} "{n}"' for d, t, n, _ in groups] + ["$EndPhysicalNames"]
    out += ["$Entities", f"0 0 {len(surfaces)} {len(volumes)}"]
    out += [f"{t} {box_} 1 {t} 0" for _, t, _, _ in surfaces + volumes]
    out += ["$EndEntities", "$Nodes", f"1 {mesh.n_nodes} 1 {mesh.n_nodes}", f"3 {volumes[0][1]} 0 {mesh.n_nodes}"]
    out += [str(i) for i in range(1, mesh.n_nodes + 1)]
    out += [f"{num(x)} {num(y)} {num(z)}" for x, y, z in mesh.nodes]
    out.append("$EndNodes")
    blocks = [(d, t, gtype, rows) for d, t, _, bl in groups for gtype, rows in bl if len(rows)]
    total = sum(len(rows) for *_, rows in blocks)
    out += ["$Elements", f"{len(blocks)} {total} 1 {total}"]
    k = 0
    for d, t, gtype, rows in blocks:
        out.append(f"{d} {t} {gtype} {len(rows)}")
        for row in rows:
            k += 1
            out.append(f"{k} " + " ".join(str(r + 1) for r in row))
    out.append("$EndElements")
    Path(path).write_text("\n".join(out) + "\n")


def main(outdir=HERE) -> list:
    """Write the nine files into `outdir`; their paths."""
    outdir = Path(outdir)
    hexes, tets, bent = block("hex20"), block("tet10"), distorted()
    title = "block 0.1 x 0.02 x 0.03 m, 4 x 1 x 2 {}, steel; node sets clamp (x = 0), tip (x = L), body"
    sets = {"clamp": ("SPC1", 1), "tip": ("SET1", 2), "body": ("SET1", 3)}
    write_inp(outdir / "block.inp", hexes, title.format("hex20"), cae=True)
    write_bdf(outdir / "block.bdf", hexes, title.format("hex20"), grid="large", element="small", sets=sets)
    write_msh22(outdir / "block.msh", hexes, gmsh_groups(hexes))
    write_inp(outdir / "block_tet.inp", tets, title.format("tet10 (six per hexahedron)"))
    write_bdf(outdir / "block_tet.bdf", tets, title.format("tet10 (six per hexahedron)"), grid="small",
              element="free", sets=sets)
    write_msh41(outdir / "block_tet.msh", tets, gmsh_groups(tets))
    write_inp(outdir / "distorted.inp", bent, "a distorted hex20 and tet10, scrambled node numbers")
    write_bdf(outdir / "distorted.bdf", bent, "a distorted hex20 and tet10, scrambled node numbers",
              element="small")
    write_msh22(outdir / "distorted.msh", bent,
                [(3, 1, "body", [(GMSH_TYPE[k], c[:, GMSH_ORDER[k]]) for k, c in bent.cells.items()])])
    return [outdir / f"{stem}.{ext}" for stem in ("block", "block_tet", "distorted") for ext in ("inp", "bdf", "msh")]


if __name__ == "__main__":
    for p in main(sys.argv[1] if len(sys.argv) > 1 else HERE):
        print(p)
