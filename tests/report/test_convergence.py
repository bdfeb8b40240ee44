"""The convergence section of a case page (`report.convergence`): the fitted rate and the point
within tolerance, the stored studies against their files, one stored point of each kind run again
with the current code, and the section drawn from the tables."""

import shutil

import numpy as np
import pandas as pd
import pytest

from flexmbd import cases
from flexmbd.harness import registry
from flexmbd.report import study
from flexmbd.cases.validate import CASES_DIR
from flexmbd.report import convergence, tables

FOLDER = CASES_DIR / convergence.FOLDER
STUDIES = sorted(FOLDER.glob("*.toml"))


def test_the_case_s_own_value_is_read_from_the_resolved_case():
    """`own_value` reads the typed case (`case.resolved`), never the file's dicts: the value as the
    file gives it (a material by its name, a list as a list), a solver setting with its default,
    None for a key the case does not hold."""
    from types import SimpleNamespace
    case = cases.load("pendulum")
    typed = SimpleNamespace(resolved=case.resolved)                        # no `data` to read
    assert convergence.own_value(typed, "bodies.beam.modes.count+bodies.beam2.modes.count") == 12
    assert convergence.own_value(typed, "bodies.beam.elements") == 100
    assert convergence.own_value(typed, "bodies.beam.material") == "steel"
    assert convergence.own_value(typed, "materials.steel.E") == case.bodies["beam"].material.E
    assert convergence.own_value(typed, "gravity") == [0.0, -9.81, 0.0]
    assert convergence.own_value(typed, "bodies.beam.modes") == {"count": 12, "boundary": "clamped-free",
                                                                 "interfaces": None, "kinds": None,
                                                                     "static": None}
    assert convergence.own_value(typed, "integrator.method") == case.integrator.method
    for key in ("nope", "bodies.nope.elements", "bodies.beam.nope", "bodies.beam.elements.x"):
        assert convergence.own_value(typed, key) is None, key
    assert convergence.own_value(case, "solvers.exudyn-beam.dt") == registry.settings(case, "exudyn-beam")["dt"]


def test_the_rate_is_the_exponent_of_a_power_law_and_ignores_points_without_an_error():
    x = np.array([4.0, 8.0, 16.0, 32.0])
    assert convergence.rate(x, 3.0 * x ** -2.0) == pytest.approx(-2.0, abs=1e-12)
    assert convergence.rate([1e-4, 5e-5, 2.5e-5], [4e-4, 1e-4, 2.5e-5]) == pytest.approx(2.0, abs=1e-12)
    assert convergence.rate(x, [1e-3, np.nan, 0.0, 1e-4]) == pytest.approx(np.log(0.1) / np.log(8.0), abs=1e-12)
    assert np.isnan(convergence.rate(x, [1e-3, np.nan, 0.0, np.nan]))


def test_within_tolerance_is_the_coarsest_point_from_which_every_finer_one_is_within():
    x = [4, 8, 12, 24, 48]
    assert convergence.within(x, [0.9, 0.2, 0.04, 0.01, 0.005], 0.05) == 12
    assert convergence.within(x, [0.01, 0.2, 0.04, 0.01, 0.005], 0.05) == 12     # not the first within
    assert convergence.within(x, [0.01, 0.02, 0.04, 0.01, 0.06], 0.05) is None   # the finest is not
    assert convergence.within(x, [0.01, 0.02, np.nan, 0.01, 0.005], 0.05) == 24  # no value: not within


@pytest.mark.parametrize("path", STUDIES, ids=lambda p: p.stem)
def test_each_stored_table_is_its_study_run_to_the_end(path):
    st = study.from_file(path)
    df = pd.read_parquet(path.with_suffix(".parquet"))
    key = convergence.varied(st)
    assert key is not None, "a convergence study varies one key"
    values = [study._value(v) for v in dict(st.vary)[key]]
    assert sorted(set(df[key].dropna())) == sorted(values)
    case = cases.load(st.cases[0])
    assert set(df["solver"]) == set(st.solvers) | ({case.report.reference} if st.reference == "base" else set())
    assert set(df["channel"]) == set(case.channels)
    assert (df["status"].str.startswith("ok")).all(), sorted(set(df["status"]))


