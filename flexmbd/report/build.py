"""The report: a pure function of stored results (`OUT/results/CASE/SOLVER.{csv,json}`).

    OUT/index.html, index.md          summary table case x solver, links to every page
    OUT/CASE/index.html, index.md     one page per case (figures next to it)
    OUT/accuracy.{csv,md,tex}         reviewer tables, the same numbers as the pages
"""

from __future__ import annotations

import datetime
import html
import json
from pathlib import Path

import numpy as np

from flexmbd import cases, flexbody, metrics, results, solvers
from flexmbd.report import accuracy, figures, tables
from flexmbd.results import _atomic_write

CSS = """body{font-family:sans-serif;max-width:1100px;margin:auto;padding:1em;color:#222}
table{border-collapse:collapse;margin:0.6em 0;font-size:13px}th,td{border:1px solid #bbb;padding:3px 7px;text-align:right}
th{background:#eee}td:first-child,th:first-child{text-align:left}.pass,.ok{background:#dfd}.fail{background:#fdd}
.bad{background:#fed;text-align:left}.outside{background:#ffe9a8;text-align:left}img{max-width:100%}code{background:#f4f4f4}h2{border-bottom:1px solid #ccc}"""


def load_results(out: Path, case_name: str, names) -> dict:
    """Stored results of one case, by solver (those with a sidecar)."""
    got = {}
    for s in names:
        if (out / "results" / case_name / f"{s}.json").exists():
            got[s] = results.read(out / "results", case_name, s)
    return got


def fe_modes(case) -> tuple[dict, dict]:
    """(body -> natural frequencies Hz of the retained modes, deflection channel -> (frequencies,
    labels) of the modes that move the channel's point in the channel's direction). Pre-processing,
    no solver is run."""
    bodies = flexbody.for_case(case)
    freqs = {n: fb.freq_hz.tolist() for n, fb in bodies.items()}
    per_channel = {}
    for ch, c in case["channels"].items():
        if c["kind"] == "deflection" and c["body"] in bodies:
            fb = bodies[c["body"]]
            w = np.abs(fb.Phi[fb.node_at(c["at"]), 3 + "xyz".index(c["component"])])
            keep = w > 1e-6 * w.max() if w.max() > 0 else np.zeros(w.size, dtype=bool)
            per_channel[ch] = (fb.freq_hz[keep].tolist(), fb.labels[keep].tolist())
    return freqs, per_channel


def timing_rows(res: dict, t_end: float) -> list[list]:
    rows = []
    for s, r in res.items():
        sim = r.t[-1] if len(r.t) else t_end
        rows.append([s, str(r.status), r.wall_s, r.setup_s, r.extra.get("compile_s", np.nan), r.steps, r.rhs_evals,
                     metrics.per_simulated_second(r.wall_s, sim)])
    return rows


def provenance_rows(out: Path, case_name: str, res: dict) -> list[list]:
    rows = []
    for s in res:
        meta = json.loads((out / "results" / case_name / f"{s}.json").read_text())
        rows.append([s, meta.get("solver_version", ""), meta.get("case_sha256", ""), meta.get("git_commit", ""),
                     meta.get("date", ""), meta.get("machine", ""),
                     json.dumps(meta.get("settings", {}), sort_keys=True)[:300]])
    return rows


