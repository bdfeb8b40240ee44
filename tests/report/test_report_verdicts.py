"""The report's verdicts on the command line and the index: the reference a comparison needs runs
too, a channel beyond its tolerance is a fail, --strict exits 1 on a fail or when nothing was
compared, --json carries the verdicts."""

import re
from pathlib import Path

import numpy as np
import pytest

from flexmbd import cases
from flexmbd.harness import results
from flexmbd.cli import main

pytestmark = pytest.mark.heavy(19)       # seconds, measured with both cores busy (tests/conftest.py)


def test_report_runs_the_reference_it_compares_against(tmp_path, capsys):
    """`--solvers analytic` on cantilever_step, whose reference is fe-linear: the reference runs
    too (said in one line) and analytic is compared with it (a pass: graded); with an empty
    tolerance table (a copy of the case file) nothing is compared: --strict exits 1 saying so;
    without the table each kind's default grades it. (A tolerance no run meets, a fail and --strict
    exiting 1: test_a_failing_channel_is_a_fail_on_the_index_and_with_strict_exit_1.)"""
    args = ["--cases", "cantilever_step", "--solvers", "analytic", "--strict", "--out", str(tmp_path / "a")]
    assert main(["report", *args]) == 0
    out, err = capsys.readouterr()
    assert "cantilever_step: its reference fe-linear runs too" in err
    assert (tmp_path / "a" / "results" / "cantilever_step" / "fe-linear.json").is_file()
    assert out.startswith("2 runs: 1 pass, 1 reference"), out
    text = (cases.find("cantilever_step")).read_text()
    none = re.sub(r"(?m)^tolerances = .*$", "tolerances = {}", text)        # an empty table grades nothing
    default = re.sub(r"(?m)^tolerances = .*$", "", text)                   # no table: each kind's default
    for name, body, want, code in (("none", none, "1 not compared", 1), ("default", default, "1 pass", 0)):
        path = tmp_path / name / "cantilever_step.toml"
        path.parent.mkdir()
        path.write_text(body)
        assert main(["report", "--cases", str(path), "--solvers", "analytic", "--strict",
                     "--out", str(tmp_path / name)]) == code, name
        out, err = capsys.readouterr()
        assert want in out.splitlines()[0], (name, out)
        if name == "none":
            assert "--strict: nothing was compared" in err


def test_a_failing_channel_is_a_fail_on_the_index_and_with_strict_exit_1(tmp_path, capsys):
    """The cantilever with a tolerance no solver meets: the index says fail (worst channel, by how
    much) in red on top of a one-line summary; --strict exits 1; --json carries the verdicts."""
    import json
    text = (Path(cases.find("cantilever_step"))).read_text()
    strict = re.sub(r"tolerances = \{[^}]*\}", "tolerances = { tip_deflection = 1e-9, stress_vm = 1.0 }", text)
    path = tmp_path / "tight.toml"
    path.write_text(strict)
    out = tmp_path / "rep"
    args = ["report", "--cases", str(path), "--solvers", "analytic,fe-linear", "--out", str(out)]
    assert main(args) == 0
    printed = capsys.readouterr().out
    assert "2 runs: 1 fail, 1 reference" in printed and "tight / analytic: fail: tip_deflection RMS" in printed
    index = (out / "index.html").read_text()
    assert "<b>2 runs: 1 fail, 1 reference</b>" in index
    assert re.search(r"<td class='fail'>fail: tip_deflection RMS [0-9.e-]+ = [0-9.e]+ × its tolerance 1e-9</td>", index)
    assert "td.fail::before{content:'✗\\a0'}" in index                  # its icon beside its colour
    # the case x solver matrix above the table of every run
    assert index.index("<table class='matrix'>") < index.index("<h2>Every run</h2>")
    assert re.search(r"<tr><td><a href='tight/index.html'>tight</a></td><td class='fail'[^>]*>fail</td>", index)
    capsys.readouterr()
    assert main(args[:1] + ["--no-run", "--strict", "--json"] + args[1:]) == 1
    got = json.loads(capsys.readouterr().out)
    assert [r["verdict"] for r in got["runs"]] == ["fail", "reference"] and got["summary"] == "2 runs: 1 fail, 1 reference"


