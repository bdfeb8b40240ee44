"""Error measures between two histories, FFT spectra with interpolated peaks, timing figures.

Comparing undamped vibrations: over many cycles a tiny frequency difference
becomes a large phase difference, so besides RMS differences we report phase-robust measures:
the identified frequencies, the amplitude envelope, and the slow (low-pass) part.
Every measure is normalised by the reference's maximum magnitude unless stated.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import butter, find_peaks, hilbert, sosfiltfilt


def on_grid(t_ref, t, y) -> np.ndarray:
    """y(t) sampled at t_ref (linear interpolation; NaN outside t)."""
    return np.interp(t_ref, t, y, left=np.nan, right=np.nan)


def scale(ref) -> float:
    """Normalisation: the reference's maximum magnitude (1 when it is identically zero)."""
    m = float(np.nanmax(np.abs(ref))) if len(ref) else 0.0
    return m if m > 0 else 1.0


NOISE = 1e-9    # a reference smaller than this fraction of its channel's physical scale is numerical noise


def channel_norm(kind: str, ref, physical: float = 0.0) -> float:
    """What a channel's differences are measured against, in the channel's unit. `physical`: the
    channel's scale in the case (`channels.physical_scale`: for a total energy the case's largest
    kinetic energy, for a deflection its beam's length, ...; 0 when the case has none).

    A total energy, whose level is arbitrary and which a conservative run keeps constant, is
    measured against the case's largest kinetic energy. Any other channel is measured against the
    reference's largest magnitude, but never against less than NOISE times its physical scale: a
    reference that small (a rigid peer's deflection) is roundoff, and measured against itself its
    noise would read as a difference of order one."""
    if kind == "energy" and physical > 0:
        return float(physical)
    m = float(np.nanmax(np.abs(ref))) if len(ref) else 0.0
    m = max(m, NOISE * physical) if kind != "energy" else m
    return m if m > 0 else 1.0


def rms_diff(ref, y, norm: float | None = None) -> float:
    """RMS of y - ref over the common samples, over `norm` (default max |ref|)."""
    d = y - ref
    d = d[np.isfinite(d)]
    return float(np.sqrt(np.mean(d ** 2)) / (norm or scale(ref))) if d.size else np.nan


def max_diff(ref, y, norm: float | None = None) -> float:
    """max |y - ref| over `norm` (default max |ref|)."""
    d = np.abs(y - ref)
    d = d[np.isfinite(d)]
    return float(d.max() / (norm or scale(ref))) if d.size else np.nan


def peak_diff(ref, y, norm: float | None = None) -> float:
    """(max |y| - max |ref|) over `norm` (default max |ref|): how far the extreme value is off."""
    return float((np.nanmax(np.abs(y)) - np.nanmax(np.abs(ref))) / (norm or scale(ref)))


# ---------------------------------------------------------------------------------------------
# spectra


