"""Every mishandled input gets its documented answer (README.md, Exit statuses): exit 2 with one
line `flexmbd: FILE: key: what` (or naming the option, or stdout) and no traceback, or an
`unavailable: why` in a report with one warning line, and nothing written half or mixed. One test
per input; the cheapest solver (`analytic` on `cantilever_step`) keeps the module fast.

The second part holds the cost limits (README.md, "Cost limits"): before anything is solved or
read, every stage is estimated; a stage beyond 3 GB, 10 s without progress or 1 h with progress is
refused with exit 2 and one line naming the key that drives it, its estimate and the limit
(`--allow-large` goes on), and whatever runs longer than a couple of seconds shows progress on
stderr. Refusals come before the work, and progress is tested through the estimates and the bar's
own decision, never by timing a long run.
"""

import io
import json
import math
import os
import re
import shutil
import subprocess
import sys
import uuid
import warnings
from importlib.metadata import EntryPoint
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import flexmbd
from flexmbd import cases
from flexmbd.harness import cost, results, registry
from flexmbd.core import files
from flexmbd.solvers import linearize, inhouse
from flexmbd.mbd import integrate
from flexmbd.cli import main
from flexmbd.core.errors import InputError
from flexmbd.harness.progress import Progress
from flexmbd.report import spectra
from tests.cli.test_faults import BASE, CASE, ENV, ONE, SOLVER, check, cli, edit_result, no_leftovers
from tests.cli.test_faults import base  # noqa: F401 - the fixture: a copy of the shipped analytic baseline

pytestmark = pytest.mark.heavy(19)       # seconds, measured with both cores busy (tests/conftest.py)

SHIPPED = cases.CASES_DIR / f"{CASE}.toml"
DEEP = "[" * 200_000 + "]" * 200_000          # far beyond any parser's recursion


# ---------------------------------------------------------------------------------------------
# fixtures: the solver's kernel compiled (a report's first page otherwise says it compiles it, a
# line no test here is about); a stored result of the shipped case (for regress --results); a
# report of the case with analytic as its reference (among the solvers: nothing else runs or is read)


@pytest.fixture(scope="module", autouse=True)
def compiled():
    spectra.prepare([cases.load(CASE)])


@pytest.fixture(scope="module")
def stored(tmp_path_factory) -> Path:
    """A report folder holding analytic's run of the shipped case (results only)."""
    out = tmp_path_factory.mktemp("stored") / "rep"
    cli(["run", CASE, "--solver", SOLVER, "--out", out], 0, 0)
    return out


@pytest.fixture
def results_dir(stored, tmp_path) -> Path:
    """A fresh copy of the stored results (RESULTS/cantilever_step/analytic.{csv,json})."""
    shutil.copytree(stored, tmp_path / "rep")
    return tmp_path / "rep" / "results"


def regress_results(base: Path, results_dir: Path, status: int, lines: int = 1, names=()) -> list[str]:
    return cli(["regress", "--baseline", base, "--results", results_dir.parent, *BASE], status, lines, names)


@pytest.fixture(scope="module")
def own_case(tmp_path_factory) -> Path:
    """The case with analytic as its reference, as a case file of the same name."""
    path = tmp_path_factory.mktemp("case") / f"{CASE}.toml"
    path.write_text(SHIPPED.read_text().replace('reference = "fe-linear"', f'reference = "{SOLVER}"'))
    return path


@pytest.fixture(scope="module")
def paged(tmp_path_factory, own_case) -> Path:
    """A report folder of analytic on the own case: results/ plus the pages (made once)."""
    out = tmp_path_factory.mktemp("paged") / "rep"
    cli(["report", "--cases", own_case, "--solvers", SOLVER, "--out", out], 0, 0)
    return out


@pytest.fixture
def report(paged, tmp_path) -> Path:
    """A fresh copy of the paged report."""
    shutil.copytree(paged, tmp_path / "rep")
    return tmp_path / "rep"


def report_no_run(report: Path, own_case: Path, status: int, lines: int, names=()) -> list[str]:
    return cli(["report", "--cases", own_case, "--solvers", SOLVER, "--out", report, "--no-run"], status, lines, names)


