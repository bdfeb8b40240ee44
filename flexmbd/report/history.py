"""History: what each report judged and each benchmark run measured, kept per machine and commit
(as asv keeps its results), and the page of how they moved across commits.

    OUT/history/MACHINE/COMMIT.json         a report's record: every case x solver it judged
                                            (status, verdict, each channel's RMS difference and
                                            tolerance, the worst over its tolerance, wall time)
    OUT/history/MACHINE/COMMIT-bench.json   a `flexmbd bench` run written to OUT/bench
    benchmarks/history/DATE[THHMM]_COMMIT[_NOTE].json   the project's stored bench runs, read in place
                                            (machine PROJECT, commit from the file name)
    OUT/history.html, history.md            the page; its figures and key in OUT/history-page/

MACHINE is the host name and a digest of the CPU model and core count (`machine`). COMMIT is the
short commit of flexmbd's source tree, `+dirty` when the code or the cases have uncommitted
changes (`results.git_commit`); outside a git checkout, flexmbd's version and the first 12 hex
digits of its source's SHA-256 (`commit`). A later report at the same commit on the same machine
replaces the entries of the runs it judged and keeps the others.

Commits are ordered by git's topology where git knows them, the others by the time they were
first recorded (`order`). The page is a function of the records alone: it is drawn again only
when they (or flexmbd's source) changed (`history_page_key`).
"""

from __future__ import annotations

import datetime
import html
import json
import math
import os
import platform
import re
import socket
import subprocess
from pathlib import Path

import matplotlib.pyplot as plt
from matplotlib.ticker import FuncFormatter

from flexmbd.core import files, resources
from flexmbd.harness import results, registry
from flexmbd import version
from flexmbd.core.errors import InputError
from flexmbd.report import accuracy, figures, pages, tables
from flexmbd.report.pages import seconds
from flexmbd.version import __version__

FOLDER = "history"              # in OUT: MACHINE/COMMIT.json, MACHINE/COMMIT-bench.json
PAGE = "history-page"           # in OUT: the page's figures and its key (page.json)
BENCH = "-bench.json"           # the name ending of a bench record
PROJECT = "project machine"     # the machine of the stored runs in benchmarks/history
NAME = re.compile(r"[A-Za-z0-9][\w.-]*")            # a machine name or commit id: a safe file name
LINES = ["-", "--", ":", "-."]                     # one line style per machine


def folder(out) -> Path:
    """Where the records of report folder `out` live: OUT/history."""
    return Path(out) / FOLDER


# ---------------------------------------------------------------------------------------------
# this machine and this commit


def machine() -> dict:
    """This machine: {name, hostname, cpu, cores, memory_gb, os, python}; name is the host name and
    six hex digits of the SHA-256 of the CPU model and core count, stable across reports."""
    cpu = cpu_model()
    host = re.sub(r"[^\w.-]", "-", socket.gethostname() or "host").lstrip(".-_") or "host"
    digest = version.cache_key(f"{cpu}|{os.cpu_count()}", digits=6)
    try:
        memory = round(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30, 1)
    except (ValueError, OSError, AttributeError):
        memory = None
    return {"name": f"{host}-{digest}", "hostname": socket.gethostname(), "cpu": cpu, "cores": os.cpu_count(),
            "memory_gb": memory, "os": platform.platform(), "python": platform.python_version()}


