"""Accuracy of every solver against the case's reference solver, per channel (stored results only)."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from flexmbd import cases
from flexmbd.harness import channels, metrics
from flexmbd.harness.results import CAUSES, Status

DEFORMATION = ("deflection", *cases.STRESS_KINDS)


def comparable(case, solver_module, channel: str) -> bool:
    """Whether a solver's model has the channel, so that it is compared and graded on it: a rigid
    peer (module attribute RIGID) models no deformation, so neither its deflections and stresses
    (zero) nor, on a case with a flexible body, its energy (no strain energy) are compared; its
    joint angles and reactions are."""
    if not getattr(solver_module, "RIGID", False):
        return True
    kind = case.channels[channel].kind
    flexible = any(getattr(b, "flexible", False) for b in case.bodies.values())
    return kind not in DEFORMATION and not (kind == "energy" and flexible)


def cutoff_hz(case, channel: str, freqs: dict) -> float:
    """Low-pass cutoff separating the slow part of a channel from its vibration: half the lowest
    retained natural frequency of the channel's body (of any flexible body for body-less channels)."""
    body = case.channels[channel].body
    pool = freqs.get(body) if body in freqs else [f for fs in freqs.values() for f in fs]
    pool = [f for f in pool if f > 0]
    return 0.5 * min(pool) if pool else np.nan


def dominant_frequency(t, y, fmin: float) -> float:
    """Frequency of the largest spectral peak above fmin (Hz), NaN if none."""
    pk = metrics.spectral_peaks(t, y, n=1, fmin=fmin)
    return pk[0][0] if pk else np.nan


def ungraded(case) -> str:
    """'' when the case grades its runs, else why not: a case that names no reference solver has
    nothing to compare a run with and no tolerance to hold it to."""
    if case.report.reference is not None:
        return ""
    return ("the case names no reference solver (report.reference) and none of the default references "
            "(cases/README.md, [report]) can run it, so no run is compared and no tolerance applies")


@np.errstate(over="ignore")        # a difference beyond the largest double is inf: a fail, shown as such
def rows(case, results: dict, modules: dict, freqs: dict) -> list[dict]:
    """One row per (solver, channel) compared with the reference. `results`: solver -> Result."""
    ref_name = case.report.reference
    ref = results.get(ref_name)
    if ref is None or not ref.ok:
        return []
    tol = case.report.tolerances
    out = []
    for name, r in results.items():
        if name == ref_name or not r.ok:
            continue
        for ch in case.channels:
            if ch not in r.channels or ch not in ref.channels or not comparable(case, modules.get(name), ch):
                continue
            graded = ref.t >= case.report.graded_from - 1e-12 * max(1.0, case.duration)
            y = metrics.on_grid(ref.t, r.t, r.channels[ch])[graded]
            x = ref.channels[ch][graded]
            k = metrics.channel_norm(case.channels[ch].kind, x,
                                     channels.physical_scale(case, ch, ref.extra.get("kinetic_max_J")))
            row = {"case": case.name, "solver": name, "reference": ref_name, "channel": ch,
                   "label": channels.label(case, ch),
                   "rms": metrics.rms_diff(x, y, k), "max": metrics.max_diff(x, y, k),
                   "peak": metrics.peak_diff(x, y, k),
                   "f_ref": np.nan, "f_solver": np.nan, "envelope": np.nan, "slow": np.nan,
                   "tolerance": tol.get(ch, np.nan)}
            fc = cutoff_hz(case, ch, freqs)
            if case.channels[ch].kind in DEFORMATION and np.isfinite(fc):
                ok = np.isfinite(y)
                tt, xx, yy = ref.t[graded][ok], x[ok], y[ok]
                row["f_ref"] = dominant_frequency(tt, xx, fc)
                row["f_solver"] = dominant_frequency(tt, yy, fc)
                row["envelope"] = metrics.envelope_rms_diff(tt, xx, yy, fc)
                row["slow"] = metrics.slow_rms_diff(tt, xx, yy, fc)
            row["pass"] = "" if np.isnan(row["tolerance"]) else ("pass" if row["rms"] <= row["tolerance"] else "fail")
            out.append(row)
    return out


def number(x, digits: int = 3) -> str:
    """A number with `digits` significant digits, its notation chosen by its magnitude: decimal
    from 1e-3 to 1e5 (0.0378, 12.5, 401, 12345), else scientific (1.27e-6, 2.5e5); trailing
    zeros dropped, 0 as '0', never '0.0' for a value that is not 0. NaN as 'nan', +-inf as 'inf'."""
    x = float(x)
    if not math.isfinite(x):
        return "nan" if math.isnan(x) else ("-inf" if x < 0 else "inf")
    if x == 0:
        return "0"
    m, e = f"{x:.{digits - 1}e}".split("e")           # rounded first: 9.996e-4 is 1.00e-3
    e = int(e)
    if -3 <= e < 5:
        s = f"{x:.{max(digits - 1 - e, 0)}f}"
        return s.rstrip("0").rstrip(".") if "." in s else s
    return f"{m.rstrip('0').rstrip('.') if '.' in m else m}e{e}"


