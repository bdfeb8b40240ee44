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


def channel(case, name: str, results: dict, reference: str, path: Path) -> str:
    """Overlay of one channel for every solver, and the magnitude of each solver's difference from
    the reference on a shared log scale (every solver readable, whatever the worst one does)."""
    kind = case["channels"][name]["kind"]
    unit, k = UNITS[kind]
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(9, 5.6), sharex=True, height_ratios=[3, 2])
    ref = results.get(reference)
    floor = None
    for s, r in results.items():
        if name not in r.channels or not len(r.t):
            continue
        extra = {"lw": 2.2, "alpha": 0.6} if s == reference else {"lw": 1.0}
        top.plot(r.t, r.channels[name] * k, label=s, **style(s, len(r.t)), **extra)
        if ref is not None and s != reference and name in ref.channels:
            d = np.abs(metrics.on_grid(ref.t, r.t, r.channels[name]) - ref.channels[name]) * k
            scale = np.nanmax(np.abs(ref.channels[name])) * k
            floor = 1e-9 * scale if scale > 0 else 1e-12
            bottom.semilogy(ref.t, np.maximum(d, floor), lw=1.0, label=f"{s} - {reference}", **style(s, len(ref.t)))
    top.set_title(where(case, name), fontsize=10)
    top.set_ylabel(f"{name} [{unit}]")
    legend(top, fontsize=8, ncol=3)
    top.grid(alpha=0.3)
    bottom.set_ylabel(f"|difference| [{unit}]")
    bottom.set_xlabel("t [s]")
    bottom.grid(alpha=0.3, which="both")
    legend(bottom, fontsize=8, ncol=3)
    fig.tight_layout()
    return save(fig, path)


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
