"""The report: pages and links, the same numbers in every format, FFT peaks, regression, robustness."""

import csv
import json
import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from flexmbd import cases
from flexmbd.harness import channels, metrics, registry
from flexmbd.fe import flexbody
from flexmbd.core import resources
from flexmbd.cli import main
from flexmbd.report import regress, spectra, tables
from tests.report.test_tables import compile_input

pytestmark = pytest.mark.heavy(11)       # seconds, measured with both cores busy (tests/conftest.py)

FAST = "analytic,fe-linear"


@pytest.fixture(scope="module")
def report(cantilever_report):
    """A report of cantilever_step by analytic, its reference fe-linear and pinocchio (which does not
    apply): the session's (conftest.py). Read only: a test that changes it works on a copy."""
    return cantilever_report


def referenced_files(page: Path) -> list:
    text = page.read_text()
    return re.findall(r"(?:src|href)='([^'#:]+)'", text) + re.findall(r"\]\(([^)#:]+)\)", text)


def test_every_referenced_file_exists(report):
    pages = [report / "index.html", report / "index.md", report / "cantilever_step" / "index.html",
             report / "cantilever_step" / "index.md"]
    for page in pages:
        refs = referenced_files(page)
        assert refs, page
        for ref in refs:
            assert (page.parent / ref).is_file(), f"{page}: broken link {ref}"


def test_page_has_every_section(report):
    page = (report / "cantilever_step" / "index.html").read_text()
    for title in ("Deflection", "Stress", "FFT spectra", "Timing", "Accuracy", "Convergence", "Provenance"):
        assert f"<h2>{title}" in page
    assert "fe-linear" in page and "analytic" in page


def test_deformed_shapes_follow_the_deflections(report):
    """The snapshot section comes right after the deflection channels, its figure drawn as PNG and
    SVG from the shapes the solvers stored."""
    page = (report / "cantilever_step" / "index.html").read_text()
    titles = re.findall(r"<h2>([^<]*)</h2>", page)
    assert titles[titles.index("Deflection") + 1] == "Deformed shape at chosen instants"
    assert "<img src='shapes.png'" in page and (report / "cantilever_step" / "shapes.svg").is_file()
    from flexmbd.harness import results
    stored = {s: results.read(report / "results", "cantilever_step", s).extra.get("shapes") for s in FAST.split(",")}
    assert all(sh["beam"]["t"] == [0.5, 1.0, 1.5, 2.0] for sh in stored.values())


def test_unavailable_and_inapplicable_solvers_show_their_reason(report):
    index = (report / "index.html").read_text()
    assert "not applicable" in index or "unavailable" in index


def test_same_numbers_in_csv_markdown_latex_and_html(report):
    rows = list(csv.DictReader((report / "accuracy.csv").open(newline="")))
    assert rows
    md = (report / "accuracy.md").read_text()
    tex = (report / "accuracy.tex").read_text()
    page = (report / "cantilever_step" / "index.html").read_text()
    for r in rows:
        if r["metric"] not in ("rms", "max", "peak", "envelope", "slow") or not r["value"]:
            continue
        s = tables.fmt(float(r["value"]))
        assert s in md and s in page, (r, s)
        if r["metric"] in ("rms", "max"):
            assert tables.tex_number(float(r["value"])) in tex, r


def test_accuracy_csv_is_tidy(report):
    raw = (report / "accuracy.csv").read_bytes()
    assert b"\r" not in raw and b"nan" not in raw.lower()
    rows = list(csv.DictReader(raw.decode().splitlines()))
    assert list(rows[0]) == ["case", "solver", "reference", "channel", "metric", "value", "unit"]
    units = {r["metric"]: r["unit"] for r in rows}
    assert units["rms"] == "1" and units["f_ref"] == "Hz" and units["pass"] == ""
    per_row = {(r["case"], r["solver"], r["channel"], r["metric"]) for r in rows}
    assert len(per_row) == len(rows)                                  # one row per case, solver, channel, metric


def markdown_tables(text: str) -> list:
    """Blocks of consecutive lines starting with '|': the tables a Markdown page means to have."""
    blocks, cur = [], []
    for line in text.splitlines() + [""]:
        if line.startswith("|"):
            cur.append(line)
        elif cur:
            blocks.append(cur)
            cur = []
    return blocks