def factor(x: float) -> str:
    """How many times its tolerance a difference is, with two significant digits kept (2.0, 15,
    0.50): 'inf' for an infinite or NaN difference."""
    if not math.isfinite(x):
        return "inf"
    return f"{x:.0f}" if x >= 99.5 else f"{x:#.2g}".rstrip(".")


class Verdict(NamedTuple):
    """One case x solver at a glance: `kind` one of VERDICTS, `text` the one line shown (str()),
    `outside` what an ok run's model exceeded of its linear validity ('' when it stayed within):
    the validity flag, shown beside the verdict, never instead of it."""

    kind: str
    text: str
    outside: str = ""

    def __str__(self) -> str:
        return self.text + (f"; outside linear validity: {self.outside}" if self.outside else "")


# one word per meaning: pass / fail (a channel beyond its tolerance), diverged (the run broke the
# divergence rule or its state went non-finite), aborted (the run stopped for another reason: a
# step size too small, Newton, a solver's error): a failed run's cause (results.CAUSES), not
# applicable, unavailable, and the reference and runs with nothing to compare; "outside validity"
# is a flag beside a verdict (Verdict.outside)
VERDICTS = ("pass", "fail", *CAUSES, "not applicable", "unavailable", "reference", "not compared")


def run_word(status) -> str:
    """The word of a run's Status: ok, diverged or aborted (a failed run: its cause,
    `results.Status.cause`), not applicable, unavailable."""
    return status.cause if status.kind == "failed" else status.kind


def status_text(status) -> str:
    """A run's Status as its one line, with its word (`run_word`): 'diverged: ... at t = 10.58 s';
    'aborted: step size too small at t = 0.2 s'; a why that begins with its word not said twice
    ('diverged (|tip| beyond 16 m, 2 beam lengths) at t = 10.58 s'); an ok run outside its linear
    validity: 'ok, outside linear validity (...)'."""
    text, word = str(status), run_word(status)
    if status.kind != "failed":
        return text
    return text[len("failed: "):] if status.why.startswith(word) else word + text[len(status.kind):]


def verdict(status, solver: str, reference: str, rows_: list[dict]) -> Verdict:
    """The verdict of a solver's run (`status`: its results.Status) from its accuracy rows:
    diverged / aborted / not applicable / unavailable from the status; else fail when a channel's
    RMS difference exceeds its tolerance (the worst one and how many times its tolerance), pass
    when every compared channel is within tolerance; the reference solver is `reference`, a run
    with nothing compared `not compared`. An ok run outside its model's linear validity carries
    that beside its verdict (`Verdict.outside`)."""
    if not status.ok:
        return Verdict(run_word(status), status_text(status))
    outside = status.why if status.outside else ""
    if solver == reference:
        return Verdict("reference", "reference", outside)
    if reference is None:
        return Verdict("not compared", "not compared: the case names no reference solver (report.reference)",
                       outside)
    mine = [r for r in rows_ if r["solver"] == solver and np.isfinite(r["tolerance"])]
    bad = [r for r in mine if not r["rms"] <= r["tolerance"]]
    if bad:
        w = worst_row(rows_, solver)
        more = f" and {len(bad) - 1} more" if len(bad) > 1 else ""
        return Verdict("fail", f"fail: {w['channel']} RMS {number(w['rms'])} = {factor(w['rms'] / w['tolerance'])} "
                               f"× its tolerance {number(w['tolerance'])}{more}", outside)
    if not mine:
        return Verdict("not compared", "not compared: no channel with a tolerance against the reference", outside)
    return Verdict("pass", f"pass: {len(mine)} channel{'s' * (len(mine) != 1)} within tolerance", outside)


class Outcome(NamedTuple):
    """One run of a case as the pages and the command line show it: its `status`, its `verdict`
    (`verdict`), its `worst` normalised RMS difference (`worst`; NaN for the reference), its solve
    wall time `wall_s` (s; NaN for a result that was not run) and the `channel` of its worst
    difference, the one its verdict names ('' when none)."""

    case: str
    solver: str
    status: Status
    verdict: Verdict
    worst: float
    wall_s: float
    channel: str = ""


def summary(verdicts: list) -> str:
    """One line: how many runs of each verdict and how many outside linear validity, e.g.
    '36 runs: 20 pass, 5 fail, 2 diverged (3 outside linear validity)'."""
    counts = [(k, sum(v.kind == k for v in verdicts)) for k in VERDICTS]
    outside = sum(bool(v.outside) for v in verdicts)
    return (f"{len(verdicts)} runs: " + ", ".join(f"{n} {k}" for k, n in counts if n)
            + (f" ({outside} outside linear validity)" if outside else ""))


def worst_row(rows_: list[dict], solver: str) -> dict | None:
    """A solver's worst channel, the one its verdict names: of its graded channels (those with a
    tolerance) the largest RMS difference over its tolerance (a non-finite one first), or, when
    none is graded, the largest normalised RMS difference of every compared channel."""
    mine = [r for r in rows_ if r["solver"] == solver]
    graded = [r for r in mine if np.isfinite(r["tolerance"])]
    if graded:
        return max(graded, key=lambda r: r["rms"] / r["tolerance"] if np.isfinite(r["rms"]) else np.inf)
    finite = [r for r in mine if np.isfinite(r["rms"])]
    return max(finite, key=lambda r: r["rms"]) if finite else None


