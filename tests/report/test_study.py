"""`flexmbd study`: the grid, the study file, every point checked before any run, the tidy table
(the same bytes in this process and on a Dask LocalCluster) and its figures."""

import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from flexmbd.report import study
from flexmbd.cli import main
from flexmbd.core.errors import InputError

pytestmark = pytest.mark.kernel_free

GRID = ["cantilever_step", "--vary", "solvers.analytic.modes=2,8", "--vary", "integrator.output_dt=1e-3,5e-4",
        "--vary", "duration=0.4",
        "--solvers", "analytic"]


def test_vary_splits_on_commas_outside_brackets_and_quotes():
    assert study.parse_vary("a.b=1,2.5,3") == ("a.b", ("1", "2.5", "3"))
    assert study.parse_vary("gravity=[0,-9.81,0],[0,0,0]") == ("gravity", ("[0,-9.81,0]", "[0,0,0]"))
    assert study.parse_vary('s="x,y",z') == ("s", ('"x,y"', "z"))
    for bad in ("a.b", "=1,2", "a.b=1,,2", "a.b=", "a.b+=1"):
        with pytest.raises(InputError, match="expected KEY=VALUE1,VALUE2"):
            study.parse_vary(bad)


def test_the_grid_varies_the_last_key_fastest_and_ends_at_the_finest_point():
    st = study.Study(("c",), (("a", ("1", "2")), ("b", ("x", "y"))))
    assert study.grid(st) == [("a=1", "b=x"), ("a=1", "b=y"), ("a=2", "b=x"), ("a=2", "b=y")]
    assert len({study.point_id(p) for p in study.grid(st)}) == 4
    tied = study.Study(("c",), (("x.n+y.n", ("4", "8")),))
    assert study.grid(tied) == [("x.n=4", "y.n=4"), ("x.n=8", "y.n=8")]
    assert study.values(tied, ("x.n=8", "y.n=8")) == {"x.n+y.n": 8}
    assert study.parse_vary("x.n+y.n=4,8") == ("x.n+y.n", ("4", "8"))


def test_a_point_s_folder_is_named_as_before_the_one_key_recipe():
    """The digest of a point's overrides names its folder of stored runs: the value it had before
    every key went through `version.cache_key`, so that no stored point is run again."""
    assert study.point_id(["bodies.beam.modes.count=8", "integrator.dt=1e-4"]) == "e1bb3157ebb8"
    assert study.point_id([]) == "e3b0c44298fc"


def test_a_study_file_gives_the_study_of_the_arguments(tmp_path):
    f = tmp_path / "s.toml"
    f.write_text('[study]\ncases = ["cantilever_step"]\nsolvers = ["analytic"]\n'
                 '[study.vary]\n"solvers.analytic.modes" = [2, 8]\n"integrator.output_dt" = [1e-3, 5e-4]\n')
    st = study.from_file(f)
    assert st.cases == ("cantilever_step",) and st.solvers == ("analytic",)
    assert study.grid(st) == [tuple(f"{k}={v}" for k, v in zip(("solvers.analytic.modes", "integrator.output_dt"), c))
                              for c in (("2", "0.001"), ("2", "0.0005"), ("8", "0.001"), ("8", "0.0005"))]


@pytest.mark.parametrize("text, key", [("x = 1\n", "study: expected a [study] table"),
                                       ('[study]\ncases = "c"\n[study.vary]\na = [1]\n', "study.cases"),
                                       ('[study]\ncases = ["c"]\n', "study.vary"),
                                       ('[study]\ncases = ["c"]\n[study.vary]\na = 1\n', "study.vary.a"),
                                       ('[study]\ncases = ["c"]\nsteps = 3\n[study.vary]\na = [1]\n', "study.steps"),
                                       ("[study\n", "not a TOML file")])
