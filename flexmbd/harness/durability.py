"""Durability of a stress history: rainflow cycles, S-N curves, mean-stress correction,
Palmgren-Miner damage and the damage-equivalent stress range (docs/durability.md).

The chain is a sequence of free functions on plain arrays::

    c = cycles(s)                                   # Cycles: ranges, means, counts, where (ASTM E1049-85)
    N = life(CURVES["ec3-71"], c.ranges / 1e6)      # cycles to failure at each range, MPa
    D = damage(c, CURVES["ec3-71"], scale=1e-6)     # sum n / N per pass of the history
    S = equivalent_range(c, m=3, scale=1e-6)        # (sum n S^m / N_ref)^(1/m), MPa

Counting is exact: the `rainflow` package implements ASTM E1049-85 without binning and gives
each cycle's first and last sample (binning into classes, as `fatpack` does by default with 64,
moves a range by up to half a class). A history's residue is counted as half cycles, or, for a
duty cycle that repeats (`repeat=True`), closed: the history is taken from its largest reversal
round to it again, so that every residue pairs into whole cycles.

S-N curves are data with their provenance (`CURVES`): N = a S^-m on each segment, ranges in MPa.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import rainflow


@dataclass(frozen=True)
class Cycles:
    """The rainflow cycles of a history, k of them: range and mean (the history's unit), count (1
    a whole cycle, 0.5 a half one) and the samples where each starts and ends."""

    ranges: np.ndarray      # (k,)
    means: np.ndarray       # (k,)
    counts: np.ndarray      # (k,)
    starts: np.ndarray      # (k,) int, sample index
    ends: np.ndarray        # (k,) int


def reversals(s) -> tuple[np.ndarray, np.ndarray]:
    """(indices, values) of the history's turning points, its first and last sample included."""
    got = list(rainflow.reversals(np.asarray(s, dtype=float)))
    return np.array([i for i, _ in got], dtype=int), np.array([x for _, x in got], dtype=float)


def cycles(s, repeat: bool = False) -> Cycles:
    """The rainflow cycles of the history s (n,) (ASTM E1049-85, `rainflow.extract_cycles`). With
    `repeat` the history is a duty cycle that repeats: counted from its largest turning point
    round to it again, so that the residue's half cycles pair into whole ones; the indices are
    then the history's own samples."""
    idx, val = reversals(s)
    if repeat and val.size > 2:
        k = int(np.argmax(val))
        order = np.concatenate([np.arange(k, val.size), np.arange(1 if val[0] == val[-1] else 0, k + 1)])
        idx, val = idx[order], val[order]
    rows = list(rainflow.extract_cycles(val))
    if not rows and val.size == 2 and val[0] != val[1]:        # one rise or fall: a half cycle (the package counts none)
        rows = [(abs(val[1] - val[0]), 0.5 * (val[0] + val[1]), 0.5, 0, 1)]
    if not rows:
        empty = np.zeros(0)
        return Cycles(empty, empty, empty, empty.astype(int), empty.astype(int))
    r, m, n, i, j = (np.array(x) for x in zip(*rows))
    return Cycles(ranges=r.astype(float), means=m.astype(float), counts=n.astype(float),
                  starts=idx[i.astype(int)], ends=idx[j.astype(int)])


@dataclass(frozen=True)
class SNCurve:
    """N = 10^log_a S^-m on each segment, highest stresses first: segment k holds for S down to
    `lower[k]` (MPa); below the last, no damage when `cutoff`, else the last segment goes on."""

    name: str
    source: str
    m: tuple            # slopes, one per segment
    log_a: tuple        # log10 of the constants, S in MPa
    lower: tuple        # each segment's lowest range, MPa
    cutoff: bool

    def knees(self) -> list[tuple[float, float]]:
        """(S, N) where each segment ends (its lowest range and the life there); a last segment
        that goes on has no end."""
        return [(s, 10 ** la * s ** -m) for s, la, m in zip(self.lower, self.log_a, self.m) if s > 0]


