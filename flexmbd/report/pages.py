"""The report's pages: one page per case (`write_case`: figures, spectra, mode shapes, timing,
accuracy and provenance of its stored results) and the index (`write_index`: every run's verdict,
links, the latest work-precision run from the benchmark history).

A case page is built in three steps:

1. its table of numbers (`numbers`, a `CasePage` built once): the stored results, the accuracy
   rows, the system modes and identified peaks, each run's outcome, the timing and provenance
   rows;
2. its sections, in page order by construction: `SECTIONS` lists one builder per place on the
   page, each giving the sections it places there (none when the case has nothing to show there),
   drawing its figures from the table;
3. the page's HTML and Markdown, both filled from the same values through the templates of
   `templates` (prose, section titles, table heads and the page's frame): a value either reads the
   same in both formats or is given in the form of each (`Both`: an image, a table, a paragraph).
"""

from __future__ import annotations

import datetime
import html
import json
import re
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import NamedTuple

import numpy as np

from flexmbd import cases
from flexmbd.harness import metrics, results, registry
from flexmbd.core import resources
from flexmbd.core.files import atomic_write
from flexmbd.report import (accuracy, animation, convergence, durability, fields, figures, frequency_map, loading,
                            shapes, spectra, tables)
from flexmbd.report import templates as T


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

FLEXIBLE = "flexmbd"                    # the flexible model set against a rigid one ("Flexible minus rigid")
RIGID = ("pinocchio", "mujoco")         # the rigid models it is set against, the first that ran
DEFLECTION = ("deflection",)            # the channel kinds of each channel section
STRESS = cases.STRESS_KINDS
ANGLES = ("joint_angle", "energy", "reaction_force", "reaction_moment")


class Both(NamedTuple):
    """A piece of a page in its two formats: the same content as HTML and as Markdown."""
    html: str
    md: str


def plain(text: str, code: str = "`") -> str:
    """A page's HTML paragraph as Markdown: <code> as backticks (as `code`), other tags dropped."""
    return re.sub(r"<[^>]+>", "", re.sub(r"</?code>", code, text.replace("</p><p", "</p>\n\n<p")))


def fill(form, **values) -> Both:
    """The HTML and the Markdown of a template pair (`templates.Form` or `templates.Section`) from
    one set of values: a `Both` gives each format its own form, any other value reads the same."""
    pick = lambda k: {n: v[k] if isinstance(v, Both) else v for n, v in values.items()}
    return Both(form.html.substitute(pick(0)), form.md.substitute(pick(1)))


def section(sec: T.Section, **values) -> tuple[str, str, str]:
    """A page section (title, html, markdown) from its templates (`fill`)."""
    return (sec.title, *fill(sec, **values))


def images(names: list) -> Both:
    """Figures (their PNG names, beside the page), one after the other."""
    shown = [fill(T.IMAGE, src=i) for i in names]
    return Both("".join(s.html for s in shown), "".join(s.md for s in shown))


def table(head: list, rows: list[list], left: int = 1) -> Both:
    """A table of the page (`tables.html_table`, its first `left` columns aligned left; `tables.markdown`)."""
    return Both(tables.html_table(head, rows, left=left), tables.markdown(head, rows))


def paragraph(text: str) -> str:
    """A paragraph of plain text as HTML (escaped)."""
    return T.PARAGRAPH.substitute(text=html.escape(text))


def retained(case, name: str) -> tuple:
    """(the reduced body whose modes are drawn for beam `name`, its figure's title, the note on its
    segments as HTML: '' for an unsplit beam)."""
    segs = case.segments.get(name, ())
    if not segs:
        fb = case.reduced(name)
        return fb, T.BODY_TITLE.substitute(case=case.name, name=name, boundary=fb.boundary, length=f"{fb.length:g}"), ""
    fb = case.split.reduced(segs[0])
    title = T.SEGMENTS_TITLE.substitute(case=case.name, count=len(segs), name=name, root=segs[0],
                                        boundary=fb.boundary, length=f"{fb.length:g}")
    return fb, title, T.SEGMENTS_NOTE.substitute(name=html.escape(name), count=len(segs), length=f"{fb.length:g}",
                                                 root=html.escape(segs[0]))


