"""The mesh-file readers behind `fe.meshfile.read`, one module per format, each filling the one
named record (`records.Parsed`) that `convert.mesh` checks and turns into an SI `fe.mesh.Mesh`:

    abaqus    .inp: keyword lines, each keyword's options and data lines read by a table (KEYWORDS)
    nastran   .bdf .nas .dat: bulk data cards, each read by a function of a table (CARDS)
    gmsh      .msh, through meshio
    matrix    Abaqus matrix files (*MATRIX GENERATE, *MATRIX OUTPUT): `read_mtx`
    records   the record (nodes, elements by kind, sets, materials, bar sections, point masses)
    common    the unit systems, the file's text, the checked number readers, ranges of set members
    convert   the record checked (numbers, references, volumes, bars, materials' wave speeds), in SI

Named `meshfiles` rather than `io`: it only reads, and only mesh files and their companion matrix
files, and a package of that name would read like the standard library's `io` in an import.
"""
