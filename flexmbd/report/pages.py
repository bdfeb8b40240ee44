"""The report's pages: one page per case (`write_case`: figures, spectra, mode shapes, timing,
accuracy and provenance of its stored results) and the index (`write_index`: every run's verdict,
links, the latest work-precision run from the benchmark history).
"""

from __future__ import annotations

import datetime
import html
import json
import re
from pathlib import Path

import numpy as np

from flexmbd import cases
from flexmbd.harness import metrics, results, registry
from flexmbd.core import resources
from flexmbd.core.files import atomic_write
from flexmbd.report import accuracy, animation, convergence, fields, figures, loading, shapes, spectra, tables


CSS = """body{font-family:sans-serif;max-width:1100px;margin:auto;padding:1em;color:#222}
table{border-collapse:collapse;margin:0.6em 0;font-size:13px}th,td{border:1px solid #bbb;padding:3px 7px;text-align:right;overflow-wrap:break-word}
th{background:#eee}td:first-child,th:first-child{text-align:left}img{max-width:100%}code{background:#f4f4f4}h2{border-bottom:1px solid #ccc}
td.pass,td.fail,td.diverged,td.aborted,td.na,td.unavailable,td.notcompared,td.ref,td.outside{text-align:left}
.pass{background:#e3f5e1;color:#11561b}.fail{background:#fde2e1;color:#8f1414}
.diverged{background:#ece3fb;color:#4b1f8f}.aborted{background:#dddddd;color:#222}
.ref{background:#e1ecfb;color:#163f7a}.na,.unavailable,.notcompared{color:#666}.outside{background:#fff4d1}
.flag{display:inline-block;margin-left:0.4em;padding:0 4px;border:1px solid #b57f00;border-radius:3px;color:#6b4a00;background:#fff4d1;font-size:12px}
table.matrix td{text-align:center;white-space:nowrap}table.matrix td:first-child{text-align:left}
table.matrix a{color:inherit}.left2 :is(td,th):nth-child(-n+2),.left3 :is(td,th):nth-child(-n+3),
.left4 :is(td,th):nth-child(-n+4),.left9 :is(td,th){text-align:left}.why{border-left:4px solid #4b1f8f;padding-left:0.6em}""" + tables.icon_css()


def plain(text: str) -> str:
    """A page's HTML paragraph as Markdown: <code> as backticks, other tags dropped."""
    return re.sub(r"<[^>]+>", "", re.sub(r"</?code>", "`", text.replace("</p><p", "</p>\n\n<p")))


def mode_shapes(case, d: Path) -> tuple[str, str] | None:
    """The "Mode shapes" section (html, markdown) of a case page: one figure per flexible body with
    retained modes (`figures.mode_shapes`, written into d); None when no body has any.

    A beam split into N segments (`segments = N`) is modelled by the modal solvers as N beams
    joined rigidly, each with the same length, mesh and modes table and so the same modes: the
    root segment's modes are drawn, as those every segment carries. The unsplit beam's modes (what
    `flexbody.for_case` returns for it) are in no modal solver's model: neither drawn nor computed."""
    figs, notes, bcs = [], [], set()
    for name in [b.name for b in case.tree if b.kind == "beam"]:
        segs = case.segments.get(name, ())
        if segs:
            fb = case.split.reduced(segs[0])
            title = (f"{case.name}: retained modes of each of the {len(segs)} segments of {name} "
                     f"({segs[0]} shown; {fb.boundary}, {fb.length:g} m)")
            notes.append(f"{html.escape(name)} is split into {len(segs)} segments of {fb.length:g} m joined rigidly "
                         f"(<code>segments = {len(segs)}</code>): the modal solvers give each segment the same "
                         f"retained modes, drawn here for the root segment {html.escape(segs[0])}.")
        else:
            fb = case.reduced(name)
            title = f"{case.name}: retained modes of {name} ({fb.boundary}, {fb.length:g} m)"
        if fb.n_modes:
            figs.append(figures.mode_shapes(fb, title, d / f"modes_{name}.png"))
            bcs.add(fb.boundary)
    if not figs:
        return None
    note = ("<p>The retained modes of each flexible body under its boundary condition ("
            + ", ".join(sorted(bcs)) + "), as the modal solvers reduce it: the node displacements along the undeformed "
            "beam, transverse y and z (cubic between the nodes), and the axial displacement or the torsion "
            "angle of a mode led by it, each mode scaled to a largest value of 1 and titled with its frequency. "
            "These are the body's own modes, not the system's: the system modes (joints and bodies together, "
            "linearized about the initial state) are those the spectra are matched against, listed by "
            f"<code>flexmbd modes {html.escape(case.name)} --system</code>.</p>")
    if notes:
        note += "<p>" + " ".join(notes) + "</p>"
    return ("".join(f"<p><img src='{i}' alt='{i}'></p>" for i in figs) + note,
            "".join(f"![{i}]({i})\n\n" for i in figs) + plain(note) + "\n")


