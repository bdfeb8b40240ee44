"""Watching runs move: several solvers' runs of a case overlaid in an animation of the assembled
mechanism (`animate`: GIF, or MP4 where ffmpeg is installed) and one run as a ParaView time series
(`vtk`: a .vtu file per instant and body, and a .pvd collection), both from what a run records at
the frames' instants (`channels.shapes`, `channels.poses`, `channels.fields`): `framed` is the case
whose snapshots are the frames, run by `flexmbd animate` and `flexmbd export` as `flexmbd run`
runs a case.

Every body is where the run puts it in the global frame: a flexible beam's centreline through its
shape points at their global positions, with the stress at their sections, its bending (each
point's displacement in the beam's root-node or chord frame, as the deflection channels measure
it, turned into the global frame: `elastic`) drawn magnified by a stated factor; a body that is
rigid in the solver's model through its `outline` at its pose; a solid's surface at its pose.
Below the mechanism, a panel per beam shows that displacement in its own frame, where the
solvers' differences are seen apart from the motion. A case page shows the animation
`animation_path` finds in OUT/animations (`section`).
"""

from __future__ import annotations

import dataclasses
import json
import math
import tempfile
from pathlib import Path
from xml.sax.saxutils import quoteattr

from flexmbd import cases
from flexmbd.harness import channels
from flexmbd.core import files
from flexmbd.core.errors import InputError
from flexmbd.report.fields import surface
from flexmbd.report.figures import label, style
from flexmbd.report.shapes import drawn, nearest
import matplotlib.pyplot as plt  # noqa: E402  (after figures, which chooses the Agg backend)
import numpy as np  # noqa: E402
from matplotlib import animation as mpl_animation  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402
from scipy.spatial import ConvexHull, QhullError  # noqa: E402

POINTS = 21             # shape points along each beam at least (the case's report.shape_points when more)
SHARE = 0.1             # the largest drawn displacement, as a share of the beam's length (`magnification`)
FRAMES = 100            # frames by default (every output sample of a run that has fewer)
WRITERS = {".gif": "pillow", ".mp4": "ffmpeg"}      # file suffix -> matplotlib's animation writer


# ---------------------------------------------------------------------------------------------
# the frames


def instants(case, t_end: float | None, n: int | None) -> list:
    """n instants (s) evenly spread over [0, t_end] (the case's duration by default), each on an
    output sample (a multiple of integrator.output_dt), without repeats; n None: FRAMES, or every
    sample of a run that has fewer. An InputError naming --frames when n exceeds the run's output
    samples: a frame is drawn at a sample, so more frames would only repeat them."""
    t_end = case.duration if t_end is None else t_end
    dt = case.integrator.output_dt
    last = math.floor(t_end / dt * (1 + 1e-12))
    n = min(FRAMES, last + 1) if n is None else n
    if n > last + 1:
        raise InputError(f"{case.path}: --frames {n}: the run has {last + 1} output samples (0 to {last * dt:g} s, "
                         f"every integrator.output_dt = {dt:g} s), at most one frame each: give at most {last + 1}")
    steps = np.unique(np.rint(np.linspace(0.0, last, n)).astype(int)) if n > 1 else np.array([0])
    return [float(k * dt) for k in steps]


def framed(case, times) -> object:
    """The case whose deformed-shape snapshots are taken at `times` (s), with at least POINTS shape
    points per beam and a stress channel at each shape point of every flexible beam
    (`stress_channels`): a run of it records at every frame each beam's shape with the stress
    along it (`channels.shapes`) and the other bodies' poses (`channels.poses`). Its snapshots
    pass no check of report.snapshots (their count is not bounded): such a run is drawn, never
    stored."""
    def more(c):
        def each(resolved):
            rep = dataclasses.replace(resolved.report, snapshots=tuple(times),
                                      shape_points=max(resolved.report.shape_points, POINTS))
            return dataclasses.replace(resolved, report=rep)
        resolved = each(c.resolved)
        if resolved.split is not None:
            resolved = dataclasses.replace(resolved, split=each(resolved.split))
        return dataclasses.replace(c, resolved=resolved)
    return more(cases.load(str(case.path), [*case.overrides, *stress_channels(more(case))]))