def test_every_markdown_page_renders_its_tables(report):
    """Rendered by markdown-it-py (CommonMark with GitHub's tables): each table of a page comes out
    as an HTML table with as many header cells as the Markdown header has."""
    from markdown_it import MarkdownIt
    md = MarkdownIt("commonmark").enable("table")
    pages = [report / "index.md", report / "accuracy.md", report / "cantilever_step" / "index.md"]
    for page in pages:
        text = page.read_text()
        html = md.render(text)
        blocks = markdown_tables(text)
        assert blocks and html.count("<table>") == len(blocks), page
        heads = re.findall(r"<thead>(.*?)</thead>", html, re.S)
        for block, head in zip(blocks, heads):
            assert head.count("<th") == len(re.findall(r"(?<!\\)\|", block[0])) - 1, (page, block[0])


@pytest.mark.skipif(shutil.which("pdflatex") is None, reason="no TeX engine on this machine")
def test_accuracy_tex_compiles_in_a_two_column_article_and_fits(report, tmp_path):
    """accuracy.tex, \\input into a two-column article loading booktabs and siunitx: it compiles
    and no table is wider than its column or the text."""
    tex = (report / "accuracy.tex").read_text()
    assert "\\documentclass" not in tex and "adjustbox" not in tex
    assert "Overfull \\hbox" not in compile_input(tmp_path, tex)


def test_fft_peaks_match_fe_frequencies_on_cantilever_step(cantilever_run):
    """The first three excited (in-plane) bending modes, read from 2 s of signal, within 1 %."""
    case = cases.load("cantilever_step")
    fb = flexbody.for_case(case)["beam"]
    excited = [f for f, lab in zip(fb.freq_hz, fb.labels) if lab.startswith("bending xy")][:3]
    bin_width = 1.0 / case.duration
    assert excited[0] < 12 * bin_width                 # coarse bins: interpolation has to do the work
    for name in ("flexmbd", "fe-linear", "analytic"):
        r = cantilever_run(name)
        found = metrics.match_peaks(metrics.spectral_peaks(r.t, r.channels["tip_deflection"], n=8, fmin=1.0),
                                    excited, tol=0.05)
        for fe, fp in zip(excited, found):
            assert fp is not None and abs(fp / fe - 1) < 0.01, (name, fe, fp)


def test_peak_interpolation_beats_the_bin_width():
    t = np.linspace(0, 2, 2001)
    y = np.sin(2 * np.pi * 5.527 * t) + 0.1 * np.sin(2 * np.pi * 34.63 * t + 1)
    f, A = metrics.spectrum(t, y, pad=1)
    found = metrics.peaks(f, A, T=2.0, n=2)
    assert abs(found[0][0] - 5.527) < 0.05 * (f[1] - f[0]) * 8
    assert abs(found[1][0] - 34.63) < 0.01 * 34.63


def test_regress_flags_a_perturbed_baseline_and_passes_the_real_one(report, tmp_path, capsys):
    """Runs the solvers against the shipped baselines; then the same runs, stored in the session's
    report (`--results`), against a copy with fe-linear's tip deflection moved by 2 %."""
    real = resources.BASELINES
    args = ["--cases", "cantilever_step", "--solvers", FAST]
    assert main(["regress", "--baseline", str(real)] + args) == 0
    capsys.readouterr()
    shutil.copytree(real / "cantilever_step", tmp_path / "cantilever_step")
    p = tmp_path / "cantilever_step" / "fe-linear.csv"
    header = [line for line in p.read_text().splitlines() if line.startswith("#")]
    df = pd.read_csv(p, comment="#")
    df["tip_deflection"] *= 1.02
    p.write_text("\n".join(header) + "\n" + df.to_csv(index=False))
    assert main(["regress", "--baseline", str(tmp_path), "--results", str(report)] + args) == 1
    err = capsys.readouterr().err
    assert "cantilever_step / fe-linear / tip_deflection" in err
    assert "moved: cantilever_step / analytic" not in err


