"""Tables in Markdown, HTML and LaTeX (booktabs, siunitx), and the reviewer files accuracy.{csv,md,tex}.

Every number in every format goes through `fmt`, so the pages and the three reviewer files
show the same digits.
"""

from __future__ import annotations

import csv
import html
import io
import math
from pathlib import Path

from flexmbd.files import atomic_write
from flexmbd.report.accuracy import Verdict
from flexmbd.results import Status

ACCURACY_COLUMNS = [
    ("case", "case"), ("solver", "solver"), ("reference", "reference"), ("channel", "channel"),
    ("rms", "RMS diff / max|ref|"), ("max", "max diff / max|ref|"), ("peak", "peak diff / max|ref|"),
    ("f_ref", "f ref [Hz]"), ("f_solver", "f solver [Hz]"), ("envelope", "envelope diff / max|ref|"),
    ("slow", "slow-part diff / max|ref|"), ("tolerance", "tolerance"), ("pass", "result"),
]


def fmt(v) -> str:
    """Numbers with 3 significant digits; NaN and None as an em dash; strings as they are; a run's
    Status or a Verdict as its one line."""
    if v is None:
        return "—"
    if isinstance(v, str):
        return v
    if isinstance(v, (Status, Verdict)):
        return str(v)
    if isinstance(v, (int,)) and not isinstance(v, bool):
        return str(v)
    x = float(v)
    if math.isnan(x):
        return "—"
    return f"{x:.3g}"


def md_cell(c) -> str:
    """A Markdown table cell: pipes escaped, line breaks as spaces."""
    return fmt(c).replace("|", "\\|").replace("\r", " ").replace("\n", " ")


def markdown(head: list, rows: list[list]) -> str:
    """A GitHub-flavoured Markdown table (header and cells escaped)."""
    out = ["| " + " | ".join(md_cell(h) for h in head) + " |", "|" + "---|" * len(head)]
    out += ["| " + " | ".join(md_cell(c) for c in r) + " |" for r in rows]
    return "\n".join(out) + "\n"


# the colour class of a cell by the kind of its Status (results.KINDS) or Verdict (accuracy.VERDICTS)
CLASSES = {"pass": "pass", "ok": "ok", "reference": "ok", "failed": "bad", "fail": "fail", "outside validity": "outside",
           "not applicable": "na", "unavailable": "na", "not compared": "na"}


def css_class(v) -> str:
    """The colour class of a cell: of a run's Status or a Verdict by its kind (an ok run outside
    its model's linear validity: 'outside'); '' for any other value."""
    if isinstance(v, Status):
        return "outside" if v.outside else CLASSES[v.kind]
    return CLASSES[v.kind] if isinstance(v, Verdict) else ""