def summary_status(report: Path, solver: str = SOLVER) -> str:
    row = re.search(rf"<td>{re.escape(solver)}</td><td[^>]*>([^<]*)</td>", (report / "index.html").read_text())
    return row.group(1)


def sidecar_key(results_dir: Path, key: str, raw: str) -> Path:
    """Give a stored sidecar's `key` the JSON text `raw` (which json.dumps may not write: 1e400)."""
    js = results_dir / CASE / f"{SOLVER}.json"
    meta = json.loads(js.read_text())
    meta[key] = "@@"
    js.write_text(json.dumps(meta).replace('"@@"', raw))
    return js


def table_of(stored: Path, tmp_path: Path, change=lambda df: df, name: str = "mine.csv") -> Path:
    """The stored analytic table, changed, as a file to import."""
    df = change(pd.read_csv(results.folder(stored) / CASE / f"{SOLVER}.csv"))
    path = tmp_path / name
    df.to_csv(path, index=False)
    return path


# ---------------------------------------------------------------------------------------------
# 1. options: finite positive numbers


@pytest.mark.parametrize("value", ["inf", "-inf", "nan", "1e400", "Infinity"])
def test_t_end_must_be_finite(tmp_path, value):
    cli(["run", CASE, "--solver", SOLVER, f"--t-end={value}", "--out", tmp_path / "o"], 2,
        names=["--t-end", "finite positive", value])
    assert not (tmp_path / "o").exists()


# ---------------------------------------------------------------------------------------------
# 2., 3. tables with a header and no rows


def test_import_of_a_header_without_rows(tmp_path):
    (tmp_path / "mine.csv").write_text("t,tip_deflection\n")
    cli(["import", CASE, tmp_path / "mine.csv", "--solver", "mine", "--out", tmp_path / "o"], 2,
        names=[tmp_path / "mine.csv", "no rows"])
    assert not (tmp_path / "o").exists()


def test_regress_with_a_baseline_header_without_rows(base, results_dir):
    path = base / CASE / f"{SOLVER}.csv"
    path.write_text("".join(line for line in path.read_text().splitlines(keepends=True)
                            if line.startswith(("#", "t,"))))
    regress_results(base, results_dir, 2, names=[path, "no rows"])


def test_regress_with_a_stored_result_header_without_rows(base, results_dir):
    """A sidecar that lists 0 samples and the hash of a CSV of a header alone."""
    def header_only(meta):
        meta.update(samples=0, status="ok")
    edit_result(results_dir, change_csv=lambda rows: rows[:1], change_meta=header_only)
    regress_results(base, results_dir, 2, names=[results_dir / CASE / f"{SOLVER}.csv", "no rows"])


# ---------------------------------------------------------------------------------------------
# 4., 5. JSON nested 2 x 10^5 deep


def test_import_with_deeply_nested_metadata(stored, tmp_path):
    (tmp_path / "meta.json").write_text(DEEP)
    cli(["import", CASE, table_of(stored, tmp_path), "--solver", "mine", "--meta", tmp_path / "meta.json",
         "--out", tmp_path / "o"], 2, names=[tmp_path / "meta.json", "nested more than"])
    assert not (tmp_path / "o").exists()


def test_report_no_run_with_a_deeply_nested_sidecar(report, own_case):
    js = report / "results" / CASE / f"{SOLVER}.json"
    js.write_text(DEEP)
    report_no_run(report, own_case, 0, 1, names=["warning", js, "nested more than"])
    assert summary_status(report).startswith("unavailable: stored result unusable")
    no_leftovers(report)


def test_regress_results_with_a_deeply_nested_sidecar(base, results_dir):
    js = results_dir / CASE / f"{SOLVER}.json"
    js.write_text(DEEP)
    regress_results(base, results_dir, 2, names=[js, "nested more than"])


# ---------------------------------------------------------------------------------------------
# 6.-8. every sidecar key holds what it must: numbers finite, of their type