def eurocode3(category: float) -> SNCurve:
    """The EN 1993-1-9 (Eurocode 3) curve of detail category `category` (its range at 2e6 cycles,
    MPa): slope 3 to the constant-amplitude limit at 5e6 cycles, slope 5 to the cut-off at 1e8,
    no damage below it (EN 1993-1-9 §7.1, Fig. 7.1)."""
    d = (2.0 / 5.0) ** (1.0 / 3.0) * category              # constant-amplitude fatigue limit, 5e6 cycles
    cut = (5.0 / 100.0) ** (1.0 / 5.0) * d                  # cut-off limit, 1e8 cycles
    return SNCurve(name=f"EC3 detail category {category:g}", source="EN 1993-1-9:2005, 7.1, Figure 7.1",
                   m=(3.0, 5.0), log_a=(np.log10(2e6 * category ** 3), np.log10(5e6 * d ** 5)),
                   lower=(d, cut), cutoff=True)


def eurocode9(category: float, m1: float) -> SNCurve:
    """The EN 1999-1-3 (Eurocode 9, aluminium) curve Delta sigma_C - m1 (its range at 2e6 cycles, MPa,
    and its slope): slope m1 to the constant-amplitude limit at 5e6 cycles, slope m2 = m1 + 2 to
    the cut-off at 1e8, no damage below it (EN 1999-1-3 §6.2.1, Figure 6.1)."""
    m2 = m1 + 2.0
    d = (2.0 / 5.0) ** (1.0 / m1) * category                # constant-amplitude fatigue limit, 5e6 cycles
    cut = (5.0 / 100.0) ** (1.0 / m2) * d                   # cut-off limit, 1e8 cycles
    return SNCurve(name=f"EC9 curve {category:g}-{m1:g}", source="EN 1999-1-3:2007, 6.2.1, Figure 6.1",
                   m=(m1, m2), log_a=(np.log10(2e6 * category ** m1), np.log10(5e6 * d ** m2)),
                   lower=(d, cut), cutoff=True)


def dnv(name: str, m1: float, log_a1: float, log_a2: float, m2: float = 5.0) -> SNCurve:
    """A DNV-RP-C203 curve in air: slope m1 (log a1) to 1e7 cycles, then slope m2 (log a2), which
    goes on (no cut-off in a variable-amplitude history), DNV-RP-C203 (2021) Table 2-1."""
    knee = 10 ** ((log_a1 - 7.0) / m1)                      # the range at 1e7 cycles
    return SNCurve(name=f"DNV {name} in air", source="DNV-RP-C203 (2021), Table 2-1", m=(m1, m2),
                   log_a=(log_a1, log_a2), lower=(knee, 0.0), cutoff=False)


CURVES = {
    "ec3-160": eurocode3(160.0), "ec3-90": eurocode3(90.0), "ec3-71": eurocode3(71.0), "ec3-36": eurocode3(36.0),
    "dnv-b1": dnv("B1", 4.0, 15.117, 17.146), "dnv-c": dnv("C", 3.0, 12.592, 16.320),
    "dnv-d": dnv("D", 3.0, 12.164, 15.606), "dnv-f": dnv("F", 3.0, 11.855, 15.091),
    "ec9-71-7": eurocode9(71.0, 7.0), "ec9-40-4.3": eurocode9(40.0, 4.3),
}


def life(curve: SNCurve, S) -> np.ndarray:
    """Cycles to failure at the ranges S (MPa): the segment holding each range; inf below the
    cut-off (and at S = 0)."""
    S = np.asarray(S, dtype=float)
    N = np.full(S.shape, np.inf)
    upper = np.inf
    for m, la, low in zip(curve.m, curve.log_a, curve.lower):
        here = (S >= low) & (S < upper) & (S > 0)
        N[here] = 10 ** la * S[here] ** -m
        upper = low
    if not curve.cutoff:
        rest = (S < upper) & (S > 0)
        N[rest] = 10 ** curve.log_a[-1] * S[rest] ** -curve.m[-1]
    return N