def spectrum(t, y, pad: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """One-sided amplitude spectrum of y (mean removed, Hann window, zero-padded `pad` times).

    Amplitudes are scaled so that a sinusoid of amplitude A shows a peak of height A.
    Returns (frequencies Hz, amplitudes).
    """
    y = np.asarray(y, dtype=float) - np.mean(y)
    n = y.size
    w = np.hanning(n)
    N = int(2 ** np.ceil(np.log2(n * pad)))
    Y = np.fft.rfft(y * w, N)
    dt = (t[-1] - t[0]) / (n - 1)
    return np.fft.rfftfreq(N, dt), 2.0 * np.abs(Y) / w.sum()


def hann_sidelobe(k):
    """Envelope of a Hann window's side lobes, relative to its main peak, k bins (1/T) away."""
    k = np.maximum(np.abs(k), 2.0)
    return 1.0 / (np.pi * k * (k * k - 1.0))


def peaks(f, A, T: float, n: int = 8, rel: float = 1e-3, fmin: float = 0.0, floor: float = 0.0) -> list:
    """The n largest spectral peaks above rel * max(A), above the amplitude `floor` (`noise_floor`)
    and above fmin, as (frequency, amplitude) sorted by frequency, from a Hann-windowed record of
    T seconds (possibly zero-padded).

    With zero padding the window's side lobes are local maxima too, so a peak must stand a main-lobe
    width (2/T) away from every larger peak and above three times the larger peak's side-lobe
    envelope there. Each peak is refined by a parabola through the log-amplitudes of the three
    samples around it, so frequencies are read to a small fraction of the bin width 1/T."""
    df = f[1] - f[0]
    logA = np.log(np.maximum(A, 1e-300))
    if not A.size or A.max() <= floor:
        return []
    idx, _ = find_peaks(A, height=max(rel * A.max(), floor))
    idx = sorted((i for i in idx if f[i] >= fmin and 0 < i < A.size - 1), key=lambda i: -A[i])
    kept = []
    for i in idx:
        if all(abs(f[i] - f[j]) * T > 2.0 and A[i] > 3.0 * A[j] * hann_sidelobe((f[i] - f[j]) * T)
               for j in kept):
            kept.append(i)
        if len(kept) == n:
            break
    found = []
    for i in kept:
        a, b, c = logA[i - 1], logA[i], logA[i + 1]
        den = a - 2 * b + c
        p = 0.5 * (a - c) / den if den != 0 else 0.0
        found.append((f[i] + p * df, float(np.exp(b - 0.25 * (a - c) * p))))
    return sorted(found)


def spectral_peaks(t, y, n: int = 8, fmin: float = 0.0, rel: float = 1e-3, floor: float = 0.0) -> list:
    """Peaks of the amplitude spectrum of y(t) (see `spectrum` and `peaks`)."""
    f, A = spectrum(t, y)
    return peaks(f, A, T=t[-1] - t[0], n=n, rel=rel, fmin=fmin, floor=floor)


FLOOR = 1e-6    # a spectral peak below this fraction of its channel's largest magnitude is not identified


def noise_floor(runs, physical: float = 0.0) -> float:
    """The amplitude below which a channel's spectral peak is not identified, in the channel's
    unit: FLOOR times the channel's largest magnitude over every run of it (`runs`: their
    samples), and never less than NOISE times its physical scale (`channel_norm`: a channel that
    small in every run is roundoff).

    A run's own spectrum cannot tell its noise from its motion: a record of roundoff (a deflection
    of 1e-14 m where the solver models none) has its largest peaks like any other. Against the
    channel's magnitude in the other runs it can: FLOOR is the loosest relative tolerance the
    solvers are run with (Newton's 1e-6 on exudyn-beam's pendulum; flexmbd's rtol is 1e-8), below
    which a vibration is what a solver leaves unresolved rather than what it computes. Margins: the
    smallest peak identified on the shipped cases' stored results is 5.4e-4 of its channel's
    magnitude (slider_crank, 230 Hz), 540 times the floor, and the 1e-14 m record is 1e-11 of
    its channel's 1e-3 m. NOISE times the physical scale (0.3 nm on brick_pendulum's 0.3 m block)
    lies 1300 times below the smallest peak identified there relative to it (0.40 um at 1890 Hz)."""
    big = max((float(np.nanmax(np.abs(y))) for y in runs if len(y) and np.any(np.isfinite(y))), default=0.0)
    return max(FLOOR * big, NOISE * physical)


def match_peaks(found, targets, tol: float = 0.05) -> list:
    """For each target frequency, the nearest identified peak within tol (relative), else None."""
    out = []
    for ft in targets:
        near = [fp for fp, _ in found if abs(fp - ft) <= tol * ft]
        out.append(min(near, key=lambda fp: abs(fp - ft)) if near else None)
    return out


# ---------------------------------------------------------------------------------------------
# phase-robust measures


def lowpass(t, y, cutoff_hz: float) -> np.ndarray:
    """Zero-phase 4th-order Butterworth low-pass (the slow part of a history)."""
    fs = 1.0 / ((t[-1] - t[0]) / (len(t) - 1))
    if cutoff_hz >= 0.5 * fs or len(y) < 30:
        return np.asarray(y, dtype=float)
    sos = butter(4, cutoff_hz, fs=fs, output="sos")
    return sosfiltfilt(sos, y)


def envelope(t, y, cutoff_hz: float) -> np.ndarray:
    """Amplitude envelope of the vibration about the slow part: |analytic signal| of y - lowpass(y),
    itself smoothed below the cutoff."""
    fast = np.asarray(y, dtype=float) - lowpass(t, y, cutoff_hz)
    return lowpass(t, np.abs(hilbert(fast)), cutoff_hz)


def slow_rms_diff(t, ref, y, cutoff_hz: float) -> float:
    """RMS difference of the slow parts, over max |ref|."""
    d = lowpass(t, y, cutoff_hz) - lowpass(t, ref, cutoff_hz)
    return float(np.sqrt(np.mean(d ** 2)) / scale(ref))


def envelope_rms_diff(t, ref, y, cutoff_hz: float) -> float:
    """RMS difference of the amplitude envelopes, over max |ref|."""
    e_ref, e = envelope(t, ref, cutoff_hz), envelope(t, y, cutoff_hz)
    return float(np.sqrt(np.mean((e - e_ref) ** 2)) / scale(ref))


# ---------------------------------------------------------------------------------------------
# timing


def per_simulated_second(wall_s: float, t_end: float) -> float:
    """Wall time per simulated second."""
    return wall_s / t_end if t_end > 0 else np.nan