def stress_channels(case) -> list:
    """The `--set` items of a stress channel (von Mises at the outer fibre) at each shape point of
    every flexible beam of `case` (`channels.shape_positions`), named apart from its channels."""
    out, k = [], 0
    for b, body in case.bodies.items():
        if body.type != "beam" or body.rigid:
            continue
        for x in channels.shape_positions(case, b):
            while f"shape_stress_{k}" in case.channels:
                k += 1
            name = f"shape_stress_{k}"
            out += [f'channels.{name}.kind="stress_vm"', f"channels.{name}.body={json.dumps(b)}",
                    f"channels.{name}.at={x!r}"]
            k += 1
    return out


def writer(path: Path) -> str:
    """The matplotlib writer of an animation file by its suffix; an InputError naming the file
    when the suffix is neither .gif nor .mp4, or MP4 is asked for without ffmpeg."""
    name = WRITERS.get(path.suffix.lower())
    if name is None:
        raise InputError(f"{path}: --out: expected a file ending in .gif or .mp4")
    if not mpl_animation.writers.is_available(name):
        raise InputError(f"{path}: --out: MP4 needs ffmpeg, which is not installed here (write a .gif instead)")
    return name


# ---------------------------------------------------------------------------------------------
# the mechanism in the global frame


def elastic(shape: dict, k: int) -> np.ndarray:
    """(nx, 3) a beam's elastic displacement at its snapshot k in global components, m: each shape
    point's displacement u in the root-node (or chord) frame turned by that frame's rotation, the
    one that takes the points' offsets from the root there, (x, 0, 0) + u, onto their global
    offsets r - r_root, which the records satisfy exactly (found as the least-squares rotation,
    Kabsch's: the SVD of their correlation)."""
    r, u = np.asarray(shape["r"][k], dtype=float), np.asarray(shape["u"][k], dtype=float)
    a = u + np.column_stack([shape["x"], np.zeros((len(u), 2))])
    U, _, Vt = np.linalg.svd(a.T @ (r - r[0]))
    R = Vt.T @ np.diag([1.0, 1.0, np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0]) @ U.T
    return u @ R.T


def bent(shape: dict, k: int, factor: float) -> np.ndarray:
    """(nx, 3) a beam's centreline as drawn at its snapshot k: its points' global positions with
    their elastic displacement (`elastic`) magnified `factor` times, m."""
    r = np.asarray(shape["r"][k], dtype=float)
    return r if factor == 1.0 else r + (factor - 1.0) * elastic(shape, k)


def outline(case, body: str) -> np.ndarray:
    """(m, 3) the points a body without shape points is drawn through, in its body frame (m): a
    beam's root and tip; a solid's surface nodes (`fields.surface`); a rigid body's (or point
    mass's) origin, the points of the joints on it and its centre of mass, without repeats."""
    b = case.bodies[body]
    if b.type == "beam":
        return np.array([[0.0, 0.0, 0.0], [b.length, 0.0, 0.0]])
    if b.type == "solid":
        return surface(b)[0]
    joints = [*case.joints.values(), *case.loops.values()]
    on = [j.offset for j in joints if j.parent == body] + [j.child_offset for j in case.loops.values()
                                                             if j.child == body]
    return np.array(list(dict.fromkeys(tuple(map(float, p)) for p in [(0.0, 0.0, 0.0), *on, b.com])))


def mechanism(case, result, factor: float) -> dict:
    """{body: (t [k], points (k, m, 3), stress (k, m) or None)}: where a run draws its bodies in
    the global frame at the instants it records (m): a flexible beam's centreline (`bent`, with
    the stress at its points where recorded), every other body through its `outline` at its pose
    (`channels.poses`). A beam without global positions (its solver reports no poses) and a frame
    (bars: no outline) are left out."""
    out = {}
    for body, s in result.extra.get("shapes", {}).items():
        if "r" in s:
            out[body] = (s["t"], np.array([bent(s, k, factor) for k in range(len(s["t"]))]),
                         np.asarray(s["stress"], dtype=float) if "stress" in s else None)
    for body, p in result.extra.get("poses", {}).items():
        if body in case.bodies and not getattr(case.bodies[body], "is_frame", False):
            pose = (np.asarray(p["R"], dtype=float), np.asarray(p["p"], dtype=float))
            out[body] = (p["t"], channels.to_global(pose, slice(None), outline(case, body)), None)
    return out


