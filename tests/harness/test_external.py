"""flexmbd import (external.py): a result computed elsewhere, checked against the case, joins the
report, the reviewer tables and regress like any solver's."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from flexmbd import cases
from flexmbd.harness import external, results
from flexmbd.cli import main
from flexmbd.core.errors import InputError

CASE = "cantilever_step"
SHORT = Path(__file__).resolve().parents[2] / "cases" / f"{CASE}.toml"


@pytest.fixture(scope="module")
def short(tmp_path_factory) -> str:
    """The case over 0.2 s, as a case file (a report takes no --set)."""
    path = tmp_path_factory.getbasetemp() / "short" / f"{CASE}.toml"
    path.parent.mkdir(exist_ok=True)
    path.write_text(SHORT.read_text().replace("duration = 2.0", "duration = 0.2", 1))
    return str(path)


@pytest.fixture(scope="module")
def reference(tmp_path_factory, short) -> Path:
    """A report folder holding the case's reference run (fe-linear) over 0.2 s."""
    out = tmp_path_factory.mktemp("rep")
    assert main(["run", short, "--solver", "fe-linear", "--out", str(out)]) == 0
    return out


def short_case(reference) -> str:
    return str(reference.parent / "short" / f"{CASE}.toml")


def table(reference: Path, scale: float = 1.0) -> pd.DataFrame:
    """The reference's tip deflection scaled: a result from "elsewhere" that differs by `scale`."""
    df = pd.read_csv(results.folder(reference) / CASE / "fe-linear.csv")
    return pd.DataFrame({"t": df["t"], "tip_deflection": df["tip_deflection"] * scale})


def imported(tmp_path, reference, df, *extra, name="myfe", meta=None, case=None) -> tuple[int, Path]:
    """`flexmbd import` of df into a copy of the reference's report folder, for the 0.2 s case
    (or `case`): (exit status, folder)."""
    out = tmp_path / "rep"
    if not out.exists():
        import shutil
        shutil.copytree(reference, out)
    csv = tmp_path / "mine.csv"
    df.to_csv(csv, index=False)
    argv = ["import", case or short_case(reference), str(csv), "--solver", name, "--out", str(out),
            *extra]
    if meta is not None:
        (tmp_path / "meta.json").write_text(json.dumps(meta) if not isinstance(meta, str) else meta)
        argv += ["--meta", str(tmp_path / "meta.json")]
    return main(argv), out


def test_an_imported_result_appears_in_the_report_and_the_tables(tmp_path, reference, capsys):
    code, out = imported(tmp_path, reference, table(reference, 1.03),
                         meta={"solver_version": "MyFE 2.3", "machine": "cluster-7", "wall_s": 12.5})
    assert code == 0
    meta = json.loads((out / "results" / CASE / "myfe.json").read_text())
    assert meta["imported"]["file"] == "mine.csv" and meta["machine"] == "cluster-7" and meta["status"] == "ok"
    assert meta["case_sha256"] == cases.load(short_case(reference)).sha256
    # the report runs no solver for it, shows it with its verdict, and the tables hold its row
    capsys.readouterr()
    case = short_case(reference)
    assert main(["report", "--no-run", "--cases", case, "--solvers", "fe-linear", "--out", str(out), "--strict"]) == 1
    assert "myfe: fail: tip_deflection" in capsys.readouterr().out
    index = (out / "index.md").read_text()
    assert "| myfe | ✗ fail: tip_deflection RMS" in index
    acc = pd.read_csv(out / "accuracy.csv")
    row = acc[(acc.solver == "myfe") & (acc.metric == "rms")]
    y = table(reference).tip_deflection
    expected = 0.03 * np.sqrt(np.mean(y ** 2)) / np.abs(y).max()          # 3 % larger everywhere
    assert len(row) == 1 and float(row.value.iloc[0]) == pytest.approx(expected, rel=1e-4)
    page = (out / CASE / "index.md").read_text()
    assert "imported: mine.csv" in page and "MyFE 2.3" in page and "cluster-7" in page


def test_an_imported_result_in_regress(tmp_path, reference, capsys):
    """A baseline made from an imported result (the case as shipped: baselines are full runs);
    the same result again: nothing moved; one 5 % off: moved."""
    t = np.linspace(0.0, 2.0, 2001)
    df = pd.DataFrame({"t": t, "tip_deflection": -2e-3 * (1 - np.cos(2 * np.pi * 5.53 * t))})
    code, out = imported(tmp_path, reference, df, case=CASE)
    base = tmp_path / "base"
    assert code == 0
    assert main(["regress", "--update", "--baseline", str(base), "--results", str(out), "--cases", CASE,
                 "--solvers", "myfe"]) == 0
    assert (base / CASE / "myfe.csv").read_text().startswith("# source: flexmbd import")
    assert main(["regress", "--baseline", str(base), "--results", str(out), "--cases", CASE]) == 0
    code, out = imported(tmp_path, reference, df.assign(tip_deflection=df.tip_deflection * 1.05), case=CASE)
    capsys.readouterr()
    assert main(["regress", "--baseline", str(base), "--results", str(out), "--cases", CASE]) == 1
    assert "moved: cantilever_step / myfe / tip_deflection" in capsys.readouterr().err
    # it cannot be rerun: without --results, one line saying so
    assert main(["regress", "--baseline", str(base), "--cases", CASE]) == 2
    assert "imported result, which cannot be rerun" in capsys.readouterr().err


