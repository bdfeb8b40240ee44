"""The report's tables: numbers by magnitude, verdict cells, the accuracy.md legend, failed runs'
rows, and the LaTeX tables compiled into a two-column article."""

import re
import shutil
import subprocess

import numpy as np
import pytest

from flexmbd.harness import results
from flexmbd.report import accuracy, tables
from flexmbd.report.accuracy import Outcome, Verdict

pytestmark = pytest.mark.kernel_free


def row(case, solver, channel, rms, tol, label=None, f=np.nan):
    """An accuracy row as accuracy.rows gives it."""
    return {"case": case, "solver": solver, "reference": "exudyn-beam", "channel": channel,
            "label": label or channel, "rms": rms, "max": 3 * rms, "peak": rms / 2, "f_ref": f, "f_solver": f,
            "envelope": rms / 3, "slow": rms / 4, "tolerance": tol,
            "pass": "" if np.isnan(tol) else ("pass" if rms <= tol else "fail")}


ROWS = [row("rotating_cantilever", "flexmbd", "tip_deflection", 0.00031, 0.005, "deflection y of beam1 at 0.75 m [m]",
            0.0378),
        row("rotating_cantilever", "exudyn-ffrf", "root_stress", 1.27e-6, 0.05, "von Mises stress of beam1 at 0.03 m [Pa]",
            1234.5),
        row("rotating_cantilever", "mujoco-rod", "hub_angle", 0.0397, 0.02, "angle of hub [rad]")]
OK, OUT = results.Status(), results.outside_validity("deflection 12 % of length", 0.3)
RUNS = [Outcome("rotating_cantilever", "flexmbd", OUT, accuracy.verdict(OUT, "flexmbd", "exudyn-beam", ROWS), 3.1e-4, 2.5),
        Outcome("rotating_cantilever", "exudyn-ffrf", OK, accuracy.verdict(OK, "exudyn-ffrf", "exudyn-beam", ROWS),
                1.27e-6, 14.0),
        Outcome("rotating_cantilever", "mujoco-rod", OK, accuracy.verdict(OK, "mujoco-rod", "exudyn-beam", ROWS),
                0.0397, 0.8),
        Outcome("rotating_cantilever", "exudyn-beam", OK, accuracy.verdict(OK, "exudyn-beam", "exudyn-beam", ROWS),
                np.nan, 120.0)]
DIVERGED = results.diverged("diverged (|tip_deflection| beyond 16 m, 2 beam lengths)", 10.58)
RUNS.append(Outcome("rotating_cantilever", "exudyn-beam-2", DIVERGED,
                    accuracy.verdict(DIVERGED, "exudyn-beam-2", "exudyn-beam", ROWS), np.nan, 9.0))


@pytest.mark.parametrize("x, shown", [(0.0378, "0.0378"), (401.2, "401"), (12345.6, "12346"), (1.27e-6, "1.27e-6"),
                                      (2.5e5, "2.5e5"), (0.02, "0.02"), (0.0009996, "0.001"), (0.0, "0"),
                                      (-3.14159e-7, "-3.14e-7")])
def test_numbers_keep_three_significant_digits_in_the_notation_their_magnitude_calls_for(x, shown):
    assert accuracy.number(x) == tables.fmt(x) == shown
    mant, _, exp = shown.partition("e")
    assert tables.tex_number(x) == f"${mant}" + (f"\\times10^{{{int(exp)}}}" if exp else "") + "$"


def test_no_nonzero_number_reads_zero():
    for x in np.geomspace(1e-12, 1e12, 241):
        for v in (x, -x):
            assert float(accuracy.number(v)) != 0 and float(accuracy.number(v)) == pytest.approx(v, rel=5e-3)


def test_a_fail_says_how_many_times_its_tolerance():
    v = RUNS[2].verdict
    assert v == ("fail", "fail: hub_angle RMS 0.0397 = 2.0 × its tolerance 0.02", "")


def test_the_validity_flag_stands_beside_the_verdict():
    v = RUNS[0].verdict
    assert v.kind == "pass" and v.outside == "deflection 12 % of length"
    assert str(v) == "pass: 1 channel within tolerance; outside linear validity: deflection 12 % of length"
    cell = tables.html_cell(v)
    assert cell == ("pass: 1 channel within tolerance <span class='flag'>outside linear validity: deflection 12 % of "
                    "length</span>")
    assert ".flag::before{content:'◐\\a0'}" in tables.icon_css()
    assert accuracy.summary([o.verdict for o in RUNS]) == ("5 runs: 2 pass, 1 fail, 1 diverged, 1 reference "
                                                           "(1 outside linear validity)")