def test_the_shipped_cases_each_show_their_reference_converged_and_the_paper_cases_their_mode_count():
    shown = {}
    for path in STUDIES:
        st = study.from_file(path)
        for name in st.cases:
            shown.setdefault(name, set()).update(st.solvers)
    for name in cases.available():
        ref = cases.load(name).report.reference
        assert ref in shown.get(name, set()), f"{name}: no study of its reference {ref}"
    for name in ("cantilever_step", "pendulum", "double_pendulum"):
        assert "flexmbd" in shown[name]


def _stored(name: str, solver: str, key: str, value) -> pd.DataFrame:
    df = pd.read_parquet(FOLDER / f"{name}.parquet")
    return df[(df.solver == solver) & (df[key] == value)]


@pytest.mark.parametrize("name, solver, override", [
    ("cantilever_step.modes", "flexmbd", "bodies.beam.modes.count=4"),
    ("cantilever_step.mesh", "fe-linear", "bodies.beam.elements=25")])
def test_a_stored_point_is_what_the_current_code_computes(name, solver, override):
    """max_abs, mean and final of each channel: the same run again. Margin 1e-6 relative: the run is
    deterministic (one BLAS thread); platforms differ by rounding (1e-12 of the values, the
    integrator's rtol 1e-8 amplifying it at most to 1e-8), so a larger change is a change of the
    code: run `make convergence` (docs/studies.md)."""
    key, value = override.split("=")
    case = cases.load(name.split(".")[0], [override])
    r = registry.run(case, solver)
    assert r.ok, r.status
    rows = _stored(name, solver, key, int(value))
    for _, row in rows[rows.metric.isin(["max_abs", "mean", "final"])].iterrows():
        y = np.asarray(r.channels[row.channel])
        got = {"max_abs": np.max(np.abs(y)), "mean": np.mean(y), "final": y[-1]}[row.metric]
        scale = np.max(np.abs(y))
        assert abs(got - row.value) <= 1e-6 * scale, (row.channel, row.metric, got, row.value)


def test_the_section_shows_the_stored_numbers_and_says_where_a_study_is_missing(tmp_path):
    case = cases.load("cantilever_step")
    html, md = convergence.section(case, tmp_path)
    assert "within tolerance from" in html and "cantilever_step.modes" in md
    df = pd.read_parquet(FOLDER / "cantilever_step.modes.parquet")
    for ch in case.channels:                              # the page's numbers are the table's
        v = df[(df.solver == "flexmbd") & (df.channel == ch) & (df.metric == "rms_vs_reference")
               & (df["bodies.beam.modes.count"] == 12)]["value"].iloc[0]
        assert tables.fmt(v) in md
    ref = case.report.reference
    assert sorted(p.name for p in tmp_path.glob("*.png")) == sorted(        # one figure per study of the case
        f"convergence_{n}_{'rms_vs_finest' if ref in st.solvers else 'rms_vs_reference'}.png"
        for n, st, _ in convergence.studies(case))
    assert html.index("cantilever_step.mesh:") < html.index("cantilever_step.modes:")   # the reference's first
    # a copy of the case beside a study with no table yet
    (tmp_path / "c" / convergence.FOLDER).mkdir(parents=True)
    shutil.copy(case.path, tmp_path / "c" / "mine.toml")
    (tmp_path / "c" / convergence.FOLDER / "mine.modes.toml").write_text(
        '[study]\ncases = ["mine"]\nsolvers = ["flexmbd"]\n[study.vary]\n"bodies.beam.modes.count" = [4, 8]\n')
    mine = cases.load(str(tmp_path / "c" / "mine.toml"))
    html, md = convergence.section(mine, tmp_path / "c")
    assert "not run yet" in md and "make convergence STUDIES=mine.modes" in md


def test_a_counted_channel_s_s_eq_is_drawn_against_the_study_s_key(tmp_path):
    """pendulum's stress_normal is counted ([durability]): each of its studies whose table holds
    the channel's seq5_MPa draws it against the varied key (convergence_NAME_seq5_MPa.png), shown in
    the section; a case without a count draws none."""
    html, _ = convergence.section(cases.load("pendulum"), tmp_path)
    assert (tmp_path / "convergence_pendulum.forces_seq5_MPa.png").is_file()
    assert "convergence_pendulum.forces_seq5_MPa.png" in html
    other = tmp_path / "other"
    other.mkdir()
    convergence.section(cases.load("cantilever_step"), other)
    assert not list(other.glob("*seq5*"))