def cpu_model() -> str:
    """The CPU's model name (/proc/cpuinfo on Linux), else what `platform` says."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.partition(":")[2].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"


def commit() -> dict:
    """The commit of flexmbd's source: {id, dirty, date, subject} from git (`results.git_commit`:
    dirty when flexmbd/, cases/ or pyproject.toml have uncommitted changes; date and subject '' when
    git cannot say); outside a git checkout {id: VERSION-SOURCE12, dirty: False, version, source}."""
    rev, _, dirty = results.git_commit().partition("+")
    if not rev:
        source = registry.source_sha256()
        return {"id": f"{__version__}-{source[:12]}", "dirty": False, "date": "", "subject": "",
                "version": __version__, "source": source}
    date, _, subject = git("log", "-1", "--format=%cI%x1f%s", rev).partition("\x1f")
    return {"id": rev, "dirty": dirty == "dirty", "date": date, "subject": subject}


def git(*args) -> str:
    """What git says (stdout, stripped) about the source checkout; '' when it cannot or there is
    none (an installed package: `resources.CHECKOUT`)."""
    if resources.CHECKOUT is None:
        return ""
    try:
        done = subprocess.run(["git", *args], cwd=resources.CHECKOUT, capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return ""
    return done.stdout.strip() if done.returncode == 0 else ""


def label(rec: dict) -> str:
    """A record's commit as the page names it and its file is named: the id, `+dirty` appended."""
    return rec["commit"]["id"] + ("+dirty" if rec["commit"].get("dirty") else "")


def now() -> str:
    return datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")


# ---------------------------------------------------------------------------------------------
# writing records


def entry(o, rows: list) -> dict:
    """One judged run (`o`: accuracy.Outcome) with its accuracy rows `rows` (report.accuracy.rows
    of its case): status and verdict kinds, each compared channel's RMS difference and tolerance,
    the worst channel's RMS difference over its tolerance (None: no channel with a tolerance; inf
    stored as None with a fail verdict), the worst RMS difference and the solve wall time [s]."""
    mine = [r for r in rows if r["case"] == o.case and r["solver"] == o.solver]
    over = [r["rms"] / r["tolerance"] for r in mine if number(r["tolerance"]) and r["tolerance"] > 0]
    return {"case": o.case, "solver": o.solver, "status": o.status.kind, "outside": bool(o.status.outside),
            "verdict": o.verdict.kind, "text": o.verdict.text,
            "worst_over_tolerance": max(over) if over else None, "worst_rms": o.worst, "wall_s": o.wall_s,
            "channels": {r["channel"]: {"rms": r["rms"], "tolerance": r["tolerance"]} for r in mine}}


def record(out, runs: list, rows: list) -> Path:
    """Write this report's record, OUT/history/MACHINE/COMMIT.json (`runs`: accuracy.Outcome,
    `rows`: the accuracy rows): machine, commit, the time, one entry per run. The runs of an
    earlier record at the same commit and machine that this report did not judge are kept; a record
    whose entries are unchanged is left as it is (its page need not be drawn again)."""
    rec = {"machine": machine(), "commit": commit(), "recorded": now(), "runs": [entry(o, rows) for o in runs]}
    path = folder(out) / rec["machine"]["name"] / f"{label(rec)}.json"
    try:
        old = read(path) if path.exists() else None
    except InputError:                                  # unreadable: replaced
        old = None
    if old:
        judged = {(e["case"], e["solver"]) for e in rec["runs"]}
        rec["runs"] = [e for e in old["runs"] if (e["case"], e["solver"]) not in judged] + rec["runs"]
        if dumps({**rec, "recorded": old["recorded"]}) == dumps(old):
            return path
    return files.atomic_write(path, dumps(rec))


def keep_bench(out, result: dict) -> Path:
    """Keep a `flexmbd bench` result (`bench.run`) as OUT/history/MACHINE/COMMIT-bench.json."""
    rec = {"machine": machine(), "commit": commit(), "recorded": now(), "bench": result}
    return files.atomic_write(folder(out) / rec["machine"]["name"] / f"{label(rec)}{BENCH}", dumps(rec))


def dumps(rec: dict) -> str:
    """A record as JSON text, NaN and inf as null."""
    return files.json_text(rec, indent=1) + "\n"


def number(v) -> bool:
    """Whether v is a finite number (not a bool)."""
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


# ---------------------------------------------------------------------------------------------
# reading records