def pivots(case) -> np.ndarray:
    """(m, 3) the points where joints hold bodies to the ground, global, m."""
    return np.array([j.offset for j in [*case.joints.values(), *case.loops.values()] if j.parent == "ground"],
                    dtype=float).reshape(-1, 3)


def plane(points) -> tuple:
    """(a, b): the two global axes the mechanism is drawn in, from the points (n, 3) it takes over
    the animation: x-y, unless the points spread less across another axis than across z (the
    motion lies in that axis's plane)."""
    spread = np.ptp(np.asarray(points, dtype=float).reshape(-1, 3), axis=0)
    normal = 2 if spread[2] <= spread.min() + 1e-6 * spread.max() else int(np.argmin(spread))
    return tuple(a for a in range(3) if a != normal)


def hull(xy) -> np.ndarray:
    """(m + 1, 2) the closed outline of points xy (n, 2) drawn in the plane: their convex hull (the
    points themselves when they span no area)."""
    try:
        v = ConvexHull(xy).vertices
    except (QhullError, ValueError):
        return xy
    return xy[np.r_[v, v[:1]]]


# ---------------------------------------------------------------------------------------------
# the animation


def magnification(peak: float, length: float) -> float:
    """The factor the displacements are drawn at: 1 when the largest, `peak` (m), reaches SHARE of
    the beam's length, else the round number (1, 2 or 5 x 10^k) at or below SHARE x length / peak."""
    if peak <= 0.0 or peak >= SHARE * length:
        return 1.0
    want = SHARE * length / peak
    k = 10.0 ** math.floor(math.log10(want))
    return max(m * k for m in (1.0, 2.0, 5.0) if m * k <= want)


def panels(case, results: dict) -> list:
    """[(beam, transverse component (1: y, 2: z), factor)]: a panel per beam and component a
    figure of the shapes draws (`shapes.drawn`), each beam's displacements drawn at one factor
    (`magnification`)."""
    out = []
    for body, comps in drawn(case, results).items():
        peak = 0.0
        for r in results.values():
            s = r.extra.get("shapes", {}).get(body)
            if s:
                peak = max(peak, float(np.abs(np.asarray(s["u"], dtype=float)).max()))
        out += [(body, c, magnification(peak, case.bodies[body].length)) for c in comps]
    return out


def frame_times(results: dict) -> list:
    """Every instant (s) at which a result holds a shape or a pose, in order: the frames."""
    return sorted({t for r in results.values() for key in ("shapes", "poses")
                   for s in r.extra.get(key, {}).values() for t in s["t"]})


def centreline(shape: dict, k: int, c: int, factor: float) -> tuple:
    """(x, y) of a beam's drawn centreline at its snapshot k: each shape point's undeformed position
    along the beam plus its displacement's axial and `c` components, times `factor` (m)."""
    u = np.asarray(shape["u"][k], dtype=float)
    return np.asarray(shape["x"], dtype=float) + factor * u[:, 0], factor * u[:, c]


def limits(case, results: dict, body: str, c: int, factor: float) -> tuple:
    """((x0, x1), (y0, y1)) of a panel, m: the whole beam and every drawn shape of every instant
    (at least SHARE of the length either side), fixed for the animation."""
    L = float(case.bodies[body].length)
    u = [np.abs(np.asarray(r.extra["shapes"][body]["u"], dtype=float)) for r in results.values()
         if body in r.extra.get("shapes", {})]
    y = 1.15 * max([SHARE * L] + [factor * float(a[:, :, c].max()) for a in u])
    return (-0.05 * L, 1.05 * L + max([factor * float(a[:, :, 0].max()) for a in u], default=0.0)), (-y, y)


