"""Tables in Markdown, HTML and LaTeX (booktabs), and the reviewer files accuracy.{csv,md,tex}.

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

ACCURACY_COLUMNS = [
    ("case", "case"), ("solver", "solver"), ("reference", "reference"), ("channel", "channel"),
    ("rms", "RMS diff / max|ref|"), ("max", "max diff / max|ref|"), ("peak", "peak diff / max|ref|"),
    ("f_ref", "f ref [Hz]"), ("f_solver", "f solver [Hz]"), ("envelope", "envelope diff / max|ref|"),
    ("slow", "slow-part diff / max|ref|"), ("tolerance", "tolerance"), ("pass", "result"),
]


def fmt(v) -> str:
    """Numbers with 3 significant digits; NaN and None as an em dash; strings as they are."""
    if v is None:
        return "—"
    if isinstance(v, str):
        return v
    if isinstance(v, (int,)) and not isinstance(v, bool):
        return str(v)
    x = float(v)
    if math.isnan(x):
        return "—"
    return f"{x:.3g}"


def markdown(head: list, rows: list[list]) -> str:
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    out += ["| " + " | ".join(fmt(c).replace("|", "\\|") for c in r) + " |" for r in rows]
    return "\n".join(out) + "\n"


def html_table(head: list, rows: list[list], raw_cols: tuple = ()) -> str:
    """An HTML table; columns in raw_cols hold ready HTML (links), others are escaped."""
    th = "".join(f"<th>{html.escape(h)}</th>" for h in head)
    body = []
    for r in rows:
        cells = []
        for j, c in enumerate(r):
            text = fmt(c) if j not in raw_cols else c
            cls = f" class='{text}'" if text in ("pass", "fail", "ok") else ""
            if isinstance(text, str) and (text.startswith("failed") or text.startswith("unavailable")
                                          or text.startswith("not applicable")):
                cls = " class='bad'"
            if isinstance(text, str) and text.startswith("ok, outside linear validity"):
                cls = " class='outside'"
            cells.append(f"<td{cls}>{text if j in raw_cols else html.escape(text)}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    return f"<table><thead><tr>{th}</tr></thead><tbody>{''.join(body)}</tbody></table>"


def latex(head: list, rows: list[list], caption: str) -> str:
    """A booktabs table."""
    esc = lambda s: (s.replace("\\", "\\textbackslash{}").replace("_", "\\_").replace("%", "\\%")
                     .replace("&", "\\&").replace("#", "\\#").replace("|", "$|$").replace("—", "--"))
    lines = ["\\begin{table}", "\\centering", f"\\caption{{{esc(caption)}}}",
             "\\begin{tabular}{" + "l" * 4 + "r" * (len(head) - 4) + "}", "\\toprule",
             " & ".join(esc(h) for h in head) + " \\\\", "\\midrule"]
    lines += [" & ".join(esc(fmt(c)) for c in r) + " \\\\" for r in rows]
    lines += ["\\bottomrule", "\\end{tabular}", "\\end{table}"]
    return "\n".join(lines) + "\n"


def accuracy_rows(rows_: list[dict]) -> tuple[list, list[list]]:
    head = [h for _, h in ACCURACY_COLUMNS]
    return head, [[r[k] for k, _ in ACCURACY_COLUMNS] for r in rows_]


def write_accuracy(out: Path, rows_: list[dict]) -> None:
    """reports/accuracy.csv (full precision), accuracy.md and accuracy.tex (3 significant digits)."""
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow([k for k, _ in ACCURACY_COLUMNS])
    for r in rows_:
        w.writerow([f"{r[k]:.6g}" if isinstance(r[k], float) else r[k] for k, _ in ACCURACY_COLUMNS])
    atomic_write(out / "accuracy.csv", buf.getvalue())
    head, body = accuracy_rows(rows_)
    atomic_write(out / "accuracy.md", "# Accuracy against each case's reference solver\n\n" + markdown(head, body))
    atomic_write(out / "accuracy.tex", latex(head, body, "Accuracy of each solver against the case's "
                                                          "reference solver (differences normalised by the "
                                                          "reference's maximum magnitude)"))