def read(path) -> dict:
    """A record file, checked (`problem`); an InputError naming it when it is not one."""
    path = Path(path)
    try:
        rec = json.loads(path.read_text())
    except OSError as e:
        raise files.unusable(path, e, "history record") from None
    except ValueError as e:
        raise InputError(f"{path}: not a history record: not JSON ({e})") from None
    why = problem(rec, path.name.endswith(BENCH))
    if why:
        raise InputError(f"{path}: not a history record: {why}")
    return rec


def problem(rec, bench: bool) -> str:
    """What keeps `rec` from being a record (a bench record with `bench`), '' when nothing does."""
    if not isinstance(rec, dict):
        return "not a JSON object"
    m, c = rec.get("machine"), rec.get("commit")
    if not (isinstance(m, dict) and isinstance(m.get("name"), str) and NAME.fullmatch(m["name"])):
        return "machine.name missing or not a plain name"
    if not (isinstance(c, dict) and isinstance(c.get("id"), str) and NAME.fullmatch(c["id"])
            and isinstance(c.get("dirty", False), bool)):
        return "commit.id missing or not a plain name, or commit.dirty not true or false"
    if seconds(rec.get("recorded")) is None:
        return "recorded is not an ISO date and time"
    if bench:
        return "" if isinstance(rec.get("bench"), dict) else "bench is not an object"
    runs = rec.get("runs")
    if not isinstance(runs, list):
        return "runs is not a list"
    for k, e in enumerate(runs):
        if not (isinstance(e, dict) and all(isinstance(e.get(key), str) for key in ("case", "solver", "verdict"))):
            return f"runs[{k}] lacks a case, solver or verdict"
        bad = [key for key in ("worst_over_tolerance", "wall_s") if not (e.get(key) is None or number(e[key]))]
        if bad:
            return f"runs[{k}].{bad[0]} is not a number"
    return ""


def records(out, warn=None) -> list[dict]:
    """Every record under OUT/history (MACHINE/*.json), each with its file as `file`; a file that
    is not one is an InputError naming it, or with `warn` passed over (`warn` is told)."""
    got = []
    for path in sorted(folder(out).glob("*/*.json")):
        try:
            got.append({**read(path), "file": str(path)})
        except InputError as e:
            if warn is None:
                raise
            warn(f"warning: {e} (left out of the history page)")
    return got


def stored_bench(where: Path | None, warn=None) -> list[dict]:
    """The project's stored bench runs (benchmarks/history/DATE[THHMM]_COMMIT[_NOTE].json, oldest
    first: `pages.bench_runs`; where None: an installed package, which has none) as bench records
    of machine PROJECT, their commit from the file name, recorded at its date and time; a file that
    cannot be read is passed over (`warn` is told)."""
    got = []
    for path in pages.bench_runs(where):
        date, _, rest = path.stem.partition("_")
        rev = rest.split("_")[0]
        try:
            run = json.loads(path.read_text())
            if not (isinstance(run, dict) and NAME.fullmatch(rev) and seconds(date) is not None):
                raise ValueError("not DATE[THHMM]_COMMIT[_NOTE].json holding a JSON object")
        except (OSError, ValueError) as e:
            if warn:
                warn(f"warning: {path}: benchmark run left out of the history page: {e}")
            continue
        got.append({"machine": {"name": PROJECT}, "commit": {"id": rev, "dirty": False}, "recorded": date,
                    "bench": run, "file": str(path)})
    return got


def add(out, sources) -> int:
    """Bring the records of other report folders or history folders (`sources`: each DIR/history
    or DIR holding MACHINE/*.json) into OUT/history; every file is checked before any is copied, and
    one recorded later than its namesake here replaces it. The number of records copied."""
    incoming = []
    for source in map(Path, sources):
        src = source / FOLDER if (source / FOLDER).is_dir() else source
        if not src.is_dir():
            raise InputError(f"{source}: --add: no such folder")
        found = [read(p) for p in sorted(src.glob("*/*.json"))]
        if not found:
            raise InputError(f"{source}: --add: no history records (MACHINE/COMMIT.json) in it")
        incoming += found
    copied = 0
    for rec in incoming:
        path = folder(out) / rec["machine"]["name"] / (label(rec) + (BENCH if "bench" in rec else ".json"))
        try:
            here = read(path) if path.exists() else None
        except InputError:
            here = None
        if here is None or seconds(rec["recorded"]) > seconds(here["recorded"]):
            files.atomic_write(path, dumps(rec))
            copied += 1
    return copied


