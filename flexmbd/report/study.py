"""`flexmbd study`: a grid of overrides on one or more cases, run on the executor, and its tidy table
and figures (docs/studies.md).

A study is cases x the product of the varied keys' values (`grid`) x solvers; each grid point is a
set of `--set` overrides, and its results live in OUT/points/ID/results/CASE/SOLVER.{csv,json}
(ID: `point_id`, a digest of the overrides), so a study run again keeps every result already
stored with the key of its run (`executor.into`) and runs only the missing ones. Every point is
loaded and checked before anything runs, and before that, without building the grid, a key varied
twice and a grid beyond the cost limits are refused (`check`).

The table (`table`, OUT/study.parquet) has one row per point, solver, channel and metric
(METRICS), with each varied key as a column, the run's status and its provenance; it holds no
times, so the same study gives the same table, bitwise, wherever it ran (the runs' times are in
OUT/timing.csv). The values of a varied key are listed from coarse to fine: the last point of the
grid is the finest, which the `rms_vs_finest` metric measures each solver against.
"""

from __future__ import annotations

import json
import math
import re
import sys
import tomllib
from dataclasses import dataclass, field
from itertools import product
from pathlib import Path

import numpy as np
import pandas as pd

from flexmbd import version
from flexmbd.harness import channels, cost, metrics, results, registry
from flexmbd.harness import durability as fatigue
from flexmbd.core.errors import InputError
from flexmbd.core.files import atomic_write
from flexmbd.report import loading
from flexmbd.version import __version__

# metric -> what it is (docs/studies.md); the two differences are RMS over the reference's
# largest magnitude (or the channel's physical scale), as the report grades them
METRICS = {"rms_vs_reference": "RMS difference from the case's reference solver at the same point",
           "rms_vs_finest": "RMS difference from the same solver at the finest point (the last of the grid)",
           "max_abs": "largest magnitude over the run", "mean": "time mean", "final": "value at the last instant"}
# and, for a channel the case's [durability] table counts, its fatigue count (docs/durability.md)
FATIGUE = {"seq3_MPa": "damage-equivalent stress range at slope 3 (2e6 cycles), MPa",
           "seq5_MPa": "damage-equivalent stress range at slope 5 (2e6 cycles), MPa",
           "damage": "Palmgren-Miner damage per repeat of the counted span on the case's curve"}
DRAWN = ("rms_vs_reference", "rms_vs_finest", "seq5_MPa")      # metrics drawn against each varied key
LABEL = {"rms_vs_reference": "RMS difference from the reference", "rms_vs_finest": "RMS difference from the finest point",
         "seq5_MPa": "S_eq at m = 5 [MPa]"}


@dataclass(frozen=True)
class Study:
    """What a study runs: case names or paths, the varied keys with their values (override text, in
    the order given: coarse to fine), the solvers (empty: each case's report solvers), and where
    the case's reference solver runs (REFERENCE_AT)."""
    cases: tuple
    vary: tuple                                     # ((dotted key, (value text, ...)), ...)
    solvers: tuple = field(default=())
    reference: str = "each"                         # a key of REFERENCE_AT


# where the reference solver runs -> what that means (docs/studies.md)
REFERENCE_AT = {"each": "at every point, with the point's overrides (the varied keys may change the physics)",
                "base": "once, on the case without the study's overrides (the varied keys are a discretisation "
                        "the reference does not read, e.g. flexmbd's mode count against exudyn-beam)"}


def parse_vary(item: str, where: str = "--vary") -> tuple:
    """'KEY=v1,v2,...' as (KEY, (v1, v2, ...)); a comma inside brackets or quotes stays in its
    value (`gravity=[0,-9.81,0],[0,0,0]`). InputError naming the item when it is not that form."""
    key, sep, text = item.partition("=")
    items, depth, quote, cur = [], 0, "", ""
    for ch in text:
        if quote:
            quote = "" if ch == quote else quote
        elif ch in "\"'":
            quote = ch
        elif ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
        elif ch == "," and depth == 0:
            items.append(cur.strip())
            cur = ""
            continue
        cur += ch
    items.append(cur.strip())
    if not sep or not all(part.strip() for part in key.split("+")) or not all(items):
        raise InputError(f"{where} {item!r}: expected KEY=VALUE1,VALUE2,... or KEY1+KEY2=VALUE1,... "
                         "(e.g. bodies.beam.modes.count=4,8,12)")
    return key.strip(), tuple(items)


