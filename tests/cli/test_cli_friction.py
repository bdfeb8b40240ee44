"""What a user meets on the command line: the exit statuses of report, compare and regress as the
README and each command's --help say them, compare's page beside the report's (never over it),
compare --t-end, list CASE, the LaTeX reviewer tables (they fit a two-column page, numbers written
plainly, no unit beside a relative difference) and a result's record of flexmbd's source.

Every run here is of the cantilever on its closed form (`analytic`) and its reference (`fe-linear`),
shortened where a full run is not needed; the tolerance no run meets is set in a copy of the case."""

import argparse
import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from flexmbd import cases, version
from flexmbd.harness import results
from flexmbd.cli import EXIT, main, parser
from flexmbd.report import accuracy, tables
from flexmbd.report.accuracy import Outcome
from tests.report.test_tables import compile_input

pytestmark = pytest.mark.heavy(19)       # seconds, measured with both cores busy (tests/conftest.py)

ROOT = Path(__file__).resolve().parents[2]
FAST = ["--solvers", "analytic,fe-linear", "--workers", "1"]


@pytest.fixture
def tight(tmp_path) -> Path:
    """The cantilever, 0.05 s long, with a tolerance on its tip deflection that no solver meets."""
    text = cases.find("cantilever_step").read_text()
    text = re.sub(r"(?m)^duration = .*$", "duration = 0.05", text)
    text = re.sub(r"tolerances = \{[^}]*\}", "tolerances = { tip_deflection = 1e-12, stress_vm = 1.0 }", text)
    path = tmp_path / "tight.toml"
    path.write_text(text)
    return path


# ---------------------------------------------------------------------------------------------
# exit statuses: one meaning each, the same in the README, in --help and in the behaviour


def test_report_and_compare_exit_0_over_a_fail_and_1_with_strict(tight, tmp_path, capsys):
    """A fail is shown as a fail (the summary line), and the command that wrote its pages did its
    work: exit 0; --strict makes it a gate: exit 1."""
    out = str(tmp_path / "rep")
    assert main(["report", "--cases", str(tight), *FAST, "--out", out]) == 0
    assert "1 fail" in capsys.readouterr().out
    assert main(["report", "--cases", str(tight), *FAST, "--out", out, "--no-run", "--strict"]) == 1
    assert main(["compare", str(tight), *FAST, "--out", out]) == 0
    assert "tight / analytic: fail: tip_deflection" in capsys.readouterr().out
    assert main(["compare", str(tight), *FAST, "--out", out, "--strict"]) == 1


def test_regress_exits_1_on_a_difference_without_strict(tmp_path, capsys):
    """A baseline moved by 10 %: the fresh run differs from it, exit 1 with no option asked."""
    base = tmp_path / "base" / "cantilever_step"
    base.mkdir(parents=True)
    lines = (ROOT / "references" / "baselines" / "cantilever_step" / "analytic.csv").read_text().splitlines()
    head = [line for line in lines if line.startswith("#") or line.startswith("t,")]
    rows = [",".join(repr(1.1 * float(x)) if k == 1 else x for k, x in enumerate(line.split(",")))
            for line in lines[len(head):]]
    (base / "analytic.csv").write_text("\n".join(head + rows) + "\n")
    argv = ["regress", "--baseline", str(tmp_path / "base"), "--cases", "cantilever_step", "--solvers", "analytic",
            "--workers", "1"]
    assert main(argv) == 1
    assert "moved: cantilever_step / analytic / tip_deflection" in capsys.readouterr().err