def timing_rows(res: dict, t_end: float) -> list[list]:
    """Per solver: status, solve / set-up / compile wall times, steps, RHS evaluations, wall time per
    simulated second; NaN (shown as —) for a solver that did not run."""
    rows = []
    for s, r in res.items():
        sim = r.t[-1] if len(r.t) else t_end
        got = [r.wall_s, r.setup_s, r.extra.get("compile_s", np.nan), r.steps, r.rhs_evals,
               metrics.per_simulated_second(r.wall_s, sim)]
        rows.append([s, r.status] + (got if loading.ran(r) else [np.nan] * len(got)))
    return rows


def provenance_rows(res: dict) -> list[list]:
    """Per solver: version, case hash, commit, date, machine, Python and numba (flexmbd's compiler),
    the --set overrides, where an imported result came from, and the settings, whole (the page
    wraps them)."""
    rows = []
    for s, r in res.items():
        e = r.extra
        python = ", ".join(x for x in [e.get("python") and f"Python {e['python']}",
                                       (e.get("versions") or {}).get("numba") and f"numba {e['versions']['numba']}"] if x)
        came = f"imported: {e['imported'].get('file', '')} (sha256 {e['imported'].get('sha256', '')[:16]})" \
            if isinstance(e.get("imported"), dict) else " ".join(f"--set {o}" for o in e.get("overrides") or [])
        rows.append([s, r.solver_version, r.case_sha256[:16], e.get("git_commit", ""), e.get("date", ""),
                     e.get("machine", ""), python, came, json.dumps(r.settings, sort_keys=True)])
    return rows


def defaults_note(case) -> str:
    """One line saying which of the reference and the tolerances are defaults, not the case file's."""
    rep, said = case.report, []
    if "reference" in rep.defaults:
        said.append(f"the reference {rep.reference} is the default (the first independent solver that runs "
                    f"the case, in the order {', '.join(registry.REFERENCES)})")
    if "tolerances" in rep.defaults:
        said.append("the tolerances are the defaults of each channel's kind ("
                    + ", ".join(f"{k} {v:g}" for k, v in cases.TOLERANCES.items()) + ")")
    return "Defaults, not the case file's choices: " + "; ".join(said) + " (cases/README.md, [report])."


def runs_section(case, runs: list) -> tuple[str, str]:
    """The "Runs" section (html, markdown) of a case page: each run's verdict (`runs`:
    accuracy.Outcome) with its validity flag, and for each run that diverged or was aborted why
    (its status), with the case's explanation of it where the case gives one
    (report.expected_failures)."""
    head = ["solver", "verdict"]
    rows = [[o.solver, o.verdict] for o in runs]
    why_html, why_md = [], []
    for o in runs:
        if o.verdict.kind not in results.CAUSES:
            continue
        said = case.report.expected_failures.get(o.solver, "")
        text = f"**{o.solver}**: {accuracy.status_text(o.status)}."
        why_html.append(f"<p class='why'><b>{html.escape(o.solver)}</b>: {html.escape(accuracy.status_text(o.status))}."
                        + (f" {html.escape(' '.join(said.split()))}" if said else "") + "</p>")
        why_md.append(text + (f" {' '.join(said.split())}" if said else "") + "\n")
    return (tables.html_table(head, rows, left=2) + "".join(why_html),
            tables.markdown(head, rows) + ("\n" + "\n".join(why_md) if why_md else ""))