def test_a_bad_study_file_is_one_line_naming_the_key(tmp_path, text, key):
    f = tmp_path / "s.toml"
    f.write_text(text)
    with pytest.raises(InputError, match=re.escape(key)) as e:
        study.from_file(f)
    assert str(f) in str(e.value) and "\n" not in str(e.value)


def test_one_bad_point_stops_the_study_before_anything_runs(tmp_path, capsys):
    out = tmp_path / "st"
    code = main(["study", "cantilever_step", "--vary", "solvers.analytic.modes=2,-1", "--solvers", "analytic",
                 "--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "solvers.analytic.modes" in err[0] and err[0].startswith("flexmbd: ")
    assert not out.exists()


@pytest.fixture(scope="module")
def grid_study(tmp_path_factory) -> Path:
    """The study of GRID run in this process (its folder; read only: copy it to change it)."""
    out = tmp_path_factory.mktemp("grid") / "st"
    assert main(["study", *GRID, "--out", str(out), "--workers", "1"]) == 0
    return out


def test_a_study_writes_its_table_and_figures_and_keeps_its_runs(grid_study, tmp_path, capsys):
    out = tmp_path / "st"
    shutil.copytree(grid_study, out)
    df = pd.read_parquet(out / "study.parquet")
    # 4 points x (analytic and the reference fe-linear) x 2 channels x 5 metrics
    assert len(df) == 4 * 2 * 2 * len(study.METRICS)
    assert list(df.columns[:5]) == ["case", "point", "solvers.analytic.modes", "integrator.output_dt", "duration"]
    assert df["solvers.analytic.modes"].dtype.kind == "i" and df["integrator.output_dt"].dtype.kind == "f"
    fin = df[(df.solver == "analytic") & (df.metric == "rms_vs_finest")]
    last = (fin["solvers.analytic.modes"] == 8) & (fin["integrator.output_dt"] == 5e-4)
    assert (fin[last]["value"] == 0).all() and (fin[~last]["value"] > 0).all()
    ref = df[(df.solver == "analytic") & (df.metric == "rms_vs_reference")]
    assert (ref["reference"] == "fe-linear").all() and np.isfinite(ref["value"]).all()
    assert sorted(p.name for p in (out / "figures").glob("*.png")) == sorted(
        f"cantilever_step__{k}__{m}.png" for k in ("solvers.analytic.modes", "integrator.output_dt")
        for m in ("rms_vs_reference", "rms_vs_finest"))          # no fatigue count on this case: no S_eq figure
    capsys.readouterr()
    assert main(["study", *GRID, "--out", str(out), "--workers", "1"]) == 0
    assert capsys.readouterr().err.count("(stored, unchanged)") == 8


def test_the_table_is_the_same_bytes_in_this_process_and_on_a_dask_local_cluster(grid_study, tmp_path):
    """(test_executor.py: a study's table on the pool and on a Dask cluster.)"""
    pytest.importorskip("distributed")
    assert main(["study", *GRID, "--out", str(tmp_path / "dask"), "--dask-local", "2"]) == 0
    assert (grid_study / "study.parquet").read_bytes() == (tmp_path / "dask" / "study.parquet").read_bytes()


def test_the_study_options_are_one_line_when_missing_or_doubled(tmp_path, capsys):
    f = tmp_path / "s.toml"
    f.write_text('[study]\ncases = ["cantilever_step"]\n[study.vary]\n"solvers.analytic.modes" = [2]\n')
    for argv, says in ((["study", "cantilever_step"], "--vary"),
                       (["study", "cantilever_step", "--file", str(f)], "not both"),
                       (["study", *GRID, "--workers", "0"], "--workers"),
                       (["study", *GRID, "--workers", "2", "--dask-local", "2"], "not allowed with")):
        assert main([*argv, "--out", str(tmp_path / "o")]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and says in err[0], err
    assert not Path(tmp_path / "o").exists()


def test_a_reference_at_the_base_runs_once_and_grades_every_point(tmp_path, capsys):
    out = tmp_path / "st"
    argv = ["study", "cantilever_step", "--vary", "solvers.analytic.modes=2,8", "--solvers", "analytic",
            "--reference-at", "base", "--out", str(out), "--workers", "1"]
    assert main(argv) == 0
    assert "runs once, on the case without the overrides" in capsys.readouterr().err
    assert sorted(p.parent.name + "/" + p.name for p in (out / "points").rglob("*.json")) == sorted(
        [f"cantilever_step/analytic.json"] * 2 + ["cantilever_step/fe-linear.json"])
    df = pd.read_parquet(out / "study.parquet")
    # 2 points of analytic and the reference once (its key column empty) x 2 channels x 5 metrics
    assert set(df.solver) == {"analytic", "fe-linear"} and len(df) == 3 * 2 * len(study.METRICS)
    assert df[df.solver == "fe-linear"]["solvers.analytic.modes"].isna().all()
    ref = df[(df.metric == "rms_vs_reference") & (df.solver == "analytic")]
    assert (ref["reference"] == "fe-linear").all() and np.isfinite(ref["value"]).all()
    assert main(["study", "cantilever_step", "--vary", "solvers.fe-linear.dt=1e-4,5e-5", "--solvers", "analytic",
                 "--reference-at", "base", "--out", str(tmp_path / "bad")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "solvers.fe-linear.dt" in err[0] and not (tmp_path / "bad").exists()


def test_a_counted_channel_has_its_fatigue_metrics_and_no_other_channel_does():
    """study._metrics on the pendulum with a [durability] table (tests/data/pendulum_durability.toml):
    the counted channel's S_eq at m = 3 and 5 and damage are the fatigue count's (`harness.durability`,
    as the report counts them): a cosine of 4 MPa amplitude over 10 periods, from a peak to a peak,
    is 10 cycles of 8 MPa, S_eq,m = 8 (10 / 2e6)^(1/m) MPa; another channel has the plain metrics
    only."""
    from pathlib import Path
    from flexmbd import cases
    from flexmbd.harness.results import Result
    case = cases.load(str(Path(__file__).resolve().parents[1] / "data" / "pendulum_durability.toml"))
    t = np.linspace(0.0, 1.0, 4001)
    r = Result(solver="flexmbd", case=case.name, t=t, channels={"stress_normal": 4e6 * np.cos(2 * np.pi * 10 * t),
                                                                 "joint_angle": t})
    got = study._metrics(case, "stress_normal", r, None, None)
    assert set(got) == set(study.METRICS) | set(study.FATIGUE)
    for m in (3, 5):
        assert got[f"seq{m}_MPa"] == pytest.approx(8.0 * (10 / 2e6) ** (1 / m), rel=1e-9)
    assert got["damage"] > 0
    assert set(study._metrics(case, "joint_angle", r, None, None)) == set(study.METRICS)


@pytest.mark.parametrize("path", sorted((Path(__file__).resolve().parents[2] / "cases" / "studies").glob("*.toml")),
                         ids=lambda p: p.stem)
def test_each_stored_sweep_is_its_study_run_to_the_end(path):
    """cases/studies/NAME.parquet is NAME.toml's table: every value of its varied key, every solver
    and channel of the case, every run ended, and the fatigue metrics of the counted channel."""
    from flexmbd import cases
    st = study.from_file(path)
    df = pd.read_parquet(path.with_suffix(".parquet"))
    (key, values), = st.vary
    assert sorted(set(df[key].dropna())) == sorted(study._value(v) for v in values)
    case = cases.load(st.cases[0])
    assert set(df["solver"]) == set(st.solvers) and set(df["channel"]) == set(case.channels)
    assert df["status"].str.startswith("ok").all()
    seq = df[df["metric"] == "seq5_MPa"]
    assert set(seq["channel"]) == set(case.durability["channels"]) and (seq["value"] > 0).all()