# ---------------------------------------------------------------------------------------------
# the order of commits


def topology() -> list[tuple]:
    """Every commit git knows (all refs), oldest first in topological order: (full hash, commit
    time [s since the epoch], date (ISO), subject); [] outside a git checkout."""
    lines = git("log", "--all", "--topo-order", "--reverse", "--format=%H%x1f%ct%x1f%cI%x1f%s").splitlines()
    return [(h, float(t), date, subject) for h, t, date, subject in (line.split("\x1f", 3) for line in lines)]


def found(ids, known: list) -> dict:
    """Each of the commit ids `ids` (short hashes) that git knows -> its position in `known`
    (`topology()`)."""
    lengths = {len(c) for c in ids}
    where = {}
    for k, (sha, *_) in enumerate(known):
        for n in lengths:
            where.setdefault(sha[:n], k)
    return {c: where[c] for c in ids if c in where}


def order(first: dict, known: list) -> list[str]:
    """Commit labels (`first`: label -> the time it was first recorded [s]), oldest first: those git
    knows (`known`: `topology()`) in its topological order, the others merged in by their first
    record time against the known ones' commit times; a dirty label right after its commit."""
    ids = {lab.removesuffix("+dirty") for lab in first}
    when = {c: min(t for lab, t in first.items() if lab.removesuffix("+dirty") == c) for c in ids}
    at = found(ids, known)
    rest = sorted((c for c in ids if c not in at), key=lambda c: (when[c], c))
    merged = []
    for c in sorted(at, key=at.get):
        while rest and when[rest[0]] < known[at[c]][1]:
            merged.append(rest.pop(0))
        merged.append(c)
    merged += rest
    return [lab for c in merged for lab in (c, c + "+dirty") if lab in first]


def ordered(recs: list, known: list) -> list[str]:
    """The commit labels of records `recs`, oldest first (`order`; `known`: `topology()`)."""
    first = {}
    for rec in recs:
        first[label(rec)] = min(first.get(label(rec), math.inf), seconds(rec["recorded"]))
    return order(first, known)


def described(recs: list, known: list) -> list:
    """The records, each commit's date and subject taken from git (`known`: `topology()`) where the
    record lacks them (a stored bench run, a record written outside git)."""
    at = found({r["commit"]["id"] for r in recs}, known)
    out = []
    for r in recs:
        c = r["commit"]
        if c["id"] in at and not (c.get("date") and c.get("subject")):
            _, _, date, subject = known[at[c["id"]]]
            r = {**r, "commit": {**c, "date": c.get("date") or date, "subject": c.get("subject") or subject}}
        out.append(r)
    return out


# ---------------------------------------------------------------------------------------------
# the figures


def ticks(ax, labels: list) -> None:
    """The commit labels under the x axis (at most about 16 of them named), and the grid."""
    step = max(1, math.ceil(len(labels) / 16))
    ax.set_xticks(range(0, len(labels), step), labels[::step], rotation=30, ha="right", fontsize=8)
    ax.set_xlim(-0.5, len(labels) - 0.5)
    ax.grid(alpha=0.3, which="both")
    if ax.get_yscale() == "log":                        # plain numbers (0.6, 20), not 6 x 10^-1
        lo, hi = ax.get_ylim()
        decades = math.log10(hi / lo) if 0 < lo < hi else math.inf
        minor = (2, 3, 5) if decades < 1.2 else (2, 5) if decades < 2.5 else ()
        ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        ax.yaxis.set_minor_formatter(FuncFormatter(lambda v, _: f"{v:g}" if mantissa(v) in minor else ""))