def goodman(ranges, means, ultimate: float) -> np.ndarray:
    """Ranges corrected for a tensile mean (Goodman): S / (1 - S_m / S_u); a compressive mean is
    not credited (S unchanged). ultimate: the material's ultimate strength, the ranges' unit."""
    m = np.clip(np.asarray(means, dtype=float), 0.0, None)
    return np.asarray(ranges, dtype=float) / (1.0 - m / ultimate)


def walker(ranges, means, gamma: float) -> np.ndarray:
    """Ranges corrected for the mean (Walker): the range at zero mean with the same damage,
    2 S_max^(1 - gamma) (S / 2)^gamma, S_max = S_m + S / 2 (0 when the cycle stays compressive)."""
    S = np.asarray(ranges, dtype=float)
    top = np.clip(np.asarray(means, dtype=float) + S / 2.0, 0.0, None)
    return 2.0 * top ** (1.0 - gamma) * (S / 2.0) ** gamma


def corrected(c: Cycles, correction: str = "none", ultimate: float = np.inf, gamma: float = 0.5) -> np.ndarray:
    """The ranges of c with the mean-stress correction named ("none", "goodman", "walker")."""
    if correction == "goodman":
        return goodman(c.ranges, c.means, ultimate)
    if correction == "walker":
        return walker(c.ranges, c.means, gamma)
    return c.ranges


def damage(c: Cycles, curve: SNCurve, scale: float = 1.0, correction: str = "none", ultimate: float = np.inf,
           gamma: float = 0.5) -> float:
    """Palmgren-Miner damage of one pass of the history: sum n_i / N(S_i), the ranges times
    `scale` in MPa (1e-6 for a history in Pa), corrected for their means as named."""
    S = corrected(c, correction, ultimate, gamma) * scale
    return float(np.sum(c.counts / life(curve, S)))


def equivalent_range(c: Cycles, m: float, n_ref: float = 2e6, scale: float = 1.0) -> float:
    """The damage-equivalent stress range (sum n S^m / n_ref)^(1/m): the constant range that does
    the same damage in n_ref cycles on a single-slope curve of slope m. It scales one to one with
    the stresses, so its ratio between two solvers is their stress error as it reaches the life."""
    return float((np.sum(c.counts * (c.ranges * scale) ** m) / n_ref) ** (1.0 / m))


# ---------------------------------------------------------------------------------------------
# a case's fatigue count (its [durability] table, cases/README.md)

MPA = 1e-6          # the stress channels are in Pa; ranges, S_eq and curves in MPa
SLOPES = (3.0, 5.0)  # the slopes of the damage-equivalent ranges tabulated


@dataclass(frozen=True)
class Settings:
    """A case's `[durability]` table, its curve resolved."""

    channels: tuple
    curve: SNCurve
    correction: str     # "none", "goodman", "walker"
    ultimate: float     # MPa (goodman; inf otherwise)
    gamma: float        # walker
    repeat: bool        # the residue closed as the history repeats (else half cycles)
    discard: float      # s: the start-up left out
    tolerance: float    # on |S_eq / S_eq of the reference - 1|


def check(case) -> None:
    """The case's curve name is one of CURVES (InputError naming the file and key)."""
    dur = case.durability
    if dur is not None and isinstance(dur["curve"], str) and dur["curve"] not in CURVES:
        from flexmbd.core.errors import InputError
        raise InputError(f"{case.path}: durability.curve: unknown curve {dur['curve']!r} (expected one of "
                         f"{', '.join(CURVES)}, or a table m, log_a, lower)")