def matrix(runs: list) -> tuple[str, str]:
    """The index's case x solver matrix (html, markdown): each run's verdict word with its icon
    and validity flag, each case linked to its page; '' where a solver did not run a case."""
    cases = list(dict.fromkeys(o.case for o in runs))
    names = list(dict.fromkeys(o.solver for o in runs))
    got = {(o.case, o.solver): o.verdict for o in runs}

    def word(v) -> str:                                     # markdown: no CSS, the icons written
        return f"{tables.ICONS.get(v.kind, '')} {v.kind}" + (f" {tables.FLAG}" if v.outside else "")
    rows_html, rows_md = [], []
    for c in cases:
        cells = []
        for s in names:
            v = got.get((c, s))
            cls = f" class='{tables.css_class(v)}'" if v else ""
            title = f" title='{html.escape(str(v), quote=True)}'" if v else ""
            flag = " <span class='flag'></span>" if v and v.outside else ""    # its icon; the cell's title says it
            cells.append(f"<td{cls}{title}>{html.escape(v.kind)}{flag}</td>" if v else "<td></td>")
        rows_html.append(f"<tr><td><a href='{c}/index.html'>{html.escape(c)}</a></td>{''.join(cells)}</tr>")
        rows_md.append([f"[{c}]({c}/index.md)"] + [word(got[(c, s)]) if (c, s) in got else ""
                                                   for s in names])
    head = "".join(f"<th>{html.escape(s)}</th>" for s in ["case"] + names)
    legend = ("Each case on each solver: " + ", ".join(f"{tables.ICONS[k]} {k}" for k in accuracy.VERDICTS)
              + f"; {tables.FLAG} the run left its model's linear validity (beside its verdict).")
    return (f"<p>{html.escape(legend)}</p><table class='matrix'><thead><tr>{head}</tr></thead>"
            f"<tbody>{''.join(rows_html)}</tbody></table>",
            legend + "\n\n" + tables.markdown(["case"] + names, rows_md))


