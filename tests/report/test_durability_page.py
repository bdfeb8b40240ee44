"""The Durability section of a case page and `flexmbd.durability` (report/durability.py,
docs/durability.md): on the paper pendulum with a fatigue count (tests/data/pendulum_durability.toml)
run briefly, by flexmbd against its reference."""

import csv
from pathlib import Path

import numpy as np
import pytest

import flexmbd
from flexmbd import cli

pytestmark = pytest.mark.heavy(30)       # seconds, measured with both cores busy (tests/conftest.py)

T_END = 0.3     # s: a few of the stress's cycles near the pin
CASE = str(Path(__file__).resolve().parents[1] / "data" / "pendulum_durability.toml")


def test_the_api_counts_each_solver_and_grades_it_against_the_reference():
    """flexmbd.durability: a row per solver with its count and, for flexmbd, ratios to
    exudyn-beam's; units in attrs; the cycles of each run with the times they start and end."""
    df = flexmbd.durability(CASE, ["flexmbd"], t_end=T_END)
    assert list(df["solver"]) == ["exudyn-beam", "flexmbd"]
    row = df.set_index("solver").loc["flexmbd"]
    assert row["cycles"] > 3 and row["seq5_MPa"] > 0 and np.isfinite(row["seq5_ratio"])
    assert abs(row["seq5_ratio"] - 1) < 0.2 and row["verdict"] in ("pass", "fail")
    assert flexmbd.units(df)["seq5_MPa"] == "MPa" and df.attrs["curve"] == "DNV C in air"
    cyc = df.attrs["cycles"]["flexmbd"]
    assert set(cyc["channel"]) == {"stress_normal"} and cyc["t_start"].min() >= 0 and cyc["t_end"].max() <= T_END


def test_the_case_page_shows_the_count_and_stores_each_run_s_cycles(tmp_path):
    """compare's page holds the Durability section with its table, figure and files; the CSV's
    numbers are those of the page's table (the reference first, then flexmbd)."""
    assert cli.main(["compare", CASE, "--solvers", "flexmbd", "--t-end", str(T_END), "--out", str(tmp_path)]) == 0
    page = tmp_path / "compare" / "pendulum_durability"
    md = (page / "index.md").read_text()
    assert "## Durability" in md and "durability.png" in md and "| stress_normal | flexmbd |" in md
    for f in ("durability.csv", "durability.tex", "durability.png", "cycles/flexmbd.csv", "cycles/exudyn-beam.csv"):
        assert (page / f).is_file(), f
    rows = list(csv.DictReader((page / "durability.csv").open()))
    assert [r["solver"] for r in rows] == ["exudyn-beam", "flexmbd"]
    assert "\\begin{tabular}" in (page / "durability.tex").read_text()


def test_the_report_s_durability_tables_hold_every_case_s_rows(tmp_path):
    """durability.write_index: one CSV of every case's rows with the case, reference and curve
    first (full precision: the rows' own numbers), Markdown and LaTeX with one table per case, and
    each case's LaTeX table also on its own; nothing at all when no case counts fatigue. Two
    synthetic cases: sinusoids of 10 and 10.5 MPa amplitude counted on the case's curve."""
    from flexmbd import cases
    from flexmbd.harness import durability as fatigue
    from flexmbd.report import durability
    assert durability.write_index(tmp_path, []) == [] and not any(tmp_path.iterdir())
    case = cases.load(CASE)
    st = fatigue.settings(case)
    t = np.linspace(0.0, 1.0, 2001)
    runs = {s: (t, {"stress_normal": a * 1e6 * np.sin(2 * np.pi * 10 * t)})
            for s, a in (("exudyn-beam", 10.0), ("flexmbd", 10.5))}
    rows, _ = fatigue.table(st, runs, "exudyn-beam")
    got = (case, (st, rows, {}))
    index = durability.index_rows(*got) + [dict(r, case="other") for r in durability.index_rows(*got)]
    written = durability.write_index(tmp_path, index)
    assert written == ["durability.csv", "durability.md", "durability.tex"]
    table = list(csv.DictReader((tmp_path / "durability.csv").open()))
    assert [(r["case"], r["solver"]) for r in table] == [(n, s) for n in ("pendulum_durability", "other")
                                                         for s in ("exudyn-beam", "flexmbd")]
    assert table[0]["reference"] == "exudyn-beam" and table[0]["curve"] == "DNV C in air"
    assert float(table[1]["seq5_ratio"]) == rows[1]["seq5_ratio"] == pytest.approx(1.05, rel=1e-9)
    md, tex = (tmp_path / "durability.md").read_text(), (tmp_path / "durability.tex").read_text()
    assert md.count("## ") == 2 and "| stress_normal | flexmbd |" in md
    assert tex.count("\\begin{tabular}") == 2 and "tab:durability:other" in tex
    assert (tmp_path / "tex" / "durability_other.tex").read_text() in tex