def from_file(path: Path) -> Study:
    """The `[study]` table of a TOML file: cases = [...], solvers = [...] (optional), and a `vary`
    table of dotted key -> list of values (TOML values, coarse to fine). InputError naming the
    file and key for anything else."""
    where = str(path)
    try:
        doc = tomllib.loads(Path(path).read_text(encoding="utf-8"))
    except OSError as e:
        raise InputError(f"{where}: cannot be read ({e.strerror or e})") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        raise InputError(f"{where}: not a TOML file ({e})") from None
    st = doc.get("study")
    if not isinstance(st, dict):
        raise InputError(f"{where}: study: expected a [study] table (cases, vary, solvers)")
    unknown = set(st) - {"cases", "vary", "solvers", "reference"}
    if unknown:
        raise InputError(f"{where}: study.{sorted(unknown)[0]}: unknown key (expected cases, vary, solvers, reference)")
    names = st.get("cases")
    if not (isinstance(names, list) and names and all(isinstance(c, str) for c in names)):
        raise InputError(f"{where}: study.cases: expected a list of case names or paths")
    chosen = st.get("solvers", [])
    if not (isinstance(chosen, list) and all(isinstance(s, str) for s in chosen)):
        raise InputError(f"{where}: study.solvers: expected a list of solver names")
    vary = st.get("vary")
    if not (isinstance(vary, dict) and vary):
        raise InputError(f"{where}: study.vary: expected a table of dotted keys, each a list of values")
    flat = dict(_dotted(vary))
    for key, vs in flat.items():
        if not (isinstance(vs, list) and vs):
            raise InputError(f"{where}: study.vary.{key}: expected a list of values")
    at = st.get("reference", "each")
    if at not in REFERENCE_AT:
        raise InputError(f"{where}: study.reference: expected one of {', '.join(map(repr, REFERENCE_AT))}")
    return Study(tuple(names), tuple((k, tuple(_toml(v) for v in vs)) for k, vs in flat.items()), tuple(chosen), at)


def _dotted(table: dict, prefix: str = ""):
    """(dotted key, value) of a nested table down to its non-table values (`a.b = [..]` in TOML
    is nested)."""
    for k, v in table.items():
        if isinstance(v, dict):
            yield from _dotted(v, f"{prefix}{k}.")
        else:
            yield f"{prefix}{k}", v


