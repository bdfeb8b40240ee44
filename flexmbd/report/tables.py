"""Tables in Markdown, HTML and LaTeX (booktabs), and the reviewer files accuracy.{csv,md,tex}.

Every number in every format goes through `fmt`, so the pages and the three reviewer files
show the same digits.
"""

from __future__ import annotations

import csv
import html
import io
import math
import re
from pathlib import Path

import numpy as np

from flexmbd.core.files import atomic_write
from flexmbd.report import accuracy
from flexmbd.report.accuracy import Verdict
from flexmbd.harness.results import CAUSES, Status

# the accuracy table's columns: (row key, header, what it means, with its unit) -- the legend of accuracy.md
ACCURACY_COLUMNS = [
    ("case", "case", "the case (cases/CASE.toml)"),
    ("solver", "solver", "the solver compared"),
    ("reference", "reference", "the case's reference solver (report.reference), which it is compared with"),
    ("channel", "channel", "the channel compared (its kind, body, place and SI unit on the case page)"),
    ("rms", "RMS diff / max|ref|", "RMS of the difference from the reference over the run, divided by the "
     "reference's largest magnitude (dimensionless)"),
    ("max", "max diff / max|ref|", "largest difference from the reference, divided by the reference's largest "
     "magnitude (dimensionless)"),
    ("peak", "peak diff / max|ref|", "difference of the largest magnitudes, divided by the reference's "
     "(dimensionless)"),
    ("f_ref", "f ref [Hz]", "dominant vibration frequency of the reference (deflection and stress channels; Hz)"),
    ("f_solver", "f solver [Hz]", "dominant vibration frequency of the solver (Hz)"),
    ("envelope", "envelope diff / max|ref|", "RMS difference of the amplitude envelopes of the vibration, "
     "divided by the reference's largest magnitude (dimensionless; robust to a phase drift)"),
    ("slow", "slow-part diff / max|ref|", "RMS difference of the slow parts (low-pass below half the lowest "
     "natural frequency), divided by the reference's largest magnitude (dimensionless)"),
    ("tolerance", "tolerance", "the case's tolerance on the RMS difference (report.tolerances; dimensionless; "
     "— : the channel is not graded)"),
    ("pass", "result", "pass or fail: the RMS difference within its tolerance or not; a run that diverged or "
     "was aborted has one row with its status and no differences"),
]


def fmt(v) -> str:
    """Numbers with 3 significant digits, in the notation their magnitude calls for
    (`accuracy.number`); NaN and None as an em dash; strings as they are; a run's Status as its
    one line with its word (`accuracy.status_text`); a Verdict with its icon and validity flag."""
    if v is None:
        return "—"
    if isinstance(v, str):
        return v
    if isinstance(v, Status):
        return f"{ICONS.get(accuracy.run_word(v), '')} {accuracy.status_text(v)}".strip()
    if isinstance(v, Verdict):
        flag = f" {FLAG} outside linear validity: {v.outside}" if v.outside else ""
        return f"{ICONS.get(v.kind, '')} {v.text}".strip() + flag
    if isinstance(v, (int,)) and not isinstance(v, bool):
        return str(v)
    x = float(v)
    if math.isnan(x):
        return "—"
    return accuracy.number(x)


def md_cell(c) -> str:
    """A Markdown table cell: pipes escaped, line breaks as spaces."""
    return fmt(c).replace("|", "\\|").replace("\r", " ").replace("\n", " ")


def markdown(head: list, rows: list[list]) -> str:
    """A GitHub-flavoured Markdown table (header and cells escaped)."""
    out = ["| " + " | ".join(md_cell(h) for h in head) + " |", "|" + "---|" * len(head)]
    out += ["| " + " | ".join(md_cell(c) for c in r) + " |" for r in rows]
    return "\n".join(out) + "\n"


# each verdict (accuracy.VERDICTS) and run word (accuracy.run_word): its icon and colour class;
# the kinds of older records ('failed', 'outside validity') as what they meant
ICONS = {"pass": "✓", "ok": "✓", "fail": "✗", "diverged": "↯", "aborted": "■", "not applicable": "–",
         "unavailable": "?", "reference": "★", "not compared": "○", "failed": "↯", "outside validity": "◐"}
