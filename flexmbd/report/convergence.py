"""The convergence section of a case page, from the stored convergence studies of the case.

A case's convergence studies are the study files `convergence/NAME.toml` beside its case file
whose `[study] cases` name it, each with its table `convergence/NAME.parquet` (`make
convergence` runs them: docs/studies.md). Each study varies one discretisation key (the other
keys, if any, hold one value); for each solver and channel the page shows its error against the
key's values, coarse to fine:

    the reference solver      rms_vs_finest     (its own convergence: against its finest point)
    every other solver        rms_vs_reference  (against the case's converged reference)

with the fitted rate b of error ~ x^b (least squares in log-log over the points with an error,
`rate`) and the coarsest value from which every finer point is within the channel's tolerance
(`within`). The tables are read, never recomputed here: their runs' keys and flexmbd version are
in them, and the page says at which flexmbd source they were run.
"""

from __future__ import annotations

import dataclasses
import html
import re
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pandas as pd

from flexmbd.harness import registry
from flexmbd.report import study
from flexmbd.core.errors import InputError
from flexmbd.report import figures, tables

FOLDER = "convergence"      # beside the case file


def studies(case, warn=None) -> list[tuple[str, study.Study, pd.DataFrame | None]]:
    """(name, study, its stored table or None when not run yet) of every convergence study of
    `case`: its reference's first, then flexmbd's, then the other solvers', each by file name. A
    study file or table that cannot be read is said (`warn`) and skipped."""
    found = []
    for f in sorted((Path(case.path).parent / FOLDER).glob("*.toml")):
        try:
            st = study.from_file(f)
        except InputError as e:
            if warn:
                warn(f"warning: {e}")
            continue
        if case.name not in st.cases:
            continue
        table = f.with_suffix(".parquet")
        df = None
        if table.is_file():
            try:
                df = pd.read_parquet(table)
            except (OSError, ValueError) as e:
                if warn:
                    warn(f"warning: {table}: cannot be read ({e})")
        found.append((f.stem, st, df))
    ref = case.report.reference
    return sorted(found, key=lambda x: (0 if ref in x[1].solvers else 1 if "flexmbd" in x[1].solvers else 2, x[0]))


def files(case) -> list[Path]:
    """The files the convergence section of `case` is drawn from (study files and tables), for
    the page's key."""
    folder = Path(case.path).parent / FOLDER
    return sorted(p for p in folder.glob("*") if p.suffix in (".toml", ".parquet")) if folder.is_dir() else []


def varied(st: study.Study) -> str | None:
    """The study's varied key: the one with more than one value (None if not exactly one)."""
    keys = [k for k, vs in st.vary if len(vs) > 1]
    return keys[0] if len(keys) == 1 else None


def rate(x, err) -> float:
    """b of err ~ c x^b, least squares in log-log over the points with a finite, positive error
    (NaN with fewer than two)."""
    x, err = np.asarray(x, dtype=float), np.asarray(err, dtype=float)
    use = np.isfinite(err) & (err > 0) & (x > 0)
    if use.sum() < 2:
        return np.nan
    return float(np.polyfit(np.log(x[use]), np.log(err[use]), 1)[0])


def within(x, err, tol):
    """The first of `x` (coarse to fine) from which every error is finite and <= tol; None if the
    last is not."""
    first = None
    for xi, e in zip(x, err):
        if np.isfinite(e) and e <= tol:
            first = xi if first is None else first
        else:
            first = None
    return first


def own_value(case, key: str):
    """The case's own value of a varied key (the first of tied keys; a solver setting with its
    default), or None when the case does not hold it: read from the resolved case
    (`case.resolved`), each part of the key an entry of one of its tables or a field of one of its
    parts, as the file gives it (`_as_given`)."""
    parts = key.split("+")[0].split(".")
    if parts[0] == "solvers" and len(parts) == 3 and parts[1] in registry.NAMES:
        return registry.settings(case, parts[1]).get(parts[2])
    at = case.resolved
    for p in parts:
        if isinstance(at, Mapping) and p in at:
            at = at[p]
        elif dataclasses.is_dataclass(at) and p in {f.name for f in dataclasses.fields(at)}:
            at = getattr(at, p)
        else:
            return None
    return _as_given(at)


