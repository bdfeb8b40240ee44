"""The von Mises field on a solid's surface at the case's chosen instants (`report.snapshots`),
from the `fields` a result stores (`channels.fields`): one figure per solid, a row per solver and
view, a panel per instant. Each boundary face is drawn in its element's centre stress, seen from +z
(the x-y plane) and from +y (the x-z plane): the faces turned towards the viewer, on the
undeformed mesh, in one colour scale per figure."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from flexmbd.fe import flexbody
from flexmbd.fe import solid
from flexmbd.report.figures import label, save
import matplotlib.pyplot as plt  # noqa: E402  (after figures, which chooses the Agg backend)
import numpy as np  # noqa: E402
from matplotlib.collections import PolyCollection  # noqa: E402

COLUMNS = 4         # instants per row at most (the first ones)
VIEWS = (("+z", 2, (0, 1)), ("+y", 1, (0, 2)))      # (name, the axis seen along, the plane's axes)


def surface(body) -> tuple:
    """(nodes (nn, 3), faces) of a case solid: its mesh's nodes in its body frame (m, the frame
    interface's reference point at the origin) and its boundary faces (corner-node index arrays,
    3 or 4 each, outward by the right-hand rule), in the order of a stored field's values."""
    mesh = flexbody.solid_mesh(**dataclasses.asdict(body.mesh))
    faces, _ = solid.boundary_faces(mesh)
    frame = body.interfaces[body.frame]
    return mesh.nodes - flexbody.reference_point(mesh, frame.set, frame.point), faces


def views(body) -> list:
    """[(view name, plane axes (2,), polygons (nf_view, k, 2), face rows (nf_view,))] of a case
    solid's boundary faces turned towards each viewer (outward normal along the view axis), in its
    body frame (m): the faces of a view in the order drawn."""
    x, faces = surface(body)
    out = []
    for name, axis, plane in VIEWS:
        rows, polys = [], []
        for i, f in enumerate(faces):
            p = x[f]
            n = np.cross(p[1] - p[0], p[2] - p[0])
            if n[axis] > 1e-9 * np.linalg.norm(n):
                rows.append(i)
                polys.append(p[:, plane])
        order = np.argsort([x[faces[i], axis].mean() for i in rows], kind="stable")     # far faces first
        out.append((name, plane, [polys[k] for k in order], np.array(rows, dtype=int)[order]))
    return out


def figure(case, body: str, results: dict, path: Path, reference: str | None = None) -> str | None:
    """The field figure of one solid, or None when no result stores its field."""
    have = {s: r.extra["fields"][body] for s, r in results.items() if body in r.extra.get("fields", {})}
    if not have:
        return None
    order = sorted(have, key=lambda s: (s != reference, s))
    instants = sorted({t for f in have.values() for t in f["t"]})[:COLUMNS]
    shown = views(case.bodies[body])
    top = max(float(np.max(f["vm"])) for f in have.values()) or 1.0
    rows = [(s, v) for s in order for v in shown]
    fig, axes = plt.subplots(len(rows), len(instants), squeeze=False, layout="constrained",
                             figsize=(3.0 * len(instants) + 1.2, 1.35 * len(rows) + 1.0))
    for r, (s, (name, plane, polys, faces)) in enumerate(rows):
        f = have[s]
        for j, t in enumerate(instants):
            ax = axes[r, j]
            if t not in f["t"]:
                ax.set_visible(False)
                continue
            vm = np.asarray(f["vm"][f["t"].index(t)], dtype=float)[faces]
            pc = PolyCollection(polys, array=vm / 1e6, cmap="viridis", clim=(0.0, top / 1e6), edgecolors="face",
                                linewidths=0.3)                     # edges in the face colour: no seams
            ax.add_collection(pc)
            ax.autoscale_view()
            ax.tick_params(labelsize=7)
            ax.set_title(f"{label(s, results[s], reference)}, t = {t:g} s, seen from {name}", fontsize=8)
            ax.set_xlabel(f"{'xyz'[plane[0]]} [m]", fontsize=7)
            ax.set_ylabel(f"{'xyz'[plane[1]]} [m]", fontsize=7)
    fig.colorbar(pc, ax=axes, shrink=0.8, label="von Mises [MPa]")
    fig.suptitle(f"{case.name}: von Mises stress on the surface of {body} (each face: its element's centre stress; "
                 f"undeformed mesh, body frame)", fontsize=9)
    return save(fig, path)


def section(case, results: dict, folder: Path, reference: str | None = None) -> tuple | None:
    """The case page's section (title, HTML, Markdown) of every solid's field figure; None when no
    result holds a field."""
    imgs = [figure(case, b, results, folder / f"field_{b}.png", reference)
            for b, body in case.bodies.items() if body.type == "solid"]
    imgs = [i for i in imgs if i]
    if not imgs:
        return None
    note = ("The von Mises stress on each solid's boundary faces at the chosen instants (report.snapshots, the first "
            f"{COLUMNS} of them), each face coloured by the stress at the centre of its element, seen from +z and from "
            "+y on the undeformed mesh (the axes are not to scale: a slender part is stretched across). Every solver "
            "that models the solid's whole stress field stores it with its result; the colour scale is shared.")
    return ("Stress on the surface",
            "".join(f"<p><img src='{i}' alt='{i}'></p>" for i in imgs) + f"<p>{note}</p>",
            "".join(f"![{i}]({i})\n\n" for i in imgs) + f"{note}\n\n")
