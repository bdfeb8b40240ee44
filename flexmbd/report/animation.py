"""Watching runs move: the deformed shapes of several solvers' runs overlaid in an animation
(`animate`: GIF, or MP4 where ffmpeg is installed) and one run's shapes as a ParaView time series
(`vtk`: a .vtu file per instant and body, and a .pvd collection), both from the shapes a run
records (`channels.shapes`) at the frames' instants: `framed` is the case whose snapshots are
the frames, run by `flexmbd animate` and `flexmbd export` as `flexmbd run` runs a case.

A shape is each shape point's displacement in its beam's root-node frame (hinged-hinged modes:
the chord frame), as the deflection channels measure it: the elastic motion, without the body's
rigid motion. A case page shows the animation `animation_path` finds in OUT/animations (`section`).
"""

from __future__ import annotations

import dataclasses
import math
import tempfile
from pathlib import Path
from xml.sax.saxutils import quoteattr

from flexmbd import files
from flexmbd.errors import InputError
from flexmbd.report.fields import surface
from flexmbd.report.figures import style
from flexmbd.report.shapes import drawn, nearest
import matplotlib.pyplot as plt  # noqa: E402  (after figures, which chooses the Agg backend)
import numpy as np  # noqa: E402
from matplotlib import animation as mpl_animation  # noqa: E402

POINTS = 21             # shape points along each beam at least (the case's report.shape_points when more)
SHARE = 0.1             # the largest drawn displacement, as a share of the beam's length (`magnification`)
WRITERS = {".gif": "pillow", ".mp4": "ffmpeg"}      # file suffix -> matplotlib's animation writer


# ---------------------------------------------------------------------------------------------
# the frames


def instants(case, t_end: float | None, n: int) -> list:
    """n instants (s) evenly spread over [0, t_end] (the case's duration by default), each on an
    output sample (a multiple of integrator.output_dt), without repeats."""
    t_end = case.duration if t_end is None else t_end
    dt = case.integrator.output_dt
    last = math.floor(t_end / dt * (1 + 1e-12))
    steps = np.unique(np.rint(np.linspace(0.0, last, n)).astype(int)) if n > 1 else np.array([0])
    return [float(k * dt) for k in steps]


def framed(case, times) -> object:
    """The case whose deformed-shape snapshots are taken at `times` (s), with at least POINTS shape
    points per beam: a run of it records its shapes at every frame (`channels.shapes`). Its
    snapshots pass no check of report.snapshots (their count is not bounded): such a run is drawn,
    never stored."""
    def more(resolved):
        rep = dataclasses.replace(resolved.report, snapshots=tuple(times),
                                  shape_points=max(resolved.report.shape_points, POINTS))
        return dataclasses.replace(resolved, report=rep)
    resolved = more(case.resolved)
    if resolved.split is not None:
        resolved = dataclasses.replace(resolved, split=more(resolved.split))
    return dataclasses.replace(case, resolved=resolved)


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
    """Every instant (s) at which a result holds a shape, in order: the frames."""
    return sorted({t for r in results.values() for s in r.extra.get("shapes", {}).values() for t in s["t"]})


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


def animate(case, results: dict, path: Path, reference: str | None, fps: int) -> int:
    """Write the animation of every result's deformed shapes overlaid (one colour per solver, the
    reference drawn wider) to `path` (.gif or .mp4, `writer`) at `fps` frames a second: a panel per beam and transverse
    component, equal axes and fixed limits, the undeformed beam dashed, the time in the title.
    A run that ended before an instant shows no shape there. Drawn by matplotlib's animation
    writers (Pillow, ffmpeg), one frame per instant; the number of frames."""
    name, rows, times = writer(path), panels(case, results), frame_times(results)
    if not rows or not times:
        raise InputError(f"{case.path}: no solver's run recorded a deformed shape (the case has no flexible beam: "
                         f"a solid's field is exported by `flexmbd export`, a frame's shape is not recorded; or every "
                         f"run ended before its first sample)")
    half = 0.5 * case.integrator.output_dt * (1.0 + 1e-9)
    boxes = [limits(case, results, body, c, factor) for body, c, factor in rows]
    tall = sum(6.8 * (y1 - y0) / (x1 - x0) + 1.0 for (x0, x1), (y0, y1) in boxes)
    fig, axes = plt.subplots(len(rows), 1, squeeze=False, layout="constrained", figsize=(8.0, tall + 0.4),
                             height_ratios=[(y1 - y0) / (x1 - x0) + 0.15 for (x0, x1), (y0, y1) in boxes])
    lines = []                                          # (line, shape, component, factor)
    for ax, (body, c, factor), (xlim, ylim) in zip(axes[:, 0], rows, boxes):
        L = float(case.bodies[body].length)
        ax.plot([0.0, L], [0.0, 0.0], color="0.6", lw=0.8, ls="--", label="undeformed")
        for s, r in results.items():
            shape = r.extra.get("shapes", {}).get(body)
            if not shape:
                continue
            wide = {"lw": 3.0, "alpha": 0.55, "zorder": 1} if s == reference else {"lw": 1.4, "zorder": 2}
            line, = ax.plot([], [], label=s + " (reference)" * (s == reference), **style(s), **wide)
            lines.append((line, shape, c, factor))
        ax.set_xlim(*xlim)
        ax.set_ylim(*ylim)
        ax.set_aspect("equal")
        ax.grid(alpha=0.3)
        ax.tick_params(labelsize=8)
        ax.set_xlabel("x along the beam [m]", fontsize=8)
        ax.set_ylabel(f"{'xyz'[c]} [m]", fontsize=8)
        shown = f"displacement x {factor:g}" if factor != 1.0 else "displacement to scale"
        ax.set_title(f"{body}, x-{'xyz'[c]} plane of its root-node frame ({shown})", fontsize=9)
        ax.legend(fontsize=8, loc="upper left", frameon=False, ncol=4)
    label = fig.suptitle(f"{case.name}: deformed shape, t = {max(times):.4f} s", fontsize=10)
    fig.canvas.draw()                                   # the layout once, for the widest label:
    fig.set_layout_engine("none")                       # each frame is then drawn once

    def draw(j: int) -> None:
        label.set_text(f"{case.name}: deformed shape, t = {times[j]:.4f} s")
        for line, shape, c, factor in lines:
            k = nearest(shape, times[j], half)
            line.set_data(*(centreline(shape, k, c, factor) if k is not None else ([], [])))

    try:
        with tempfile.TemporaryDirectory(dir=files.make_dir(path.parent), prefix=f".{path.name}.") as tmp:
            made = Path(tmp) / f"animation{path.suffix.lower()}"
            movie = mpl_animation.writers[name](fps=fps)
            with movie.saving(fig, made, dpi=80):
                for j in range(len(times)):
                    draw(j)
                    movie.grab_frame()
            files.atomic_write(path, made.read_bytes())
    except OSError as e:                                # the temporary folder, or the writer's file
        raise files.unusable(path, e) from None
    finally:
        plt.close(fig)
    return len(times)


