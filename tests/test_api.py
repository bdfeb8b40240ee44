"""The Python API: every code block of docs/api.md and every script in examples/ runs."""

import re
import runpy
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
BLOCKS = re.findall(r"```python\n(.*?)```", (ROOT / "docs" / "api.md").read_text(), re.S)
EXAMPLES = sorted((ROOT / "examples").glob("*.py"))


def test_import_is_cheap():
    import subprocess
    import sys
    out = subprocess.run([sys.executable, "-c", "import flexmbd, sys; print('numba' in sys.modules, "
                          "'flexmbd.solvers' in sys.modules)"], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False"]


@pytest.mark.parametrize("code", BLOCKS, ids=[f"api.md block {k + 1}" for k in range(len(BLOCKS))])
def test_docs_api_block_runs(code):
    assert len(BLOCKS) >= 3
    exec(compile(code, "docs/api.md", "exec"), {})


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.name for p in EXAMPLES])
def test_example_runs(path):
    runpy.run_path(str(path), run_name="__main__")


NOTEBOOK = ROOT / "examples" / "notebook.ipynb"


def notebook_code(path: Path, t_end: str) -> list:
    """The code cells of a notebook (nbformat 4 JSON, outputs cleared), in order, with its
    `T_END = ...` line set to t_end (s)."""
    import json
    nb = json.loads(path.read_text())
    assert nb["nbformat"] == 4 and isinstance(nb["metadata"], dict) and nb["cells"]
    cells = []
    for c in nb["cells"]:
        assert c["cell_type"] in ("markdown", "code") and isinstance(c["metadata"], dict)
        if c["cell_type"] == "code":
            assert c["outputs"] == [] and c["execution_count"] is None, "outputs are cleared"
            cells.append("".join(c["source"]))
    set_end = [re.subn(r"^T_END = [0-9.e+-]+", f"T_END = {t_end}", s, flags=re.M) for s in cells]
    assert sum(n for _, n in set_end) == 1, "one T_END line"
    return [s for s, _ in set_end]


def test_the_notebook_runs_its_cells_in_order(capsys):
    """The example notebook, executed as Jupyter would (one namespace, cells in order), with a
    short run: a case on two solvers and their comparison, units printed, system modes."""
    ns = {}
    for k, code in enumerate(notebook_code(NOTEBOOK, "0.05")):
        exec(compile(code, f"{NOTEBOOK.name} cell {k + 1}", "exec"), ns)
    out = capsys.readouterr().out
    assert "'tip_deflection': 'm'" in out and "'f_ref': 'Hz'" in out and "reference" in out
    assert ns["df"].index[-1] == pytest.approx(0.05) and set(ns["acc"]["solver"]) == {"flexmbd", "analytic"}
    assert len(ns["modes"]) and (ns["modes"]["damping"] == 0).all()


def test_a_notebook_without_a_t_end_line_is_refused(tmp_path):
    bad = tmp_path / "nb.ipynb"
    bad.write_text(NOTEBOOK.read_text().replace("T_END = ", "END = "))
    with pytest.raises(AssertionError, match="one T_END line"):
        notebook_code(bad, "0.05")


# ---------------------------------------------------------------------------------------------
# units, shapes, comparison and verdicts, system modes


@pytest.fixture(scope="module")
def ran():
    import flexmbd
    case = flexmbd.load_case("pendulum", ["report.snapshots=[0.02, 0.04]"])
    return case, flexmbd.run(case, "flexmbd", t_end=0.04, shapes=True)


def test_every_column_of_a_run_has_its_unit(ran):
    import flexmbd
    case, (df, _) = ran
    want = {"t": "s", "joint_angle": "rad", "tip_deflection": "m", "stress_vm": "Pa", "stress_normal": "Pa", "energy": "J"}
    assert flexmbd.units(df) == df.attrs["units"] == want == flexmbd.units(case) == flexmbd.units("pendulum")
    assert [flexmbd.units(df[c]) for c in df.columns] == [want[c] for c in df.columns]
    assert flexmbd.units(df[["energy"]]) == {"t": "s", "energy": "J"}          # a selection keeps its own
    assert "shapes" not in df.attrs


def test_a_prismatic_joints_coordinate_is_in_metres():
    import flexmbd
    case = flexmbd.load_case("slider_crank")
    slides = [n for n, c in case.channels.items() if c.kind == "joint_angle"
              and case.joints[c.joint].type == "prismatic"]
    assert slides and all(flexmbd.units(case)[n] == "m" for n in slides)


