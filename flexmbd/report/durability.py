"""A case page's Durability section, for a case with a `[durability]` table (docs/durability.md):
per signed stress channel and solver its rainflow count, S_eq, damage and life, and against the
reference the S_eq and damage ratios with the damage ratio the S_eq ratio predicts and the band
the RMS stress difference predicts (`harness.durability.table`); a figure (each solver's
exceedance spectrum on the S-N curve, the damage ratios with their bands); and, beside the page,
the table as CSV and LaTeX and every run's cycles (`cycles/SOLVER.csv`: each cycle's range, mean,
count and the times it starts and ends, so that a peak can be traced back to its time)."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from flexmbd.core.files import atomic_write, make_dir
from flexmbd.harness import durability as fatigue
from flexmbd.harness import registry
from flexmbd.report import tables
from flexmbd.report.accuracy import comparable

HEAD = ["channel", "solver", "cycles", "largest range [MPa]", "S_eq m=3 [MPa]", "S_eq m=5 [MPa]", "damage / repeat",
        "life [repeats]", "life [h]", "S_eq / ref m=3", "S_eq / ref m=5", "damage / ref", "(S_eq / ref)^m",
        "m", "RMS band (1 -/+ e)^m", "S_eq verdict"]
KEYS = ["channel", "solver", "cycles", "largest_MPa", "seq3_MPa", "seq5_MPa", "damage", "life_repeats", "life_h",
        "seq3_ratio", "seq5_ratio", "damage_ratio", "predicted_ratio", "slope"]


def counts(case, ok: dict) -> tuple[fatigue.Settings, list, dict] | None:
    """(settings, rows, cycles) of `harness.durability.table` over the runs in `ok` (solver ->
    Result) that give every counted channel and whose model has it (`accuracy.comparable`: a rigid
    peer's zero stress is never counted); None without a `[durability]` table."""
    st = fatigue.settings(case)
    if st is None:
        return None
    runs = {s: (r.t, r.channels) for s, r in ok.items()
            if all(c in r.channels and np.isfinite(r.channels[c]).all()
                   and comparable(case, registry.module(s), c) for c in st.channels)}
    rows, cyc = fatigue.table(st, runs, case.report.reference)
    return st, rows, cyc


def cells(r: dict) -> list:
    """A row of the table: its numbers (`tables.fmt`), the band, and the verdict with `mixed`'s
    flag: the prediction is not made where the damaging cycles lie on two segments or a cycle lies
    within the tolerance of a cut-off (`harness.durability.relative`)."""
    out = [tables.fmt(r[k]) for k in KEYS]
    if r["mixed"]:
        out[KEYS.index("predicted_ratio")] = "cycles on two segments or at the cut-off"
    band = "" if not np.isfinite(r["band_low"]) else f"{tables.fmt(r['band_low'])} .. {tables.fmt(r['band_high'])}"
    return out + [band, r["verdict"] or "reference"]


def csv_text(rows: list, lead: tuple = ()) -> str:
    """The table as CSV, full precision, a header row of `harness.durability.COLUMNS` with units,
    after the columns `lead` (text)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow([*lead, *(f"{k} [{u}]" if u and u != "1" else k for k, u in fatigue.COLUMNS)])
    for r in rows:
        w.writerow([*(r[k] for k in lead),
                    *("" if isinstance(r[k], float) and not np.isfinite(r[k]) else r[k] for k, _ in fatigue.COLUMNS)])
    return buf.getvalue()


def latex(name: str, reference: str | None, curve: str, source: str, rows: list) -> str:
    """Case `name`'s table as an \\input-able booktabs table (`tables.latex_table`)."""
    keys = ["channel", "solver", "cycles", "seq3_MPa", "seq5_MPa", "damage", "seq3_ratio", "seq5_ratio",
            "damage_ratio", "predicted_ratio"]
    head = ["channel", "solver", "cycles", "$S_3$ [MPa]", "$S_5$ [MPa]", "$D$", "$S_3/S_3^r$", "$S_5/S_5^r$",
            "$D/D^r$", "pred.", "verdict"]
    body = [[tables.tex(str(r[k])) if k in ("channel", "solver") else tables.tex_number(r[k]) for k in keys]
            + [tables.tex(r["verdict"] or "reference")] for r in rows]
    return tables.latex_table(
        f"{tables.tex(name)}: fatigue count against {tables.tex(reference or 'no reference')} "
        f"on {tables.tex(curve)} ({tables.tex(source)}): rainflow cycles per repeat; $S_3$, $S_5$ the "
        "damage-equivalent stress ranges at slopes 3 and 5 (2e6 cycles); $D$ the Palmgren-Miner damage per "
        "repeat; their ratios to the reference's ($^r$); pred.: the damage ratio the ratio of the "
        "damage-equivalent ranges predicts, $(S_m/S_m^r)^m$ at the slope $m$ of the curve's segment that holds "
        "the damaging cycles (-- where they lie on two segments or a cycle lies at the cut-off); the verdict "
        "is on $S_3$ and $S_5$.", f"tab:durability:{name}",
        head, list("ll") + ["r"] * (len(head) - 3) + ["l"], body)


# the report's durability tables (`write_index`): every case's rows, with its case, reference and curve
INDEX_KEYS = ("case", "reference", "curve", "source")


def index_rows(case, got) -> list:
    """A case's rows (`counts`: (settings, rows, cycles), or None) for the report's tables, each
    with the case, its reference and its curve's name and source (`INDEX_KEYS`)."""
    if got is None:
        return []
    st, rows, _ = got
    return [{"case": case.name, "reference": case.report.reference or "", "curve": st.curve.name,
             "source": st.curve.source, **r} for r in rows]


def write_index(stage: Path, rows: list) -> list:
    """reports/durability.csv (every case's rows, full precision, `INDEX_KEYS` first), durability.md
    and durability.tex (one \\input-able table per case, also one to a file: tex/durability_CASE.tex)
    from `index_rows` of every case; nothing when no case counts fatigue. Returns the files written."""
    if not rows:
        return []
    atomic_write(stage / "durability.csv", csv_text(rows, INDEX_KEYS))
    first = {r["case"]: r for r in reversed(rows)}                    # each case's first row
    names = list(dict.fromkeys(r["case"] for r in rows))
    md = [f"## {n}\n\nAgainst {first[n]['reference'] or 'no reference'}, on {first[n]['curve']} "
          f"({first[n]['source']}).\n\n" + tables.markdown(HEAD, [cells(r) for r in rows if r["case"] == n])
          for n in names]
    atomic_write(stage / "durability.md", "# Fatigue count against each case's reference solver\n\n"
                 "Per signed stress channel and solver (docs/durability.md): rainflow cycles per repeat of the "
                 "counted span, the largest range, the damage-equivalent ranges S_eq at m = 3 and 5 (2e6 cycles), "
                 "Palmgren-Miner damage per repeat, life, their ratios to the reference's, the damage ratio the "
                 "S_eq ratio predicts and the band the RMS stress difference predicts; the verdict is on S_eq.\n\n"
                 + "\n".join(md))
    per = {n: latex(n, first[n]["reference"], first[n]["curve"], first[n]["source"],
                    [r for r in rows if r["case"] == n]) for n in names}
    atomic_write(stage / "durability.tex", "% flexmbd durability tables: \\input{durability.tex} into a document "
                 "with booktabs\n\n" + "\n".join(per.values()))
    make_dir(stage / "tex")
    for n, text in per.items():
        atomic_write(stage / "tex" / f"durability_{n}.tex", text)
    return ["durability.csv", "durability.md", "durability.tex"]


def write_cycles(folder: Path, cyc: dict) -> list:
    """Each run's cycle table, cycles/SOLVER.csv beside the page; the file names."""
    make_dir(folder / "cycles")
    names = []
    for solver, rows in cyc.items():
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(["channel", "range [MPa]", "mean [MPa]", "count", "t_start [s]", "t_end [s]"])
        w.writerows([r["channel"], repr(float(r["range_MPa"])), repr(float(r["mean_MPa"])), r["count"],
                     repr(float(r["t_start"])), repr(float(r["t_end"]))] for r in rows)
        atomic_write(folder / "cycles" / f"{solver}.csv", buf.getvalue())
        names.append(f"cycles/{solver}.csv")
    return names


def figure(case, st: fatigue.Settings, rows: list, cyc: dict, path: Path) -> str:
    """Left: the S-N curve and each solver's exceedance spectrum per channel (the cycles per
    repeat whose range is at least S, against S); right: each solver's damage ratio to the
    reference with the band (1 -/+ e)^m its RMS stress difference predicts. Returns the file name."""
    import matplotlib.pyplot as plt

    from flexmbd.report import figures
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2), layout="constrained")
    tops = [r["largest_MPa"] for r in rows if r["largest_MPa"] > 0]
    S = np.geomspace(min(min(tops, default=1.0) * 0.05, min(st.curve.lower[-1] or np.inf, 1e9) * 0.5),
                     max(tops, default=1.0) * 3, 300)
    a.loglog(fatigue.life(st.curve, S), S, "k-", lw=2, label=st.curve.name)
    widths = {s: 3.0 - 1.6 * k / max(len(cyc) - 1, 1) for k, s in enumerate(cyc)}   # wide to thin: overlaps show
    for solver, got in cyc.items():
        for j, ch in enumerate(st.channels):
            rng = np.array([r["range_MPa"] for r in got if r["channel"] == ch])
            n = np.array([r["count"] for r in got if r["channel"] == ch])
            if rng.size:
                order = np.argsort(rng)[::-1]
                look = {**figures.style(solver, among=list(cyc)), "ls": ("-", "--", ":", "-.")[j % 4]}
                a.loglog(np.cumsum(n[order]), rng[order], drawstyle="steps-post", lw=widths[solver],
                         label=f"{solver}: {ch}", **look)
    a.set_ylim(max(tops, default=1.0) * 1e-3, max(tops, default=1.0) * 3)
    a.set_xlabel("cycles (per repeat: exceedance; S-N: to failure)")
    a.set_ylabel("stress range [MPa]")
    a.legend(fontsize=7)
    a.set_title("Exceedance spectra on the S-N curve", fontsize=9)
    graded = [r for r in rows if r["verdict"]]
    x = np.arange(len(graded))
    b.bar(x, [r["damage_ratio"] - 1.0 for r in graded], bottom=1.0, color="C0", label="damage ratio")   # from 1
    for k, r in enumerate(graded):
        b.plot([k, k], [r["band_low"], r["band_high"]], "k-", lw=3, alpha=0.4)
        b.plot(k, r["predicted_ratio"], "r_", ms=14)
    b.axhline(1.0, color="grey", lw=0.8)
    b.margins(y=0.15)
    b.set_xticks(x, [f"{r['solver']}\n{r['channel']}" for r in graded], fontsize=7)
    b.set_ylabel("damage / reference's")
    b.set_title("Damage ratio (bar), from the S_eq ratio (red), RMS band (grey)", fontsize=9)
    return figures.save(fig, path)
