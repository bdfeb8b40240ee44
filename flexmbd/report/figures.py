"""Figures of the report (matplotlib; PNG and SVG, written atomically), one colour and marker per
solver throughout (`looks`), the reference named in every legend, a failed run drawn up to its
failure and named so (`label`), tick labels that carry their whole value (`Plain`: no offset): a
case page's channels, spectra, flexible minus rigid angles and the retained modes of its flexible
bodies; the index's work-precision figure of a benchmark run."""

from __future__ import annotations

import ast
import importlib.util
import re
import warnings
import zlib
from itertools import product
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib import ticker  # noqa: E402

from flexmbd.harness import channels, metrics, registry  # noqa: E402
from flexmbd import cases, version  # noqa: E402
from flexmbd.core.errors import InputError  # noqa: E402
from flexmbd.core.files import atomic_write, user_cache  # noqa: E402

DRAWN = {"m": ("mm", 1e3), "Pa": ("MPa", 1e-6)}     # SI unit (`channels.unit`) -> drawn unit, factor


def drawn_unit(case, name: str) -> tuple[str, float]:
    """(unit, factor from SI) a channel is drawn in: deflections and slides in mm, stresses in MPa."""
    u = channels.unit(case, name)
    return DRAWN.get(u, (u, 1.0))


def declared(name: str, what: str):
    """A built-in solver's module-level literal `what` (its `STYLE`), read from its module's source
    without importing it: a solver's look is the same where its engine is not installed (a page drawn
    from stored results) and costs no engine's import. None when the module declares none."""
    path = registry.BUILT_IN.get(name)
    spec = importlib.util.find_spec(path) if path else None
    source = spec.loader.get_source(path) if spec and spec.loader else None
    for node in ast.parse(source or "").body:
        if isinstance(node, ast.Assign) and [getattr(t, "id", None) for t in node.targets] == [what]:
            return ast.literal_eval(node.value)
    return None


# one colour and marker per solver on every figure and page: each built-in solver's own (the `STYLE`
# its module declares: `color`, `marker`), solid lines
STYLE = {name: (look["color"], look["marker"]) for name in registry.BUILT_IN if (look := declared(name, "STYLE"))}

# any other name (a plug-in, an imported result): one of the (colour, marker, line style) combinations
# of colours none of STYLE's, the colour changing fastest, chosen by a hash of the name (`looks`)
EXTRA_COLOURS = ("#17becf", "#bcbd22", "#393b79", "#843c39", "#637939", "#7b4173", "#e6550d", "#3182bd")
EXTRA_MARKERS = ("X", "*", "h", "d", "p", "8")
EXTRA_LINES = ("--", "-.", ":", (0, (5, 1, 1, 1, 1, 1)))
EXTRA = [(c, m, ls) for ls, m, c in product(EXTRA_LINES, EXTRA_MARKERS, EXTRA_COLOURS)]


def looks(names) -> dict:
    """{name: (colour, marker, line style)} of the solvers drawn on one figure: a registered
    solver's own (STYLE, solid); any other's the EXTRA combination its name hashes to (CRC-32:
    the same in every process), or, when a name sorted before it on the same figure holds that
    one, the next free one (another colour first): never two solvers alike in one figure."""
    out = {s: (*STYLE[s], "-") for s in names if s in STYLE}
    used = set(out.values())
    for s in sorted(set(names) - set(STYLE)):
        k = zlib.crc32(s.encode())
        look = next((EXTRA[(k + i) % len(EXTRA)] for i in range(len(EXTRA)) if EXTRA[(k + i) % len(EXTRA)] not in used),
                    EXTRA[k % len(EXTRA)])                  # more names than combinations: the hashed one
        out[s] = look
        used.add(look)
    return out