def box(points, axes: tuple) -> tuple:
    """((x0, x1), (y0, y1)) of the mechanism's panel, m: every drawn point in the plane `axes`
    with a margin of 5 % of the larger extent, fixed for the animation."""
    xy = np.asarray(points, dtype=float).reshape(-1, 3)[:, list(axes)]
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    pad = 0.05 * max(float((hi - lo).max()), 1e-9)
    return (lo[0] - pad, hi[0] + pad), (lo[1] - pad, hi[1] + pad)


def animate(case, results: dict, path: Path, reference: str | None, fps: int) -> int:
    """Write the animation of every result's run overlaid (one colour per solver, the reference
    drawn wider) to `path` (.gif or .mp4, `writer`) at `fps` frames a second: on top the whole
    mechanism in the global plane it moves in (`plane`), each body where the run puts it
    (`mechanism`), the beams' bending magnified by one round factor said in the title, the first
    solver's beams coloured by the von Mises stress where recorded, the ground pivots marked;
    below, a panel per beam and transverse component of its displacement in its own frame (equal
    axes, the undeformed beam dashed). Fixed limits, the time in the title; a run that ended
    before an instant shows nothing there. Drawn by matplotlib's animation writers (Pillow,
    ffmpeg), one frame per instant; the number of frames."""
    name, rows, times = writer(path), panels(case, results), frame_times(results)
    factor = min([f for _, _, f in rows], default=1.0)
    bodies = {s: mechanism(case, r, factor) for s, r in results.items()}
    drawn_at = np.concatenate([pts.reshape(-1, 3) for got in bodies.values() for _, pts, _ in got.values()]
                              or [np.zeros((0, 3))])
    if not (len(drawn_at) or rows) or not times:
        raise InputError(f"{case.path}: no solver's run recorded where its bodies are or a deformed shape (a "
                         f"frame's shape is not recorded; or every run ended before its first sample)")
    half = 0.5 * case.integrator.output_dt * (1.0 + 1e-9)
    ground = pivots(case)
    everything = np.vstack([drawn_at, ground])
    axes_xy = plane(everything) if len(drawn_at) else (0, 1)
    boxes = ([box(everything, axes_xy)] if len(drawn_at) else []) + \
            [limits(case, results, body, c, f) for body, c, f in rows]
    widths = [5.9 if k == 0 and len(drawn_at) else 6.8 for k in range(len(boxes))]    # in: the colour bar's room
    tall = [w * min((y1 - y0) / (x1 - x0), 1.2) + 0.9 for w, ((x0, x1), (y0, y1)) in zip(widths, boxes)]
    fig, axes = plt.subplots(len(boxes), 1, squeeze=False, layout="constrained", figsize=(8.0, sum(tall) + 0.4),
                             height_ratios=tall)
    axes = list(axes[:, 0])
    update = []                                         # functions of an instant t that set the artists
    if len(drawn_at):
        update += mechanism_panel(axes.pop(0), case, results, bodies, ground, axes_xy, boxes.pop(0), reference,
                                  factor, half)
    for ax, (body, c, f), (xlim, ylim) in zip(axes, rows, boxes):
        update += beam_panel(ax, case, results, body, c, f, xlim, ylim, reference, half)
    whole = len(drawn_at) > 0
    title = lambda t: f"{case.name}: t = {t:.4f} s" + (f", bending drawn x {factor:g}" if whole and factor != 1.0
                                                        else ", to scale" if whole else "")
    heading = fig.suptitle(title(max(times)), fontsize=10)
    handles = {}                                        # one legend for every panel, below them
    for ax in fig.axes:
        for h, text in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(text, h)
    fig.legend(handles.values(), handles.keys(), loc="outside lower center", ncol=min(len(handles), 4), fontsize=8,
               frameon=False)
    fig.canvas.draw()                                   # the layout once, for the widest label:
    fig.set_layout_engine("none")                       # each frame is then drawn once
    try:
        with tempfile.TemporaryDirectory(dir=files.make_dir(path.parent), prefix=f".{path.name}.") as tmp:
            made = Path(tmp) / f"animation{path.suffix.lower()}"
            movie = mpl_animation.writers[name](fps=fps)
            with movie.saving(fig, made, dpi=80):
                for t in times:
                    heading.set_text(title(t))
                    for set_at in update:
                        set_at(t)
                    movie.grab_frame()
            files.atomic_write(path, made.read_bytes())
    except OSError as e:                                # the temporary folder, or the writer's file
        raise files.unusable(path, e) from None
    finally:
        plt.close(fig)
    return len(times)