def test_the_readme_and_each_command_s_help_say_the_same_exit_statuses():
    subs = next(a for a in parser()._actions if isinstance(a, argparse._SubParsersAction)).choices
    for name in ("run", "report", "compare", "regress"):
        text = " ".join(subs[name].format_help().split())
        assert " ".join(EXIT[name].split()) in text, name
    for name in ("report", "compare"):
        assert "Exit status: 0 once the" in EXIT[name] and "1 with --strict" in EXIT[name]
        assert "exit 0 once the pages are written" in " ".join(subs[name].format_help().split())
    assert "1 when a result moved" in EXIT["regress"] and "with or without --strict" in EXIT["regress"]
    readme = (ROOT / "README.md").read_text()
    one = next(line for line in readme.splitlines() if line.startswith("| 1 |"))
    zero = next(line for line in readme.splitlines() if line.startswith("| 0 |"))
    assert "`regress`" in one and "with `--strict`" in one and one.index("`regress`") < one.index("with `--strict`")
    assert "`report` or `compare`" in zero and "fail" in zero


# ---------------------------------------------------------------------------------------------
# compare beside the report


def test_compare_writes_its_own_page_and_leaves_the_report_s_as_it_was(tmp_path, capsys):
    """A report of three solvers, then a compare of one: the report's page (and the index linking
    it) unchanged, byte for byte; the compare page in OUT/compare/CASE, linking the index."""
    out = tmp_path / "rep"
    assert main(["report", "--cases", "cantilever_step", "--solvers", "analytic,fe-linear,pinocchio",
                 "--workers", "1", "--out", str(out)]) == 0
    page = out / "cantilever_step" / "index.html"
    before = page.read_bytes()
    assert b"pinocchio" in before
    capsys.readouterr()
    assert main(["compare", "cantilever_step", "--solvers", "analytic", "--t-end", "0.05", "--workers", "1",
                 "--out", str(out)]) == 0
    mine = out / "compare" / "cantilever_step" / "index.html"
    assert capsys.readouterr().out.splitlines()[-1] == f"page: {mine}"
    assert page.read_bytes() == before
    text = mine.read_text()
    assert "pinocchio" not in text and "<a href='../../index.html'>index</a>" in text
    assert (mine.parent / "tip_deflection.png").is_file()


# ---------------------------------------------------------------------------------------------
# compare --t-end