def mode_shapes(case, d: Path) -> Both | None:
    """The "Mode shapes" section (html, markdown) of a case page: one figure per flexible body with
    retained modes (`figures.mode_shapes`, written into d); None when no body has any.

    A beam split into N segments (`segments = N`) is modelled by the modal solvers as N beams
    joined rigidly, each with the same length, mesh and modes table and so the same modes: the
    root segment's modes are drawn, as those every segment carries. The unsplit beam's modes (what
    `flexbody.for_case` returns for it) are in no modal solver's model: neither drawn nor computed."""
    figs, notes, bcs = [], [], set()
    for name in [b.name for b in case.tree if b.kind == "beam"]:
        fb, title, note = retained(case, name)
        notes += [note] if note else []
        if fb.n_modes:
            figs.append(figures.mode_shapes(fb, title, d / f"modes_{name}.png"))
            bcs.add(fb.boundary)
    if not figs:
        return None
    note = T.MODES_NOTE.substitute(conditions=", ".join(sorted(bcs)), case=html.escape(case.name))
    note += T.PARAGRAPH.substitute(text=" ".join(notes)) if notes else ""
    return fill(T.MODES, images=images(figs), note=Both(note, plain(note)))


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
        said.append(T.DEFAULT_REFERENCE.substitute(reference=rep.reference, order=", ".join(registry.REFERENCES)))
    if "tolerances" in rep.defaults:
        said.append(T.DEFAULT_TOLERANCES.substitute(
            tolerances=", ".join(f"{k} {v:g}" for k, v in cases.TOLERANCES.items())))
    return T.DEFAULTS.substitute(said="; ".join(said))


def runs_section(case, runs: list) -> Both:
    """The "Runs" section (html, markdown) of a case page: each run's verdict (`runs`:
    accuracy.Outcome) with its validity flag, and for each run that diverged or was aborted why
    (its status), with the case's explanation of it where the case gives one
    (report.expected_failures), which also follows a run that failed its tolerances."""
    why = []
    for o in runs:
        explained = o.verdict.kind == "fail" and o.solver in case.report.expected_failures
        if o.verdict.kind not in results.CAUSES and not explained:
            continue
        said = case.report.expected_failures.get(o.solver, "")
        status = str(o.verdict) if o.verdict.kind == "fail" else accuracy.status_text(o.status)
        text = " ".join(said.split())
        why.append(fill(T.WHY, solver=Both(html.escape(o.solver), o.solver), status=Both(html.escape(status), status),
                        said=Both(f" {html.escape(text)}", f" {text}") if said else ""))
    return fill(T.RUNS, table=table(T.RUNS_HEAD, [[o.solver, o.verdict] for o in runs], left=2),
                why=Both("".join(w.html for w in why), "\n" + "\n".join(w.md for w in why) if why else ""))


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


# ---------------------------------------------------------------------------------------------
# a case page: its table of numbers, its sections in order, its HTML and Markdown


@dataclass
class CasePage:
    """The table of one case page, built once (`numbers`): where the page goes, its stored results
    and every number it shows; the sections only draw and format it. The sections that other
    modules make (shapes, stress field, animation) are made once, where the page first places them."""
    case: object
    out: Path               # the report folder, whose results the page shows
    folder: Path            # the page's folder, its figures beside it
    up: str                 # the report folder seen from the page's folder
    indexed: bool           # whether the report has an index to link
    warn: object
    res: dict               # solver -> its stored Result
    ok: dict                # those that ran to the end
    mods: dict              # solver -> its module (None: an imported result)
    reference: str
    ungraded: str           # why nothing is graded ('' when something is)
    acc: list               # the accuracy rows (`accuracy.rows`)
    runs: list              # each run's accuracy.Outcome
    dt: float               # the output step
    system: list            # (frequency, label) of the system modes
    frozen: object          # the frozen-time modes (`spectra.frozen_modes`), or None
    peaks: list             # the identified spectral peaks (`accuracy.peak_table`)
    rigid: str | None       # the rigid model set against FLEXIBLE, if one ran
    timing: list            # `timing_rows`
    provenance: list        # `provenance_rows`

    @property
    def nyquist(self) -> float:
        """The Nyquist frequency of the output step: the spectra end there."""
        return 0.5 / self.dt

    @cached_property
    def fatigue(self) -> tuple | None:
        """The fatigue count of a case with a `[durability]` table (`durability.counts`), else None."""
        return durability.counts(self.case, self.ok)

    @cached_property
    def shape(self) -> tuple | None:
        """The deformed-shape section (`shapes.section`), None when no result holds shapes."""
        return shapes.section(self.case, figures.drawable(self.res), self.folder, self.reference)

    @cached_property
    def field(self) -> tuple | None:
        """The solids' stress-field section (`fields.section`), None when no result holds a field."""
        return fields.section(self.case, self.ok, self.folder, self.reference)

    @cached_property
    def movie(self) -> tuple | None:
        """The animation section (`animation.section`), None when `flexmbd animate` wrote none."""
        return animation.section(self.out, self.case, self.up)