def animation_path(out: Path, case_name: str) -> Path | None:
    """The animation a case page links, OUT/animations/CASE.gif (or .mp4), where `flexmbd animate`
    writes it by default; None when there is none."""
    return next((p for p in (Path(out) / "animations" / f"{case_name}{x}" for x in WRITERS) if p.is_file()), None)


def section(out: Path, case) -> tuple | None:
    """The case page's section (title, HTML, Markdown) showing the animation `animation_path` finds
    (the page OUT/CASE/index.html links ../animations/CASE.*); None when there is none."""
    path = animation_path(out, case.name)
    if path is None:
        return None
    src = f"../animations/{path.name}"
    shown = (f"<p><img src='{src}' alt='{path.name}'></p>" if path.suffix == ".gif"
             else f"<p><video src='{src}' controls loop></video></p>")
    note = lambda a, b: (f"The deformed shapes of the solvers' runs over time, written by {a}flexmbd animate "
                         f"{case.name} --solvers ...{b} (docs/animation.md): each beam's displacement in its root-node "
                         f"frame, magnified as its title says; it is not redrawn with the report.")
    return ("Animation", shown + f"<p>{note('<code>', '</code>')}</p>",
            f"[{path.name}]({src})\n\n{note('`', '`')}\n\n")


# ---------------------------------------------------------------------------------------------
# the ParaView time series


def beam_mesh(shape: dict, k: int) -> tuple:
    """(points (nx, 3), line cells (nx - 1, 2), displacement (nx, 3)) of a beam's centreline at its
    snapshot k, in its root-node frame (m): the undeformed points (x, 0, 0) moved by their
    displacements."""
    u = np.asarray(shape["u"][k], dtype=float)
    x0 = np.zeros_like(u)
    x0[:, 0] = shape["x"]
    n = len(x0)
    return x0 + u, np.column_stack([np.arange(n - 1), np.arange(1, n)]), u


def solid_cells(faces, vm) -> tuple:
    """(cell blocks [(type, corners)], cell data {"von_mises": [per block]}) of a solid's boundary
    faces (`fields.surface`) with the von Mises stress of each face's element vm (nf,) Pa,
    triangles and quadrilaterals in their own blocks."""
    blocks, data = [], []
    for kind, n in (("triangle", 3), ("quad", 4)):
        rows = [i for i, f in enumerate(faces) if len(f) == n]
        if rows:
            blocks.append((kind, np.array([faces[i] for i in rows], dtype=int)))
            data.append(np.asarray(vm, dtype=float)[rows])
    return blocks, {"von_mises": data}


def meshes(case, result) -> dict:
    """{body: [(t, meshio.Mesh)]}: a run's deformed beams (`beam_mesh`, point data `displacement`)
    and its solids' undeformed surfaces with their stress (`solid_cells`, cell data `von_mises`), at the
    instants its result records them."""
    import meshio
    out = {}
    for body, shape in result.extra.get("shapes", {}).items():
        out[body] = []
        for k, t in enumerate(shape["t"]):
            points, lines, u = beam_mesh(shape, k)
            out[body].append((t, meshio.Mesh(points, [("line", lines)], point_data={"displacement": u})))
    for body, field in result.extra.get("fields", {}).items():
        x, faces = surface(case.bodies[body])          # undeformed, body frame
        out[body] = []
        for t, vm in zip(field["t"], field["vm"]):
            blocks, data = solid_cells(faces, vm)
            out[body].append((t, meshio.Mesh(x, blocks, cell_data=data)))
    return out


def vtk(case, result, folder: Path) -> tuple:
    """Write one run's deformed shapes as a ParaView time series into `folder`: BODY_NNNNN.vtu per
    body and instant (`meshes`: a beam's centreline as line cells with point data `displacement`,
    m; a solid's surface with cell data `von_mises`, Pa) and CASE_SOLVER.pvd listing them by time,
    one part per body. (the .pvd's path, the number of instants)."""
    import meshio
    got = meshes(case, result)
    if not got:
        raise InputError(f"{case.path}: {result.solver}'s run recorded no deformed shape or surface stress (the "
                         f"case has no flexible beam or solid, a frame's shape is not recorded; or the run ended "
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