def test_regress_measures_a_conserved_energy_against_the_kinetic_energy(tmp_path):
    """A conserved total energy is round-off around zero: regress normalises it as the accuracy
    table does (by the run's largest kinetic energy), not by its own maximum."""
    from flexmbd.harness.results import Result
    case = cases.load("pendulum")
    t = np.linspace(0.0, 1.0, 101)
    rng = np.random.default_rng(0)
    ref = case.report.reference                                  # the pendulum's: exudyn-beam
    base = Result(solver=ref, case="pendulum", t=t, channels={"energy": 1e-10 * rng.standard_normal(101)},
                  extra={"kinetic_max_J": 12.9})
    fresh = Result(solver=ref, case="pendulum", t=t, channels={"energy": 1e-10 * rng.standard_normal(101)})
    regress.write(tmp_path, case, base)
    stored = regress.read(tmp_path, "pendulum", ref)
    assert float(stored.attrs["kinetic_max_J"]) == 12.9
    kinetic = regress.reference_kinetic(tmp_path, case)
    assert kinetic == 12.9
    [row] = regress.compare(case, fresh, stored, kinetic)
    assert row["rms"] < 1e-10 and not row["moved"]
    drifted = Result(solver=ref, case="pendulum", t=t, channels={"energy": 0.02 * 12.9 * t})
    assert regress.compare(case, drifted, stored, kinetic)[0]["moved"]      # RMS 0.0115 > 0.01


def test_regress_measures_a_rigid_peer_s_energy_noise_against_the_case_s_scale(tmp_path):
    """A rigid peer records no kinetic energy and its conserved total is integration noise (about
    1e-11 J): measured against its own largest magnitude, 9e-11 J of noise read as 22 %. Against
    the reference run's largest kinetic energy (its baseline's header), or without one against the
    gravity closed form |g| sum m l (25.9 J for the pendulum: m g L with m = 1.76 kg, L = 1.5 m),
    it reads about 1e-11."""
    from flexmbd.harness.results import Result
    case = cases.load("pendulum")
    t = np.linspace(0.0, 1.0, 101)
    rng = np.random.default_rng(1)
    noise = lambda: 6e-11 * rng.standard_normal(101)
    regress.write(tmp_path, case, Result(solver="pinocchio", case="pendulum", t=t, channels={"energy": noise()}))
    stored = regress.read(tmp_path, "pendulum", "pinocchio")
    fresh = Result(solver="pinocchio", case="pendulum", t=t, channels={"energy": noise()})
    assert regress.reference_kinetic(tmp_path, case) is None
    assert channels.gravity_energy(case) == pytest.approx(9.81 * 7820.0 * 0.01 * 0.015 * 1.5 * 1.5, rel=1e-12)
    [row] = regress.compare(case, fresh, stored, None)
    assert row["rms"] < 1e-10 and not row["moved"], row
    shutil.copy(resources.BASELINES / "pendulum" / f"{case.report.reference}.csv", tmp_path / "pendulum")
    kinetic = regress.reference_kinetic(tmp_path, case)
    assert 12.0 < kinetic < 14.0                                  # m g L / 2 = 12.9 J released horizontally
    [row] = regress.compare(case, fresh, stored, kinetic)
    assert row["rms"] < 1e-10 and not row["moved"], row


def test_a_reference_of_roundoff_is_measured_against_the_physical_scale():
    """metrics.channel_norm: the reference's largest magnitude, never below 1e-9 of the channel's
    physical scale (a rigid peer's deflection of 1e-17 m on a 1.5 m beam is measured against
    1.5e-9 m); an energy against its scale alone."""
    case = cases.load("pendulum")
    tiny = np.array([0.0, 1e-17, -2e-17])
    assert metrics.channel_norm("deflection", tiny, channels.physical_scale(case, "tip_deflection")) == \
        pytest.approx(1.5e-9)
    assert metrics.channel_norm("deflection", np.array([0.0, 3e-3]), 1.5) == 3e-3
    assert metrics.channel_norm("energy", np.array([1.0, 2.0]), 12.9) == 12.9
    assert metrics.channel_norm("stress_vm", np.zeros(3), 0.0) == 1.0


def test_baselines_carry_provenance():
    for c, s in regress.listing(resources.BASELINES):
        head = [l for l in (resources.BASELINES / c / f"{s}.csv").read_text().splitlines()[:8] if l.startswith("#")]
        keys = {l[2:].split(":")[0] for l in head}
        assert {"source", "solver", "settings", "date", "units", "columns"} <= keys, (c, s)


def test_a_baseline_written_from_a_stored_result_carries_that_run_s_date_and_commit(tmp_path):
    case = cases.load("cantilever_step")
    r = registry.run(case, "analytic", 0.01)
    r.extra.update(date="2000-01-02T03:04:05+00:00", git_commit="abc1234", python="3.0.1")   # as read back
    text = regress.write(tmp_path, case, r).read_text()
    assert "# date: 2000-01-02T03:04:05+00:00; git commit: abc1234; python 3.0.1\n" in text