def test_units_of_a_frame_not_from_flexmbd_are_refused():
    import pandas as pd

    import flexmbd
    with pytest.raises(ValueError, match="no units"):
        flexmbd.units(pd.DataFrame({"a": [1.0]}))
    df = pd.DataFrame({"a": [1.0]})
    df.attrs["units"] = {"a": "m"}
    with pytest.raises(ValueError, match="no unit for 'b'"):
        flexmbd.units((df["a"] * 2).rename("b"))


def test_the_shapes_are_the_runs_snapshots(ran):
    """One row per (body, t, x): at each snapshot the tip's uy is the tip deflection channel there."""
    import numpy as np
    _, (df, shapes) = ran
    assert list(shapes.columns) == ["body", "t", "x", "ux", "uy", "uz"]
    assert sorted(set(shapes.t)) == pytest.approx([0.02, 0.04]) and set(shapes.body) == {"beam"}
    assert shapes.attrs["units"] == {"t": "s", "x": "m", "ux": "m", "uy": "m", "uz": "m"}
    for t, at in shapes.groupby("t"):
        assert at.x.iloc[0] == 0.0 and at.x.max() == pytest.approx(1.5)
        tip = at[at.x == at.x.max()].uy.iloc[0]
        assert tip == df["tip_deflection"].iloc[int(np.argmin(np.abs(df.index - t)))] != 0.0


def test_compare_returns_the_reports_columns_and_verdicts(monkeypatch):
    """The report's accuracy columns and verdicts, from the report's own functions: a tolerance
    the run misses makes a fail, with the verdict the report words."""
    import flexmbd
    from flexmbd.report import accuracy, tables
    case = flexmbd.load_case("cantilever_step", ["report.tolerances.stress_vm=1e-6"])
    acc = flexmbd.compare(case, ["flexmbd"], t_end=0.05)
    assert list(acc.columns) == [k for k, *_ in tables.ACCURACY_COLUMNS]
    assert acc.attrs["headers"]["rms"] == "RMS diff / max|ref|" and flexmbd.units(acc)["f_solver"] == "Hz"
    row = acc.set_index("channel").loc["stress_vm"]
    assert row["pass"] == "fail" and row["rms"] > 1e-6 and row["tolerance"] == 1e-6
    assert acc.set_index("channel").loc["tip_deflection", "pass"] == "pass"
    v = flexmbd.verdicts(acc)
    assert list(v.index) == ["fe-linear", "flexmbd"] and list(v.verdict) == ["reference", "fail"]
    assert v.loc["flexmbd", "text"].startswith("fail: stress_vm") and set(accuracy.VERDICTS) >= set(v.verdict)
    assert v.loc["flexmbd", "worst_rms"] == row["rms"] and v.loc["flexmbd", "wall_s"] > 0
    assert flexmbd.units(v) == {"worst_rms": "1", "wall_s": "s"}


def test_a_solver_that_cannot_run_has_a_verdict_and_no_rows():
    import flexmbd
    acc = flexmbd.compare("cantilever_step", ["pinocchio"], t_end=0.01)
    v = flexmbd.verdicts(acc)
    assert acc.empty and v.loc["pinocchio", "verdict"] in ("not applicable", "unavailable")
    assert v.loc["pinocchio", "text"] == acc.attrs["status"]["pinocchio"] and v.loc["fe-linear", "verdict"] == "reference"


def test_system_modes_write_their_damping_resolution():
    """Undamped: every ratio is round-off, shown as 0 beside its resolution; with 1 % modal damping
    the beam's own modes show 0.01."""
    import flexmbd
    modes = flexmbd.system_modes("cantilever_step")
    assert list(modes.columns) == ["freq_hz", "damping", "damping_resolution", "label", "share"]
    assert (modes.damping == 0.0).all() and (modes.damping_resolution > 0).all()
    assert (modes.damping_resolution < 1e-9).all() and flexmbd.units(modes)["freq_hz"] == "Hz"
    damped = flexmbd.system_modes(flexmbd.load_case("cantilever_step", ["bodies.beam.damping_ratio=0.01"]))
    assert damped.damping.to_numpy() == pytest.approx(0.01, abs=1e-9)