def outcomes(case, res: dict, acc: list) -> list:
    """Each run's accuracy.Outcome: its verdict, worst channel and its difference (none for the
    reference), its solve time (NaN when it did not run)."""
    ref = case.report.reference
    return [accuracy.Outcome(case.name, s, r.status, accuracy.verdict(r.status, s, ref, acc),
                             accuracy.worst(acc, s) if s != ref else np.nan, r.wall_s if loading.ran(r) else np.nan,
                             accuracy.worst_channel(acc, s) if s != ref else "")
            for s, r in res.items()]


def numbers(out: Path, stage: Path, case, names, warn, indexed: bool = True, up: str = "..") -> CasePage:
    """The table of `case`'s page (`CasePage`) from the results under `out`, the page going to
    `stage/CASE/`; `warn` is told of results that cannot be used and of a case that grades nothing."""
    names = loading.page_solvers(out, case, names)
    res = loading.load_results(out, case, names, warn)
    ok = {s: r for s, r in res.items() if r.ok}
    mods = {s: registry.module(s) if s in registry.MODULES else None for s in res}     # None: imported
    freqs = spectra.fe_frequencies(case)
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
    return CasePage(case=case, out=out, folder=stage / case.name, up=up, indexed=indexed, warn=warn, res=res, ok=ok,
                    mods=mods, reference=case.report.reference, ungraded=ungraded, acc=acc,
                    runs=outcomes(case, res, acc), dt=dt, system=system, frozen=frozen, peaks=peaks,
                    rigid=next((s for s in RIGID if s in ok), None), timing=timing_rows(res, case.duration),
                    provenance=provenance_rows(res))


def has(p: CasePage, kinds: tuple) -> bool:
    """Whether the case has a channel of one of `kinds`: its channel section is on the page."""
    return any(c.kind in kinds for c in p.case.channels.values())


def channels(p: CasePage, sec: T.Section, kinds: tuple) -> list:
    """The section of the case's channels of `kinds` (one figure each, of the runs comparable on
    it), or none when it has no such channel."""
    chans = [n for n, c in p.case.channels.items() if c.kind in kinds]
    if not chans:
        return []
    drawable = figures.drawable(p.res)
    imgs = [figures.channel(p.case, n, {s: r for s, r in drawable.items() if accuracy.comparable(p.case, p.mods[s], n)},
                            p.reference, p.folder / f"{n}.png") for n in chans]
    return [section(sec, images=images(imgs))]


def shape_and_movie(p: CasePage) -> list:
    """The deformed shapes and after them the animation, when the results hold shapes."""
    return [s for s in (p.shape, p.shape and p.movie) if s]


# the sections, one builder per place on the page: each gives the sections it places there


def lead(p: CasePage) -> list:
    """A case without deflection channels opens its page with its deformed shapes and animation."""
    return [] if has(p, DEFLECTION) else shape_and_movie(p)


def runs_part(p: CasePage) -> list:
    """Each run's verdict and, for a run that did not finish, why (`runs_section`)."""
    return [(T.RUNS.title, *runs_section(p.case, p.runs))]