def write_case(out: Path, stage: Path, case, names, warn, indexed: bool = True, up: str = "..") -> dict:
    """One case's page from the results under `out`, written into `stage/CASE/`; it links to the
    report's index when there is one (`indexed`), and says how to build one otherwise; `up` is the
    report folder seen from the page's folder (OUT/CASE: '..'):
    {"accuracy": its accuracy rows, "runs": each run's accuracy.Outcome}."""
    names = loading.page_solvers(out, case, names)
    res = loading.load_results(out, case, names, warn)
    ok = {s: r for s, r in res.items() if r.ok}
    mods = {s: registry.module(s) if s in registry.MODULES else None for s in res}     # None: imported
    freqs = spectra.fe_frequencies(case)
    ref = case.report.reference
    ungraded = accuracy.ungraded(case)
    if ungraded and warn:
        warn(f"warning: {case.path}: nothing graded: {ungraded}")
    acc = accuracy.rows(case, ok, mods, freqs)
    system = spectra.system_modes(case)
    dt = case.integrator.output_dt
    own, fine = spectra.spectral_modes(case)
    frozen = spectra.frozen_modes(case, ok)
    peaks = accuracy.peak_table(case, ok, own, dt,
                                others=[fine] + ([spectra.frozen_channel_modes(case, frozen[1])] if frozen else []))
    runs = [accuracy.Outcome(case.name, s, r.status, accuracy.verdict(r.status, s, ref, acc),
                             accuracy.worst(acc, s) if s != ref else np.nan, r.wall_s if loading.ran(r) else np.nan,
                             accuracy.worst_channel(acc, s) if s != ref else "")
            for s, r in res.items()]
    d = stage / case.name
    sections = [("Runs", *runs_section(case, runs))]          # (title, html, markdown)

    # channels, grouped as a reader looks for them
    groups = [("Deflection", ("deflection",)), ("Stress (von Mises at the stress points)", ("stress_vm",)),
              ("Joint angles, energy and reactions", ("joint_angle", "energy", "reaction_force", "reaction_moment"))]
    for title, kinds in groups:
        chans = [n for n, c in case.channels.items() if c.kind in kinds]
        if not chans:
            continue
        shown = lambda n: {s: r for s, r in figures.drawable(res).items() if accuracy.comparable(case, mods[s], n)}
        imgs = [figures.channel(case, n, shown(n), ref, d / f"{n}.png") for n in chans]
        sections.append((title, "".join(f"<p><img src='{i}' alt='{i}'></p>" for i in imgs),
                         "".join(f"![{i}]({i})\n\n" for i in imgs)))
    shape = shapes.section(case, figures.drawable(res), d, ref)     # the deformed shapes, after the deflections
    if shape:
        sections.insert(next((k + 1 for k, sec in enumerate(sections) if sec[0] == "Deflection"), 0), shape)
    field = fields.section(case, ok, d, ref)                # a solid's stress field, after its stress channels
    if field:
        sections.insert(next((k + 1 for k, sec in enumerate(sections) if sec[0].startswith("Stress")), len(sections)),
                        field)
    movie = animation.section(out, case, up)                # the animation `flexmbd animate` wrote, if any
    if movie:
        sections.insert(next((k + 1 for k, sec in enumerate(sections) if sec[0] == "Deformed shape at chosen instants"),
                             len(sections)), movie)

    # spectra of the deflection channels, with the identified peaks and the system's modes
    spec = [figures.spectra(case, n, ok, [f for f, _ in system], 0.5 / dt, d / f"fft_{n}.png",
                            peaks=[p["f_identified"] for p in peaks if p["channel"] == n])
            for n, c in case.channels.items() if c.kind == "deflection" and system]
    if spec:
        head = ["solver", "channel", "identified [Hz]", "system mode", "system [Hz]", "difference"]
        rows = [[p["solver"], p["channel"], p["f_identified"], p["mode"], p["f_system"], p["difference"]] for p in peaks]
        high = [(f, lab) for f, lab in system if f > 0.5 / dt]
        note = ("<p>Hann window, zero-padded 8x; a peak must stand clear of the main lobe and side lobes of "
                "every larger peak; refined by a parabola through the log-amplitudes. Each peak is named after "
                "the nearest frequency within 2 % of the system modes that move the channel's point in its "
                "direction: the case's equations (joint and modal coordinates) linearized about the initial "
                "state (<code>flexmbd modes CASE --system</code>, docs/formulation.md §10). A peak none of "
                f"them explains is matched against the same system with {spectra.FINER} times the retained modes per "
                "beam (labels ending '(N modes)'): such a peak, of a finer solver, is a mode the retained set "
                "truncates or places too high. Peaks below half "
                "the lowest of them are the forced, quasi-static response and are not listed. A system whose "
                "configuration or spin changes much during the run (a swinging double pendulum, a spun-up beam) "
                "vibrates at shifting frequencies: its peaks are matched last against the system linearized about "
                "the run's state at evenly spaced instants (free joints at their recorded angles and rates, driven "
                "ones on their profile, modal coordinates at rest; labels ending 'at t = T s (frozen)'), a "
                "frozen-time approximation. A vibration whose "
                "amplitude the swing modulates also shows sidebands at its frequency plus and minus the swing's, "
                "which no mode explains.</p>")
        if high:
            note += (f"<p class='outside'>{len(high)} system mode{'s lie' if len(high) > 1 else ' lies'} above "
                     f"the Nyquist frequency "
                     f"{0.5 / dt:.4g} Hz of the {dt * 1e3:.4g} ms output (the lowest: "
                     + ", ".join(f"{f:.4g} Hz, {html.escape(lab)}" for f, lab in high[:3])
                     + "); sampled without filtering, they show as aliases at |f - k / dt|, which the table "
                       "names.</p>")
        if frozen:
            shown = [f for f, _ in system if f <= 0.5 / dt]
            fmax = min(0.5 / dt, 1.15 * max(shown)) if shown else 0.5 / dt
            spec.append(figures.frozen(case, frozen[0], frozen[1], 0.5 * min(shown or [1.0]), fmax, d / "frozen.png"))
        sections.append(("FFT spectra and identified frequencies",
                         "".join(f"<p><img src='{i}' alt='{i}'></p>" for i in spec) + note + tables.html_table(head, rows),
                         "".join(f"![{i}]({i})\n\n" for i in spec)
                         + re.sub(r"<[^>]+>", "", note.replace("</p><p", "</p>\n\n<p")) + "\n\n"
                         + tables.markdown(head, rows)))

    # the flexible bodies' retained modes
    modes_section = mode_shapes(case, d)
    if modes_section:
        sections.append(("Mode shapes", *modes_section))

    # what elasticity changes: flexible minus rigid joint angles
    rigid = next((s for s in ("pinocchio", "mujoco") if s in ok), None)
    if "flexmbd" in ok and rigid and figures.angle_channels(case):
        img = figures.elasticity(case, ok["flexmbd"], ok[rigid], rigid, d / "elasticity.png")
        sections.append(("Flexible minus rigid", f"<p><img src='{img}' alt='{img}'></p>", f"![{img}]({img})\n\n"))

    # timing
    head = ["solver", "status", "wall [s] (solve)", "set-up [s]", "compile [s]", "steps", "RHS evals",
            "wall / simulated s"]
    rows = timing_rows(res, case.duration)
    sections.append(("Timing", tables.html_table(head, rows, left=2), tables.markdown(head, rows)))

    # accuracy
    head, rows = tables.accuracy_rows(acc)
    note = (f"<p>Nothing graded: {html.escape(ungraded)}.</p>" if ungraded else
            f"<p>Reference: <b>{html.escape(ref)}</b>. Differences are normalised by the reference's maximum "
            "magnitude; the result compares the RMS difference with the case's tolerance. Phase-robust measures "
            "(over many cycles a small frequency difference becomes a large phase difference): dominant "
            "frequency, RMS difference of the amplitude envelopes and of the slow (low-pass below half the "
            "lowest natural frequency) parts.</p>")
    if case.report.defaults:                                # said on the page: not the case file's choice
        note += f"<p>{html.escape(defaults_note(case))}</p>"
    notes = case.report.notes.strip()
    if notes:                                               # the case file's notes on its reference and verdicts
        note += "".join(f"<p>{html.escape(' '.join(par.split()))}</p>" for par in notes.split("\n\n"))
    sections.append(("Accuracy", note + tables.html_table(head, rows, left=4),
                     (defaults_note(case) + "\n\n" if case.report.defaults else "")
                     + ("\n\n".join(" ".join(par.split()) for par in notes.split("\n\n")) + "\n\n" if notes else "")
                     + tables.markdown(head, rows)))

    # convergence: each solver against its discretisation, from the case's stored studies
    conv = convergence.section(case, d, warn)
    if conv:
        sections.append(("Convergence", *conv))

    # provenance
    head = ["solver", "version", "case sha256", "git commit", "date", "machine", "Python, numba", "overrides / source",
            "settings"]
    rows = provenance_rows(res)
    sections.append(("Provenance", tables.html_table(head, rows, left=len(head)), tables.markdown(head, rows)))

    title = f"{case.name}: {case.title}"
    build_index = f"no index yet: flexmbd report --no-run --out {out} builds it from the stored results"
    top_html = f"<a href='{up}/index.html'>index</a>" if indexed else f"<code>{html.escape(build_index)}</code>"
    top_md = f"[index]({up}/index.md)" if indexed else f"`{build_index}`"
    page = [f"<!doctype html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title>",
            f"<style>{CSS}</style></head><body><p>{top_html}</p><h1>{html.escape(title)}</h1>"]
    md = [f"# {title}\n", top_md + "\n"]
    for t, h, m in sections:
        page.append(f"<h2>{html.escape(t)}</h2>{h}")
        md.append(f"## {t}\n\n{m}")
    page.append("</body></html>")
    atomic_write(d / "index.html", "".join(page) + "\n")
    atomic_write(d / "index.md", "\n".join(md))
    return {"accuracy": acc, "runs": runs}