def mechanism_panel(ax, case, results: dict, bodies: dict, ground, axes_xy: tuple, lims: tuple,
                    reference: str | None, factor: float, half: float) -> list:
    """Draw the mechanism's panel on `ax` (`animate`); the functions of an instant that move its
    artists there. bodies: {solver: `mechanism`}."""
    a, b = axes_xy
    first = next((s for s, got in bodies.items() if any(v[2] is not None for v in got.values())), None)
    top = max([float(v[2].max()) for v in bodies.get(first, {}).values() if v[2] is not None], default=0.0)
    norm = plt.Normalize(0.0, (top or 1.0) / 1e6)
    update = []
    for s, got in bodies.items():
        look = style(s, among=results)
        wide = {"lw": 3.2, "alpha": 0.55, "zorder": 1} if s == reference else {"lw": 1.5, "zorder": 2}
        ax.plot([], [], label=label(s, results[s], reference), **look, **wide)           # the legend's entry
        for body, (ts, pts, stress) in got.items():
            kind = case.bodies[body].type
            if s == first and stress is not None:
                art = LineCollection([], cmap="viridis", norm=norm, lw=wide["lw"] + 1.0, zorder=3)
                ax.add_collection(art)
            else:
                art, = ax.plot([], [], marker="s" if len(pts[0]) == 1 else None, ms=6, **look, **wide)
            update.append(placer(art, ts, pts, stress if s == first else None, kind == "solid", (a, b), half))
    if first is not None:
        cb = plt.colorbar(plt.cm.ScalarMappable(norm=norm, cmap="viridis"), ax=ax, shrink=0.8, pad=0.01)
        cb.set_label(f"{first}: von Mises [MPa]", fontsize=7)
        cb.ax.tick_params(labelsize=7)
    if len(ground):
        ax.plot(ground[:, a], ground[:, b], "^", color="k", ms=8, zorder=4, label="ground pivot")
    ax.set_xlim(*lims[0])
    ax.set_ylim(*lims[1])
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    ax.tick_params(labelsize=8)
    ax.set_xlabel(f"{'xyz'[a]} [m]", fontsize=8)
    ax.set_ylabel(f"{'xyz'[b]} [m]", fontsize=8)
    shown = f"bending x {factor:g}" if factor != 1.0 else "to scale"
    ax.set_title(f"the mechanism in the global {'xyz'[a]}-{'xyz'[b]} plane ({shown})", fontsize=9)
    return update


def placer(art, times: list, pts, stress, closed: bool, axes_xy: tuple, half: float):
    """The function of an instant t that puts one body of one run on its artist: its points
    (k, m, 3) at the snapshot (of those at `times`) nearest to t (`shapes.nearest`) in the plane
    `axes_xy` (a solid's outline: `hull`), a LineCollection's segments coloured by the stress
    (k, m) (Pa, drawn in MPa); nothing where the run has no snapshot within `half` of t."""
    def set_at(t: float) -> None:
        k = nearest({"t": times}, t, half)
        xy = np.zeros((0, 2)) if k is None else pts[k][:, list(axes_xy)]
        xy = hull(xy) if closed and len(xy) else xy
        if isinstance(art, LineCollection):
            art.set_segments(np.stack([xy[:-1], xy[1:]], axis=1) if len(xy) else [])
            art.set_array(np.zeros(0) if k is None else 0.5 * (stress[k][:-1] + stress[k][1:]) / 1e6)
        else:
            art.set_data(xy[:, 0], xy[:, 1])
    return set_at