def _as_given(x):
    """A value of the resolved case as the case file gives it: a part it names by reference (a
    body's material) as its name, any other part and a table as a dict, tuples as lists."""
    if dataclasses.is_dataclass(x):
        return x.name if hasattr(x, "name") else {f.name: _as_given(getattr(x, f.name)) for f in dataclasses.fields(x)}
    if isinstance(x, Mapping):
        return {k: _as_given(v) for k, v in x.items()}
    return [_as_given(v) for v in x] if isinstance(x, tuple) else x


def summary(case, st: study.Study, df: pd.DataFrame) -> list[dict]:
    """One row per solver and channel of a study's table: the metric shown, the key's values and
    the errors at them, the fitted rate, the tolerance and `within`. For a solver's own
    convergence (rms_vs_finest) the finest point (0 by construction) is left out."""
    key = varied(st)
    ref = case.report.reference
    out = []
    pts = df[(df["case"] == case.name) & df[key].notna()] if key else df.iloc[0:0]
    for s in dict.fromkeys(pts["solver"]):
        metric = "rms_vs_finest" if s == ref else "rms_vs_reference"
        for ch in case.channels:
            sel = pts[(pts["solver"] == s) & (pts["channel"] == ch) & (pts["metric"] == metric)]
            if sel.empty:
                continue
            x, err = sel[key].to_numpy(), sel["value"].to_numpy(dtype=float)
            if metric == "rms_vs_finest":
                x, err = x[:-1], err[:-1]
            tol = case.report.tolerances.get(ch, np.nan)
            out.append({"solver": s, "channel": ch, "metric": metric, "key": key, "x": list(x), "err": list(err),
                        "rate": rate(x, err), "tolerance": tol,
                        "within": within(x, err, tol) if np.isfinite(tol) else None,
                        "statuses": sorted(set(sel["status"]))})
    return out


def means(case, st: study.Study, df: pd.DataFrame, kind: str = "stress_vm") -> tuple[list, list] | None:
    """(head, rows): the time mean of each `kind` channel at every point of the study, and of the
    reference run once on the case itself when the study has it (its key columns empty); None when
    the case has no such channel."""
    key = varied(st)
    chans = [n for n, c in case.channels.items() if c.kind == kind]
    if not key or not chans:
        return None
    sel = df[(df["case"] == case.name) & (df["metric"] == "mean") & df["channel"].isin(chans)]
    head = ["solver", key] + [f"{c} mean" for c in chans]
    rows = []
    for (s, x), part in sel.groupby(["solver", key], sort=False, dropna=False):
        got = dict(zip(part["channel"], part["value"]))
        rows.append([s, "the case's own setting (reference)" if pd.isna(x) else x] + [got.get(c, np.nan) for c in chans])
    return head, rows


