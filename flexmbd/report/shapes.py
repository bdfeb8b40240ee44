"""The deformed-shape snapshots of a case page: every solver's shape of each flexible beam at the
case's chosen instants (`report.snapshots`), from the `shapes` its result stores
(`channels.shapes`), one panel per beam, transverse component and instant."""

from __future__ import annotations

from pathlib import Path

from flexmbd.report.figures import held_to, label, save, style
import matplotlib.pyplot as plt  # noqa: E402  (after figures, which chooses the Agg backend)
import numpy as np  # noqa: E402

COLUMNS = 4         # panels per row; more instants wrap onto further rows


def drawn(case, results: dict) -> dict:
    """{beam: {component index: largest |u| over every solver and instant}} of the transverse
    components (y, z) a figure shows: those any solver moves by more than 1e-6 of the largest
    (y alone when nothing moves)."""
    out = {}
    for r in results.values():
        for body, s in r.extra.get("shapes", {}).items():
            u, size = np.abs(np.asarray(s["u"], dtype=float)), out.setdefault(body, {1: 0.0, 2: 0.0})
            for c in size:
                size[c] = max(size[c], float(u[:, :, c].max()))
    for body, size in out.items():
        top = max(size.values())
        out[body] = {c: v for c, v in size.items() if v > 1e-6 * top} or {1: 0.0}
    return {b: out[b] for b in case.bodies if b in out}


def nearest(s: dict, instant: float, half: float) -> int | None:
    """The index of a solver's snapshot within `half` of `instant`, None when it has none."""
    if not s["t"]:
        return None
    i = int(np.argmin(np.abs(np.asarray(s["t"]) - instant)))
    return i if abs(s["t"][i] - instant) <= half else None


def snapshot(case, results: dict, path: Path, reference: str | None = None) -> str | None:
    """Figure of the deformed shapes: for each flexible beam and transverse component, one panel
    per instant of `report.snapshots` with every solver's displacement (mm) against the
    undeformed position along the beam (m), the reference drawn wider and named so; a failed
    run's shapes up to its failure, named with its failure time, within the limits of the runs
    that did not fail. The PNG's file name, or None when no result holds shapes."""
    panels = [(body, c) for body, comps in drawn(case, results).items() for c in comps]
    instants = case.report.snapshots
    if not panels:
        return None
    half = 0.5 * case.integrator.output_dt * (1.0 + 1e-9)
    ncol = min(len(instants), COLUMNS)
    rows_each = -(-len(instants) // ncol)
    fig, axes = plt.subplots(len(panels) * rows_each, ncol, squeeze=False, layout="constrained",
                             figsize=(2.5 * ncol + 0.8, 2.4 * len(panels) * rows_each + 0.8))
    for p, (body, c) in enumerate(panels):
        frame = "chord" if case.bodies[body].modes.boundary == "hinged-hinged" else "root-node"
        for j, instant in enumerate(instants):
            ax = axes[p * rows_each + j // ncol, j % ncol]
            held, failed = [], False                     # the runs that did not fail set a panel's limits
            for s, r in results.items():
                shape = r.extra.get("shapes", {}).get(body)
                k = nearest(shape, instant, half) if shape else None
                if k is None:
                    continue
                wide = {"lw": 2.4, "alpha": 0.55, "zorder": 1} if s == reference else {"lw": 1.0, "zorder": 2}
                u = np.asarray(shape["u"][k])[:, c] * 1e3
                ax.plot(shape["x"], u, label=label(s, r, reference), **style(s, len(shape["x"]), among=results), **wide)
                failed |= r.status.kind == "failed"
                held += [] if r.status.kind == "failed" else [u]
            if failed:
                held_to(ax, held)
            ax.axhline(0.0, color="k", lw=0.5)
            ax.set_title(f"{body}, t = {instant:g} s", fontsize=9)
            ax.grid(alpha=0.3)
            ax.tick_params(labelsize=8)
            if j % ncol == 0:
                ax.set_ylabel(f"u{'xyz'[c]} [mm] ({frame} frame)", fontsize=8)
            if j + ncol >= len(instants):
                ax.set_xlabel("x along the beam [m]", fontsize=8)
        for j in range(len(instants), rows_each * ncol):
            axes[p * rows_each + j // ncol, j % ncol].set_visible(False)
    handles = {}
    for ax in axes.flat:
        for h, lab in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(lab, h)
    fig.suptitle(f"{case.name}: deformed shape at the chosen instants (displacement minus the undeformed position)",
                 fontsize=10)
    if handles:
        fig.legend(handles.values(), handles.keys(), loc="outside lower center", ncol=min(len(handles), 6),
                   fontsize=8, frameon=False)
    return save(fig, path)


def section(case, results: dict, folder: Path, reference: str | None = None) -> tuple | None:
    """The case page's section (title, HTML, Markdown) of the snapshot figure `folder/shapes.png`;
    None when no result holds shapes."""
    img = snapshot(case, results, folder / "shapes.png", reference)
    if img is None:
        return None
    n = case.report.shape_points
    note = (f"Displacement of {n} evenly spaced points along each flexible beam (report.shape_points), in the frame "
            f"of the deformed root node (hinged-hinged modes: of the chord through both ends) minus the undeformed "
            f"position, as the deflection channels measure it, at each solver's output sample nearest to each instant "
            f"(report.snapshots). Each solver tracks its own nodes nearest to those points, and draws them at their "
            f"undeformed positions; a run that ended before an instant has no shape there.")
    return ("Deformed shape at chosen instants", f"<p><img src='{img}' alt='{img}'></p><p>{note}</p>",
            f"![{img}]({img})\n\n{note}\n\n")