def deflection_part(p: CasePage) -> list:
    """The deflection channels, then the deformed shapes and the animation."""
    return channels(p, T.DEFLECTION, DEFLECTION) + (shape_and_movie(p) if has(p, DEFLECTION) else [])


def stress_part(p: CasePage) -> list:
    """The stress channels, then a solid's stress field."""
    got = channels(p, T.STRESS, STRESS)
    return got + [p.field] if got and p.field else got


def angles_part(p: CasePage) -> list:
    """The joint angle, energy and reaction channels; then a stress field the case has no stress
    channel to follow, and an animation it has no shapes to follow."""
    rest = (None if has(p, STRESS) else p.field, None if p.shape else p.movie)
    return channels(p, T.ANGLES, ANGLES) + [s for s in rest if s]


def frozen_figure(p: CasePage) -> str:
    """The frozen-time modes over the run (`figures.frozen`), up to just above the highest system
    mode below the Nyquist frequency."""
    shown = [f for f, _ in p.system if f <= p.nyquist]
    fmax = min(p.nyquist, 1.15 * max(shown)) if shown else p.nyquist
    return figures.frozen(p.case, p.frozen[0], p.frozen[1], 0.5 * min(shown or [1.0]), fmax, p.folder / "frozen.png")


def aliases(p: CasePage) -> str:
    """The note (HTML) on the system modes above the Nyquist frequency of the output, if any."""
    high = [(f, lab) for f, lab in p.system if f > p.nyquist]
    if not high:
        return ""
    return T.ALIASES.substitute(count=len(high), lie="s lie" if len(high) > 1 else " lies", nyquist=f"{p.nyquist:.4g}",
                                output=f"{p.dt * 1e3:.4g}",
                                lowest=", ".join(f"{f:.4g} Hz, {html.escape(lab)}" for f, lab in high[:3]))


def spectra_part(p: CasePage) -> list:
    """Each deflection channel's spectrum with the identified peaks and the system modes, and the
    table naming the peaks; none without system modes or deflection channels."""
    imgs = [figures.spectra(p.case, n, p.ok, [f for f, _ in p.system], p.nyquist, p.folder / f"fft_{n}.png",
                            peaks=[q["f_identified"] for q in p.peaks if q["channel"] == n])
            for n, c in p.case.channels.items() if c.kind == "deflection" and p.system]
    if not imgs:
        return []
    imgs += [frozen_figure(p)] if p.frozen else []
    note = T.SPECTRA_NOTE.substitute(finer=spectra.FINER) + aliases(p)
    rows = [[q["solver"], q["channel"], q["f_identified"], q["mode"], q["f_system"], q["difference"]] for q in p.peaks]
    return [section(T.SPECTRA, images=images(imgs), note=Both(note, plain(note, code="")),
                    table=table(T.PEAKS_HEAD, rows))]


def modes_part(p: CasePage) -> list:
    """The flexible bodies' retained modes (`mode_shapes`)."""
    got = mode_shapes(p.case, p.folder)
    return [(T.MODES.title, *got)] if got else []