def settings(case) -> Settings | None:
    """The case's `[durability]` table as Settings (None: the case has none)."""
    check(case)
    dur = case.durability
    if dur is None:
        return None
    c = dur["curve"]
    curve = CURVES[c] if isinstance(c, str) else SNCurve(
        name=c["name"], source="the case file", m=tuple(c["m"]), log_a=tuple(c["log_a"]), lower=tuple(c["lower"]),
        cutoff=c["cutoff"])
    return Settings(channels=tuple(dur["channels"]), curve=curve, correction=dur["correction"],
                    ultimate=np.inf if dur["ultimate"] is None else dur["ultimate"] * MPA, gamma=dur["gamma"],
                    repeat=dur["residue"] == "repeat", discard=dur["discard"], tolerance=dur["tolerance"])


def counted(t, s, st: Settings) -> tuple[Cycles, float]:
    """(the cycles of the history s (n,) Pa at times t (n,) s after the start-up, ranges in MPa
    corrected for the mean as the settings say; the counted span, s: one repeat of the duty cycle)."""
    keep = np.asarray(t) >= st.discard
    tk = np.asarray(t)[keep]
    c = cycles(np.asarray(s)[keep] * MPA, repeat=st.repeat)
    first = int(np.argmax(keep))
    S = corrected(c, st.correction, st.ultimate, st.gamma)
    return Cycles(S, c.means, c.counts, c.starts + first, c.ends + first), float(tk[-1] - tk[0])


def segments_of(curve: SNCurve, S) -> set:
    """The curve's segments (0, 1, ...; len(m): below a cut-off) that hold the ranges S, MPa."""
    upper, out = np.inf, set()
    for k, low in enumerate(curve.lower):
        if np.any((S >= low) & (S < upper)):
            out.add(k)
        upper = low
    if np.any(S < upper):
        out.add(len(curve.m) if curve.cutoff else len(curve.m) - 1)
    return out


def summary(c: Cycles, span: float, curve: SNCurve) -> dict:
    """One history's count: cycles, largest range (MPa), S_eq at SLOPES (MPa), damage per repeat,
    life in repeats and hours."""
    D = float(np.sum(c.counts / life(curve, c.ranges))) if c.counts.size else 0.0
    return {"c": c, "cycles": float(c.counts.sum()), "largest_MPa": float(c.ranges.max()) if c.ranges.size else 0.0,
            **{f"seq{m:g}_MPa": equivalent_range(c, m) for m in SLOPES}, "damage": D,
            "life_repeats": 1.0 / D if D > 0 else np.inf, "life_h": span / D / 3600.0 if D > 0 else np.inf}


def relative(row: dict, ref: dict, curve: SNCurve, rms: float, tolerance: float) -> dict:
    """A solver's count (`summary`, with its Cycles as `c`) against the reference's: S_eq and
    damage ratios; the damage ratio its S_eq ratio predicts, (S_eq / S_eq,ref)^m at the slope m of
    the one segment that holds the damaging cycles of both counts, S_eq over those cycles (the
    cycles below a cut-off, which do no damage in either count, left out); NaN and `mixed` where
    the damaging cycles lie on several segments or a cycle of either count lies within the
    tolerance of the cut-off, where a stress error can move it across and make damage jump; the
    band (1 -/+ rms)^m that the channel's RMS stress difference predicts; and the verdict on S_eq
    at SLOPES."""
    cut = curve.lower[-1] if curve.cutoff else 0.0
    near = lambda c: bool(np.any(np.abs(c.ranges - cut) <= tolerance * cut))        # could cross the cut-off
    hurt = lambda c: Cycles(*(a[c.ranges >= cut] for a in (c.ranges, c.means, c.counts, c.starts, c.ends)))
    mine, theirs = hurt(row["c"]), hurt(ref["c"])                                   # the damaging cycles
    seg = segments_of(curve, mine.ranges) | segments_of(curve, theirs.ranges)
    one = len(seg) == 1 and min(seg) < len(curve.m) and not (near(row["c"]) or near(ref["c"]))
    m = curve.m[min(seg)] if one else curve.m[0]
    ratio = {f"seq{s:g}_ratio": row[f"seq{s:g}_MPa"] / ref[f"seq{s:g}_MPa"] if ref[f"seq{s:g}_MPa"] > 0 else np.nan
             for s in SLOPES}
    s_ref = equivalent_range(theirs, m)
    predicted = (equivalent_range(mine, m) / s_ref) ** m if one and s_ref > 0 else np.nan
    worst = max(abs(v - 1.0) for v in ratio.values())
    return {**ratio, "damage_ratio": row["damage"] / ref["damage"] if ref["damage"] > 0 else np.nan,
            "slope": m, "predicted_ratio": predicted, "mixed": not one, "rms": rms,
            "band_low": max(1.0 - rms, 0.0) ** m, "band_high": (1.0 + rms) ** m,
            "verdict": "pass" if worst <= tolerance else "fail"}