def test_side_lobes_are_not_peaks():
    """A strong line and a 300x weaker one far away: zero padding makes the strong line's side lobes
    local maxima, which must not be reported."""
    t = np.linspace(0, 2, 2001)
    y = 20 * np.sin(2 * np.pi * 5.527 * t) + 0.07 * np.sin(2 * np.pi * 96.94 * t)
    found = [f for f, _ in metrics.spectral_peaks(t, y, n=8, fmin=1.0)]
    assert len(found) == 2 and abs(found[0] - 5.527) < 0.01 and abs(found[1] - 96.94) < 0.05, found


def test_no_peak_below_the_noise_floor():
    """`peaks` identifies nothing below its `floor`, however the record's own spectrum looks; the
    floor is 1e-6 of the channel's largest magnitude over its runs, never below 1e-9 of its
    physical scale."""
    t = np.linspace(0, 2, 2001)
    y = 1e-14 * np.sin(2 * np.pi * 5.527 * t)
    assert len(metrics.spectral_peaks(t, y)) == 1 and metrics.spectral_peaks(t, y, floor=1e-12) == []
    assert metrics.noise_floor([y, 1e-3 * np.ones(3), [np.nan]], physical=1.5) == pytest.approx(1.5e-9)
    assert metrics.noise_floor([y, [np.nan, -0.01]], physical=1.5) == pytest.approx(1e-8)


def test_verdicts_of_a_run():
    from flexmbd.harness import results
    from flexmbd.report import accuracy
    row = lambda s, ch, rms, tol: {"solver": s, "channel": ch, "rms": rms, "tolerance": tol}
    rows = [row("a", "tip", 0.001, 0.01), row("a", "stress", 0.1, 0.05), row("a", "energy", 0.5, 0.1),
            row("b", "tip", 0.004, 0.01), row("c", "tip", np.nan, 0.01), row("d", "tip", 0.1, np.nan)]
    ok, out = results.Status(), results.outside_validity("deflection 12 % of length", 0.3)
    v = lambda st, s: accuracy.verdict(st, s, "ref", rows)
    assert v(ok, "a") == ("fail", "fail: energy RMS 0.5 = 5.0 × its tolerance 0.1 and 1 more", "")
    assert v(ok, "b") == ("pass", "pass: 1 channel within tolerance", "")
    assert v(ok, "c").kind == "fail"                                    # a NaN difference is no pass
    assert v(ok, "d").kind == "not compared"
    assert v(out, "b") == ("pass", "pass: 1 channel within tolerance", "deflection 12 % of length")   # the flag beside
    assert v(out, "a").kind == "fail" and v(out, "a").outside == "deflection 12 % of length"
    assert str(v(out, "a")).endswith("; outside linear validity: deflection 12 % of length")
    assert v(results.diverged("non-finite state", 0.2), "a") == ("diverged", "diverged: non-finite state at t = 0.2 s", "")
    assert v(results.failed("step size too small", 0.2), "a").kind == "aborted"
    assert v(results.not_applicable("fixed base"), "a").kind == "not applicable"
    assert v(ok, "ref").kind == "reference"
    verdicts = [v(ok, "a"), v(ok, "b"), v(out, "b"), v(results.failed("x"), "a")]
    assert accuracy.summary(verdicts) == "4 runs: 2 pass, 1 fail, 1 aborted (1 outside linear validity)"


def test_every_figure_has_an_svg_and_each_solver_one_colour(report):
    from flexmbd.report import figures
    pngs = list((report / "cantilever_step").glob("*.png"))
    assert pngs and all(p.with_suffix(".svg").is_file() for p in pngs)
    colours = [figures.style(s)["color"] for s in list(figures.STYLE) + ["a-plug-in", "another"]]
    assert len(set(colours[:len(figures.STYLE)])) == len(figures.STYLE)
    assert figures.style("a-plug-in") == figures.style("a-plug-in")            # stable across figures
    svg = (report / "cantilever_step" / "tip_deflection.svg").read_text()
    assert figures.STYLE["analytic"][0] in svg and figures.STYLE["fe-linear"][0] in svg


def test_case_page_shows_each_flexible_body_s_retained_modes(report):
    """A "Mode shapes" section with one figure per flexible body, saying these are the body's own
    modes and where the system modes are; the same in Markdown."""
    page = (report / "cantilever_step" / "index.html").read_text()
    md = (report / "cantilever_step" / "index.md").read_text()
    assert "<h2>Mode shapes</h2><p><img src='modes_beam.png'" in page
    assert (report / "cantilever_step" / "modes_beam.png").is_file() and (report / "cantilever_step" / "modes_beam.svg").is_file()
    for text in (page, md):
        assert "not the system's" in text and "flexmbd modes cantilever_step --system" in text
    assert "## Mode shapes\n\n![modes_beam.png](modes_beam.png)" in md
    assert page.index("<h2>FFT spectra") < page.index("<h2>Mode shapes") < page.index("<h2>Timing")