def frequency_map_part(p: CasePage) -> list:
    """The system's frequencies against a setting (`report.frequency_map`), flexmbd's modes tracked
    by shape and the peers' own eigen-solves beside them: the figure, the table of the lowest
    tracks with each peer's largest difference at each value, the whole map as CSV."""
    m = frequency_map.taken(p.case)
    if m is None:
        return []
    fm = p.case.frequency_map
    n = fm["tracks"]
    img, csv_name = frequency_map.write(m, p.folder, p.case.name, n)
    rows = frequency_map.agreement(m, n)
    head = [m.key, *[f"flexmbd {k + 1} [Hz]" for k in range(n)],
            *[f"{s}: largest |f / f_flexmbd - 1| (the nearest)" for s in m.peers]]
    num = accuracy.number
    cells = [[num(r["value"], 4), *[num(f, 5) for f in r["flexmbd"]], *[num(r[f"{s} diff"], 2) for s in m.peers]]
             for r in rows]
    said = "; ".join(f"{s}: {why}" for s, why in m.refused.items())
    lead = (f"The system linearized at {len(m.values)} values of {m.key} from {m.values[0]:g} to {m.values[-1]:g}"
            f"{' with ' + ', '.join(fm['set']) if fm['set'] else ''}; flexmbd's modes are followed from value to "
            f"value by their shapes (the largest MAC, node translations), not by sorting, and each curve is named by "
            f"the link and mode that hold most of its strain energy at the first value. "
            + (f"Marked over them: the lowest frequencies of {', '.join(m.peers)}, each from its own eigen-solve of "
               f"the same assembly (no array of flexmbd's); below, each peer's {n} lowest against the nearest of "
               f"flexmbd's, over those within its range (a peer may model families the retained modes leave "
               f"out). " if m.peers
               else "") + (f"Not shown: {said}." if said else ""))
    links = Both(f"<p><a href='{csv_name}'>{csv_name}</a></p>", f"[{csv_name}]({csv_name})")
    sens_head = ["model", "discretization", *[f"f{k + 1} [Hz]" for k in range(n)]]
    sens = [[r["model"], r["setting"], *[num(f, 6) for f in r["freq_hz"]]] for r in m.sensitivity]
    said_sens = (f"Each model's sensitivity to its discretization at {m.key} = {m.values[0]:g}: flexmbd's retained "
                 f"modes doubled, each peer's elements per beam halved and doubled.")
    return [section(T.FREQUENCY_MAP, lead=Both(paragraph(lead), lead), images=images([img]),
                    table=Both(*[a + b + c for a, b, c in zip(table(head, cells, left=1),
                                                                Both(paragraph(said_sens), "\n" + said_sens + "\n\n"),
                                                                table(sens_head, sens, left=2))]),
                    files=links)]


def elasticity_part(p: CasePage) -> list:
    """What elasticity changes: the flexible model's joint angles minus a rigid model's."""
    if FLEXIBLE not in p.ok or not p.rigid or not figures.angle_channels(p.case):
        return []
    img = figures.elasticity(p.case, p.ok[FLEXIBLE], p.ok[p.rigid], p.rigid, p.folder / "elasticity.png")
    return [section(T.ELASTICITY, images=images([img]))]


def timing_part(p: CasePage) -> list:
    """Each run's wall times and work (`timing_rows`)."""
    return [section(T.TIMING, table=table(T.TIMING_HEAD, p.timing, left=2))]


def accuracy_part(p: CasePage) -> list:
    """The accuracy rows, after what they are measured against (HTML only), which of the reference
    and tolerances are defaults, and the case file's notes on them."""
    head, rows = tables.accuracy_rows(p.acc)
    said = defaults_note(p.case) if p.case.report.defaults else ""
    notes = p.case.report.notes.strip()
    pars = [" ".join(par.split()) for par in notes.split("\n\n")] if notes else []
    first = (T.UNGRADED.substitute(ungraded=html.escape(p.ungraded)) if p.ungraded
             else T.REFERENCE.substitute(reference=html.escape(p.reference)))
    return [section(T.ACCURACY, lead=first, defaults=Both(paragraph(said), said + "\n\n") if said else "",
                    notes=Both("".join(map(paragraph, pars)), "\n\n".join(pars) + "\n\n") if pars else "",
                    table=table(head, rows, left=4))]