CLASSES = {"pass": "pass", "ok": "pass", "fail": "fail", "diverged": "diverged", "aborted": "aborted",
           "not applicable": "na", "unavailable": "unavailable", "reference": "ref", "not compared": "notcompared",
           "failed": "diverged", "outside validity": "outside"}
FLAG = "◐"      # the validity flag, beside a verdict


def css_class(v) -> str:
    """The colour class of a cell: of a run's Status by its word (`accuracy.run_word`), of a
    Verdict by its kind; '' for any other value."""
    if isinstance(v, Status):
        return CLASSES[accuracy.run_word(v)]
    return CLASSES.get(v.kind, "") if isinstance(v, Verdict) else ""


def html_cell(v) -> str:
    """A cell's HTML: a Verdict or Status as its text (its icon comes with its colour class:
    `icon_css`) and (a Verdict) the validity flag beside it, each escaped; any other value as
    `fmt` gives it."""
    if isinstance(v, Status):
        return html.escape(accuracy.status_text(v))
    if not isinstance(v, Verdict):
        return html.escape(fmt(v))
    flag = f" <span class='flag'>outside linear validity: {html.escape(v.outside)}</span>" if v.outside else ""
    return html.escape(v.text) + flag


def icon_css() -> str:
    """The CSS giving each colour class's cells (`CLASSES`) its icon before the text (joined to it
    by a no-break space), and the validity flag its own."""
    first = {}
    for kind, cls in CLASSES.items():
        first.setdefault(cls, ICONS[kind])
    return "".join(f"td.{cls}::before{{content:'{icon}\\a0'}}" for cls, icon in first.items() if cls != "outside") \
        + f".flag::before{{content:'{FLAG}\\a0'}}"


