"""The report index: one table of case x solver with status and timing, from stored results."""

from __future__ import annotations

import html
from pathlib import Path

from flexmbd import results
from flexmbd.results import _atomic_write


def rows(out: Path, case_names, solver_names) -> list[dict]:
    """One row per stored result under out/results."""
    table = []
    for c in case_names:
        for s in solver_names:
            if not (out / "results" / c / f"{s}.json").exists():
                continue
            r = results.read(out / "results", c, s)
            table.append({"case": c, "solver": s, "status": r.status, "wall_s": r.wall_s,
                          "steps": r.steps, "channels": ", ".join(r.channels)})
    return table


def write_index(out: Path, case_names, solver_names) -> Path:
    """Write out/index.md and out/index.html; return the HTML path."""
    table = rows(out, case_names, solver_names)
    head = ["case", "solver", "status", "wall_s", "steps", "channels"]
    md = ["# flexmbd report", "", "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in table:
        md.append("| " + " | ".join(_fmt(r[h]) for h in head) + " |")
    _atomic_write(out / "index.md", "\n".join(md) + "\n")
    cells = "".join(f"<th>{h}</th>" for h in head)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(_fmt(r[h]))}</td>" for h in head) + "</tr>"
                   for r in table)
    page = (f"<!doctype html><html><head><meta charset='utf-8'><title>flexmbd report</title></head>"
            f"<body><h1>flexmbd report</h1><table border='1'><tr>{cells}</tr>{body}</table></body></html>")
    _atomic_write(out / "index.html", page + "\n")
    return out / "index.html"


def _fmt(v) -> str:
    return f"{v:.3f}" if isinstance(v, float) else str(v)