def test_compare_t_end_runs_that_long_and_says_so(tmp_path, capsys):
    out = tmp_path / "rep"
    assert main(["compare", "cantilever_step", *FAST, "--t-end", "0.03", "--out", str(out)]) == 0
    stored = results.folder(out) / "cantilever_step"
    for solver in ("analytic", "fe-linear"):
        r = results.read(results.folder(out), "cantilever_step", solver)
        assert r.t[-1] == pytest.approx(0.03) and len(r.t) == 31
        assert r.extra["overrides"] == ["duration=0.03"]
    meta = json.loads((stored / "analytic.json").read_text())          # what pins the code that ran it
    assert meta["flexmbd_version"] == version.__version__ and meta["source_sha256"] == version.source_sha256()
    capsys.readouterr()
    assert main(["compare", "cantilever_step", *FAST, "--t-end", "0.0001", "--out", str(out)]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("flexmbd: --t-end 0.0001: ") and "output_dt" in err[0]


# ---------------------------------------------------------------------------------------------
# list CASE


def test_list_takes_case_names_and_paths(tight, capsys):
    assert main(["list", "cantilever_step", str(tight), "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [r["case"] for r in rows] == ["cantilever_step", "tight"]
    assert rows[1]["solvers"]["analytic"] == "ok"
    assert main(["list", "pendulum"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("pendulum ") and "cantilever_step" not in out
    for argv, named in ((["list", "no_such_case"], "no_such_case"), (["list", "pendulum", "--solvers"], "--solvers")):
        assert main(argv) == 2
        err = capsys.readouterr().err.splitlines()
        assert len(err) == 1 and named in err[0], err


@pytest.mark.skipif(shutil.which("bash") is None, reason="no bash")
def test_list_completes_case_names(tmp_path):
    from tests.cli.test_completion import complete
    assert complete(tmp_path, "flexmbd", "list", "pend") == ["pendulum"]
    assert complete(tmp_path, "flexmbd", "list", "pendulum", "canti") == ["cantilever_solid", "cantilever_step"]
    assert complete(tmp_path, "flexmbd", "study", "canti") == ["cantilever_solid", "cantilever_step"]


# ---------------------------------------------------------------------------------------------
# the LaTeX reviewer tables


def many_runs() -> tuple[list, list]:
    """Accuracy rows and runs of a report of every shipped case on 8 solvers (a realistic
    summary of about 100 rows), with numbers that siunitx would group."""
    rows, runs, ok = [], [], results.Status()
    kinds = ["pass", "fail", "reference", "not compared"]
    for c in cases.available():
        for k, s in enumerate(["flexmbd", "fe-linear", "analytic", "exudyn-ffrf", "exudyn-beam", "mujoco-rod",
                               "pinocchio", "mujoco"]):
            v = accuracy.Verdict(kinds[k % 4], kinds[k % 4], "")
            runs.append(Outcome(c, s, ok, v, 0.00425, 12345.6))
        rows.append({"case": c, "solver": "flexmbd", "reference": "exudyn-beam", "channel": "tip_deflection",
                     "label": "deflection y at 0.75 m [m]", "rms": 0.00425, "max": 0.0128, "peak": 0.001,
                     "f_ref": 12345.6, "f_solver": 12.3, "envelope": 0.001, "slow": 0.001, "tolerance": 0.02,
                     "pass": "pass"})
    return rows, runs


def test_latex_numbers_are_written_plainly_and_relative_columns_carry_no_unit():
    rows, runs = many_runs()
    tex = tables.latex_document(rows, runs)
    assert "siunitx" not in tex and "\\num" not in tex
    assert "$0.00425$" in tex and "$12346$" in tex                     # no "0.004 25", no "12 346"
    assert not [m for m in re.findall(r"\$[^$]*\$", tex) if "\\," in m or " " in m or "~" in m]
    for line in tex.splitlines():
        cells = line.split(" & ")
        if line.startswith("flexmbd & deflection"):                     # a case table's row
            assert cells[1] == "deflection y at 0.75 m", cells           # its unit not beside the RMS
            assert all(re.fullmatch(r"\$[-0-9.]+(\\times10\^\{-?\d+\})?\$", c) for c in cells[2:7]), cells
    heads = [line for line in tex.splitlines() if line.startswith("solver & ")]
    units = {u for h in heads for u in re.findall(r"\[([^\]]*)\]", h)}
    assert units == {"s", "Hz"}                                          # wall time, frequencies: nothing else


def test_a_long_summary_is_cut_into_floats_that_each_fit_a_page():
    rows, runs = many_runs()
    tex = tables.latex_summary(runs)
    floats = tex.split("\\end{table}")[:-1]
    assert len(floats) >= 3
    for k, f in enumerate(floats):
        body = f.split("\\midrule")[1].split("\\bottomrule")[0].strip().splitlines()
        assert len(body) <= tables.ROWS
        assert body[0].startswith("\\multicolumn"), "each float starts at a case's heading"
        assert ("\\label{tab:accuracy:summary}" if k == 0 else f"\\label{{tab:accuracy:summary:{k + 1}}}") in f
    assert "Continued from Table~\\ref{tab:accuracy:summary}." in floats[1]
    one = tables.pieces([["case"]] + [["a", "b"]] * 90, 40)                # one case longer than a float
    assert [len(p) for p in one] == [40, 40, 13] and one[1][0] == ["case (continued)"]


@pytest.mark.skipif(shutil.which("pdflatex") is None, reason="no TeX engine on this machine")
def test_the_whole_accuracy_tex_of_every_case_compiles_and_fits(tmp_path):
    rows, runs = many_runs()
    log = compile_input(tmp_path, tables.latex_document(tables.with_failed(rows, runs), runs))
    assert "Float too large" not in log and "Overfull \\hbox" not in log
