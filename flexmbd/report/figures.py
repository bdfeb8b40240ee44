"""Figures of a case page (matplotlib; PNG and SVG, written atomically), one colour and marker
per solver throughout."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from flexmbd import metrics  # noqa: E402
from flexmbd.files import atomic_write  # noqa: E402

UNITS = {"deflection": ("mm", 1e3), "stress_vm": ("MPa", 1e-6), "joint_angle": ("rad", 1.0),
         "energy": ("J", 1.0), "reaction_force": ("N", 1.0), "reaction_moment": ("N m", 1.0)}


# one colour and marker per solver on every figure and page (plug-ins: from a second palette)
STYLE = {"flexmbd": ("#1f77b4", "o"), "fe-linear": ("#7f7f7f", "s"), "analytic": ("#8c564b", "D"),
         "exudyn-ffrf": ("#ff7f0e", "^"), "exudyn-beam": ("#2ca02c", "v"), "mujoco-rod": ("#d62728", "<"),
         "pinocchio": ("#9467bd", ">"), "mujoco": ("#e377c2", "P")}
EXTRA = [("#17becf", "X"), ("#bcbd22", "*"), ("#393b79", "h"), ("#843c39", "d")]


def style(solver: str, n: int = 0) -> dict:
    """Line colour and marker of a solver (markers every n / 12 samples when n is given)."""
    color, marker = STYLE.get(solver) or EXTRA[sum(map(ord, solver)) % len(EXTRA)]
    return {"color": color, "marker": marker, "markevery": max(n // 12, 1), "markersize": 4} if n else {"color": color}


def save(fig, path: Path) -> str:
    """Write the figure atomically (`files.atomic_write`) as PNG, and as SVG beside it; return the
    PNG's file name (pages link relatively)."""
    try:
        atomic_write(path, lambda f: fig.savefig(f, dpi=90, format="png"))
        atomic_write(path.with_suffix(".svg"), lambda f: fig.savefig(f, format="svg"))
    finally:
        plt.close(fig)
    return path.name


def where(case, name: str) -> str:
    """A channel's title: what, on which body, where."""
    c = case["channels"][name]
    if c["kind"] in ("deflection", "stress_vm") and "body" in c:
        at = f" at x = {c['at']:g} m" if "at" in c else ""
        comp = f", {c['component']}" if c["kind"] == "deflection" else ""
        return f"{case.name}: {name} ({c['kind']}{comp}) of {c['body']}{at}"
    if c["kind"] == "joint_angle":
        return f"{case.name}: {name} (angle of joint {c['joint']})"
    return f"{case.name}: {name} ({c['kind']})"


def legend(ax, **kw) -> None:
    """The axes' legend, when anything drawn carries a label."""
    if ax.get_legend_handles_labels()[0]:
        ax.legend(**kw)


# long vibrating histories: the first and the last few periods drawn again, side by side
ZOOM_ABOVE = 20       # periods of a visible vibration over the history beyond which it is zoomed
ZOOM_PERIODS = 4      # periods in each zoom window
VISIBLE = 0.02        # a vibration is visible when its amplitude is this share of the history's range


def vibration_hz(t, y) -> float:
    """Frequency (Hz) of the largest peak of y's amplitude spectrum (`metrics.spectrum`) at 10
    periods or more over the record (slower motion never draws as a band); NaN when that peak's
    amplitude is under VISIBLE times the range of y: no visible vibration."""
    t, y = np.asarray(t, dtype=float), np.asarray(y, dtype=float)
    if len(t) < 16 or not np.all(np.isfinite(y)) or np.ptp(y) == 0:
        return np.nan
    f, A = metrics.spectrum(t, y)
    A = np.where(f >= 10.0 / (t[-1] - t[0]), A, 0.0)
    k = int(np.argmax(A))
    return float(f[k]) if A[k] >= VISIBLE * np.ptp(y) else np.nan