def case_page(out: Path, case, names) -> dict:
    """Write one case's page; return its accuracy rows and summary rows."""
    res = load_results(out, case.name, names)
    ok = {s: r for s, r in res.items() if r.ok}
    mods = {s: solvers.module(s) for s in res}
    freqs, modes = fe_modes(case)
    ref = case["report"]["reference"]
    acc = accuracy.rows(case, ok, mods, freqs)
    peaks = accuracy.peak_table(case, ok, modes)
    d = out / case.name
    sections = []                                             # (title, html, markdown)

    # channels, grouped as a reader looks for them
    groups = [("Deflection", ("deflection",)), ("Stress (von Mises at the stress points)", ("stress_vm",)),
              ("Joint angles, energy and reactions", ("joint_angle", "energy", "reaction_force", "reaction_moment"))]
    for title, kinds in groups:
        chans = [n for n, c in case["channels"].items() if c["kind"] in kinds]
        if not chans:
            continue
        shown = lambda n: {s: r for s, r in ok.items() if accuracy.comparable(case, mods[s], n)}
        imgs = [figures.channel(case, n, shown(n), ref, d / f"{n}.png") for n in chans]
        sections.append((title, "".join(f"<p><img src='{i}' alt='{i}'></p>" for i in imgs),
                         "".join(f"![{i}]({i})\n\n" for i in imgs)))

    # spectra of the deflection channels, with the identified peaks
    spec = []
    for n in modes:
        if modes[n][0]:
            spec.append(figures.spectra(case, n, ok, modes[n][0], d / f"fft_{n}.png"))
    if spec:
        head = ["solver", "channel", "identified [Hz]", "FE mode", "FE [Hz]", "difference"]
        rows = [[p["solver"], p["channel"], p["f_identified"], p["mode"], p["f_fe"], p["difference"]] for p in peaks]
        note = ("<p>Hann window, zero-padded 8x; a peak must stand clear of the main lobe and side lobes of "
                "every larger peak; refined by a parabola through the log-amplitudes. Each peak is set beside the nearest FE natural frequency of "
                "the body's retained modes and named after it within 2 %. A body held differently from its mode "
                "set's boundary conditions (a pendulum's pinned root with clamped-free modes) vibrates at the "
                "system's frequencies, which are listed as unmatched.</p>")
        sections.append(("FFT spectra and identified frequencies",
                         "".join(f"<p><img src='{i}' alt='{i}'></p>" for i in spec) + note + tables.html_table(head, rows),
                         "".join(f"![{i}]({i})\n\n" for i in spec) + tables.markdown(head, rows)))

    # what elasticity changes: flexible minus rigid joint angles
    rigid = next((s for s in ("pinocchio", "mujoco") if s in ok), None)
    if "flexmbd" in ok and rigid and any(c["kind"] == "joint_angle" for c in case["channels"].values()):
        img = figures.elasticity(case, ok["flexmbd"], ok[rigid], rigid, d / "elasticity.png")
        sections.append(("Flexible minus rigid", f"<p><img src='{img}' alt='{img}'></p>", f"![{img}]({img})\n\n"))

    # timing
    head = ["solver", "status", "wall [s] (solve)", "set-up [s]", "compile [s]", "steps", "RHS evals",
            "wall / simulated s"]
    rows = timing_rows(res, case["duration"])
    sections.append(("Timing", tables.html_table(head, rows), tables.markdown(head, rows)))

    # accuracy
    head, rows = tables.accuracy_rows(acc)
    note = (f"<p>Reference: <b>{html.escape(ref)}</b>. Differences are normalised by the reference's maximum "
            "magnitude; the result compares the RMS difference with the case's tolerance. Phase-robust measures "
            "(DESIGN.md §2): dominant frequency, RMS difference of the amplitude envelopes and of the slow "
            "(low-pass below half the lowest natural frequency) parts.</p>")
    sections.append(("Accuracy", note + tables.html_table(head, rows), tables.markdown(head, rows)))

    # provenance
    head = ["solver", "version", "case sha256", "git commit", "date", "machine", "settings"]
    rows = provenance_rows(out, case.name, res)
    sections.append(("Provenance", tables.html_table(head, rows), tables.markdown(head, rows)))

    title = f"{case.name}: {case['title']}"
    page = [f"<!doctype html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title>",
            f"<style>{CSS}</style></head><body><p><a href='../index.html'>index</a></p><h1>{html.escape(title)}</h1>"]
    md = [f"# {title}\n", "[index](../index.md)\n"]
    for t, h, m in sections:
        page.append(f"<h2>{html.escape(t)}</h2>{h}")
        md.append(f"## {t}\n\n{m}")
    page.append("</body></html>")
    _atomic_write(d / "index.html", "".join(page) + "\n")
    _atomic_write(d / "index.md", "\n".join(md))
    summary = [[case.name, s, str(r.status), accuracy.worst(acc, s) if s != ref else np.nan, r.wall_s] for s, r in res.items()]
    return {"accuracy": acc, "summary": summary}


def write(out: Path, case_names, names) -> Path:
    """Every case page, the index and the reviewer tables; return the index path."""
    out = Path(out)
    all_acc, summary = [], []
    for name in case_names:
        got = case_page(out, cases.load(name), names)
        all_acc += got["accuracy"]
        summary += got["summary"]
    tables.write_accuracy(out, all_acc)
    head = ["case", "solver", "status", "worst RMS diff / max|ref|", "wall [s]"]
    links_html = [[f"<a href='{r[0]}/index.html'>{html.escape(r[0])}</a>"] + r[1:] for r in summary]
    links_md = [[f"[{r[0]}]({r[0]}/index.md)"] + r[1:] for r in summary]
    when = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    intro = (f"Every case on every solver; the worst difference is the largest normalised RMS difference from "
             f"the case's reference solver over the channels compared. Generated {when}, commit "
             f"{results.git_commit() or 'unknown'}. Reviewer tables: ")
    files = ["accuracy.csv", "accuracy.md", "accuracy.tex"]
    page = (f"<!doctype html><html><head><meta charset='utf-8'><title>flexmbd report</title><style>{CSS}</style>"
            f"</head><body><h1>flexmbd report</h1><p>{html.escape(intro)}"
            + ", ".join(f"<a href='{f}'>{f}</a>" for f in files) + "."
            + (" Benchmarks: <a href='bench/index.html'>bench</a>." if (out / "bench" / "index.html").exists() else "")
            + "</p>" + tables.html_table(head, links_html, raw_cols=(0,)) + "</body></html>")
    _atomic_write(out / "index.html", page + "\n")
    _atomic_write(out / "index.md", "# flexmbd report\n\n" + intro + ", ".join(f"[{f}]({f})" for f in files)
                  + ".\n\n" + tables.markdown(head, links_md))
    return out / "index.html"