def section(case, d: Path, warn=None) -> tuple[str, str] | None:
    """(html, markdown) of the convergence section of `case`'s page, figures written into `d`;
    None when the case has no convergence study."""
    found = studies(case, warn)
    if not found:
        return None
    h, m = [INTRO], [_plain(INTRO)]
    for name, st, df in found:
        key = varied(st)
        title = f"{name}: {', '.join(st.solvers) or 'report solvers'} against {key or 'several keys'}"
        h.append(f"<h3>{html.escape(title)}</h3>")
        m.append(f"### {title}\n")
        fixed = [f"{k} = {vs[0]}" for k, vs in st.vary if len(vs) == 1]
        about = (f"<p>Study file <code>{FOLDER}/{name}.toml</code>"
                 + (f" (held: {html.escape(', '.join(fixed))})" if fixed else "")
                 + ("; the reference runs once, on the case itself" if st.reference == "base" else "") + ".</p>")
        if df is None or key is None:
            why = "not run yet: `make convergence STUDIES=" + name + "` runs it" if df is None else \
                "it varies more than one key: see its figures in reports/convergence/" + name
            h.append(about + f"<p>{html.escape(why)}.</p>")
            m.append(_plain(about) + f"{why}.\n")
            continue
        made = sorted(set(df["flexmbd"])) if "flexmbd" in df else []
        about += (f"<p>Run with flexmbd {html.escape(', '.join(made))}; each run's key is in the table, so "
                  f"<code>make convergence STUDIES={html.escape(name)}</code> reruns only what the source has "
                  "changed since.</p>") if made else ""
        rows = summary(case, st, df)
        imgs = []
        for metric in dict.fromkeys(r["metric"] for r in rows):
            sel = df[(df["case"] == case.name) & (df["metric"] == metric) & df[key].notna()
                     & df["solver"].isin([r["solver"] for r in rows if r["metric"] == metric])]
            sel = sel[sel["value"].astype(float) > 0]
            if not sel.empty:
                fig = study.figure(sel, case.name, key, metric, case.report.reference)
                imgs.append(figures.save(fig, d / f"convergence_{name}_{metric}.png"))
        seq = df[(df["case"] == case.name) & (df["metric"] == "seq5_MPa") & df[key].notna()]
        seq = seq[seq["value"].astype(float) > 0]
        if not seq.empty:                               # a counted channel's S_eq against the key (docs/durability.md)
            fig = study.figure(seq, case.name, key, "seq5_MPa", case.report.reference)
            once = df[(df["case"] == case.name) & (df["metric"] == "seq5_MPa") & df[key].isna()
                      & (df["solver"] == case.report.reference)]
            for ax, ch in zip(fig.axes, dict.fromkeys(seq["channel"])):   # the reference run once: a line
                v = once[once["channel"] == ch]["value"].astype(float)
                if len(v) and v.iloc[0] > 0:
                    ax.axhline(v.iloc[0], ls=":", color="k", lw=1.0)
                    ax.annotate(f"{case.report.reference}: {v.iloc[0]:.4g}", (0.02, v.iloc[0]), fontsize=7,
                                xycoords=("axes fraction", "data"), va="bottom")
            imgs.append(figures.save(fig, d / f"convergence_{name}_seq5_MPa.png"))
        finest = _fmt_x(study._value(dict(st.vary)[key][-1]))
        head = ["solver", "channel", "error", *[_fmt_x(x) for x in (rows[0]["x"] if rows else [])], "rate b",
                "tolerance", "within tolerance from"]
        body = [[r["solver"], r["channel"], f"vs finest ({finest})" if r["metric"] == "rms_vs_finest" else
                 "vs reference", *r["err"], r["rate"], r["tolerance"], _within_text(r)] for r in rows]
        own = own_value(case, key)
        about += (f"<p>The case's own value: {html.escape(key)} = {html.escape(_fmt_x(own))}.</p>"
                  if own is not None else "")
        h.append(about + "".join(f"<p><img src='{i}' alt='{i}'></p>" for i in imgs) + tables.html_table(head, body))
        m.append(_plain(about) + "".join(f"![{i}]({i})\n\n" for i in imgs) + tables.markdown(head, body))
        mean = means(case, st, df)
        if mean and st.reference == "base":
            h.append("<p>Time mean of the stress channels [Pa] at each point and of the reference:</p>"
                     + tables.html_table(*mean))
            m.append("Time mean of the stress channels [Pa] at each point and of the reference:\n\n"
                     + tables.markdown(*mean))
    return "".join(h), "\n".join(m)


INTRO = ("<p>Each solver's error against its discretisation, coarse to fine: the reference against its "
         "own finest point (rms_vs_finest), every other solver against the reference (rms_vs_reference), "
         "each an RMS difference over the reference's largest magnitude as in the accuracy table. "
         "<i>rate b</i>: the fitted exponent of error ~ x^b (least squares in log-log); "
         "<i>within tolerance from</i>: the coarsest value from which every finer point is within the "
         "channel's tolerance. A channel the case counts for fatigue also has its S_eq at m = 5 against the "
         "same values, the reference's (run once) dotted. The tables are stored beside the case "
         "(<code>convergence/NAME.parquet</code>) "
         "and made by <code>make convergence</code>.</p>")


def _fmt_x(x) -> str:
    return f"{x:g}" if isinstance(x, (int, float, np.integer, np.floating)) else str(x)


def _within_text(r: dict) -> str:
    if not np.isfinite(r["tolerance"]):
        return "no tolerance"
    if r["within"] is None:
        return "not reached" + (" before the finest" if r["metric"] == "rms_vs_finest" else "")
    return _fmt_x(r["within"])


def _plain(text: str) -> str:
    return re.sub(r"<[^>]+>", "", text.replace("</p><p>", "</p>\n\n<p>")).replace("&lt;", "<").replace("&gt;", ">").replace("&amp;", "&") + "\n\n"