def seconds(text) -> float | None:
    """An ISO date and time as seconds since the epoch (UTC when it names no zone); None if it is not one."""
    try:
        t = datetime.datetime.fromisoformat(text)
    except (TypeError, ValueError):
        return None
    return (t if t.tzinfo else t.replace(tzinfo=datetime.timezone.utc)).timestamp()


def bench_runs(folder: Path | None) -> list[Path]:
    """The stored bench runs in `folder` (DATE[THHMM]_COMMIT[_NOTE].json; None: an installed
    package, which has none), oldest first: by the date and time that start the name (a name
    without a time counts from its day's start, one that is no date before every other), then by
    name."""
    def when(path: Path) -> float:
        t = seconds(path.stem.partition("_")[0])
        return -np.inf if t is None else t
    return sorted(Path(folder).glob("*.json") if folder else [], key=lambda p: (when(p), p.name))


def latest_bench(folder: Path | None, warn=None) -> tuple[Path, dict] | None:
    """The newest benchmark run in `folder` (`bench_runs`' last) with work-precision rows: (its
    file, its contents), or None; a file that cannot be read or whose rows lack a key is passed
    over (`warn` is told)."""
    keys = {"case", "solver", "scheme", "error", "wall_s"}
    number = lambda v: v is None or (isinstance(v, (int, float)) and not isinstance(v, bool))
    for path in reversed(bench_runs(folder)):
        try:
            run = json.loads(path.read_text())
            rows = run.get("work_precision") if isinstance(run, dict) else None
            if rows and not all(isinstance(r, dict) and keys <= r.keys() and number(r["error"]) and number(r["wall_s"])
                                for r in rows):
                raise ValueError(f"a work_precision row lacks one of {sorted(keys)} or has an error or a wall time "
                                 "that is not a number")
        except (OSError, ValueError) as e:
            if warn:
                warn(f"warning: {path}: benchmark run not shown: {e}")
            continue
        if rows:                                         # a diverged setting's error: NaN or null
            nan = lambda v: np.nan if v is None else float(v)
            return path, {**run, "work_precision": [{**r, "error": nan(r["error"]), "wall_s": nan(r["wall_s"])}
                                                    for r in rows]}
    return None