def mantissa(v: float) -> int:
    """The leading digit of a positive number's decimal form (0.3 -> 3)."""
    return round(v / 10 ** math.floor(math.log10(v))) if v > 0 else 0


def case_figure(case: str, series: dict, labels: list, machines: list):
    """One case across commits: each solver's worst RMS difference over its tolerance (left, log,
    the tolerance at 1) and its solve wall time (right, log); `series` {(solver, machine): {label:
    entry}}, `labels` the commits drawn, oldest first; a line per solver in its colour (`figures.
    style`) and a line style per machine (`machines`). Returns the Figure (a fixed layout: drawn
    in a fraction of a second)."""
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    fig.subplots_adjust(left=0.07, right=0.79, bottom=0.22, top=0.91, wspace=0.28)
    x = {lab: k for k, lab in enumerate(labels)}
    for (s, m), pts in series.items():
        name = s if len(machines) == 1 else f"{s} ({m})"
        look = {**figures.style(s), "ls": LINES[machines.index(m) % len(LINES)],
                "marker": figures.STYLE.get(s, ("", "o"))[1], "ms": 5, "lw": 1.2}
        for ax, key in zip(axes, ("worst_over_tolerance", "wall_s")):
            xy = sorted((x[lab], e[key]) for lab, e in pts.items() if lab in x and number(e.get(key)) and e[key] > 0)
            if xy:
                ax.semilogy(*zip(*xy), label=name, **look)
    axes[0].axhline(1.0, color="k", ls=":", lw=1.0, label="tolerance")
    axes[0].set_ylabel("worst RMS difference / tolerance")
    axes[1].set_ylabel("wall time, solve only [s]")
    for ax, what in zip(axes, ("accuracy against the reference", "wall time")):
        ax.set_title(f"{case}: {what}", fontsize=10)
        ticks(ax, labels)
    handles = {}
    for ax in axes:
        handles.update(zip(*reversed(ax.get_legend_handles_labels())))
    if handles:
        fig.legend(list(handles.values()), list(handles), loc="upper left", bbox_to_anchor=(0.8, 0.91), fontsize=8)
    return fig


def bench_series(recs: list) -> dict:
    """The bench records' figures of merit: {panel: {(series, machine): {label: value}}} for the
    panels of `bench_figure` (matched-accuracy ratio per case and error target, rigid-chain ratio
    per n, flexible-chain exponent, cold and cached compile [s])."""
    out = {"matched": {}, "rigid": {}, "exponent": {}, "compile": {}}
    for rec in recs:
        b, at = rec["bench"], (label(rec), rec["machine"]["name"])
        rows = lambda key: [r for r in b.get(key) or [] if isinstance(r, dict)]
        c = b.get("compile_s") if isinstance(b.get("compile_s"), dict) else {}
        got = ([("matched", f"{r.get('case')} at {r.get('error_target')}", r.get("ratio"))
                for r in rows("matched_accuracy")]
               + [("rigid", f"n = {r.get('n')}", r.get("ratio")) for r in rows("rigid_chain")]
               + [("exponent", "flexible chain", b.get("flexible_chain_exponent")),
                  ("compile", "first (empty cache)", c.get("cold_s")), ("compile", "cached start", c.get("cached_s"))])
        for panel, key, v in got:
            if number(v):
                out[panel].setdefault((key, at[1]), {})[at[0]] = v
    return out


BENCH_PANELS = [("matched", "flexmbd / exudyn-ffrf wall time\nat matched accuracy", True, 1.0),
                ("rigid", "flexmbd / pinocchio\none rigid-chain evaluation", True, None),
                ("exponent", "flexible-chain cost exponent\n(n >= 4)", False, 1.0),
                ("compile", "compile time [s]", True, None)]