def zoom_windows(t, f: float) -> list:
    """[(t0, t1) of the first ZOOM_PERIODS periods of a vibration of f Hz, (t0, t1) of the last]
    over the samples t (s), when they span more than ZOOM_ABOVE of its periods; [] otherwise
    (f NaN: no vibration)."""
    if not f * (t[-1] - t[0]) > ZOOM_ABOVE:
        return []
    w = ZOOM_PERIODS / f
    return [(float(t[0]), float(t[0] + w)), (float(t[-1] - w), float(t[-1]))]


def drawn(kind: str, y, k: float) -> np.ndarray:
    """What a channel's figure draws of a history y (n,): y times k (the figure's unit); a total
    energy as its change from the start, E(t) - E(0), the same for any datum of potential energy."""
    y = np.asarray(y, dtype=float) * k
    return y - y[0] if kind == "energy" and len(y) else y


def floor_of(diffs: dict, norm: float) -> float:
    """Lower clip of the |difference| panel: a hundredth of the smallest of the solvers' median
    (non-zero) differences, so that every solver's usual level shows, while exact agreement (at
    t = 0, at crossings) does not stretch the axis; at least 1e-15 norm (round-off)."""
    medians = [np.median(d[d > 0]) for d in diffs.values() if np.any(d > 0)]
    return max(0.01 * min(medians), 1e-15 * norm) if medians else 1e-15 * norm


def channel(case, name: str, results: dict, reference: str, path: Path) -> str:
    """`channel_figure`, saved (`save`)."""
    return save(channel_figure(case, name, results, reference), path)


def channel_figure(case, name: str, results: dict, reference: str):
    """Overlay of one channel for every solver (top), and the magnitude of each solver's difference
    from the reference on a shared log scale (every solver readable, whatever the worst one does).

    A history holding more than ZOOM_ABOVE (20) periods of a visible vibration of the reference
    (`vibration_hz`: the largest spectral peak at 10 periods or more, its amplitude at least 2 % of
    the range) draws as a solid band: a third row then shows its first and its last ZOOM_PERIODS (4)
    periods side by side, shaded on the overview. An energy is drawn as its change from t = 0 (each
    solver's own E(0) removed) and is never zoomed. Returns the Figure (`channel` saves it)."""
    kind = case["channels"][name]["kind"]
    unit, k = UNITS[kind]
    curves = {s: (np.asarray(r.t, dtype=float), drawn(kind, r.channels[name], k)) for s, r in results.items()
              if name in r.channels and len(r.t)}
    ref = curves.get(reference)
    diffs = {s: np.abs(metrics.on_grid(ref[0], t, y) - ref[1]) for s, (t, y) in curves.items()
             if ref is not None and s != reference}
    kinetic = results[reference].extra.get("kinetic_max_J") if ref is not None else None
    floor = floor_of(diffs, metrics.channel_norm(kind, ref[1], kinetic) * k if ref is not None else 1.0)
    f = vibration_hz(*ref) if ref is not None and kind != "energy" else np.nan
    windows = zoom_windows(ref[0], f) if ref is not None else []
    line = lambda s, n: {**style(s, n), **({"lw": 2.2, "alpha": 0.6} if s == reference else {"lw": 1.0})}

    fig = plt.figure(figsize=(9, 8.4 if windows else 5.6), layout="constrained")
    outer = fig.add_gridspec(2 if windows else 1, 1, height_ratios=[5, 2.6] if windows else [1])
    over = outer[0].subgridspec(2, 1, height_ratios=[3, 2])
    top = fig.add_subplot(over[0])
    bottom = fig.add_subplot(over[1], sharex=top)

    # overview and differences
    for s, (t, y) in curves.items():
        top.plot(t, y, label=s, **line(s, len(t)))
    for s, d in diffs.items():
        bottom.semilogy(ref[0], np.maximum(d, floor), lw=1.0, label=f"{s} - {reference}", **style(s, len(ref[0])))
    if kind == "energy":
        ylabel = "energy change from t = 0 [J]"
        title = f"{case.name}: {name}, change of the total energy (kinetic + gravity + strain) from t = 0"
        if kinetic:
            title += (f"\naccuracy table: differences over {reference}'s largest kinetic energy, "
                      f"{kinetic:.3g} J")
    else:
        ylabel, title = f"{name} [{unit}]", where(case, name)
    top.set_title(title, fontsize=10)
    top.set_ylabel(ylabel)
    top.tick_params(labelbottom=False)
    legend(top, fontsize=8, ncol=3)
    top.grid(alpha=0.3)
    bottom.set_ylabel(f"|difference| [{unit}]")
    bottom.set_xlabel("t [s]")
    bottom.grid(alpha=0.3, which="both")
    legend(bottom, fontsize=8, ncol=3)

    # zoom windows: the first and the last periods, shaded on the overview
    zoom = outer[1].subgridspec(1, 2) if windows else None
    for i, ((t0, t1), which) in enumerate(zip(windows, ("first", "last"))):
        ax = fig.add_subplot(zoom[i])
        margin = 0.02 * (t1 - t0)
        for s, (t, y) in curves.items():
            inside = (t >= t0 - margin) & (t <= t1 + margin)
            ax.plot(t[inside], y[inside], **line(s, int(inside.sum())))
        ax.set_xlim(t0, t1)
        for a in (top, bottom):
            a.axvspan(t0, t1, color="0.5", alpha=0.15, lw=0)
        ax.set_title(f"{which} {ZOOM_PERIODS} periods of {f:.3g} Hz (shaded above)", fontsize=9)
        ax.set_xlabel("t [s]")
        ax.grid(alpha=0.3)
        if i == 0:
            ax.set_ylabel(ylabel)
    return fig