@pytest.mark.parametrize("key, raw", [
    ("samples", "1e400"), ("samples", '"abc"'), ("samples", "-1"), ("samples", "2001.5"), ("samples", "true"),
    ("failed_at_s", '"abc"'), ("failed_at_s", "1e400"), ("wall_s", '"abc"'), ("wall_s", "Infinity"),
    ("setup_s", '"abc"'), ("steps", '"abc"'), ("steps", "1.5"), ("rhs_evals", "-3"), ("compile_s", "[1]"),
    ("kinetic_max_J", '"abc"'), ("kinetic_max_J", "-1e400"), ("channels", "[1]"), ("case_sha256", "5"),
    ("settings", "[1]"), ("overrides", "3"), ("machine", "{}"), ("versions", "[]"), ("csv_sha256", "1"),
])
def test_regress_results_with_a_sidecar_value_of_the_wrong_kind(base, results_dir, key, raw):
    if key == "failed_at_s":
        edit_result(results_dir, change_meta=lambda m: m.update(status="failed: boom"))
    js = sidecar_key(results_dir, key, raw)
    regress_results(base, results_dir, 2, names=[js, f"{key}: expected"])


def test_report_no_run_with_a_wall_time_that_is_not_a_number(report, own_case):
    js = sidecar_key(report / "results", "wall_s", '"abc"')
    report_no_run(report, own_case, 0, 1, names=["warning", js, "wall_s: expected a number"])
    assert summary_status(report).startswith("unavailable: stored result unusable")


# ---------------------------------------------------------------------------------------------
# 9. a stored status that only a reader gives


def test_report_no_run_with_a_stored_status_of_a_reader(report, own_case):
    edit_result(report / "results", change_meta=lambda m: m.update(status="unavailable: stored result unusable: x"))
    report_no_run(report, own_case, 0, 1, names=["warning", f"{SOLVER}.json", "status", "not the status of a run"])
    assert summary_status(report).startswith("unavailable: stored result unusable")


# ---------------------------------------------------------------------------------------------
# 10. values whose comparisons would overflow; inf never reaches --json


def test_import_of_a_value_beyond_the_largest_magnitude(stored, tmp_path):
    path = table_of(stored, tmp_path, lambda df: df.assign(stress_vm=np.where(df.t > 0.5, 1e300, df.stress_vm)))
    cli(["import", CASE, path, "--solver", "mine", "--out", tmp_path / "o"], 2,
        names=[path, "column stress_vm, row 502", "beyond 1e+100", "overflow"])
    assert not (tmp_path / "o").exists()


def test_regress_results_with_a_stored_value_beyond_the_largest_magnitude(base, results_dir):
    edit_result(results_dir, change_csv=lambda rows: rows[:10] + ["0.009,1e300,1"] + rows[11:])
    regress_results(base, results_dir, 2, names=[results_dir / CASE / f"{SOLVER}.csv", "beyond 1e+100"])


def test_report_json_with_values_near_the_largest_magnitude(report, own_case, paged, tmp_path, capsys):
    """An imported stress of 1e99 Pa against the reference: a fail, every number in the JSON
    finite or null, and no warning line of numpy's on stderr."""
    path = table_of(paged, tmp_path, lambda df: df[["t", "stress_vm"]].assign(stress_vm=1e99), "big.csv")
    cli(["import", own_case, path, "--solver", "big", "--out", report], 0, 0)
    capsys.readouterr()
    code = main(["report", "--cases", str(own_case), "--solvers", SOLVER, "--out", str(report),
                             "--no-run", "--json"])
    out, err = capsys.readouterr()
    check(code, err, 0, 0, [])
    got = json.loads(out, parse_constant=lambda c: pytest.fail(f"{c} in the JSON"))
    assert [r["verdict"] for r in got["runs"] if r["solver"] == "big"] == ["fail"]


def test_jsonable_maps_every_non_finite_number_to_null():
    assert files.jsonable([math.inf, -math.inf, math.nan, np.float64("inf"), 1.5, 10 ** 400, "x"]) == \
        [None, None, None, None, 1.5, 10 ** 400, "x"]


# ---------------------------------------------------------------------------------------------
# 11., 12. stdout full or closed (real processes)


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="no /dev/full")
def test_stdout_on_a_full_device():
    with open("/dev/full", "w") as full:
        r = subprocess.run([sys.executable, "-m", "flexmbd.cli", "list"], stdout=full, stderr=subprocess.PIPE,
                           text=True, env=ENV, timeout=120)
    check(r.returncode, r.stderr, 2, 1, ["flexmbd: stdout: no space left on the device"])