def bench_figure(series: dict, labels: list, machines: list):
    """The bench records across commits (`bench_series`): one panel per figure of merit, a colour
    per series, a line style per machine, a dotted line at 1 where it means parity or linear cost.
    Returns the Figure."""
    fig, axes = plt.subplots(2, 2, figsize=(11, 7.6))
    fig.subplots_adjust(left=0.07, right=0.98, bottom=0.1, top=0.93, wspace=0.2, hspace=0.45)
    x = {lab: k for k, lab in enumerate(labels)}
    for ax, (panel, title, log, line) in zip(axes.flat, BENCH_PANELS):
        keys = list(dict.fromkeys(key for key, _ in series[panel]))
        for (key, m), pts in series[panel].items():
            xy = sorted((x[lab], v) for lab, v in pts.items() if lab in x and (v > 0 or not log))
            name = key if len(machines) == 1 else f"{key} ({m})"
            if xy:
                ax.plot(*zip(*xy), ls=LINES[machines.index(m) % len(LINES)], marker="o", ms=4, lw=1.2,
                        color=f"C{keys.index(key) % 10}", label=name)
        if log:
            ax.set_yscale("log")
        if line is not None:
            ax.axhline(line, color="k", ls=":", lw=1.0)
        ax.set_title(title, fontsize=10)
        ticks(ax, labels)
        figures.legend(ax, fontsize=7)
    return fig


# ---------------------------------------------------------------------------------------------
# the page


def figure(make, d: Path, name: str, shown) -> str:
    """The figure `make()` as d/NAME-DIGEST.png and .svg (`figures.save`), DIGEST of what it shows
    (`shown`, as JSON) and of flexmbd's source; copied from the user's cache of drawn figures when
    drawn before (`figures.kept`). Its PNG's name."""
    source = json.dumps([name, shown, registry.source_sha256()], default=str).encode()
    return figures.kept(d / f"{name}-{version.cache_key(source, digits=12)}.png", source, make)


def history_page_key(recs: list, labels: list) -> str:
    """SHA-256 (hex) of what the history page is drawn from: every record's file and contents, the
    order of the commits and flexmbd's source (`registry.source_sha256`)."""
    return version.cache_key({"labels": labels, "flexmbd": registry.source_sha256()},
                             *(part for rec in recs for part in (f"\0{rec['file']}\0", rec)))


def change(new, old) -> str:
    """The relative change from old to new as '+12 %', '' when either is not a positive number."""
    if not (number(new) and number(old) and old > 0):
        return ""
    return f"{100 * (new / old - 1):+.0f} %"


def latest_rows(series: dict, labels: list) -> list[list]:
    """A case's table: per (solver, machine), its latest commit, verdict, worst RMS difference over
    tolerance and wall time, each with its change since the previous commit recorded for it."""
    rows = []
    for (s, m), pts in series.items():
        have = [lab for lab in labels if lab in pts]
        if not have:
            continue
        e = pts[have[-1]]
        p = pts[have[-2]] if len(have) > 1 else {}
        rows.append([s, m, have[-1], accuracy.Verdict(e["verdict"], e["verdict"]), e.get("worst_over_tolerance"),
                     change(e.get("worst_over_tolerance"), p.get("worst_over_tolerance")), e.get("wall_s"),
                     change(e.get("wall_s"), p.get("wall_s")), have[-2] if len(have) > 1 else ""])
    return rows