def test_each_verdict_has_its_own_word_icon_and_colour():
    assert len(set(accuracy.VERDICTS)) == len(accuracy.VERDICTS)
    icons = [tables.ICONS[k] for k in accuracy.VERDICTS]
    assert len(set(icons)) == len(icons)
    assert len({tables.CLASSES[k] for k in accuracy.VERDICTS}) == len(accuracy.VERDICTS)   # each its class, so its icon
    assert accuracy.run_word(results.failed("step size too small", 0.2)) == "aborted"
    assert accuracy.run_word(results.diverged("non-finite state", 0.2)) == "diverged"
    assert accuracy.status_text(DIVERGED) == "diverged (|tip_deflection| beyond 16 m, 2 beam lengths) at t = 10.58 s"
    assert accuracy.status_text(results.failed("step size too small", 0.2)) == "aborted: step size too small at t = 0.2 s"


def test_a_diverged_run_has_a_row_in_every_table():
    full = tables.with_failed(ROWS, RUNS)
    assert [r["solver"] for r in full][-1] == "exudyn-beam-2" and full[-1]["pass"] == "diverged"
    csv = tables.tidy_csv(full)
    assert "rotating_cantilever,exudyn-beam-2,exudyn-beam,,pass,diverged," in csv
    head, body = tables.accuracy_rows(full)
    assert "↯ diverged (\\|tip_deflection\\| beyond 16 m" in tables.markdown(head, body)
    tex = tables.latex_document(full, RUNS)
    assert "exudyn-beam-2 & \\multicolumn{7}{l}{diverged (\\textbar{}tip\\_deflection\\textbar{} beyond 16 m" in tex


def test_each_table_is_also_a_file_of_its_own(tmp_path):
    """tex/summary.tex and tex/CASE.tex: the tables of accuracy.tex, one to a file."""
    tables.write_accuracy(tmp_path, ROWS, RUNS)
    whole = (tmp_path / "accuracy.tex").read_text()
    files = sorted(p.name for p in (tmp_path / "tex").iterdir())
    assert files == sorted(["summary.tex"] + [f"{c}.tex" for c in {r["case"] for r in ROWS}])
    for p in (tmp_path / "tex").iterdir():
        part = p.read_text()
        assert part.count("\\toprule") == 1 and part in whole


def test_accuracy_md_defines_every_column(tmp_path):
    tables.write_accuracy(tmp_path, ROWS, RUNS)
    md = (tmp_path / "accuracy.md").read_text()
    legend = re.findall(r"^- \*\*(.+?)\*\*: ", md, re.M)
    head = next(line for line in md.splitlines() if line.startswith("| case"))
    cols = [c.strip().replace("\\|", "|") for c in re.split(r"(?<!\\)\|", head)[1:-1]]
    assert cols == legend


def test_latex_tables_are_inputable_and_use_human_channel_names():
    tex = tables.latex_document(ROWS, RUNS)
    assert "\\documentclass" not in tex and "adjustbox" not in tex and "\\begin{document}" not in tex
    assert tex.count("\\toprule") == 2                        # the summary and the case
    assert "deflection y of beam1 at 0.75 m &" in tex and "tip\\_deflection &" not in tex
    assert "$0.0378$" in tex and "$1.27\\times10^{-6}$" in tex
    assert not re.search(r"\de-?\d", tex)                      # powers of ten written as such
    assert "pass$^\\dagger$" in tex                           # the validity flag beside the verdict


def compile_input(tmp_path, tex: str) -> str:
    """pdflatex's log of a two-column article that \\input's `tex` (with the packages it asks for)."""
    (tmp_path / "accuracy.tex").write_text(tex)
    (tmp_path / "paper.tex").write_text(f"\\documentclass[twocolumn]{{article}}\n{tables.PACKAGES}\n"
                                        "\\begin{document}\nText.\n\\input{accuracy.tex}\n\\end{document}\n")
    r = subprocess.run(["pdflatex", "-interaction=nonstopmode", "-halt-on-error", "paper.tex"], cwd=tmp_path,
                       capture_output=True, text=True, timeout=120)
    log = (tmp_path / "paper.log").read_text(errors="replace")
    assert r.returncode == 0, log[-2000:]
    return log


@pytest.mark.skipif(shutil.which("pdflatex") is None, reason="no TeX engine on this machine")
def test_latex_tables_compile_in_a_two_column_article_and_fit(tmp_path):
    tex = tables.latex_document(tables.with_failed(ROWS, RUNS), RUNS)
    assert "\\begin{table*}" in tex                           # the case's 8 columns: the text width
    log = compile_input(tmp_path, tex)
    assert "Overfull \\hbox" not in log


@pytest.mark.skipif(shutil.which("pdflatex") is None, reason="no TeX engine on this machine")
def test_a_table_put_in_one_column_fits_it(tmp_path):
    """The choice of `table` against `table*` is tight enough: a summary chosen for one column fits."""
    runs = [o._replace(case="cantilever_step") for o in RUNS if o.verdict.kind != "diverged"]
    tex = tables.latex_summary(runs)
    assert "\\begin{table}" in tex
    assert "Overfull \\hbox" not in compile_input(tmp_path, tex)