def html_table(head: list, rows: list[list], raw_cols: tuple = (), left: int = 1) -> str:
    """An HTML table; columns in raw_cols hold ready HTML (links), others are escaped; its first
    `left` columns (text) aligned left (the page's CSS: left2, left3, left4, left9), the others right."""
    th = "".join(f"<th>{html.escape(h)}</th>" for h in head)
    body = []
    for r in rows:
        cells = []
        for j, c in enumerate(r):
            k = f" class='{css_class(c)}'" if css_class(c) else ""
            cells.append(f"<td{k}>{c if j in raw_cols else html_cell(c)}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    attr = f" class='left{left}'" if left > 1 else ""
    return f"<table{attr}><thead><tr>{th}</tr></thead><tbody>{''.join(body)}</tbody></table>"


# ---------------------------------------------------------------------------------------------
# LaTeX: booktabs tables to \input into a paper

# the LaTeX table of one case: (row key, header, alignment, a number); the differences and the
# tolerance are relative (over the reference's largest magnitude): no unit beside them
LATEX_COLUMNS = [("solver", "solver", "l", False), ("label", "channel", "l", False),
                 ("rms", "RMS", "r", True), ("max", "max", "r", True),
                 ("f_ref", "$f_\\mathrm{ref}$ [Hz]", "r", True), ("f_solver", "$f$ [Hz]", "r", True),
                 ("tolerance", "tol.", "r", True), ("pass", "result", "l", False)]
PACKAGES = "\\usepackage{booktabs}"
# widths (pt) the tables are fitted to: a two-column article's column and its text (10 pt, letter)
COLUMN_PT, TEXT_PT = 229.0, 469.0
CHAR_PT, SEP_PT = 4.3, 12.0     # \footnotesize: a character's width (generous), a column's separation
FILL = 0.97                     # the share of its place a table may take
# rows of one float: 40 \footnotesize rows (9.5 pt each) and a caption of a few lines take about
# 450 pt, within the text height of a two-column article's page (549 to 598 pt: letter or A4, 10
# or 12 pt); a longer table goes on in the next float ("continued")
ROWS = 40


def tex_number(v) -> str:
    """A number as LaTeX math: its 3 significant digits (`accuracy.number`), written as they are
    (never grouped: 0.00425, 12346), scientific notation as a power of ten; -- for a missing one."""
    if v is None or not math.isfinite(float(v)):
        return "--"
    mant, _, exp = accuracy.number(float(v)).partition("e")
    return f"${mant}" + (f"\\times10^{{{int(exp)}}}" if exp else "") + "$"


def tex(s: str) -> str:
    """Text escaped for LaTeX."""
    return (s.replace("\\", "\\textbackslash{}").replace("_", "\\_").replace("%", "\\%").replace("&", "\\&")
            .replace("#", "\\#").replace("$", "\\$").replace("{", "\\{").replace("}", "\\}")
            .replace("|", "\\textbar{}").replace("—", "--").replace("×", "$\\times$")
            .replace("~", "\\textasciitilde{}").replace("^", "\\textasciicircum{}"))


def shown_width(cell: str) -> int:
    """Characters a cell takes when typeset: a number (`tex_number`) as its digits (a power of
    ten: its mantissa, 'x10' and the exponent), other LaTeX commands not counted."""
    text = cell.replace("\\times", "x")
    text = re.sub(r"\\[a-zA-Z]+(\{\})?", "", text)
    return len(re.sub(r"[${}^]", "", text))


def pieces(body: list[list], most: int = ROWS) -> list[list[list]]:
    """A table's rows cut into floats of at most `most` rows each: a group (a heading, a row of one
    cell, and the rows under it) kept whole in the next float when it fits one, else cut, its
    heading said again (continued) at the top of the next."""
    groups = []
    for r in body:
        if len(r) == 1 or not groups:
            groups.append([])
        groups[-1].append(r)
    out, cur = [], []
    for g in groups:
        if cur and len(cur) + len(g) > most:
            out.append(cur)
            cur = []
        while len(g) > most:
            out.append(g[:most])
            g = ([[g[0][0] + " (continued)"]] if len(g[0]) == 1 else []) + g[most:]
        cur += g
    return out + [cur] if cur else out


def latex_table(caption: str, label: str, head: list, align: list, body: list[list], note: str = "",
                wrap: int | None = None) -> str:
    """A booktabs table of ready LaTeX cells, \\input-able and never scaled: in one column (`table`)
    when its estimated width (`shown_width`) fits a two-column article's column, else across the
    text (`table*`), in floats of at most ROWS rows each (`pieces`), so that each fits a page: the
    first with the caption and label, the others "Continued from Table N" (labels LABEL:2, ...).
    A row of two cells is a first cell and a text spanning the other columns, a row of one cell a
    heading (in italics) spanning them all.
    What is still too wide for its place is wrapped: the column `wrap` (ragged right) and the
    spanning texts."""
    full = [r for r in body if len(r) == len(head)]
    widths = [max(shown_width(c) for c in col) * CHAR_PT + SEP_PT for col in zip(head, *full)]
    spans = [shown_width(r[1]) * CHAR_PT + SEP_PT for r in body if len(r) == 2 < len(head)]
    heads = [shown_width(r[0]) * CHAR_PT for r in body if len(r) == 1]
    natural = max([sum(widths)] + [widths[0] + w for w in spans] + heads)
    env = "table" if natural <= COLUMN_PT else "table*"
    room = FILL * (COLUMN_PT if env == "table" else TEXT_PT)
    align = list(align)
    if wrap is not None and sum(widths) > room:
        align[wrap] = f"p{{{max(room - sum(widths) + widths[wrap] - SEP_PT, 6 * CHAR_PT):.0f}pt}}"
        body = [[("\\raggedright " + c if k == wrap and len(r) == len(head) else c) for k, c in enumerate(r)]
                for r in body]
    span = "l" if widths[0] + max(spans, default=0) <= room else f"p{{{room - widths[0] - SEP_PT:.0f}pt}}"
    cells = lambda r: r if len(r) == len(head) else [f"\\multicolumn{{{len(head)}}}{{@{{}}l}}{{\\emph{{{r[0]}}}}}"] \
        if len(r) == 1 else [r[0], f"\\multicolumn{{{len(head) - 1}}}{{{span}}}"
                                   f"{{{'' if span == 'l' else chr(92) + 'raggedright '}{r[1]}}}"]
    floats = []
    for k, part in enumerate(pieces(body)):
        said = (caption, label) if k == 0 else (f"Continued from Table~\\ref{{{label}}}.", f"{label}:{k + 1}")
        lines = [f"\\begin{{{env}}}[tbp]", "\\centering", "\\footnotesize",
                 f"\\caption{{{said[0]}}}", f"\\label{{{said[1]}}}",
                 f"\\begin{{tabular}}{{@{{}}{''.join(align)}@{{}}}}", "\\toprule", " & ".join(head) + " \\\\",
                 "\\midrule"]
        lines += [" & ".join(cells(r)) + " \\\\" for r in part]
        lines += ["\\bottomrule", "\\end{tabular}"]
        if note:
            lines += ["\\par\\smallskip", f"\\parbox{{\\linewidth}}{{\\raggedright {note}}}"]
        lines.append(f"\\end{{{env}}}")
        floats.append("\n".join(lines) + "\n")
    return "\n".join(floats)


def latex_case(case: str, rows_: list[dict]) -> str:
    """One case's accuracy table (booktabs): per solver and channel (by its name, row key `label`:
    `channels.label` without its unit, which the relative differences beside it do not have) the
    RMS and largest difference over the reference's largest magnitude, the dominant frequencies,
    the tolerance and the result; a run that did not end (row key `status`) one row saying so."""
    ref = next((r["reference"] for r in rows_ if r["reference"]), "")
    text = lambda r, k: unitless(r.get(k) or r["channel"]) if k == "label" else fmt(r[k])
    body = [[tex(r["solver"]), tex(r["status"])] if r.get("status") else
            [tex_number(r[k]) if n else tex(text(r, k)) for k, _, _, n in LATEX_COLUMNS] for r in rows_]
    return latex_table(f"{tex(case)}: accuracy against {tex(ref)}. RMS and largest difference over the "
                       "reference's largest magnitude, and the tolerance on the RMS difference: ratios, without a "
                       "unit; dominant vibration frequencies; the result compares the RMS difference with the "
                       "tolerance.", f"tab:accuracy:{case}",
                       [h for _, h, _, _ in LATEX_COLUMNS], [a for _, _, a, _ in LATEX_COLUMNS], body, wrap=1)


def unitless(label: str) -> str:
    """A channel's name without the SI unit `channels.label` ends it with ('deflection y at 8 m')."""
    return re.sub(r" \[[^\[\]]*\]$", "", label)


def latex_summary(runs: list) -> str:
    """Every compared, reference, diverged or aborted run (`runs`: accuracy.Outcome; those not
    applicable or unavailable left out), under its case: its verdict word, marked when the run
    left its model's linear validity, its worst RMS difference over the reference's largest
    magnitude and its solve wall time."""
    shown = [o for o in runs if o.verdict.kind not in ("not applicable", "unavailable")]
    mark = "$^\\dagger$"
    body = []
    for case in dict.fromkeys(o.case for o in shown):
        body.append([tex(case)])
        body += [[tex(o.solver), tex(o.verdict.kind) + (mark if o.verdict.outside else ""), tex_number(o.worst),
                  tex_number(o.wall_s)] for o in shown if o.case == case]
    note = (f"{mark}\\,outside its model's linear validity." if any(o.verdict.outside for o in shown) else "")
    return latex_table("Verdict of every run, by case: pass when every graded channel's RMS difference from the "
                       "case's reference solver, over the reference's largest magnitude, is within its tolerance; the "
                       "worst such difference (a ratio, without a unit); the solve wall time.", "tab:accuracy:summary",
                       ["solver", "verdict", "worst RMS", "wall [s]"], list("llrr"), body, note)


def latex_document(rows_: list[dict], runs: list) -> str:
    """accuracy.tex: the summary table and one table per case, each \\input-able into a document
    loading booktabs (no document of its own)."""
    cases = list(dict.fromkeys(r["case"] for r in rows_))
    head = ("% flexmbd accuracy tables: \\input{accuracy.tex} into a document with\n"
            + "".join(f"% {line}\n" for line in PACKAGES.splitlines()))
    return head + "\n" + latex_summary(runs) + "\n" + "\n".join(
        latex_case(c, [r for r in rows_ if r["case"] == c]) for c in cases)


# the tidy accuracy.csv: one row per (case, solver, channel, metric), with its unit
TIDY_METRICS = [("rms", "1"), ("max", "1"), ("peak", "1"), ("f_ref", "Hz"), ("f_solver", "Hz"), ("envelope", "1"),
                ("slow", "1"), ("tolerance", "1"), ("pass", "")]


def tidy_csv(rows_: list[dict]) -> str:
    """Long-format CSV, LF line endings, an empty cell for a missing value; differences are
    normalised by the reference's largest magnitude (unit 1). A run that did not end has one
    row, metric `pass`, its word (diverged, aborted) and no channel."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["case", "solver", "reference", "channel", "metric", "value", "unit"])
    for r in rows_:
        for k, unit in TIDY_METRICS if not r.get("status") else [("pass", "")]:
            v = r[k]
            value = "" if v is None or (isinstance(v, float) and math.isnan(v)) else (
                f"{v:.6g}" if isinstance(v, float) else str(v))
            w.writerow([r["case"], r["solver"], r["reference"], r["channel"], k, value, unit])
    return buf.getvalue()


def with_failed(rows_: list[dict], runs: list) -> list[dict]:
    """The accuracy rows with one row for each run that diverged or was aborted (`runs`:
    accuracy.Outcome), after its case's rows: no channel, no differences, `pass` its word and
    `status` its one line."""
    out = list(rows_)
    for o in runs:
        if o.verdict.kind not in CAUSES:
            continue
        ref = next((p.solver for p in runs if p.case == o.case and p.verdict.kind == "reference"), "")
        row = {**{k: np.nan for k, _, _ in ACCURACY_COLUMNS}, "case": o.case, "solver": o.solver, "reference": ref,
               "channel": "", "label": "", "pass": o.verdict.kind, "status": accuracy.status_text(o.status)}
        last = max((k for k, r in enumerate(out) if r["case"] == o.case), default=len(out) - 1)
        out.insert(last + 1, row)
    return out


def accuracy_rows(rows_: list[dict]) -> tuple[list, list[list]]:
    """The accuracy table's header and cells; the result (row key `pass`: 'pass', 'fail', '' with
    no tolerance, or a run's word, `with_failed`) as a Verdict of that kind, a run that did not end
    with its status line."""
    head = [h for _, h, _ in ACCURACY_COLUMNS]

    def cell(r, k):
        if k == "pass" and r[k]:
            return Verdict(r[k], r.get("status") or r[k])
        return "—" if k == "channel" and r.get("status") else r[k]
    return head, [[cell(r, k) for k, _, _ in ACCURACY_COLUMNS] for r in rows_]


def legend() -> str:
    """accuracy.md's legend: each column, what it means and its unit."""
    return "".join(f"- **{h}**: {meaning}\n" for _, h, meaning in ACCURACY_COLUMNS)


def write_accuracy(out: Path, rows_: list[dict], runs: list = ()) -> None:
    """reports/accuracy.csv (tidy, full precision), accuracy.md (with a legend of its columns) and
    accuracy.tex (3 significant digits; \\input-able tables: `latex_document`), and the same tables
    one to a file, tex/summary.tex and tex/CASE.tex; the runs that diverged or were aborted
    (`runs`: accuracy.Outcome) have a row in each."""
    full = with_failed(rows_, list(runs))
    atomic_write(out / "accuracy.csv", tidy_csv(full))
    head, body = accuracy_rows(full)
    atomic_write(out / "accuracy.md", "# Accuracy against each case's reference solver\n\nColumns:\n\n" + legend()
                 + "\n" + markdown(head, body))
    atomic_write(out / "accuracy.tex", latex_document(full, list(runs)))
    tex_dir = out / "tex"                       # the same tables one to a file, to \input one of them
    tex_dir.mkdir(exist_ok=True)
    atomic_write(tex_dir / "summary.tex", latex_summary(list(runs)))
    for c in dict.fromkeys(r["case"] for r in full):
        atomic_write(tex_dir / f"{c}.tex", latex_case(c, [r for r in full if r["case"] == c]))