def style(solver: str, n: int = 0, among=()) -> dict:
    """Line colour, line style and (when n samples are drawn) marker every n / 12 samples of a
    solver on a figure that also draws the solvers `among` (`looks`)."""
    color, marker, ls = looks({solver, *among})[solver]
    return {"color": color, "ls": ls, "marker": marker, "markevery": max(n // 12, 1), "markersize": 4} if n else \
        {"color": color, "ls": ls}


def label(solver: str, r=None, reference: str | None = None) -> str:
    """A solver's name in a legend: '(reference)' after the reference, and after a failed run its
    cause, the word of its verdict (`results.Status.cause`): '(diverged at t = T s)' (the
    divergence rule's failures: a bound passed, a value not finite) or '(aborted at t = T s)'."""
    marks = ["reference"] if solver == reference else []
    status = getattr(r, "status", None)
    if status is not None and status.kind == "failed":
        marks.append(status.cause + (f" at t = {status.t:.4g} s" if status.t is not None else ""))
    return f"{solver} ({', '.join(marks)})" if marks else solver


def drawable(res: dict) -> dict:
    """The results a case page draws: the ok runs, and the failed ones that kept samples (drawn up
    to their failure)."""
    return {s: r for s, r in res.items() if r.ok or (r.status.kind == "failed" and len(r.t))}


class Plain(ticker.Formatter):
    """Tick labels that each carry their whole value (no offset, no multiplier above the axis):
    fixed-point between 1e-3 and 1e5, else scientific (1.5e-7), with as many digits as tell the
    ticks apart: a near-constant signal's ticks read 40.0601270, 40.0601272."""

    digits = (0, "f")

    def __call__(self, x, pos=None) -> str:
        d, kind = self.digits
        text = f"{x:.{d}{kind}}"
        text = re.sub(r"e([+-])0*(\d)", lambda m: "e" + m.group(1).replace("+", "") + m.group(2), text)
        return "0" if re.fullmatch(r"-?0(\.0*)?(e-?0)?", text) else text

    def format_ticks(self, values) -> list:
        v = np.asarray(values, dtype=float)
        v = v[np.isfinite(v)]
        top = float(np.max(np.abs(v))) if v.size else 0.0
        kind = "f" if top == 0 or 1e-3 <= top < 1e5 else "e"
        steps = np.abs(np.diff(np.unique(v)))
        step = float(steps.min()) if steps.size else top or 1.0
        for d in range(17):                     # the fewest digits that give every tick back to 1e-6 of a step
            if all(abs(float(f"{x:.{d}{kind}}") - x) <= 1e-6 * step for x in v):
                break
        self.digits = (d, kind)
        return [self(x) for x in values]


def plain_ticks(fig) -> None:
    """Every linear axis of the figure whose labels are matplotlib's default (ScalarFormatter)
    labelled by `Plain`: no offset label anywhere in the report."""
    for ax in fig.axes:
        for axis, scale in ((ax.xaxis, ax.get_xscale()), (ax.yaxis, ax.get_yscale())):
            if scale == "linear" and type(axis.get_major_formatter()) is ticker.ScalarFormatter:
                axis.set_major_formatter(Plain())


def held_to(ax, held: list) -> None:
    """Y limits of the axes 5 % beyond the range of the arrays `held` (the runs that did not fail:
    a diverging run leaves the axes rather than flatten the others); unchanged without a finite
    value in them."""
    v = np.concatenate([np.asarray(y, dtype=float).ravel() for y in held]) if held else np.zeros(0)
    v = v[np.isfinite(v)]
    if v.size:
        lo, hi = float(v.min()), float(v.max())
        pad = 0.05 * (hi - lo) or 0.05 * max(abs(lo), abs(hi)) or 1.0
        ax.set_ylim(lo - pad, hi + pad)


SPAN = 1e-6     # the least y span of a history's axes, relative to its largest magnitude


def least_span(ax, values, floor: float = 0.0) -> None:
    """Widen the axes' y limits about their middle to at least SPAN times the largest |value|, and
    at least `floor` (the channel's numerical noise: `metrics.NOISE` times its physical scale), so
    that round-off on a constant signal, or a signal that is only round-off, draws as the straight
    line it is, not as a square wave."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if not v.size:
        return
    lo, hi = ax.get_ylim()
    need = max(SPAN * float(np.max(np.abs(v))), floor)
    if hi - lo < need:
        mid = 0.5 * (lo + hi)
        ax.set_ylim(mid - 0.5 * need, mid + 0.5 * need)


def save(fig, path: Path) -> str:
    """Write the figure atomically (`files.atomic_write`) as PNG, and as SVG beside it; return the
    PNG's file name (pages link relatively). Linear axes get plain tick labels (`plain_ticks`)."""
    plain_ticks(fig)
    try:
        with warnings.catch_warnings():         # drawing: matplotlib's advice (a legend placed slowly over a
            warnings.simplefilter("ignore")     # long history) is no line of the command's on stderr
            atomic_write(path, lambda f: fig.savefig(f, dpi=90, format="png"))
            fig.set_layout_engine("none")       # the SVG keeps the PNG's layout, not computed again
            atomic_write(path.with_suffix(".svg"), lambda f: fig.savefig(f, format="svg"))
    finally:
        plt.close(fig)
    return path.name


def where(case, name: str) -> str:
    """A channel's title: what, on which body, where."""
    c = case.channels[name]
    if c.kind in ("deflection", *cases.STRESS_KINDS):
        comp = f", {c.component}" if c.kind == "deflection" else ""
        if c.where is not None:                     # a solid's stress point
            point = f"({', '.join(f'{v:g}' for v in c.where)}) m"
            at = f"the fibre {point} of the nearest bar" if case.bodies[c.body].is_frame else f"the point {point}"
        else:
            at = f"interface {c.at}" if isinstance(c.at, str) else f"x = {c.at:g} m"
        return f"{case.name}: {name} ({c.kind}{comp}) of {c.body} at {at}"
    if c.kind == "joint_angle":
        what = "position" if channels.unit(case, name) == "m" else "angle"
        return f"{case.name}: {name} ({what} of joint {c.joint})"
    return f"{case.name}: {name} ({c.kind})"


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
    (non-zero) differences (`diffs`: solver -> (t, |difference|)), so that every solver's usual
    level shows, while exact agreement (at t = 0, at crossings) does not stretch the axis; at least
    1e-15 norm (round-off)."""
    medians = [np.median(d[d > 0]) for _, d in diffs.values() if np.any(d > 0)]
    return max(0.01 * min(medians), 1e-15 * norm) if medians else 1e-15 * norm


def differences(curves: dict, reference: str) -> dict:
    """Solver -> (t, |y - y_ref|) on the reference's samples up to the solver's last sample (a
    failed run's differences end where its samples do), of every drawn curve but the reference's;
    {} without a reference curve."""
    ref = curves.get(reference)
    if ref is None:
        return {}
    out = {}
    for s, (t, y) in curves.items():
        inside = ref[0] <= t[-1] + 1e-9 * abs(t[-1])        # the reference's samples within the run's
        if s != reference and inside.any():
            out[s] = (ref[0][inside], np.abs(metrics.on_grid(ref[0][inside], t, y) - ref[1][inside]))
    return out


def channel(case, name: str, results: dict, reference: str, path: Path) -> str:
    """`channel_figure`, saved (`save`)."""
    return save(channel_figure(case, name, results, reference), path)


def channel_figure(case, name: str, results: dict, reference: str):
    """Overlay of one channel for every solver (top), and the magnitude of each solver's difference
    from the reference on a shared log scale (every solver readable, whatever the worst one does);
    without another solver than the reference, the overlay alone. The reference is named so in
    the legend.

    A failed run that kept samples (`drawable`) is drawn up to its failure, named in the legend
    with its failure time (`label`) and marked by a dotted line in its colour at that time; the
    overlay's y limits are those of the runs that did not fail, so that a diverging run leaves the
    axes rather than flatten every other curve. A history holding more than ZOOM_ABOVE (20) periods
    of a visible vibration of the reference (`vibration_hz`: the largest spectral peak at 10
    periods or more, its amplitude at least 2 % of the range) draws as a solid band: a third row
    then shows its first and its last ZOOM_PERIODS (4) periods side by side, shaded on the
    overview. An energy is drawn as its change from t = 0 (each solver's own E(0) removed) and is
    never zoomed. Returns the Figure (`channel` saves it)."""
    kind = case.channels[name].kind
    unit, k = drawn_unit(case, name)
    curves = {s: (np.asarray(r.t, dtype=float), drawn(kind, r.channels[name], k)) for s, r in results.items()
              if name in r.channels and len(r.t)}
    failed = {s: results[s].status for s in curves if results[s].status.kind == "failed"}
    ref = curves.get(reference)
    diffs = differences(curves, reference)
    kinetic = results[reference].extra.get("kinetic_max_J") if ref is not None else None
    physical = channels.physical_scale(case, name, kinetic) * k
    floor = floor_of(diffs, metrics.channel_norm(kind, ref[1], physical) if ref is not None else 1.0)
    noise = metrics.NOISE * physical
    f = vibration_hz(*ref) if ref is not None and kind != "energy" else np.nan
    windows = zoom_windows(ref[0], f) if ref is not None else []
    looks_of = lambda s, n: style(s, n, among=curves)
    line = lambda s, n: {**looks_of(s, n), **({"lw": 2.2, "alpha": 0.6} if s == reference else {"lw": 1.0})}
    name_of = lambda s: label(s, results[s], reference)

    height = (5.6 if diffs else 3.6) + (2.8 if windows else 0.0)
    fig = plt.figure(figsize=(9, height), layout="constrained")
    outer = fig.add_gridspec(2 if windows else 1, 1, height_ratios=[5 if diffs else 3, 2.6] if windows else [1])
    over = outer[0].subgridspec(2 if diffs else 1, 1, height_ratios=[3, 2] if diffs else [1])
    top = fig.add_subplot(over[0])
    bottom = fig.add_subplot(over[1], sharex=top) if diffs else None

    # overview and differences
    for s, (t, y) in curves.items():
        top.plot(t, y, label=name_of(s), **line(s, len(t)))
    for s, (t, d) in diffs.items():
        bottom.semilogy(t, np.maximum(d, floor), lw=1.0, label=f"{s} - {name_of(reference)}", **looks_of(s, len(t)))
    if failed:
        held_to(top, [y for s, (_, y) in curves.items() if s not in failed])
    least_span(top, np.concatenate([y for _, y in curves.values()]) if curves else [], noise)
    for s, status in failed.items():
        for ax in (top, bottom) if bottom else (top,):
            if status.t is not None:
                ax.axvline(status.t, color=looks_of(s, 0)["color"], ls=":", lw=1.0)
    ylabel, title = overview_titles(case, name, unit, reference, kinetic)
    top.set_title(title, fontsize=10)
    top.set_ylabel(ylabel)
    legend(top, fontsize=8, ncol=3)
    top.grid(alpha=0.3)
    if bottom:
        top.tick_params(labelbottom=False)
        bottom.set_ylabel(f"|difference| [{unit}]")
        bottom.set_xlabel("t [s]")
        bottom.grid(alpha=0.3, which="both")
        legend(bottom, fontsize=8, ncol=3)
    else:
        top.set_xlabel("t [s]")

    if windows:
        zoomed(fig, outer[1], windows, curves, line, [top, bottom] if bottom else [top], f, noise, ylabel)
    return fig


def overview_titles(case, name: str, unit: str, reference: str, kinetic) -> tuple[str, str]:
    """(y label, title) of a channel's overview: an energy as its change from t = 0, with the scale
    the accuracy table divides its differences by; any other channel with its unit and place."""
    if case.channels[name].kind != "energy":
        return f"{name} [{unit}]", where(case, name)
    over = f"{reference}'s largest kinetic energy" if kinetic else "the case's gravity energy scale |g| sum m l"
    return ("energy change from t = 0 [J]",
            f"{case.name}: {name}, change of the total energy (kinetic + gravity + strain) from t = 0"
            f"\naccuracy table: differences over {over}, {channels.physical_scale(case, name, kinetic):.3g} J")


def zoomed(fig, cell, windows: list, curves: dict, line, shaded: list, f: float, noise: float, ylabel: str) -> None:
    """The zoom row in `cell` of `fig`: the curves over the first and the last windows (s), each
    shaded on the axes `shaded`; f: the zoomed vibration's frequency (Hz), for the titles."""
    zoom = cell.subgridspec(1, 2)
    for i, ((t0, t1), which) in enumerate(zip(windows, ("first", "last"))):
        ax = fig.add_subplot(zoom[i])
        margin = 0.02 * (t1 - t0)
        for s, (t, y) in curves.items():
            inside = (t >= t0 - margin) & (t <= t1 + margin)
            ax.plot(t[inside], y[inside], **line(s, int(inside.sum())))
        ax.set_xlim(t0, t1)
        for a in shaded:
            a.axvspan(t0, t1, color="0.5", alpha=0.15, lw=0)
        ax.set_title(f"{which} {ZOOM_PERIODS} periods of {f:.3g} Hz (shaded above)", fontsize=9)
        ax.set_xlabel("t [s]")
        ax.grid(alpha=0.3)
        least_span(ax, np.concatenate([y[(t >= t0) & (t <= t1)] for t, y in curves.values()]), noise)
        if i == 0:
            ax.set_ylabel(ylabel)


MODE_TOL = 0.02     # a system mode is drawn on a spectrum when within 2 % of an identified peak


def identified(results: dict, name: str, system_hz) -> list:
    """The identified spectral peaks (Hz) of a channel over every drawn run, as the peak table
    seeks them (`metrics.spectral_peaks`: the 8 largest, above half the lowest system frequency)."""
    fmin = 0.5 * min(system_hz) if len(system_hz) else 0.0
    return sorted(fp for r in results.values() if name in r.channels and len(r.t) >= 16 and np.any(r.channels[name])
                  for fp, _ in metrics.spectral_peaks(r.t, r.channels[name], n=8, fmin=fmin))


def marked(system_hz, peaks, fmax: float, tol: float = MODE_TOL) -> list:
    """The system frequencies a spectrum marks: of those up to fmax, the nearest to each identified
    peak when within tol of it (at most one per peak), sorted."""
    f = np.asarray([x for x in system_hz if x <= fmax], dtype=float)
    if not f.size:
        return []
    nearest = [(float(f[np.argmin(np.abs(f - p))]), p) for p in peaks]
    return sorted({fs for fs, p in nearest if abs(fs / p - 1.0) <= tol})


def spectra(case, name: str, results: dict, system_hz, nyquist: float, path: Path, peaks=None) -> str:
    """`spectra_figure`, saved (`save`)."""
    return save(spectra_figure(case, name, results, system_hz, nyquist, peaks), path)


def spectra_figure(case, name: str, results: dict, system_hz, nyquist: float, peaks=None):
    """Amplitude spectra (Hann window, zero-padded) up to the Nyquist frequency (or 1.15 times the
    highest system frequency below it), with the system frequencies near an identified peak marked
    (dotted, `marked`): `peaks` (Hz), those of the page's peak table, or else the runs' own
    (`identified`). The reference is named in the legend. Returns the Figure, one axes."""
    fig, ax = plt.subplots(figsize=(9, 4), layout="constrained")
    shown = [f for f in system_hz if f <= nyquist]
    fmax = min(nyquist, 1.15 * max(shown)) if shown else nyquist
    drawn_runs = {s: r for s, r in results.items()
                  if name in r.channels and len(r.t) >= 16 and np.any(r.channels[name])}
    for s, r in drawn_runs.items():
        f, A = metrics.spectrum(r.t, r.channels[name])
        keep = (f > 0) & (f <= fmax)
        ax.semilogy(f[keep], np.maximum(A[keep] * 1e3, 1e-9), lw=1.0, label=label(s, r, case.report.reference),
                    **style(s, int(keep.sum()), among=drawn_runs))
    lines = marked(system_hz, identified(drawn_runs, name, system_hz) if peaks is None else peaks, fmax)
    for fs in lines:
        ax.axvline(fs, color="k", ls=":", lw=0.8)
    ax.set_xlabel("frequency [Hz]  (dotted: the system's frequencies near an identified peak, "
                  "linearized about the initial state)")
    ax.set_ylabel(f"|FFT| of {name} [mm]")
    ax.set_title(f"spectrum of {where(case, name)}", fontsize=10)
    ax.grid(alpha=0.3)
    legend(ax, fontsize=8, ncol=3)
    return fig


def angle_channels(case) -> list:
    """The joint_angle channels that are angles (of revolute joints; a slide's is a length)."""
    return [ch for ch, c in case.channels.items() if c.kind == "joint_angle" and channels.unit(case, ch) == "rad"]


def elasticity(case, flexible, rigid, rigid_name: str, path: Path) -> str:
    """Flexible minus rigid joint angles (of revolute joints): what elasticity changes."""
    fig, ax = plt.subplots(figsize=(9, 3.6))
    for ch in angle_channels(case):
        if ch in flexible.channels and ch in rigid.channels:
            d = flexible.channels[ch] - metrics.on_grid(flexible.t, rigid.t, rigid.channels[ch])
            ax.plot(flexible.t, d, lw=1.0, label=f"{ch}: flexmbd - {rigid_name}")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("angle difference [rad]")
    ax.grid(alpha=0.3)
    legend(ax, fontsize=8)
    fig.tight_layout()
    return save(fig, path)


# a flexible body's retained modes: which node values are drawn, and how
SHAPE_LOOK = {"transverse y": {"color": "k", "ls": "-"}, "transverse z": {"color": "#7f7f7f", "ls": "--"},
              "axial x": {"color": "#17becf", "ls": ":"}, "torsion about x": {"color": "#9467bd", "ls": "-."}}


def hermite(x, u, du, points: int = 400) -> tuple[np.ndarray, np.ndarray]:
    """The cubic Hermite interpolation through node values u (N,) with slopes du (N,) at node
    positions x (N,), m: the Euler-Bernoulli element's deflection between its nodes, sampled at
    about `points` places along the beam; (positions, values)."""
    per = max(2, -(-points // (len(x) - 1)))
    s = np.linspace(0.0, 1.0, per, endpoint=False)
    l = np.diff(x)[:, None]
    h = [1 - 3 * s**2 + 2 * s**3, l * (s - 2 * s**2 + s**3), 3 * s**2 - 2 * s**3, l * (s**3 - s**2)]
    U = h[0] * u[:-1, None] + h[1] * du[:-1, None] + h[2] * u[1:, None] + h[3] * du[1:, None]
    return np.append((x[:-1, None] + l * s).ravel(), x[-1]), np.append(U.ravel(), u[-1])


def mode_curves(fb, j: int) -> dict:
    """{component: (positions along the beam (m), values)} drawn of retained mode j of a FlexBody
    (Phi rows [rot x, y, z; trans x, y, z]): the transverse displacements y and z, cubic between
    the nodes (`hermite`, slopes theta_z and -theta_y), and the axial displacement or the torsion
    angle, linear between the nodes, when the mode is led by it (its label); together scaled to a
    largest magnitude of 1 (a torsion mode's angle in rad against its displacements in m: these
    stay near zero)."""
    x, P = np.asarray(fb.x0[:, 0], dtype=float), np.asarray(fb.Phi[:, :, j], dtype=float)
    curves = {"transverse y": hermite(x, P[:, 4], P[:, 2]), "transverse z": hermite(x, P[:, 5], -P[:, 1])}
    label = str(fb.labels[j])
    if label.startswith("axial"):
        curves["axial x"] = (x, P[:, 3])
    if label.startswith("torsion"):
        curves["torsion about x"] = (x, P[:, 0])
    top = max(np.max(np.abs(v)) for _, v in curves.values())
    return {c: (xs, v / top) for c, (xs, v) in curves.items()} if top > 0 else curves


def mode_shapes(fb, title: str, path: Path) -> str:
    """`mode_shapes_figure`, saved (`save`)."""
    return save(mode_shapes_figure(fb, title), path)


def mode_shapes_figure(fb, title: str):
    """One small panel per retained mode of a FlexBody (`mode_curves` along the undeformed beam),
    titled with its number, label and frequency; four to a row. Returns the Figure, with
    one axes per mode."""
    n = fb.n_modes
    cols = min(n, 4)
    rows = -(-n // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(10, 1.2 + 1.7 * rows), sharex=True, sharey=True,
                             squeeze=False, layout="constrained")
    for j, ax in enumerate(axes.flat):
        if j >= n:                                   # the last row's empty places: the ones above show x
            fig.delaxes(ax)
            axes.flat[j - cols].tick_params(labelbottom=True)
            axes.flat[j - cols].set_xlabel(f"x along {fb.name} [m]", fontsize=8.5)
            continue
        if j >= n - cols:
            ax.set_xlabel(f"x along {fb.name} [m]", fontsize=8.5)
        for c, (x, v) in mode_curves(fb, j).items():
            ax.plot(x, v, lw=1.2, label=c, **SHAPE_LOOK[c])
        ax.axhline(0.0, color="0.75", lw=0.6)
        ax.set_title(f"{j + 1}: {fb.labels[j]}, {fb.freq_hz[j]:.4g} Hz", fontsize=8.5)
        ax.set_ylim(-1.15, 1.15)
        ax.grid(alpha=0.3)
        ax.tick_params(labelsize=8)
    handles = {}
    for ax in fig.axes:
        handles.update(zip(*reversed(ax.get_legend_handles_labels())))
    fig.legend(list(handles.values()), list(handles), loc="outside lower center", ncol=len(handles), fontsize=8)
    fig.suptitle(title, fontsize=10)
    fig.supylabel("mode shape, largest value 1", fontsize=9)
    return fig


# work and precision of a benchmark run (`flexmbd bench`)
SCHEME_LOOK = [("-", "o"), ("--", "s"), (":", "^"), ("-.", "D"), ((0, (5, 1, 1, 1)), "v")]


def work_precision(rows: list, path: Path, source: bytes = b"") -> str:
    """`work_precision_figure`, saved (`save`); when `source` (the bytes the rows were read from)
    is given, through the cache of drawn figures (`kept`)."""
    if source:
        return kept(path, source, lambda: work_precision_figure(rows))
    return save(work_precision_figure(rows), path)


def kept(path: Path, source: bytes, figure) -> str:
    """save(figure()) at path, or the PNG and SVG drawn before from the same `source` bytes by this
    module's same code and matplotlib version, copied from the user's cache (`files.user_cache`).
    A cache that cannot be read or written is drawn around: the figure is drawn."""
    key = version.cache_key(source, Path(__file__).read_bytes(), matplotlib.__version__, digits=24)
    stored = user_cache("figures", key + ".png")
    try:
        png, svg = stored.read_bytes(), stored.with_suffix(".svg").read_bytes()
    except OSError:
        name = save(figure(), path)
        try:
            stored.parent.mkdir(parents=True, exist_ok=True)
            atomic_write(stored.with_suffix(".svg"), path.with_suffix(".svg").read_bytes())
            atomic_write(stored, path.read_bytes())         # the PNG last: it says the pair is whole
        except (OSError, InputError):
            pass
        return name
    atomic_write(path, png)
    atomic_write(path.with_suffix(".svg"), svg)
    return path.name


def work_precision_figure(rows: list):
    """Error against solve-only wall time (log-log) of a benchmark's work-precision rows {case,
    solver, scheme, setting, error, wall_s} (`bench.work_precision`): one panel per case, one line
    per (solver, scheme) through its settings in the order they were run, in the solver's colour
    (`style`) with a line style and marker per scheme; settings without a finite error (diverged)
    are left out. Returns the Figure, one axes per case."""
    names = list(dict.fromkeys(r["case"] for r in rows))
    curves = list(dict.fromkeys((r["solver"], r["scheme"]) for r in rows))
    schemes = {}
    for s, scheme in curves:
        schemes.setdefault(s, []).append(scheme)
    fig, axes = plt.subplots(1, len(names), figsize=(max(4.2 * len(names), 6.5), 4.6), squeeze=False,
                             layout="constrained")
    for ax, name in zip(axes[0], names):
        for s, scheme in curves:
            pts = [(r["wall_s"], r["error"]) for r in rows if r["case"] == name and (r["solver"], r["scheme"]) == (s, scheme)
                   and np.isfinite(r["error"]) and r["error"] > 0 and r["wall_s"] > 0]
            ls, marker = SCHEME_LOOK[schemes[s].index(scheme) % len(SCHEME_LOOK)]
            if pts:
                ax.loglog(*zip(*pts), ls=ls, marker=marker, ms=4, lw=1.2, color=style(s, among=schemes)["color"],
                          label=f"{s} ({scheme})")
        ax.set_title(name, fontsize=10)
        ax.set_xlabel("wall time, solve only [s]")
        ax.grid(alpha=0.3, which="both")
    axes[0][0].set_ylabel("deflection error / max |reference|")
    handles = {}
    for ax in fig.axes:
        handles.update(zip(*reversed(ax.get_legend_handles_labels())))
    if handles:
        fig.legend(list(handles.values()), list(handles), loc="outside lower center", ncol=min(len(handles), 5), fontsize=8)
    return fig


def frozen(case, solver: str, sweep: list, fmin: float, fmax: float, path: Path) -> str:
    """The system's frequencies along a run (`report.spectra.frozen_modes`: linearized about the
    run's state at each instant, frozen) against time, from fmin to fmax on a log scale: how far a
    swinging or spun system's vibration frequencies move."""
    fig, ax = plt.subplots(figsize=(9, 4.2))
    for at, modes in sweep:
        fs = [f for f, _ in modes if fmin <= f <= fmax]
        ax.semilogy([at] * len(fs), fs, "k.", ms=3)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("frequency [Hz]")
    ax.set_ylim(fmin, fmax)
    ax.grid(alpha=0.3, which="both")
    ax.set_title(f"{case.name}: the system's frequencies about {solver}'s state at each instant "
                 "(frozen linearization)", fontsize=10)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return save(fig, path)


def frequency_map(values, tracks: list, key: str, path: Path, case: str, peers: dict | None = None,
                  log: bool = True) -> str:
    """A sweep's system frequencies (`linearize.tracked`) against the swept key, a curve per track
    labelled by what leads it at the first value; `peers`: solver -> (n, count) its own lowest
    frequencies at each value, marked over the curves up to the highest track drawn; returns the
    file name."""
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(8, 6.5), layout="constrained")
    for j, t in enumerate(tracks):
        ax.plot(values, t["freq_hz"], "-", lw=1.4, label=f"flexmbd {j + 1}: {t['label']}")
    top = max((np.nanmax(t["freq_hz"]) for t in tracks), default=np.inf)
    for (name, F), mk in zip((peers or {}).items(), "oxs^v"):
        show = F[:, :len(tracks)]
        for r in range(show.shape[1]):
            ax.plot(values, np.where(show[:, r] <= 1.05 * top, show[:, r], np.nan), mk, ms=4, mfc="none", mew=0.9,
                    color=f"C{len(tracks) + list(peers).index(name)}", label=name if r == 0 else None)
    ax.set_xlabel(key)
    ax.set_ylabel("frequency [Hz]")
    if log:
        ax.set_yscale("log")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.12), frameon=False, ncol=1)
    ax.set_title(f"{case}: system modes against {key}, tracked by shape", fontsize=10)
    return save(fig, path)