def bench_section(stage: Path, warn=None) -> tuple[str, str]:
    """The index's work-precision figure (`figures.work_precision`, into stage) and its caption
    from the newest benchmark run in `resources.HISTORY` (`latest_bench`), as (html, markdown);
    ('', '') when there is none."""
    got = latest_bench(resources.HISTORY, warn)
    if got is None:
        return "", ""
    path, run = got
    rows = run["work_precision"]
    img = figures.work_precision(rows, stage / "work_precision.png", source=path.read_bytes())
    date, _, rest = path.stem.partition("_")
    commit = rest.split("_")[0] or "not recorded"
    dropped = sum(not np.isfinite(r["error"]) for r in rows)
    caption = (f"<p>Work and precision from the latest benchmark run, <code>{html.escape(path.parent.parent.name)}/"
               f"{html.escape(path.parent.name)}/{html.escape(path.name)}</code> (commit {html.escape(commit)}, "
               f"{html.escape(date)}, machine: {html.escape(str(run.get('machine', 'not recorded')))}"
               + (", a quick run" if run.get("quick") else "") + "): for each case, every solver and time-stepping "
               "scheme over its settings (tolerances or steps, in the order run), the error against the solve-only "
               "wall time. The error is the worst deflection channel's RMS difference "
               + ("from the converged run of the same model (flexmbd's own with geometric stiffening; for "
                  "flexmbd-linear, flexmbd without it, and exudyn-ffrf, each its own converged run of the linear "
                  "floating frame)" if all("error_reference" in r for r in rows) else "from a flexmbd run at rtol 1e-12")
               + ", over that run's largest magnitude (<code>flexmbd bench</code>). The times were measured "
               "in that run, on that machine, not in this report's runs."
               + (f" {dropped} setting{'s' if dropped > 1 else ''} without a finite error (diverged) "
                  f"{'are' if dropped > 1 else 'is'} left out." if dropped else "") + "</p>")
    return (f"<h2>Work and precision</h2><p><img src='{img}' alt='{img}'></p>{caption}",
            f"## Work and precision\n\n![{img}]({img})\n\n{plain(caption)}\n")