def test_stdout_closed():
    r = subprocess.run([sys.executable, "-m", "flexmbd.cli", "list"], stderr=subprocess.PIPE, text=True, env=ENV,
                       preexec_fn=lambda: os.close(1), timeout=120)
    check(r.returncode, r.stderr, 2, 1, ["flexmbd: stdout: closed"])


# ---------------------------------------------------------------------------------------------
# 13. a case without a [report] table: graded against its default reference with the default
# tolerances, the page saying so; a case no default reference can run: nothing graded, saying why


@pytest.fixture(scope="module")
def unreported(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("unreported") / "bare.toml"
    text = SHIPPED.read_text()
    path.write_text(text[:text.index("[report]")])
    assert cases.load(str(path)).report.reference is None
    return path


def test_compare_without_a_report_table(unreported, tmp_path):
    cli(["compare", unreported, "--solvers", SOLVER, "--set", 'report.solvers=["analytic", "fe-linear"]',
         "--out", tmp_path], 0, 1, names=["its reference fe-linear runs too"])
    page = (tmp_path / "compare" / "bare" / "index.html").read_text()
    assert "Reference: <b>fe-linear</b>" in page and "Defaults, not the case file" in page
    assert "Nothing graded" not in page and (tmp_path / "compare" / "bare" / "tip_deflection.png").is_file()


def test_compare_without_a_reference_that_applies(unreported, tmp_path):
    [line] = cli(["compare", unreported, "--solvers", SOLVER, "--set", 'report.solvers=["flexmbd"]',
                  "--out", tmp_path], 0, 1, names=["nothing graded", "no reference solver", "default references"])
    assert str(unreported) in line
    assert "Nothing graded" in (tmp_path / "compare" / "bare" / "index.html").read_text()


def test_api_compare_without_a_report_table(unreported):
    df = flexmbd.compare(unreported, solvers=[SOLVER], t_end=0.1)
    ref = registry.default_reference(cases.load(str(unreported)))
    assert df.attrs["not_graded"] == "" and df.attrs["status"][SOLVER] == "ok"
    assert set(df["reference"]) == {ref} and set(df["tolerance"]) <= set(cases.TOLERANCES.values())


# ---------------------------------------------------------------------------------------------
# 14., 15. plug-ins that fail to load or have a bad name: unavailable, saying why


def plant(monkeypatch, tmp_path, name: str, source: str | None = None) -> str:
    """An installed plug-in `name` whose module has `source` (None: a working copy of a built-in),
    as `importlib.metadata` would list it; the registry rebuilt from it. Its module's name."""
    module = f"planted_{uuid.uuid4().hex}"
    (tmp_path / f"{module}.py").write_text(source if source is not None else
                                           "from flexmbd.solvers.analytic import *\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(registry, "entry_points", lambda group: [EntryPoint(name, module, group)])
    modules, refused = registry.registry()
    monkeypatch.setattr(registry, "MODULES", modules)
    monkeypatch.setattr(registry, "REFUSED", refused)
    monkeypatch.setattr(registry, "NAMES", tuple(modules))
    return module


def listed(capsys) -> dict:
    """`flexmbd list --json`: solver -> status, of the shipped case."""
    capsys.readouterr()
    assert main(["list", "--json"]) == 0
    return next(r for r in json.loads(capsys.readouterr().out) if r["case"] == CASE)["solvers"]


@pytest.mark.parametrize("source, why", [
    ("raise RuntimeError('planted')", "RuntimeError: planted"),
    ("import sys\nsys.exit(4)", "SystemExit: 4"),
    ("x = 1 / 0", "ZeroDivisionError: division by zero"),
    ("import no_such_module_anywhere", "ModuleNotFoundError: No module named 'no_such_module_anywhere'"),
    ("SETTINGS = {}\ndef version(): return '1'", "its module {module} lacks applies, run (docs/plugins.md)"),
])
def test_a_plugin_that_fails_to_load_is_unavailable_in_list(monkeypatch, tmp_path, capsys, source, why):
    module = plant(monkeypatch, tmp_path, "boom", source)
    assert listed(capsys)["boom"] == f"unavailable: plug-in boom failed to load: {why.format(module=module)}"


def test_a_plugin_whose_applies_raises_is_unavailable_in_list(monkeypatch, tmp_path, capsys):
    plant(monkeypatch, tmp_path, "boom", "from flexmbd.solvers.analytic import *\n"
                                         "def applies(case): raise ValueError('planted')\n")
    assert listed(capsys)["boom"] == "unavailable: plug-in boom failed: its applies(case) raised ValueError: planted"


def test_a_plugin_that_fails_to_load_is_unavailable_in_a_report(monkeypatch, tmp_path, own_case):
    plant(monkeypatch, tmp_path, "boom", "raise RuntimeError('planted')")
    out = tmp_path / "rep"
    cli(["report", "--cases", own_case, "--solvers", f"{SOLVER},boom", "--out", out], 0, 0)
    assert summary_status(out, "boom") == "unavailable: plug-in boom failed to load: RuntimeError: planted"
    assert summary_status(out).startswith("reference")


def test_a_working_plugin_is_listed_and_runs(monkeypatch, tmp_path, capsys):
    """The planting itself: a plug-in that loads is a solver like the built-in it copies."""
    plant(monkeypatch, tmp_path, "copy")
    assert listed(capsys)["copy"] == "ok"
    cli(["run", CASE, "--solver", "copy", "--t-end", "0.05", "--out", tmp_path / "o"], 0, 0)
    assert (tmp_path / "o" / "results" / CASE / "copy.json").is_file()


@pytest.mark.parametrize("name", ["../evil", "a/b", ".hidden", "two words", "bell\x07", "-dash", "x" * 65, ""])
def test_a_plugin_with_a_bad_name_is_unavailable_and_writes_nothing(monkeypatch, tmp_path, capsys, name):
    plant(monkeypatch, tmp_path, name)
    assert name not in registry.NAMES
    assert listed(capsys)[name].startswith(f"unavailable: plug-in name {name!r} cannot name a result file")
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    cli(["run", CASE, f"--solver={name}", "--out", "o"], 2, names=["--solver", "cannot name a result file"])
    cli(["report", "--cases", CASE, f"--solvers={SOLVER},{name}", "--out", "o"], 2,
        names=["--solvers", "cannot name a result file"])
    assert list(work.iterdir()) == []


@pytest.mark.parametrize("name", ["../x", "a/b", ".x", "two words", "tab\tname", ""])
def test_import_under_a_bad_name(stored, tmp_path, name):
    cli(["import", CASE, table_of(stored, tmp_path), f"--solver={name}", "--out", tmp_path / "o"], 2,
        names=["--solver", "cannot name a result file"])
    assert not (tmp_path / "o").exists()


def test_every_registered_name_can_name_a_result_file():
    assert [n for n in registry.BUILT_IN if results.bad_name(n)] == []


# =============================================================================================
# cost limits and progress

PENDULUM = (cases.CASES_DIR / "pendulum.toml").read_text()


def _refused(code, err, words):
    """Exit 2 with exactly one line, no traceback, holding every word."""
    lines = err.splitlines()
    assert code == 2, err
    assert len(lines) == 1 and lines[0].startswith("flexmbd: ") and "Traceback" not in err, err
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


def _channels(n: int, kind: str) -> str:
    """n channel tables of one kind along the pendulum's beam (distinct positions)."""
    one = {"deflection": 'kind = "deflection"\nbody = "beam"\nat = {x!r}\ncomponent = "y"\n',
           "stress_vm": 'kind = "stress_vm"\nbody = "beam"\nat = {x!r}\n'}[kind]
    return "".join(f"\n[channels.c{k}]\n" + one.format(x=1.5 * (k + 1) / (n + 1)) for k in range(n))


# ---------------------------------------------------------------------------------------------
# 1. many channels: forming them and writing the table, channels x samples


def test_twenty_thousand_deflection_channels_are_refused(tmp_path, capsys):
    """20,000 deflection points at 2001 samples: about 4e7 values, some 2 minutes and 2.6 GB of
    forming and writing, refused at once naming `channels`."""
    path = tmp_path / "many.toml"
    path.write_text(PENDULUM.replace("output_dt = 5e-4", "output_dt = 1e-3") + _channels(20000, "deflection"))
    out = tmp_path / "out"
    code = main(["run", str(path), "--solver", "flexmbd", "--out", str(out)])
    line = _refused(code, capsys.readouterr().err, ["many.toml", "channels:", "20005 channels at 2001 output samples",
                                                    "beyond the limit of 10 s without progress shown", "--allow-large"])
    assert float(line.split("takes about ")[1].split(" s")[0]) > 60, line
    assert not out.exists()


def test_two_thousand_stress_channels_are_refused_as_their_values(tmp_path):
    """The output stage grows with channels x samples, whatever the channels' kind, and its key
    is `channels` once they outweigh the states of a sample: 2005 x 4001 values, about 25 s."""
    path = tmp_path / "stress.toml"
    path.write_text(PENDULUM + _channels(2000, "stress_vm"))
    few, many = cases.load("pendulum"), cases.load(str(path))
    small, large = cost.output(few, few.duration), cost.output(many, many.duration)
    assert small.key == "integrator.output_dt" and not cost.excess(small)
    assert large.key == "channels" and "2005 channels at 4001 output samples" in large.what
    assert 10 < large.seconds < 100 and "without progress shown" in cost.excess(large), large


# ---------------------------------------------------------------------------------------------
# 2. the linearized system (flexmbd modes --system)


def test_system_modes_of_400_modes_run_with_progress():
    """400 modes: 1604 evaluations of about 20 ms each, half a minute: allowed, with the
    linearization's bar (a stage that shows progress, well past the 2 s the bar waits)."""
    case = cases.load("pendulum", ["bodies.beam.modes.count=400"])
    stages = cost.modes(case) + cost.system(case)
    differences = stages[1]
    assert differences.progress and differences.key == "bodies.beam.modes.count"
    assert 10 < differences.seconds < cost.PROGRESS_LIMIT, differences
    assert not any(cost.excess(st) for st in stages), stages
    cost.check([(case, None)], about="initial")


def test_system_modes_of_two_beams_of_400_modes_are_refused(capsys):
    """802 coordinates: a 1604 x 1604 eigenproblem, one silent LAPACK call of about half a minute."""
    code = main(["modes", "double_pendulum", "--system", "--set", "bodies.beam1.modes.count=400",
                 "--set", "bodies.beam2.modes.count=400"])
    _refused(code, capsys.readouterr().err, ["double_pendulum.toml", "bodies.beam2.modes.count:", "1604 x 1604",
                                             "without progress shown", "--allow-large"])


def test_system_modes_about_the_equilibrium_of_100_modes_are_refused(capsys):
    """The descent to the equilibrium takes some 2.5 n^2 energies, without progress."""
    code = main(["modes", "pendulum", "--system", "--about", "equilibrium", "--set", "bodies.beam.modes.count=100"])
    _refused(code, capsys.readouterr().err, ["bodies.beam.modes.count:", "static equilibrium", "without progress"])
    cost.check([(cases.load("pendulum", ["bodies.beam.modes.count=100"]), None)], about="initial")


def test_modes_of_50_segments_without_system_leave_the_linearization_out(capsys):
    """50 segments of 6 modes: 301 coordinates, whose equilibrium (some 2e5 energies of 0.6 ms) is
    refused with --system, while `modes` alone, which computes no system, goes on."""
    sets = ["--about", "equilibrium", "--set", "bodies.beam.segments=50", "--set", "bodies.beam.elements=50",
            "--set", "bodies.beam.modes.count=6"]
    _refused(main(["modes", "pendulum", "--system"] + sets), capsys.readouterr().err,
             ["bodies.beam.segments:", "static equilibrium over 301 coordinates", "without progress shown"])
    assert main(["modes", "pendulum", "--json"] + sets) == 0
    assert len(json.loads(capsys.readouterr().out)["bodies"]["beam"]["modes"]) == 6


def test_the_state_matrix_tells_its_bar_each_coordinate():
    """The linearization moves its bar once per coordinate (4 evaluations each)."""
    model = linearize.model_of(cases.load("pendulum", ["bodies.beam.modes.count=2"]))
    seen = []

    class Bar:
        def update(self, k):
            seen.append(k)

    linearize.state_matrix(model, model.q0, model.v0, 0.0, Bar())
    assert seen == [1, 2, 3]


def test_a_bar_over_coordinates_counts_them(capsys):
    bar = Progress(802, "pendulum / linearizing", after_s=0.0, every_s=0.0, unit="coordinates")
    bar.update(401)
    err = capsys.readouterr().err
    assert err.startswith("pendulum / linearizing [###############               ] 401/802 coordinates, "), err


# ---------------------------------------------------------------------------------------------
# 3. a soft pendulum (E = 1e3 Pa): the beam folds, VODE's steps collapse inside one output interval


def test_soft_pendulum_adams_run_is_estimated_with_progress():
    """Its estimate is small (the estimate cannot know that the step size collapses), and every
    in-house method but scipy's rk45 and dop853 is counted as showing progress."""
    case = cases.load("pendulum", ["materials.steel.E=1e3"])
    (st,) = inhouse.integration(case, case.duration)
    assert st.progress and st.seconds < cost.SILENT_LIMIT
    for method, shown in (("adams", True), ("dopri5", True), ("rk4", True), ("fox-goodwin", True), ("rk45", False),
                          ("dop853", False)):
        c = cases.load("pendulum", [f"integrator.method='{method}'"])
        assert inhouse.integration(c, 0.1)[0].progress is shown, method


def test_soft_pendulum_bar_is_due_two_seconds_in_even_off_a_terminal(monkeypatch):
    """The first line comes 2 s in (not only after the 10 s between lines off a terminal), then
    one every 10 s."""
    monkeypatch.setattr(sys, "stderr", io.StringIO())           # not a terminal
    bar = Progress(2.0, "pendulum / flexmbd")
    assert not bar.tty and bar.every == 10.0
    assert not bar.due(bar.start + 1.9) and bar.due(bar.start + 2.0)
    bar.last = bar.start + 2.0
    assert not bar.due(bar.start + 11.9) and bar.due(bar.start + 12.0)


def test_soft_pendulum_bar_moves_within_an_output_interval(capsys):
    """The right-hand side tells the bar its time: a step size that collapses at t = 0.0303 s
    shows as the time standing there, though no output instant is reached."""
    bar = Progress(2.0, "pendulum / flexmbd", after_s=0.0, every_s=0.0)
    f = bar.tracking(lambda t, y: -y)
    assert np.array_equal(f(0.0303, np.ones(2)), -np.ones(2))
    assert "pendulum / flexmbd [                              ] t = 0.030/2 s, " in capsys.readouterr().err


def test_soft_pendulum_bar_is_left_alone_once_its_right_hand_side_raised(capsys):
    """After the right-hand side raised (a failed run's Stop), VODE calls back with the exception
    pending until it returns; the bar then reads no clock (which would fail) and draws nothing."""
    bar = Progress(2.0, "pendulum / flexmbd", after_s=0.0, every_s=0.0)
    said = []

    def f(t, y):
        said.append(t)
        if len(said) == 1:
            raise integrate.Stop("failed")
        return y

    g = bar.tracking(f)
    with pytest.raises(integrate.Stop):
        g(0.1, np.ones(1))
    assert g(0.2, np.ones(1)) == 1.0 and said == [0.1, 0.2]
    assert capsys.readouterr().err == ""


def test_soft_pendulum_adams_evaluations_reach_the_bar():
    """simulate hands adams (and rk4) the right-hand side that updates the bar: the bar hears of
    times between the output instants."""
    heard = []

    class Bar(Progress):
        def update(self, t):
            heard.append(float(t))

    model = linearize.model_of(cases.load("pendulum", ["bodies.beam.modes.count=0"]))
    for method in ("adams", "rk4"):
        heard.clear()
        integrate.simulate(model, 0.02, method=method, dt=1e-3, output_dt=0.01, progress=Bar(0.02, "pendulum"))
        assert any(0.0 < t < 0.01 for t in heard), (method, heard)


# ---------------------------------------------------------------------------------------------
# 4. stored results: sized from their sidecar (or CSV) before they are read


def _stored(out, case: str, solver: str, samples: int, csv: str = "t,joint_angle\n0,0\n", csv_size: int = 0):
    """A stored imported result whose sidecar claims `samples` (its CSV: `csv`, or a sparse file of
    `csv_size` bytes)."""
    d = out / "results" / case
    d.mkdir(parents=True, exist_ok=True)
    (d / f"{solver}.json").write_text(json.dumps({
        "solver": solver, "case": case, "status": "ok", "samples": samples, "channels": ["joint_angle"] * 4,
        "imported": {"file": "mine.csv", "sha256": "", "meta": None, "description": ""}}))
    with open(d / f"{solver}.csv", "w") as f:
        f.write(csv)
        if csv_size:
            f.truncate(csv_size)
    return d / f"{solver}.json"


def test_report_no_run_over_a_three_million_row_import_is_refused(tmp_path, capsys):
    """3e6 rows x 5 columns: some 1.5 minutes and 1.4 GB to read and draw, refused before any is
    read, naming the sidecar and its `samples`; nothing of the report is written."""
    js = _stored(tmp_path / "rep", "pendulum", "mine", 3_000_000)
    code = main(["report", "--no-run", "--cases", "pendulum", "--solvers", "flexmbd", "--out", str(tmp_path / "rep")])
    _refused(code, capsys.readouterr().err, [str(js), "samples:", "3000000 samples x 5 columns",
                                             "beyond the limit of 10 s without progress shown", "--allow-large"])
    assert not (tmp_path / "rep" / "index.html").exists() and not (tmp_path / "rep" / "pendulum").exists()


def test_compare_beside_a_three_million_row_import_is_refused_before_running(tmp_path, capsys):
    js = _stored(tmp_path / "rep", "pendulum", "mine", 3_000_000)
    code = main(["compare", "pendulum", "--solvers", "flexmbd", "--out", str(tmp_path / "rep")])
    _refused(code, capsys.readouterr().err, [str(js), "samples:", "--allow-large"])
    assert not (tmp_path / "rep" / "results" / "pendulum" / "flexmbd.json").exists()


def test_a_300_mb_csv_behind_a_small_sidecar_is_sized_by_its_file(tmp_path):
    """A sidecar that claims 2 samples does not hide a 300 MB CSV (at most 18 B a value)."""
    js = _stored(tmp_path, "pendulum", "mine", 2, csv_size=300_000_000)
    st = cost.stored(js)
    assert st.key == "samples" and "300 MB of CSV" in st.what and st.seconds > 60, st
    with pytest.raises(InputError, match="samples: reading and drawing about 1.67e"):
        cost.check_stored([js])


def test_a_stored_result_of_the_shipped_size_is_within_the_limits(tmp_path):
    js = _stored(tmp_path, "pendulum", "mine", 4001)
    assert not cost.excess(cost.stored(js))
    assert cost.stored(tmp_path / "results" / "pendulum" / "none.json") is None     # reading it says why


def test_a_figure_whose_drawing_warns_prints_no_warning(tmp_path):
    """matplotlib's advice while drawing (a legend placed slowly over a long history: 'Creating
    legend with loc="best" can be slow') never reaches stderr."""
    import matplotlib.artist
    import matplotlib.pyplot as plt

    from flexmbd.report import figures

    class Loud(matplotlib.artist.Artist):
        def draw(self, renderer):
            warnings.warn('Creating legend with loc="best" can be slow with large amounts of data.', UserWarning)

    fig = plt.figure()
    fig.add_artist(Loud())
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        figures.save(fig, tmp_path / "loud.png")
    assert not said and (tmp_path / "loud.png").is_file() and (tmp_path / "loud.svg").is_file()


# ---------------------------------------------------------------------------------------------
# every shipped case stays within the limits, system modes included


def test_every_shipped_case_and_its_system_modes_are_within_the_limits():
    for name in cases.available():
        case = cases.load(name)
        cost.check([(case, s) for s in registry.NAMES])
        cost.check([(case, None)], about="initial")