def page(out, warn=None) -> Path:
    """Draw OUT/history.html and history.md (figures in OUT/history-page/) from the records under
    OUT/history and the stored bench runs (`resources.HISTORY`), swapped in together
    (`files.generation`); kept as it is when drawn from the same records (`history_page_key`). A record
    that cannot be read is an InputError naming it, or with `warn` left out (`warn` is told)."""
    out = Path(out)
    known = topology()
    recs = described(records(out, warn) + stored_bench(resources.HISTORY, warn), known)
    labels = ordered(recs, known)
    key = history_page_key(recs, labels)
    try:
        if json.loads((out / PAGE / "page.json").read_text()).get("key") == key and (out / "history.html").is_file():
            return out / "history.html"
    except (OSError, ValueError, AttributeError):
        pass
    with files.generation(out) as stage:
        html_text, md_text = sections(recs, labels, stage / PAGE)
        files.atomic_write(stage / PAGE / "page.json", json.dumps({"key": key}) + "\n")
        files.atomic_write(stage / "history.html", html_text)
        files.atomic_write(stage / "history.md", md_text)
    return out / "history.html"


def sections(recs: list, labels: list, d: Path) -> tuple[str, str]:
    """The page (html, markdown) of records `recs` (commit labels oldest first: `labels`), its
    figures written into `d` (or copied from the user's cache: `figure`)."""
    reports = [r for r in recs if "runs" in r]
    benches = [r for r in recs if "bench" in r]
    parts = [("", *introduction(recs, [lab for lab in labels if any(label(r) == lab for r in reports)])),
             ("Commits, oldest first", *commit_table(recs, labels))]
    parts += case_sections(reports, labels, d)
    if benches:
        parts.append(("Benchmarks", *bench_section(benches, labels, d)))
    title = "flexmbd history"
    doc = [f"<!doctype html><html><head><meta charset='utf-8'><title>{title}</title><style>{pages.CSS}</style></head>"
           f"<body><p><a href='index.html'>report</a></p><h1>{title}</h1>"]
    md = [f"# {title}\n\n[report](index.md)\n"]
    for t, h, m in parts:
        doc.append((f"<h2>{html.escape(t)}</h2>" if t else "") + h)
        md.append((f"## {t}\n\n" if t else "") + m)
    return "".join(doc) + "</body></html>\n", "\n".join(md)


def introduction(recs: list, commits: list) -> tuple[str, str]:
    """What the page shows, whether it has one commit only (`commits`: those with report records),
    and the machines of the records `recs`, as (html, markdown)."""
    intro = ("<p>How each solver's accuracy and solve wall time on each case moved across commits, from the "
             "records every <code>flexmbd report</code> keeps in <code>OUT/history/MACHINE/COMMIT.json</code>, and "
             "the benchmark runs (<code>flexmbd bench</code>) below. Commits are ordered as git orders them "
             "(topologically) where git knows them, the others by when they were first recorded; <code>+dirty</code> "
             "marks a record of uncommitted changes to the code or the cases. One line per solver, a line style per "
             "machine. The accuracy is the worst compared channel's RMS difference from the case's reference over "
             "its tolerance: below the dotted line at 1 every channel is within tolerance.</p>")
    if len(commits) == 1:
        intro += (f"<p><b>Only one commit has report records so far ({html.escape(commits[0])}):</b> the figures "
                  "show its points; the history grows as reports are run at later commits, or as another machine's "
                  "records are added (<code>flexmbd history --add DIR</code>).</p>")
    elif not commits:
        intro += "<p><b>No report records yet:</b> <code>flexmbd report</code> writes one at each commit.</p>"
    head = ["machine", "host", "CPU", "cores", "memory [GB]", "OS", "Python", "records"]
    desc = {r["machine"]["name"]: r["machine"] for r in sorted(recs, key=lambda r: seconds(r["recorded"]))}
    rows = [[m, d.get("hostname"), d.get("cpu"), d.get("cores"), d.get("memory_gb"), d.get("os"), d.get("python"),
             sum(r["machine"]["name"] == m for r in recs)] for m, d in desc.items()]
    return intro + tables.html_table(head, rows), pages.plain(intro) + "\n\n" + tables.markdown(head, rows)