def spectra(case, name: str, results: dict, system_hz, nyquist: float, path: Path) -> str:
    """Amplitude spectra (Hann window, zero-padded) up to the Nyquist frequency, with the system's
    frequencies marked (dotted)."""
    fig, ax = plt.subplots(figsize=(9, 4))
    shown = [f for f in system_hz if f <= nyquist]
    fmax = min(nyquist, 1.15 * max(shown)) if shown else nyquist
    for s, r in results.items():
        if name not in r.channels or len(r.t) < 16 or not np.any(r.channels[name]):
            continue
        f, A = metrics.spectrum(r.t, r.channels[name])
        keep = (f > 0) & (f <= fmax)
        ax.semilogy(f[keep], np.maximum(A[keep] * 1e3, 1e-9), lw=1.0, label=s, **style(s))
    for fs in shown:
        ax.axvline(fs, color="k", ls=":", lw=0.8)
    ax.set_xlabel("frequency [Hz]  (dotted: the system's frequencies, linearized about the initial state)")
    ax.set_ylabel(f"|FFT| of {name} [mm]")
    ax.set_title(f"spectrum of {where(case, name)}", fontsize=10)
    ax.grid(alpha=0.3)
    legend(ax, fontsize=8, ncol=3)
    fig.tight_layout()
    return save(fig, path)


def elasticity(case, flexible, rigid, rigid_name: str, path: Path) -> str:
    """Flexible minus rigid joint angles: what elasticity changes."""
    fig, ax = plt.subplots(figsize=(9, 3.6))
    for ch, c in case["channels"].items():
        if c["kind"] == "joint_angle" and ch in flexible.channels and ch in rigid.channels:
            d = flexible.channels[ch] - metrics.on_grid(flexible.t, rigid.t, rigid.channels[ch])
            ax.plot(flexible.t, d, lw=1.0, label=f"{ch}: flexmbd - {rigid_name}")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("angle difference [rad]")
    ax.grid(alpha=0.3)
    legend(ax, fontsize=8)
    fig.tight_layout()
    return save(fig, path)