def write_index(out: Path, stage: Path, runs: list, warn=None) -> None:
    """The report's index (index.html, index.md) into `stage`: the summary line, the case x solver
    matrix of verdicts (`matrix`), the table of every run (`runs`: accuracy.Outcome), links to every case page and the reviewer tables, and the
    latest work-precision run (`bench_section`)."""
    head = ["case", "solver", "verdict", "worst channel", "its RMS diff / max|ref|", "wall [s]"]
    summary = [[o.case, o.solver, o.verdict, o.channel, o.worst, o.wall_s] for o in runs]
    line = accuracy.summary([o.verdict for o in runs])
    links_html = [[f"<a href='{r[0]}/index.html'>{html.escape(r[0])}</a>"] + r[1:] for r in summary]
    links_md = [[f"[{r[0]}]({r[0]}/index.md)"] + r[1:] for r in summary]
    when = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    intro = (f"Every case on every solver. A run passes when every graded channel's RMS difference from the "
             f"case's reference solver, over the reference's largest magnitude, is within the case's tolerance; "
             f"the worst channel is the one furthest beyond (or nearest) its tolerance, the one a verdict names (a "
             f"channel without a tolerance in the case is drawn and tabled, not graded; a rigid model is graded on "
             f"the channels it has: not on deflection, stress, or a flexible case's energy, whose strain part it "
             f"cannot hold). Generated {when}, commit "
             f"{results.git_commit() or 'unknown'}. Reviewer tables: ")
    pages = ["accuracy.csv", "accuracy.md", "accuracy.tex"]
    bench_html, bench_md = bench_section(stage, warn)
    grid_html, grid_md = matrix(runs)
    page = (f"<!doctype html><html><head><meta charset='utf-8'><title>flexmbd report</title><style>{CSS}</style>"
            f"</head><body><h1>flexmbd report</h1><p class='summary'><b>{html.escape(line)}</b></p>"
            f"<p>{html.escape(intro)}"
            + ", ".join(f"<a href='{f}'>{f}</a>" for f in pages) + "."
            + (" Benchmarks: <a href='bench/index.html'>bench</a>." if (out / "bench" / "index.html").exists() else "")
            + (" Across commits: <a href='history.html'>history</a>." if (out / "history").is_dir() else "")
            + "</p>" + grid_html + "<h2>Every run</h2>" + tables.html_table(head, links_html, raw_cols=(0,), left=4)
            + bench_html + "</body></html>")
    atomic_write(stage / "index.html", page + "\n")
    atomic_write(stage / "index.md", "# flexmbd report\n\n**" + line + "**\n\n" + intro + ", ".join(f"[{f}]({f})" for f in pages)
                 + "." + (" Across commits: [history](history.md)." if (out / "history").is_dir() else "")
                 + "\n\n" + grid_md + "\n## Every run\n\n" + tables.markdown(head, links_md)
                 + ("\n" + bench_md if bench_md else ""))