def commit_table(recs: list, labels: list) -> tuple[str, str]:
    """The commits in the order the figures use (`labels`): date, subject and who recorded them."""
    info = {}
    for r in sorted(recs, key=lambda r: seconds(r["recorded"])):
        c = info.setdefault(label(r), {"date": "", "subject": "", "by": {}})
        c["date"] = r["commit"].get("date") or c["date"]
        c["subject"] = r["commit"].get("subject") or c["subject"]
        c["by"][f"{r['machine']['name']} ({'bench' if 'bench' in r else 'report'})"] = True
    short = lambda text: text if len(text) <= 72 else text[:71] + "…"
    head = ["commit", "date", "subject", "records"]
    rows = [[lab, info[lab]["date"][:16].replace("T", " "), short(info[lab]["subject"]), ", ".join(info[lab]["by"])]
            for lab in labels]
    return tables.html_table(head, rows), tables.markdown(head, rows)


def case_sections(reports: list, labels: list, d: Path) -> list[tuple]:
    """One section (title, html, markdown) per case of the report records: its figure across the
    commits (`case_figure`, into `d`) and the table of each solver's latest values (`latest_rows`)."""
    machines = list(dict.fromkeys(r["machine"]["name"] for r in reports))
    per_case = {}                                   # case -> {(solver, machine): {label: entry}}
    for r in reports:
        for e in r["runs"]:
            per_case.setdefault(e["case"], {}).setdefault((e["solver"], r["machine"]["name"]), {})[label(r)] = e
    head = ["solver", "machine", "latest commit", "verdict", "worst RMS / tolerance", "change", "wall [s]", "change",
            "previous commit"]
    out = []
    for case in sorted(per_case):
        series = {k: v for k, v in per_case[case].items()
                  if any(number(e.get("wall_s")) or number(e.get("worst_over_tolerance")) for e in v.values())}
        if not series:
            continue
        shown = [lab for lab in labels if any(lab in pts for pts in series.values())]
        img = figure(lambda: case_figure(case, series, shown, machines), d, case,
                     [sorted(series.items()), shown, machines])
        rows = latest_rows(series, shown)
        out.append((case, f"<p><img src='{PAGE}/{img}' alt='{img}'></p>" + tables.html_table(head, rows),
                    f"![{img}]({PAGE}/{img})\n\n" + tables.markdown(head, rows)))
    return out


def bench_section(benches: list, labels: list, d: Path) -> tuple[str, str]:
    """The bench records' figure across commits (`bench_figure`, into `d`), what it shows and the
    list of the records, as (html, markdown)."""
    shown = [lab for lab in labels if any(label(r) == lab for r in benches)]
    machines = list(dict.fromkeys(r["machine"]["name"] for r in benches))
    got = bench_series(benches)
    img = figure(lambda: bench_figure(got, shown, machines), d, "bench",
                 [sorted((k, sorted(v.items())) for k, v in got.items()), shown, machines])
    note = ("<p>Each <code>flexmbd bench</code> run (benchmarks/README.md): the wall-time ratio of flexmbd to "
            "exudyn-ffrf at their fastest settings meeting each error target (below 1: flexmbd faster), of one "
            "rigid-chain evaluation to Pinocchio's, the fitted exponent of the flexible chain's cost against its "
            "length, and the compile times. A ratio was measured within one run against a peer in the same "
            f"process. The runs stored with the project (<code>benchmarks/history/</code>) are of the {PROJECT} "
            "(its description was not recorded), at the commit their file is named after; a bench run written to "
            "<code>OUT/bench</code> is kept under this machine's name.</p>")
    head = ["commit", "machine", "recorded", "file"]
    rows = [[label(r), r["machine"]["name"], r["recorded"], Path(r["file"]).name]
            for r in sorted(benches, key=lambda r: (shown.index(label(r)), r["machine"]["name"]))]
    return (f"<p><img src='{PAGE}/{img}' alt='{img}'></p>" + note + tables.html_table(head, rows),
            f"![{img}]({PAGE}/{img})\n\n" + pages.plain(note) + "\n\n" + tables.markdown(head, rows))