def _toml(v) -> str:
    """A TOML value as the text of an override (`--set KEY=TEXT`)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(_toml(x) for x in v) + "]"
    return repr(v)


def grid(st: Study) -> list[tuple[str, ...]]:
    """Every point of the study as its overrides ('KEY=VALUE', ...), the last key varying fastest;
    the finest point (every key at its last value) last. A varied key 'K1+K2' sets K1 and K2 to
    the same value (e.g. the mode count of two beams)."""
    return [_overrides(st, combo) for combo in product(*(vs for _, vs in st.vary))]


def _overrides(st: Study, combo) -> tuple[str, ...]:
    """The overrides of the point whose varied keys have the values `combo` (one per key)."""
    return tuple(f"{part}={v}" for (k, _), v in zip(st.vary, combo) for part in k.split("+"))


# ---------------------------------------------------------------------------------------------
# checked before the grid is built

# Measured on this project's 2-core machine, rounded up: loading and checking one point of a case
# (cases.load with its overrides, its solver tables) 0.6-0.7 ms, holding 20-30 kB until the table
# is written; writing the table and timing.csv reads each run's result twice (1.3-1.7 ms a read of
# the cantilever's 2001 samples x 3 columns, 0.05 us more a stored value) and makes its rows
# (7-9 us and 1.2 kB a row: a channel's metric).
POINT_S = 1e-3              # s, a point loaded and checked
POINT_B = 4e4               # bytes, a point held
RUN_S = 4e-3                # s, a run's result read for the table and timing.csv
VALUE_S = 1e-7              # s, a stored value read
ROW_S = 1e-5                # s, a row of the table
ROW_B = 2e3                 # bytes, a row of the table


def check(st: Study, load, where: str, allow_large: bool = False) -> None:
    """Refuse (InputError naming `where`: --vary, or a study file's study.vary) a study that varies
    one key twice, or whose grid is beyond the cost limits (`stages`: README.md, "Cost limits"),
    before any point is built; with `allow_large` such a grid is announced on stderr instead."""
    seen = {}
    for key, _ in st.vary:
        for part in key.split("+"):
            if part in seen:
                tied = f" ({seen[part]} and {key})" if "+" in seen[part] + key else ""
                raise InputError(f"{where}: {part} is varied twice{tied}; give each key once, with all its values")
            seen[part] = key
    for stage in stages(st, load):
        why = cost.excess(stage)
        if why and not allow_large:
            raise InputError(f"{where}: {stage.what} {why}; vary fewer values or pass --allow-large")
        if why:
            print(f"flexmbd: note: {where}: {stage.what} {why}; going on (--allow-large)", file=sys.stderr, flush=True)


def stages(st: Study, load) -> list:
    """The study's own stages (cost.Stage, without progress shown), estimated from the number of
    its points and from its first point of each case (`load(name, overrides)`): loading and
    checking every point, and its table (the runs' results read, their rows)."""
    n = math.prod(len(vs) for _, vs in st.vary)
    first = _overrides(st, [vs[0] for _, vs in st.vary])
    chosen = list(st.solvers) or list(registry.NAMES)
    runs = values = rows = 0
    for name in st.cases:
        case = load(name, first)
        per = n * len(loading.jobs(case, chosen))
        runs += per
        values += per * cost.samples(case, case.duration) * (len(case.channels) + 1)
        rows += per * len(case.channels) * len(METRICS)
    points = n * len(st.cases)
    what = (f"{points:,} points ({' x '.join(str(len(vs)) for _, vs in st.vary)} values"
            f"{f' x {len(st.cases)} cases' if len(st.cases) > 1 else ''})")
    return [cost.Stage(f"loading and checking {what}", "--vary", memory=points * POINT_B, seconds=points * POINT_S),
            cost.Stage(f"writing the table of {runs:,} runs at {what}, {rows:,} rows", "--vary",
                       memory=points * POINT_B + rows * ROW_B, seconds=runs * RUN_S + values * VALUE_S + rows * ROW_S)]


def _same(v, want) -> bool:
    """A table's value of a varied key is the value `want` (a number, a word, or a list such as
    positions along a beam); a missing value is none."""
    if isinstance(want, list) or isinstance(v, (list, tuple, np.ndarray)):
        return isinstance(v, (list, tuple, np.ndarray)) and list(v) == list(want)
    return bool(v == want) if not pd.isna(v) else False


def values(st: Study, overrides) -> dict:
    """The varied keys' values (TOML values) at the point of `overrides` (one of `grid`'s)."""
    given = dict(o.partition("=")[::2] for o in overrides)
    return {k: _value(given[k.split("+")[0]]) for k, _ in st.vary}


def point_id(overrides) -> str:
    """A point's folder name: a digest of its overrides (12 hex digits)."""
    return version.cache_key("\n".join(overrides), digits=12)


def folder(out: Path, overrides) -> Path:
    """The results folder of a point (results.folder of OUT/points/ID)."""
    return results.folder(Path(out) / "points" / point_id(overrides))


def loaded(st: Study, load) -> list:
    """Every (case, its solvers) of the study at every point, loaded and checked (`load(name,
    overrides)`, which raises InputError naming the file and key) before anything runs: one bad
    point stops the study. A case's solvers are the study's (or its report solvers) with its
    reference (`loading.jobs`). With `st.reference == "base"`, a case's reference runs once, on
    the case without overrides (its entry, first of the case's, has `case.overrides == ()`), and
    not at the points unless the study lists it; InputError when a varied key is one of the
    reference's own settings (`registry.REF.*`)."""
    chosen = list(st.solvers) or list(registry.NAMES)
    out = []
    for name in st.cases:
        points = [load(name, over) for over in grid(st)]
        ref = points[0].report.reference
        if st.reference == "base" and ref:
            own = next((k for k, _ in st.vary if k.startswith(f"solvers.{ref}.")), None)
            if own:
                raise InputError(f"study.reference = \"base\": {own} is a setting of {name}'s reference {ref}, "
                                 "which then must run at every point (reference = \"each\")")
            names = loading.jobs(points[0], chosen)
            if ref in names:
                out.append((load(name, ()), [ref]))
                names = [s for s in names if s != ref or s in st.solvers]
            out += [(case, names) for case in points]
        else:
            out += [(case, loading.jobs(case, chosen)) for case in points]
    return out


def reference_once(points: list, name: str):
    """The reference's entry of case `name` in `loaded`'s list when it runs once (no overrides), or None."""
    return next(((c, n) for c, n in points if c.name == name and not c.overrides), None)


# ---------------------------------------------------------------------------------------------
# the table


def table(st: Study, out: Path, points: list) -> pd.DataFrame:
    """The tidy table of a study run into `out`: one row per point, solver, channel and metric
    (METRICS), with the varied keys' values (as their TOML values), the run's status, solver
    version, the run's key and flexmbd's version; sorted, no times (see the module docstring).
    A reference run once (`reference_once`) has its rows too, with the varied keys empty (its
    max_abs, mean and final). `points`: `loaded`'s list."""
    keys = [k for k, _ in st.vary]
    rows = []
    by_case = {}
    for case, names in points:
        if case.overrides:                                  # the grid's points (not a reference run once)
            by_case.setdefault(case.name, []).append((case, names))
    for name, entries in by_case.items():
        finest_case, finest_names = entries[-1]
        finest = {s: _read(out, finest_case, s) for s in finest_names}
        once = reference_once(points, name)
        if once:                                            # the reference run once: its own values, key columns empty
            entries = [once] + entries
        for case, names in entries:
            got = {s: _read(out, case, s) for s in names}
            varied = values(st, case.overrides) if case.overrides else {k: None for k in keys}
            ref = case.report.reference
            ref_r = got[ref] if ref in got else (_read(out, once[0], ref) if once else None)
            for s, r in got.items():
                here = finest.get(s) if case.overrides else None
                for ch in case.channels:
                    base = {"case": case.name, "point": point_id(case.overrides), **varied, "solver": s,
                            "channel": ch, "tolerance": case.report.tolerances.get(ch, np.nan),
                            "status": str(r.status), "solver_version": r.solver_version,
                            "key": r.extra.get("key", ""), "flexmbd": __version__}
                    for metric, v in _metrics(case, ch, r, ref_r if s != ref else None, here).items():
                        rows.append({**base, "metric": metric, "reference": ref if metric == "rms_vs_reference" else
                                     ("finest point" if metric == "rms_vs_finest" else ""), "value": v})
    if not rows:
        return pd.DataFrame()
    df = pd.DataFrame(rows)
    for k in integers(st):                                  # integers stay integers, beside a reference's empty cells
        df[k] = pd.array([row[k] for row in rows], dtype="Int64")
    return df[["case", "point", *keys, "solver", "channel", "metric", "value", "reference", "tolerance", "status",
               "solver_version", "key", "flexmbd"]]


def integers(st: Study) -> list:
    """The varied keys whose every value is an integer (their column: pandas' nullable Int64)."""
    return [k for k, vs in st.vary if all(type(_value(v)) is int for v in vs)]


def _read(out: Path, case, solver: str):
    """The stored result of a point's run, or a Result whose status says why it cannot be used."""
    try:
        return results.read(folder(out, case.overrides), case.name, solver)
    except InputError as e:
        return results.Result(solver=solver, case=case.name, status=results.unavailable(f"{results.UNUSABLE}: {e}"))


def _value(text: str):
    """An override's value as its TOML value (a number, a bool, a string)."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def _metrics(case, ch: str, r, ref, finest) -> dict:
    """METRICS of channel `ch` of the run r, and FATIGUE where the case's [durability] table counts
    it; NaN where the run, its reference or its finest point has no usable value. `ref`: the reference's Result at the same point (None for the reference
    itself); `finest`: the same solver's Result at the finest point."""
    st = fatigue.settings(case)
    counted = st is not None and ch in st.channels
    nan = {m: np.nan for m in (*METRICS, *(FATIGUE if counted else ()))}
    if not r.ok or ch not in r.channels or not len(r.t):
        return nan
    y = np.asarray(r.channels[ch], dtype=float)
    got = {"max_abs": float(np.max(np.abs(y))), "mean": float(np.mean(y)), "final": float(y[-1]),
           "rms_vs_reference": _rms(case, ch, ref, r), "rms_vs_finest": _rms(case, ch, finest, r)}
    if counted and np.isfinite(y).all() and r.t[-1] > st.discard:
        row = fatigue.summary(*fatigue.counted(r.t, y, st), st.curve)
        got |= {m: row[m] for m in FATIGUE}
    return {m: got.get(m, np.nan) for m in nan}


@np.errstate(over="ignore")
def _rms(case, ch: str, ref, r) -> float:
    """The RMS difference of r's channel from ref's on ref's instants, over ref's largest magnitude
    or the channel's physical scale (`metrics.channel_norm`), as the report grades it."""
    if ref is None or not ref.ok or ch not in ref.channels:
        return np.nan
    x = np.asarray(ref.channels[ch], dtype=float)
    y = metrics.on_grid(ref.t, r.t, r.channels[ch])
    k = metrics.channel_norm(case.channels[ch].kind, x, channels.physical_scale(case, ch, ref.extra.get("kinetic_max_J")))
    return float(metrics.rms_diff(x, y, k))


def timing(out: Path, points: list) -> pd.DataFrame:
    """The runs' own times (solve and set-up, s) and steps, one row per point and solver."""
    rows = []
    for case, names in points:
        for s in names:
            r = _read(out, case, s)
            rows.append({"case": case.name, "point": point_id(case.overrides), "overrides": " ".join(case.overrides),
                         "solver": s, "status": str(r.status), "wall_s": r.wall_s, "setup_s": r.setup_s,
                         "steps": r.steps})
    return pd.DataFrame(rows)


def write(st: Study, out: Path, points: list) -> pd.DataFrame:
    """OUT/study.parquet, OUT/timing.csv and the figures (`figures`) of a study whose runs are
    stored in `out`; returns the table."""
    df = table(st, out, points)
    atomic_write(out / "study.parquet", lambda f: df.to_parquet(f, index=False))
    atomic_write(out / "timing.csv", timing(out, points).to_csv(index=False, float_format="%.6g"))
    figures(st, df, out / "figures")
    return df


# ---------------------------------------------------------------------------------------------
# figures


def figures(st: Study, df: pd.DataFrame, where: Path) -> list:
    """For each case, varied key (of two values or more) and metric of DRAWN: one figure, a panel per channel, the metric
    against the key's values with one curve per solver, the other keys at their finest (last)
    values; the channel's tolerance drawn as a dashed line. Returns the file names."""
    from flexmbd.core.files import make_dir
    from flexmbd.report import figures as figs
    if df.empty:
        return []
    make_dir(where)
    keys = [k for k, _ in st.vary]
    finest = {k: _value(vs[-1]) for k, vs in st.vary}
    names = []
    for case in df["case"].unique():
        for key in [k for k, vs in st.vary if len(vs) > 1]:
            others = np.ones(len(df), dtype=bool)
            for k in keys:
                if k != key:
                    others &= df[k].map(lambda v, want=finest[k]: _same(v, want)).to_numpy(dtype=bool)
            for metric in DRAWN:
                sel = df[(df["case"] == case) & (df["metric"] == metric) & others]
                sel = sel[(sel["value"].astype(float) > 0)          # finite: on a log scale (the finest point: 0)
                          & sel[key].notna().to_numpy(dtype=bool)]     # a reference run once has no key (its S_eq)
                if sel.empty:
                    continue
                names.append(figs.save(figure(sel, case, key, metric), where / f"{case}__{key}__{metric}.png"))
    return names


def figure(sel: pd.DataFrame, case: str, key: str, metric: str, reference: str | None = None):
    """One metric of the rows `sel` against `key`: a panel per channel, a curve per solver (the
    `reference` named so in the legend, which stands right of the panels), the channel's tolerance
    dashed (log scales); the key shortened (`short`) and its labels wrapped to their room (`wrap`)."""
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FuncFormatter, LogLocator, NullLocator

    from flexmbd.report import figures as figs
    chans = list(dict.fromkeys(sel["channel"]))
    every = list(dict.fromkeys(sel["solver"]))
    names = [figs.label(s, reference=reference) for s in every] + ["tolerance"]
    panels = max(3.2 * len(chans), 5.0)                             # inches: the panels, then the legend
    width = panels + 0.6 + CHAR_IN * 0.7 * max(map(len, names))     # 8-point
    xlabel = wrap(short(key), int(0.85 * panels / len(chans) / CHAR_IN))
    title = wrap(f"{case}: {metric} against {short(key)}", int(width / CHAR_IN))
    more = LINE_IN * (xlabel.count("\n") + title.count("\n"))
    height = 3.6 + more
    fig, axes = plt.subplots(1, len(chans), figsize=(width, height), squeeze=False)
    fig.subplots_adjust(left=(0.55 + 0.04 * panels) / width, right=0.98 * panels / width, wspace=0.38,   # fixed: quick
                        bottom=(0.72 + LINE_IN * xlabel.count("\n")) / height,
                        top=1 - (0.61 + LINE_IN * title.count("\n")) / height)
    numeric = pd.api.types.is_numeric_dtype(sel[key]) and not pd.api.types.is_bool_dtype(sel[key])
    for ax, ch in zip(axes[0], chans):
        part = sel[sel["channel"] == ch]
        order = list(dict.fromkeys(part[key]))
        for s in dict.fromkeys(part["solver"]):
            pts = part[part["solver"] == s]
            x = pts[key].to_numpy() if numeric else [order.index(v) for v in pts[key]]
            ax.plot(x, pts["value"].to_numpy(dtype=float), lw=1.2, label=figs.label(s, reference=reference),
                    **{**figs.style(s, len(x), among=every), "markevery": 1})
        tol = part["tolerance"].iloc[0] if metric.startswith("rms") else np.nan     # a tolerance is on an RMS difference
        if np.isfinite(tol):
            ax.axhline(tol, ls="--", lw=0.8, color="k", label="tolerance")
        ax.set_yscale("log")
        lo, hi = ax.get_ylim()
        if np.log10(hi / lo) < 1.5:                                     # labels within a decade or so too
            ax.yaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
        ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        ax.yaxis.set_minor_locator(NullLocator())
        if numeric and (part[key] > 0).all():
            ax.set_xscale("log")
        ax.xaxis.set_minor_locator(NullLocator())
        ax.set_xticks(order if numeric else range(len(order)), [f"{v:g}" if numeric else str(v) for v in order])
        ax.set_title(ch, fontsize=10)
        ax.set_xlabel(xlabel)
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel(LABEL[metric], fontsize=9)
    drawn = {lab: h for ax in axes[0] for h, lab in zip(*ax.get_legend_handles_labels())}
    fig.legend([drawn[n] for n in names if n in drawn], [n for n in names if n in drawn], fontsize=8, frameon=False,
               loc="center left", bbox_to_anchor=(panels / width, 0.5))
    fig.suptitle(title, fontsize=10)
    return fig


CHAR_IN = 0.085             # inches: about the width of a character of 10-point text
LINE_IN = 0.17              # inches: a line of 10-point text


def short(key: str) -> str:
    """A varied key as a figure names it: tied keys that differ in one dotted part as that part's
    values in braces ('bodies.{beam1,beam2}.modes.count'); any other as written."""
    parts = [k.split(".") for k in key.split("+")]
    if len(parts) < 2 or len({len(p) for p in parts}) > 1:
        return key
    differ = [i for i in range(len(parts[0])) if len({p[i] for p in parts}) > 1]
    if len(differ) != 1:
        return key
    i = differ[0]
    return ".".join(parts[0][:i] + ["{" + ",".join(p[i] for p in parts) + "}"] + parts[0][i + 1:])


def wrap(text: str, width: int) -> str:
    """`text` in lines of at most `width` characters where it can be broken: after a '.', '+', ','
    or space (a longer piece stays whole)."""
    lines = [""]
    for piece in re.findall(r"[^.+, ]+[.+, ]*|[.+, ]+", text):
        if lines[-1] and len(lines[-1]) + len(piece.rstrip()) > width:
            lines.append("")
        lines[-1] += piece
    return "\n".join(line.rstrip() for line in lines)