def durability_part(p: CasePage) -> list:
    """The fatigue count of a case with a `[durability]` table (`report.durability`): what it
    counts, its table, its figure, and the table and every run's cycles as files beside the page."""
    got = p.fatigue
    if got is None:
        return []
    st, rows, cyc = got
    if not rows:
        return []
    img = durability.figure(p.case, st, rows, cyc, p.folder / "durability.png")
    atomic_write(p.folder / "durability.csv", durability.csv_text(rows))
    atomic_write(p.folder / "durability.tex", durability.latex(p.case.name, p.case.report.reference, st.curve.name,
                                                               st.curve.source, rows))
    listed = durability.write_cycles(p.folder, cyc)
    lead = (f"Rainflow count (ASTM E1049-85, exact) of {', '.join(st.channels)} after {st.discard:g} s, the residue "
            f"{'closed as the history repeats' if st.repeat else 'as half cycles'}; {st.curve.name} "
            f"({st.curve.source}); mean-stress correction: {st.correction}. Damage is Palmgren-Miner per repeat of "
            f"the counted span; S_eq = (sum n S^m / 2e6)^(1/m). Verdict: |S_eq / S_eq of the reference - 1| within "
            f"{st.tolerance:g} at m = 3 and 5. The predicted damage ratio is (S_eq ratio)^m at the slope of the one "
            f"curve segment that holds every damaging cycle, S_eq over those cycles (none is predicted where they lie "
            f"on two segments or a cycle lies within the tolerance of a cut-off); the band is (1 -/+ e)^m with e the "
            f"RMS stress difference over the counted span.")
    files_ = ["durability.csv", "durability.tex", *listed]
    links = Both("<p>" + ", ".join(f"<a href='{f}'>{f}</a>" for f in files_) + "</p>",
                 ", ".join(f"[{f}]({f})" for f in files_))
    return [section(T.DURABILITY, lead=Both(paragraph(lead), lead), images=images([img]), files=links,
                    table=table(durability.HEAD, [durability.cells(r) for r in rows], left=2))]


def convergence_part(p: CasePage) -> list:
    """Each solver against its discretisation, from the case's stored studies (`convergence.section`)."""
    got = convergence.section(p.case, p.folder, p.warn)
    return [section(T.CONVERGENCE, body=Both(*got))] if got else []


def provenance_part(p: CasePage) -> list:
    """Where each result came from (`provenance_rows`)."""
    return [section(T.PROVENANCE, table=table(T.PROVENANCE_HEAD, p.provenance, left=len(T.PROVENANCE_HEAD)))]


SECTIONS = (lead, runs_part, deflection_part, stress_part, angles_part, spectra_part, frequency_map_part, modes_part,
            elasticity_part,
            timing_part, accuracy_part, durability_part, convergence_part, provenance_part)


def page(p: CasePage, sections: list) -> Both:
    """The whole page (html, markdown): its title, the link to the index (or how to build one), its
    sections in the order given."""
    title = T.PAGE_TITLE.substitute(name=p.case.name, title=p.case.title)
    build = T.BUILD_INDEX.substitute(out=p.out)
    top = fill(T.INDEX, up=p.up) if p.indexed else fill(T.NO_INDEX, text=Both(html.escape(build), build))
    parts = [fill(T.SECTION, title=Both(html.escape(t), t), body=Both(h, m)) for t, h, m in sections]
    return fill(T.PAGE, title=Both(html.escape(title), title), css=CSS, top=top,
                sections=Both("".join(s.html for s in parts), "".join(s.md for s in parts)))


def write_case(out: Path, stage: Path, case, names, warn, indexed: bool = True, up: str = "..") -> dict:
    """One case's page from the results under `out`, written into `stage/CASE/`; it links to the
    report's index when there is one (`indexed`), and says how to build one otherwise; `up` is the
    report folder seen from the page's folder (OUT/CASE: '..'):
    {"accuracy": its accuracy rows, "runs": each run's accuracy.Outcome, "durability": its fatigue
    count's rows for the report's tables (`durability.index_rows`)}.

    Its table (`numbers`), then its sections in the order of `SECTIONS`, then its HTML and
    Markdown (`page`)."""
    p = numbers(out, stage, case, names, warn, indexed, up)
    got = page(p, [s for build in SECTIONS for s in build(p)])
    atomic_write(p.folder / "index.html", got.html)
    atomic_write(p.folder / "index.md", got.md)
    return {"accuracy": p.acc, "runs": p.runs, "durability": durability.index_rows(p.case, p.fatigue)}


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


def write_index(out: Path, stage: Path, runs: list, warn=None, fatigue: list = ()) -> None:
    """The report's index (index.html, index.md) into `stage`: the summary line, the case x solver
    matrix of verdicts (`matrix`), the table of every run (`runs`: accuracy.Outcome), links to every
    case page and the reviewer tables (`fatigue`: the durability tables written beside them, if
    any), and the latest work-precision run (`bench_section`)."""
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
    pages = ["accuracy.csv", "accuracy.md", "accuracy.tex", *fatigue]
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