def test_a_rigid_model_is_graded_only_on_the_channels_it_has():
    """Pinocchio's model of four_bar_swing holds the joint angles and the pin forces, but no deflection,
    stress, or strain energy: on the flexible case its energy is not compared (the coupler's strain
    energy failed it at 107 x the tolerance while its angles lay on the reference), on the rigid one
    it is."""
    from flexmbd.solvers import pinocchio_rigid
    from flexmbd.report import accuracy
    flexible, rigid = cases.load("four_bar_swing"), cases.load("four_bar_swing_rigid")
    has = {ch: accuracy.comparable(flexible, pinocchio_rigid, ch) for ch in flexible.channels}
    assert has == {"crank_angle": True, "rocker_angle": True, "midspan_deflection": False, "stress_vm": False,
                   "energy": False, "pin_force_x": True, "pin_force_y": True}, has
    assert accuracy.comparable(rigid, pinocchio_rigid, "energy")
    assert all(accuracy.comparable(flexible, None, ch) for ch in flexible.channels)   # a flexible model: all


def test_the_worst_channel_is_the_one_the_verdict_names():
    """The largest RMS difference is not the worst channel when its tolerance is wider: the index's
    worst channel is the one furthest beyond its tolerance, the one the verdict's text names."""
    from flexmbd.report import accuracy
    from flexmbd.harness.results import Status
    rows = [{"solver": "s", "channel": "energy", "rms": 0.02, "tolerance": 1e-4},
            {"solver": "s", "channel": "stress_vm", "rms": 0.3, "tolerance": 0.05},
            {"solver": "s", "channel": "free", "rms": 0.9, "tolerance": float("nan")}]
    v = accuracy.verdict(Status(), "s", "ref", rows)
    assert v.kind == "fail" and v.text.startswith("fail: energy RMS"), v
    assert accuracy.worst_channel(rows, "s") == "energy" and accuracy.worst(rows, "s") == 0.02
    ungraded = [dict(r, tolerance=float("nan")) for r in rows]
    assert accuracy.worst_channel(ungraded, "s") == "free"


@pytest.mark.parametrize("status, word", [
    (results.diverged("diverged (|tip_deflection| beyond 3 m, 2 beam lengths)", 0.6), "diverged"),
    (results.diverged("non-finite state", 0.6), "diverged"),
    (results.diverged("its watch stopped it", 0.6), "diverged"),           # the field, not the why's first word
    (results.failed("Exudyn: reduction of step size reached minimum step size", 0.6), "aborted"),
    (results.failed("non-finite, said by a solver that aborts", 0.6), "aborted"),
    (results.failed("RuntimeError: engine exploded (run, line 3)", 0.6), "aborted")])
def test_a_failed_run_has_one_word_in_its_verdict_its_cells_and_its_figures(tmp_path, status, word):
    """A failed run's cause (`results.Status.cause`), read back from its sidecar, is the word of
    its verdict, of its status cell and of its name in a figure's legend: no page calls a run
    aborted in its verdict and failed in its figure."""
    from flexmbd.report import accuracy, figures, tables
    r = results.Result(solver="s", case="c", t=np.arange(60) * 0.01, channels={"x": np.zeros(60)}, status=status)
    results.write(r, tmp_path)
    back = results.read(tmp_path, "c", "s")
    assert back.status == status
    v = accuracy.verdict(back.status, "s", "ref", [])
    assert v.kind == accuracy.run_word(back.status) == word and v.text.startswith(word)
    assert tables.css_class(back.status) == tables.css_class(v) == word
    assert figures.label("s", back, "ref") == f"s ({word} at t = 0.6 s)"
    assert figures.label("ref", back, "ref") == f"ref (reference, {word} at t = 0.6 s)"