def html_table(head: list, rows: list[list], raw_cols: tuple = ()) -> str:
    """An HTML table; columns in raw_cols hold ready HTML (links), others are escaped."""
    th = "".join(f"<th>{html.escape(h)}</th>" for h in head)
    body = []
    for r in rows:
        cells = []
        for j, c in enumerate(r):
            text = fmt(c) if j not in raw_cols else c
            cls = f" class='{css_class(c)}'" if css_class(c) else ""
            cells.append(f"<td{cls}>{text if j in raw_cols else html.escape(text)}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    return f"<table><thead><tr>{th}</tr></thead><tbody>{''.join(body)}</tbody></table>"


# the LaTeX table of one case: (key, header, siunitx column, number format) -- fits a 345 pt (A4
# article) text width
SCI = "S[table-format=1.2e-1]"
LATEX_COLUMNS = [("solver", "solver", "l", None), ("channel", "channel", "l", None),
                 ("rms", "RMS", SCI, "e"), ("max", "max", SCI, "e"),
                 ("f_ref", "{$f_\\mathrm{ref}$ [Hz]}", "S[table-format=4.1]", "f"),
                 ("f_solver", "{$f$ [Hz]}", "S[table-format=4.1]", "f"), ("tolerance", "{tol.}", SCI, "e"),
                 ("pass", "result", "l", None)]


def tex_number(v, kind: str) -> str:
    """A number for an siunitx S column: 'e' three significant digits as 1.23e-2, 'f' one
    decimal; {--} for a missing one."""
    if v is None or not math.isfinite(float(v)):
        return "{--}"
    if kind == "f":
        return f"{float(v):.1f}"
    m, e = f"{float(v):.2e}".split("e")
    return f"{m}e{int(e)}"


def tex(s: str) -> str:
    """Text escaped for LaTeX."""
    return (s.replace("\\", "\\textbackslash{}").replace("_", "\\_").replace("%", "\\%").replace("&", "\\&")
            .replace("#", "\\#").replace("$", "\\$").replace("{", "\\{").replace("}", "\\}")
            .replace("|", "\\textbar{}").replace("—", "--"))


def latex_case(case: str, rows_: list[dict]) -> str:
    """One case's accuracy table (needs PREAMBLE's packages): differences over the reference's
    largest magnitude, dominant frequencies, tolerance and result; scaled down only if it would be
    wider than the text."""
    ref = rows_[0]["reference"] if rows_ else ""
    lines = ["\\begin{table}[htbp]", "\\centering", "\\footnotesize", "\\setlength{\\tabcolsep}{2.5pt}",
             f"\\caption{{{tex(case)}: accuracy against {tex(ref)} (RMS and largest difference over the "
             f"reference's largest magnitude; dominant frequencies of the vibration)}}",
             "\\begin{adjustbox}{max width=\\linewidth}",
             "\\begin{tabular}{" + "".join(c for _, _, c, _ in LATEX_COLUMNS) + "}", "\\toprule",
             " & ".join(h for _, h, _, _ in LATEX_COLUMNS) + " \\\\", "\\midrule"]
    for r in rows_:
        lines.append(" & ".join(tex_number(r[k], n) if n else tex(fmt(r[k])) for k, _, _, n in LATEX_COLUMNS)
                     + " \\\\")
    lines += ["\\bottomrule", "\\end{tabular}", "\\end{adjustbox}", "\\end{table}"]
    return "\n".join(lines) + "\n"


PREAMBLE = ("\\usepackage{booktabs}\n\\usepackage{siunitx}\n\\usepackage{adjustbox}\n"
            "\\sisetup{output-exponent-marker=\\ensuremath{\\mathrm{e}}}\n")


def latex_document(rows_: list[dict]) -> str:
    """A compilable document with one accuracy table per case."""
    cases = list(dict.fromkeys(r["case"] for r in rows_))
    body = [latex_case(c, [r for r in rows_ if r["case"] == c]) for c in cases]
    return ("\\documentclass[a4paper]{article}\n" + PREAMBLE + "\\begin{document}\n" + "\n".join(body) + "\\end{document}\n")


# the tidy accuracy.csv: one row per (case, solver, channel, metric), with its unit
TIDY_METRICS = [("rms", "1"), ("max", "1"), ("peak", "1"), ("f_ref", "Hz"), ("f_solver", "Hz"), ("envelope", "1"),
                ("slow", "1"), ("tolerance", "1"), ("pass", "")]


def tidy_csv(rows_: list[dict]) -> str:
    """Long-format CSV, LF line endings, an empty cell for a missing value; differences are
    normalised by the reference's largest magnitude (unit 1)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["case", "solver", "reference", "channel", "metric", "value", "unit"])
    for r in rows_:
        for k, unit in TIDY_METRICS:
            v = r[k]
            value = "" if v is None or (isinstance(v, float) and math.isnan(v)) else (
                f"{v:.6g}" if isinstance(v, float) else str(v))
            w.writerow([r["case"], r["solver"], r["reference"], r["channel"], k, value, unit])
    return buf.getvalue()


def accuracy_rows(rows_: list[dict]) -> tuple[list, list[list]]:
    """The accuracy table's header and cells; the result (row key `pass`: 'pass', 'fail' or ''
    with no tolerance) as a Verdict of that kind."""
    head = [h for _, h in ACCURACY_COLUMNS]
    cell = lambda k, v: Verdict(v, v) if k == "pass" and v else v
    return head, [[cell(k, r[k]) for k, _ in ACCURACY_COLUMNS] for r in rows_]


def write_accuracy(out: Path, rows_: list[dict]) -> None:
    """reports/accuracy.csv (tidy, full precision), accuracy.md and accuracy.tex (3 significant
    digits; a document with one table per case)."""
    atomic_write(out / "accuracy.csv", tidy_csv(rows_))
    head, body = accuracy_rows(rows_)
    atomic_write(out / "accuracy.md", "# Accuracy against each case's reference solver\n\n" + markdown(head, body))
    atomic_write(out / "accuracy.tex", latex_document(rows_))