def beam_panel(ax, case, results: dict, body: str, c: int, factor: float, xlim, ylim, reference: str | None,
               half: float) -> list:
    """Draw one beam's panel of its displacement in its own frame on `ax` (`animate`): every
    solver's centreline (`centreline`) against the undeformed beam, dashed; the functions of an
    instant that move its lines."""
    L = float(case.bodies[body].length)
    ax.plot([0.0, L], [0.0, 0.0], color="0.6", lw=0.8, ls="--", label="undeformed")
    update = []
    for s, r in results.items():
        shape = r.extra.get("shapes", {}).get(body)
        if not shape:
            continue
        wide = {"lw": 3.0, "alpha": 0.55, "zorder": 1} if s == reference else {"lw": 1.4, "zorder": 2}
        line, = ax.plot([], [], label=label(s, r, reference), **style(s, among=results), **wide)

        def set_at(t, line=line, shape=shape):
            k = nearest(shape, t, half)
            line.set_data(*(centreline(shape, k, c, factor) if k is not None else ([], [])))
        update.append(set_at)
    ax.set_xlim(*xlim)
    ax.set_ylim(*ylim)
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    ax.tick_params(labelsize=8)
    ax.set_xlabel("x along the beam [m]", fontsize=8)
    ax.set_ylabel(f"{'xyz'[c]} [m]", fontsize=8)
    shown = f"displacement x {factor:g}" if factor != 1.0 else "displacement to scale"
    frame = "chord" if case.bodies[body].modes.boundary == "hinged-hinged" else "root-node"
    ax.set_title(f"{body}, x-{'xyz'[c]} plane of its {frame} frame ({shown})", fontsize=9)
    return update


def animation_path(out: Path, case_name: str) -> Path | None:
    """The animation a case page links, OUT/animations/CASE.gif (or .mp4), where `flexmbd animate`
    writes it by default; None when there is none."""
    return next((p for p in (Path(out) / "animations" / f"{case_name}{x}" for x in WRITERS) if p.is_file()), None)


def section(out: Path, case, up: str = "..") -> tuple | None:
    """The case page's section (title, HTML, Markdown) showing the animation `animation_path` finds
    (the page OUT/CASE/index.html links ../animations/CASE.*; `up`: the report folder OUT seen from
    the page's folder); None when there is none."""
    path = animation_path(out, case.name)
    if path is None:
        return None
    src = f"{up}/animations/{path.name}"
    shown = (f"<p><img src='{src}' alt='{path.name}'></p>" if path.suffix == ".gif"
             else f"<p><video src='{src}' controls loop></video></p>")
    note = lambda a, b: (f"The solvers' runs over time, written by {a}flexmbd animate {case.name} --solvers ...{b} "
                         f"(docs/animation.md): the mechanism in the global frame, the beams' bending magnified as the "
                         f"title says, and below each beam's displacement in its own frame; it is not redrawn with "
                         f"the report.")
    return ("Animation", shown + f"<p>{note('<code>', '</code>')}</p>",
            f"[{path.name}]({src})\n\n{note('`', '`')}\n\n")


# ---------------------------------------------------------------------------------------------
# the ParaView time series


def polyline(n: int) -> list:
    """meshio cell blocks of a polyline through n points: line cells, or one vertex for a point."""
    if n == 1:
        return [("vertex", np.array([[0]]))]
    return [("line", np.column_stack([np.arange(n - 1), np.arange(1, n)]))]


def solid_cells(faces, vm) -> tuple:
    """(cell blocks [(type, corners)], cell data {"von_mises": [per block]}) of a solid's boundary
    faces (`fields.surface`) with the von Mises stress of each face's element vm (nf,) Pa (None:
    no cell data), triangles and quadrilaterals in their own blocks."""
    blocks, data = [], []
    for kind, n in (("triangle", 3), ("quad", 4)):
        rows = [i for i, f in enumerate(faces) if len(f) == n]
        if rows:
            blocks.append((kind, np.array([faces[i] for i in rows], dtype=int)))
            data.append(None if vm is None else np.asarray(vm, dtype=float)[rows])
    return blocks, {} if vm is None else {"von_mises": data}