def worst(rows_: list[dict], solver: str) -> float:
    """The normalised RMS difference of a solver's worst channel (`worst_row`); NaN without one."""
    r = worst_row(rows_, solver)
    return r["rms"] if r is not None else np.nan


def worst_channel(rows_: list[dict], solver: str) -> str:
    """The name of a solver's worst channel (`worst_row`); '' without one."""
    r = worst_row(rows_, solver)
    return r["channel"] if r is not None else ""


def aliased(f: float, fs: float) -> float:
    """The frequency at which a sampled sinusoid of frequency f shows below the Nyquist frequency
    fs / 2: |f - k fs| folded into [0, fs / 2]."""
    r = f % fs
    return min(r, fs - r)


def truncation(fp: float, f_sys) -> str:
    """Why a peak may have no system mode near it: a reduced model's frequencies are upper bounds
    of the full model's (Rayleigh-Ritz), most of all its highest; a peak above all but the highest
    of the modes that move the channel's point (or above all of them) lies where the truncated
    mode set has no counterpart. '' otherwise."""
    higher = np.sort(np.asarray(f_sys)[np.asarray(f_sys) > fp])
    if higher.size > 1:
        return ""
    where = (f"below only the highest of them, {higher[0]:.4g} Hz" if higher.size else "above all of them")
    return (f"; {where}: the retained modes place their highest frequencies too high (Rayleigh-Ritz bound), "
            "so a finer model's mode here has no counterpart")


def peak_table(case, results: dict, modes: dict, output_dt: float, tol: float = 0.02,
               others=()) -> list[dict]:
    """Identified spectral peaks of each deflection channel, each matched to the system modes that
    move its point, `modes[channel]` = [(frequency Hz, label)] (solvers/linearize.py): rows (solver,
    channel, f_identified, mode, f_system, difference). Peaks are sought above half the lowest of
    those modes (below lies the forced, quasi-static response). A peak within `tol` of a mode below
    the Nyquist frequency 1 / (2 dt) is named after it; else one within `tol` of the alias of a mode
    above it is named 'alias of ...'; else one within `tol` of a mode of `others`, channel -> modes
    dicts tried in turn (the finer model's system, the same case with more retained modes: a mode
    the retained set truncates or places too high; the system frozen at instants of the run: a
    swinging system's shifting frequencies) is named after that; else 'none within 2 %', with the
    truncation note (`truncation`) where the peak lies at the top of the retained modes. A peak
    below the channel's noise floor (`metrics.noise_floor`: 1e-6 of its largest magnitude over the
    runs) is not identified, so a run that holds only roundoff in the channel has no rows."""
    fs = 1.0 / output_dt
    out = []
    for ch, chm in modes.items():
        f_sys = np.array([f for f, _ in chm])
        if not f_sys.size:
            continue
        below, above = f_sys <= fs / 2, f_sys > fs / 2
        more = [[(f, lab) for f, lab in other.get(ch, []) if f <= fs / 2] for other in others]
        floor = metrics.noise_floor([r.channels[ch] for r in results.values() if r.ok and ch in r.channels],
                                    channels.physical_scale(case, ch))
        for name, r in results.items():
            if not r.ok or ch not in r.channels or not np.any(r.channels[ch]):
                continue
            for fp, _ in metrics.spectral_peaks(r.t, r.channels[ch], n=8, fmin=0.5 * f_sys.min(), floor=floor):
                row = {"case": case.name, "solver": name, "channel": ch, "f_identified": fp}
                k = int(np.argmin(np.where(below, np.abs(f_sys - fp), np.inf))) if below.any() else 0
                d = fp / f_sys[k] - 1.0
                alias = [(abs(aliased(f, fs) / fp - 1.0), j) for j, f in enumerate(f_sys) if above[j]]
                near = next((m for m in (min(ms, key=lambda m: abs(m[0] - fp)) for ms in more if ms)
                             if abs(fp / m[0] - 1.0) <= tol), None)
                if below.any() and abs(d) <= tol:
                    row.update(mode=chm[k][1], f_system=f_sys[k], difference=d)
                elif alias and min(alias)[0] <= tol:
                    j = min(alias)[1]
                    row.update(mode=f"alias of {chm[j][1]} ({f_sys[j]:.4g} Hz above the Nyquist "
                                    f"frequency {fs / 2:.4g} Hz)", f_system=aliased(f_sys[j], fs),
                               difference=fp / aliased(f_sys[j], fs) - 1.0)
                elif near:
                    row.update(mode=near[1], f_system=near[0], difference=fp / near[0] - 1.0)
                else:
                    row.update(mode=f"none within {tol:.0%} (nearest {chm[k][1]}){truncation(fp, f_sys)}",
                               f_system=f_sys[k], difference=d)
                out.append(row)
    return out