@pytest.mark.parametrize("change, names", [
    (lambda df: df.rename(columns={"tip_deflection": "tip_defl"}), ["column tip_defl", "did you mean 'tip_deflection'"]),
    (lambda df: pd.concat([df, df[["tip_deflection"]]], axis=1), ["tip_deflection appears twice"]),
    (lambda df: df[["t"]], ["no channel columns"]),
    (lambda df: df.iloc[:50], ["ends at 0.049 s", "before the case's duration"]),
    (lambda df: df.assign(t=df.t + 0.01), ["starts at 0.01 s"]),
    (lambda df: df.assign(t=df.t ** 1.1), ["not evenly spaced"]),
    (lambda df: df.assign(t=df.t * 2), ["after the case's duration"]),
    (lambda df: df.assign(tip_deflection=np.where(df.t > 0.1, np.nan, df.tip_deflection)), ["row 102", "finite"]),
    (lambda df: df.iloc[:1], ["at least two samples"]),
])
def test_a_bad_table_is_one_line_and_nothing_is_written(tmp_path, reference, capsys, change, names):
    code, out = imported(tmp_path, reference, change(table(reference)))
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "mine.csv" in err and "Traceback" not in err
    assert all(n in err for n in names), err
    assert not (out / "results" / CASE / "myfe.json").exists()


@pytest.mark.parametrize("meta, names", [
    ({"wall": 1.0}, ["wall: not a key"]),
    ({"wall_s": -1}, ["wall_s: expected a number >= 0"]),
    ({"settings": [1]}, ["settings: expected a JSON object"]),
    ({"status": "fine"}, ["status: expected a run status"]),
    ({"status": "unavailable: no licence"}, ["status: expected a run status"]),
    ("{not json", ["not JSON"]),
    ("[1, 2]", ["expected a JSON object"]),
])
def test_bad_metadata_is_one_line_naming_the_key(tmp_path, reference, capsys, meta, names):
    code, out = imported(tmp_path, reference, table(reference), meta=meta)
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "meta.json" in err and all(n in err for n in names), err
    assert not (out / "results" / CASE / "myfe.json").exists()


@pytest.mark.parametrize("name, why", [("fe-linear", "one of flexmbd's solvers"), ("../x", "cannot name"),
                                       ("", "cannot name")])
def test_the_name_is_not_a_solver_and_safe_as_a_file_name(tmp_path, reference, capsys, name, why):
    code, _ = imported(tmp_path, reference, table(reference), name=name)
    assert code == 2 and why in capsys.readouterr().err


def test_a_run_that_failed_early_and_the_divergence_rule(tmp_path, reference):
    case = cases.load(short_case(reference))
    df = table(reference).iloc[:50]
    df.to_csv(tmp_path / "a.csv", index=False)
    (tmp_path / "m.json").write_text(json.dumps({"status": "failed: Newton did not converge at t = 0.049 s"}))
    r = external.load(case, "myfe", tmp_path / "a.csv", tmp_path / "m.json")
    assert r.status.kind == "failed" and r.status.t == pytest.approx(0.049) and len(r.t) == 50
    big = table(reference).assign(tip_deflection=lambda d: np.where(d.t > 0.1, 5.0, d.tip_deflection))
    big.to_csv(tmp_path / "b.csv", index=False)
    r = external.load(case, "myfe", tmp_path / "b.csv")
    assert r.status.kind == "failed" and "diverged" in r.status.why and r.t[-1] <= 0.1 + 1e-12


def test_comment_lines_are_allowed(tmp_path, reference):
    case = cases.load(short_case(reference))
    text = "# from MyFE 2.3\n# units: s, m\n" + table(reference).to_csv(index=False)
    (tmp_path / "c.csv").write_text(text)
    r = external.load(case, "myfe", tmp_path / "c.csv")
    assert r.ok and len(r.t) == 201 and list(r.channels) == ["tip_deflection"]
    with pytest.raises(InputError, match="imported result's metadata"):
        (tmp_path / "m.json").write_text('{"channels": []}')
        external.load(case, "myfe", tmp_path / "c.csv", tmp_path / "m.json")