# the columns of a case's durability table (`table`), with their units ("1": a ratio; "" none)
COLUMNS = (("channel", ""), ("solver", ""), ("cycles", "1"), ("largest_MPa", "MPa"), ("seq3_MPa", "MPa"),
           ("seq5_MPa", "MPa"), ("damage", "1"), ("life_repeats", "1"), ("life_h", "h"), ("seq3_ratio", "1"),
           ("seq5_ratio", "1"), ("damage_ratio", "1"), ("slope", "1"), ("predicted_ratio", "1"), ("mixed", ""),
           ("rms", "1"), ("band_low", "1"), ("band_high", "1"), ("verdict", ""))


def rms_difference(t, s, t_ref, s_ref, start: float) -> float:
    """The RMS difference of s from the reference (interpolated to t) over t >= start, over the
    reference's largest magnitude there: the accuracy table's measure on the counted span."""
    keep = np.asarray(t) >= start
    ref = np.interp(np.asarray(t)[keep], t_ref, s_ref)
    top = np.abs(np.asarray(s_ref)[np.asarray(t_ref) >= start]).max()
    return float(np.sqrt(np.mean((np.asarray(s)[keep] - ref) ** 2)) / top) if top > 0 else np.nan


def table(st: Settings, runs: dict, reference: str | None) -> tuple[list, dict]:
    """(rows, cycles): a case's count per channel and solver, and each solver's cycles. runs:
    {solver: (t (n,) s, {channel: (n,) Pa})} of the runs that give the channels; rows: dicts of
    COLUMNS, the ratios against `reference` (NaN, verdict '' for it or without it); cycles:
    {solver: [dicts channel, range_MPa, mean_MPa, count, t_start, t_end]} (the cycle table)."""
    rows, cyc = [], {}
    for name in st.channels:
        counts = {}
        for solver, (t, ch) in runs.items():
            c, span = counted(t, ch[name], st)
            counts[solver] = summary(c, span, st.curve)
            cyc.setdefault(solver, []).extend(
                {"channel": name, "range_MPa": r, "mean_MPa": mu, "count": n, "t_start": t[i], "t_end": t[j]}
                for r, mu, n, i, j in zip(c.ranges, c.means, c.counts, c.starts, c.ends))
        ref = counts.get(reference)
        for solver, row in counts.items():
            rel = {k: np.nan for k, _ in COLUMNS[9:]} | {"mixed": False, "verdict": ""}
            if ref is not None and solver != reference:
                t, ch = runs[solver]
                t_ref, ch_ref = runs[reference]
                rms = rms_difference(t, ch[name], t_ref, ch_ref[name], st.discard)
                rel = relative(row, ref, st.curve, rms, st.tolerance)
            rows.append({"channel": name, "solver": solver, **{k: v for k, v in row.items() if k in dict(COLUMNS)},
                         **rel})
    return rows, cyc