def test_a_split_beam_shows_the_modes_its_segments_carry(tmp_path):
    """The flexible pendulum's rod is 20 segments of 5 cm to the modal solvers: one figure, of the
    root segment's modes, and a note saying so; not the unsplit 1 m rod's modes."""
    from flexmbd.report import pages
    case = cases.load("flexible_pendulum")
    html, md = pages.mode_shapes(case, tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["modes_rod.png", "modes_rod.svg"]
    assert "20 segments of 0.05 m" in html and "root segment rod:1" in html and "`segments = 20`" in md
    assert "0.05 m" in (tmp_path / "modes_rod.svg").read_text()                        # the title names a segment


def bench_run(folder: Path, name: str, machine: str, error: float = 1e-4) -> None:
    import json
    rows = [{"case": "cantilever_step", "solver": s, "scheme": "fox-goodwin", "setting": f"dt={dt}", "error": error * dt / 1e-4,
             "wall_s": 1e-3 / dt} for s in ("flexmbd", "exudyn-ffrf") for dt in (2e-4, 1e-4)]
    (folder / name).write_text(json.dumps({"machine": machine, "quick": True, "work_precision": rows}))


def test_index_shows_the_latest_work_precision_run_and_nothing_without_one(report, tmp_path, monkeypatch, capsys):
    """With benchmark runs in the history folder the index shows the newest one's work-precision
    figure, naming its file, commit and machine and saying its times are not this report's (newest
    by the date and time the name starts with: a name with a date alone counts from the day's
    start, whatever its name's order); a broken file is passed over with a warning. Without any,
    the index says nothing about it."""
    out = tmp_path / "rep"
    shutil.copytree(report / "results", out / "results")
    history = tmp_path / "history"
    history.mkdir()
    bench_run(history, "2026-11-22_aaaaaaa.json", "old machine")
    bench_run(history, "2026-12-01_zzzzzzz.json", "old machine")
    bench_run(history, "2026-12-01T1700_bbbbbbb.json", "new machine")
    (history / "2026-12-02_ccccccc.json").write_text("{not json")
    monkeypatch.setattr(resources, "HISTORY", history)
    args = ["report", "--no-run", "--cases", "cantilever_step", "--solvers", FAST, "--out", str(out)]
    assert main(args) == 0
    assert "2026-12-02_ccccccc.json: benchmark run not shown" in capsys.readouterr().err
    page, md = (out / "index.html").read_text(), (out / "index.md").read_text()
    for text in (page, md):
        assert "2026-12-01T1700_bbbbbbb.json" in text and "commit bbbbbbb" in text and "machine: new machine" in text
        assert "not in this report's runs" in text and "old machine" not in text
        assert "aaaaaaa" not in text and "zzzzzzz" not in text
    assert "<h2>Work and precision</h2><p><img src='work_precision.png'" in page
    assert "![work_precision.png](work_precision.png)" in md
    assert (out / "work_precision.png").is_file() and (out / "work_precision.svg").is_file()

    monkeypatch.setattr(resources, "HISTORY", tmp_path / "no-history")
    assert main(args) == 0
    for page in (out / "index.html", out / "index.md"):
        text = page.read_text()
        assert "Work and precision" not in text and "work_precision" not in text and "benchmark" not in text


def test_a_channel_is_matched_against_the_modes_that_move_its_point_in_its_direction():
    """The double pendulum's in-plane tip deflection of beam2: the modes led by beam2's in-plane
    bending (31.3 Hz, about its hinge pivot2) and by beam1's (18.1 Hz, which shakes beam2's root
    in-plane), none led by an out-of-plane (xz) bending or a torsion."""
    case = cases.load("double_pendulum")
    labels = [lab for _, lab in spectra.channel_modes(case, spectra.system_modes(case))["tip_deflection_2"]]
    assert labels[:2] == ["beam1: bending xy 1", "beam2: bending xy 1"]
    assert [lab for lab in labels if "beam2" in lab] == [f"beam2: bending xy {k}" for k in range(1, 6)]
    assert not any(" xz " in lab or "torsion" in lab for lab in labels), labels


def test_frozen_frequencies_only_where_they_move():
    """A hub spun at a constant rate has the same system at every instant: no frozen sweep. A hub
    spun up has one, its in-plane bending stiffening with the rate (0.604 Hz at rest)."""
    from flexmbd.harness.results import Result
    t = np.linspace(0.0, 20.0, 201)
    steady = cases.load("rotating_cantilever")
    r = Result(solver="flexmbd", case=steady.name, t=t, channels={"hub_angle": 4.0 * t})
    assert spectra.frozen_modes(steady, {steady.report.reference: r}) is None
    spun = cases.load("spinup_beam")
    r = Result(solver="flexmbd", case=spun.name, t=t, channels={"hub_angle": np.zeros_like(t)})
    solver, sweep = spectra.frozen_modes(spun, {spun.report.reference: r})
    inplane = [[f for f, lab in modes if "xy 1" in lab][0] for _, modes in sweep]
    assert solver == spun.report.reference and inplane[0] == pytest.approx(0.6044, rel=1e-3)
    assert inplane[-1] > 0.7


def test_a_case_s_notes_are_on_its_page_above_the_accuracy_table(tmp_path):
    note = 'report.notes="The reference is converged. <b>Why</b>:\\n\\nA second paragraph."'     # TOML escapes
    assert main(["compare", "cantilever_step", "--solvers", "analytic", "--set", note, "--set", "duration=0.2",
                 "--out", str(tmp_path), "--workers", "1"]) == 0
    page = (tmp_path / "compare" / "cantilever_step" / "index.html").read_text()
    accuracy = page.index("<h2>Accuracy</h2>")
    assert accuracy < page.index("<p>The reference is converged. &lt;b&gt;Why&lt;/b&gt;:</p><p>A second paragraph.</p>")
    md = (tmp_path / "compare" / "cantilever_step" / "index.md").read_text()
    assert "The reference is converged. <b>Why</b>:\n\nA second paragraph." in md.split("## Accuracy")[1]


def test_a_diverged_run_s_page_says_why_with_the_case_s_explanation():
    """slewing_beam's exudyn-ffrf: its status and the case's physical explanation
    (report.expected_failures) under the page's verdicts."""
    from flexmbd.harness import results
    from flexmbd.report import accuracy, pages
    case = cases.load("slewing_beam")
    st = results.diverged("diverged (|tip_deflection| beyond 16 m, 2 beam lengths)", 10.58)
    runs = [accuracy.Outcome(case.name, "exudyn-ffrf", st, accuracy.verdict(st, "exudyn-ffrf", "exudyn-beam", []),
                             np.nan, 9.0)]
    page, md = pages.runs_section(case, runs)
    assert "<td class='diverged'>" in page
    assert "<p class='why'><b>exudyn-ffrf</b>: diverged (|tip_deflection| beyond 16 m" in page
    assert "at t = 10.58 s. A linear floating frame" in page and "loses the in-plane stiffness" in md


def test_a_run_that_misses_its_tolerances_is_explained_where_the_case_expects_it():
    """four_bar's exudyn-ffrf (a linear floating frame) misses its tolerances: the case's
    explanation follows its fail verdict; a fail the case does not explain (pinocchio's here,
    with its explanation removed) gets none, the verdict alone in the table."""
    from flexmbd.harness import results
    from flexmbd.report import accuracy, pages
    case = cases.load("four_bar", ['report.expected_failures={ exudyn-ffrf = "No geometric stiffness." }'])
    rows = [{"solver": s, "pass": "fail", "rms": 0.2, "tolerance": 0.03, "channel": "coupler_midspan"}
            for s in ("exudyn-ffrf", "pinocchio")]
    runs = [accuracy.Outcome(case.name, s, results.Status(), accuracy.verdict(results.Status(), s, "exudyn-beam", rows),
                             0.2, 1.0) for s in ("exudyn-ffrf", "pinocchio")]
    page, md = pages.runs_section(case, runs)
    assert "<p class='why'><b>exudyn-ffrf</b>: fail: coupler_midspan RMS 0.2" in page
    assert "No geometric stiffness." in page and "No geometric stiffness." in md
    assert "<b>pinocchio</b>" not in page


def test_provenance_settings_are_whole():
    from flexmbd.harness import results
    from flexmbd.report import pages
    settings = {f"key{k}": "x" * 20 for k in range(30)}
    r = results.Result(solver="flexmbd", case="c", status=results.Status(), settings=settings)
    assert pages.provenance_rows({"flexmbd": r})[0][-1] == json.dumps(settings, sort_keys=True)