def meshes(case, result) -> dict:
    """{body: [(t, meshio.Mesh)]}: a run's bodies in the global frame at the instants it records
    them (m): a flexible beam's centreline through its shape points (line cells) with the point
    data `displacement` (its elastic displacement in global components, `elastic`, m) and
    `stress_vm` (Pa) where recorded; a body rigid in the solver's model through its `outline` at
    its pose, with `displacement` zero (and a beam's `stress_vm` zero, as its channels have it); a
    solid's boundary faces at its pose with the cell data `von_mises` (`solid_cells`) where the run
    records its field. A beam without global positions (its solver reports no poses) and a frame
    (bars) are left out."""
    import meshio
    out = {}
    for body, s in result.extra.get("shapes", {}).items():
        if "r" not in s:
            continue
        out[body] = []
        for k, t in enumerate(s["t"]):
            data = {"displacement": elastic(s, k), **({"stress_vm": np.asarray(s["stress"][k], dtype=float)}
                                                      if "stress" in s else {})}
            out[body].append((t, meshio.Mesh(np.asarray(s["r"][k], dtype=float), polyline(len(s["x"])),
                                             point_data=data)))
    fields = result.extra.get("fields", {})
    for body, p in result.extra.get("poses", {}).items():
        b = case.bodies.get(body)
        if b is None or getattr(b, "is_frame", False):
            continue
        pose = (np.asarray(p["R"], dtype=float), np.asarray(p["p"], dtype=float))
        if b.type == "solid":
            x, faces = surface(b)
            vm = dict(zip(fields.get(body, {}).get("t", []), fields.get(body, {}).get("vm", [])))
            out[body] = []
            for t, at in zip(p["t"], channels.to_global(pose, slice(None), x)):
                blocks, data = solid_cells(faces, vm.get(t))
                out[body].append((t, meshio.Mesh(at, blocks, cell_data=data)))
            continue
        x = outline(case, body)
        zero = {"displacement": np.zeros((len(x), 3)), **({"stress_vm": np.zeros(len(x))} if b.type == "beam" else {})}
        out[body] = [(t, meshio.Mesh(at, polyline(len(x)), point_data=zero))
                     for t, at in zip(p["t"], channels.to_global(pose, slice(None), x))]
    return out


def vtk(case, result, folder: Path) -> tuple:
    """Write one run's bodies as a ParaView time series into `folder`: BODY_NNNNN.vtu per body and
    instant (`meshes`: in the global frame, a beam's centreline as line cells with the point data
    `displacement` (m) and `stress_vm` (Pa), a rigid body through its outline, a solid's surface
    with the cell data `von_mises` (Pa)) and CASE_SOLVER.pvd listing them by time, one part per
    body. (the .pvd's path, the number of instants)."""
    import meshio
    got = meshes(case, result)
    if not got:
        raise InputError(f"{case.path}: {result.solver}'s run recorded no body it can place in the global frame (a "
                         f"solver that reports no body poses, a frame's shape is not recorded; or the run ended "
                         f"before its first sample)")
    folder = files.make_dir(folder)
    entries = []
    for part, (body, series) in enumerate(got.items()):
        for k, (t, mesh) in enumerate(series):
            name = f"{body}_{k:05d}.vtu"
            with files.temporary(folder / name, b"") as tmp:   # meshio writes to a path: the temporary's
                meshio.write(tmp, mesh, file_format="vtu")
                files.swap([(tmp, folder / name)])
            entries.append((float(t), part, name))
    rows = "".join(f'    <DataSet timestep="{t!r}" part="{p}" file={quoteattr(n)}/>\n' for t, p, n in sorted(entries))
    pvd = folder / f"{case.name}_{result.solver}.pvd"
    files.atomic_write(pvd, '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1" '
                            f'byte_order="LittleEndian">\n  <Collection>\n{rows}  </Collection>\n</VTKFile>\n')
    return pvd, len({t for t, _, _ in entries})
