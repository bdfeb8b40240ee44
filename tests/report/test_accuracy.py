"""report/accuracy.py: the spectral peak table names each peak after a system mode, an alias of
one above the Nyquist frequency, or says why none is near."""

from __future__ import annotations

import numpy as np
import pytest

from flexmbd import cases
from flexmbd.report import accuracy
from flexmbd.harness.results import Result

pytestmark = pytest.mark.kernel_free

CASE = cases.load("pendulum")


def rows(freqs_hz, modes, dt=1e-3, duration=2.0) -> list[dict]:
    """The peak table of a signal of unit sinusoids at freqs_hz, sampled every dt."""
    t = np.arange(0.0, duration + dt / 2, dt)
    y = sum(np.sin(2 * np.pi * f * t) for f in freqs_hz)
    r = Result(solver="x", case=CASE.name, t=t, channels={"tip_deflection": y})
    return accuracy.peak_table(CASE, {"x": r}, {"tip_deflection": modes}, dt)


def test_a_peak_is_named_after_the_system_mode_within_2_percent():
    got = rows([24.3], [(24.23, "beam xy1"), (78.5, "beam xy2")])
    assert [(r["mode"], round(r["f_system"], 2)) for r in got] == [("beam xy1", 24.23)]
    assert got[0]["difference"] == pytest.approx(24.3 / 24.23 - 1, abs=2e-3)


def test_a_mode_above_the_nyquist_frequency_is_named_as_its_alias():
    got = rows([700.3], [(24.23, "beam xy1"), (700.3, "beam xy5")])             # 1 ms: Nyquist 500 Hz
    assert len(got) == 1 and got[0]["mode"].startswith("alias of beam xy5 (700.3 Hz above the Nyquist")
    assert got[0]["f_identified"] == pytest.approx(299.7, abs=0.3)


def test_a_peak_at_the_top_of_the_retained_modes_says_truncation():
    """426 Hz between the retained 281 Hz and the highest, 700 Hz: a finer model's mode that the
    truncated set places too high. With a further mode above 700 Hz, no such claim is made."""
    modes = [(24.23, "beam xy1"), (281.5, "beam xy4"), (700.3, "beam xy5")]
    got = rows([426.0], modes, dt=5e-4)
    assert got[0]["mode"].startswith("none within 2% (nearest beam xy4); below only the highest")
    assert "below only the highest of them, 700.3 Hz" in got[0]["mode"] and "Rayleigh-Ritz" in got[0]["mode"]
    got = rows([426.0], modes + [(1100.0, "beam xy6")], dt=2.5e-4)
    assert got[0]["mode"] == "none within 2% (nearest beam xy4)"
    got = rows([900.0], modes, dt=2.5e-4)
    assert "above all of them" in got[0]["mode"]


def test_a_peak_only_the_finer_system_explains_is_named_after_its_mode():
    """exudyn-beam's 426 Hz pendulum peak: none of the 12-mode system's modes is within 2 %, the
    24-mode system's 427 Hz is; the case's own modes come first when both are near."""
    modes = [(24.23, "beam xy1"), (281.5, "beam xy4"), (700.3, "beam xy5")]
    finer = {"tip_deflection": [(24.25, "beam xy1 (24 modes)"), (427.6, "beam xy5 (24 modes)")]}
    t = np.arange(0.0, 2.0 + 2.5e-4, 5e-4)
    y = np.sin(2 * np.pi * 24.3 * t) + np.sin(2 * np.pi * 426.0 * t)
    r = Result(solver="x", case=CASE.name, t=t, channels={"tip_deflection": y})
    got = accuracy.peak_table(CASE, {"x": r}, {"tip_deflection": modes}, 5e-4, others=[finer])
    assert [g["mode"] for g in got] == ["beam xy1", "beam xy5 (24 modes)"]
    assert got[1]["difference"] == pytest.approx(426.0 / 427.6 - 1, abs=1e-3)


def test_a_run_holding_only_roundoff_has_no_identified_peaks():
    """A solver that models no deflection and records 1e-14 m of roundoff (with a slow drift) has
    largest peaks like any record; against the channel's 1e-3 m in the other run they lie 1e-11
    below it, under the noise floor (`metrics.noise_floor`: 1e-6 of it), and so does the record
    alone (under 1e-9 of the 1.5 m beam). A real vibration of 1e-5 of the channel is kept."""
    t = np.arange(0.0, 2.0 + 5e-4, 1e-3)
    rng = np.random.default_rng(3)
    noise = 1e-14 * (rng.standard_normal(t.size) + np.sin(2 * np.pi * 1.21 * t))
    runs = {"ref": Result(solver="ref", case=CASE.name, t=t, channels={"tip_deflection": 1e-3 * np.sin(2 * np.pi * 24.3 * t)}),
            "rigid": Result(solver="rigid", case=CASE.name, t=t, channels={"tip_deflection": noise}),
            "small": Result(solver="small", case=CASE.name, t=t, channels={"tip_deflection": 1e-8 * np.sin(2 * np.pi * 78.5 * t)})}
    modes = {"tip_deflection": [(0.9, "joint pivot"), (24.23, "beam: bending xy 1"), (78.5, "beam: bending xy 2")]}
    got = accuracy.peak_table(CASE, runs, modes, 1e-3)
    assert [(g["solver"], g["mode"]) for g in got] == [("ref", "beam: bending xy 1"), ("small", "beam: bending xy 2")]
    assert accuracy.peak_table(CASE, {"rigid": runs["rigid"]}, modes, 1e-3) == []


def test_graded_from_leaves_the_start_up_out_of_every_difference():
    """report.graded_from = 1 s: a reference y = t and a run that differs only before 1 s by 0.5
    (RMS over the whole run 0.35 of the largest 2) grades to zero difference; the largest
    magnitude taken over the graded span too (a start-up spike of 10 in the reference before 1 s
    does not scale the difference down)."""
    case = cases.load("pendulum", ["report.graded_from=1.0", "report.tolerances={tip_deflection=0.01}"])
    t = np.linspace(0.0, 2.0, 2001)
    ref = np.where(t < 0.5, 10.0, t)
    run = ref + np.where(t < 1.0 - 1e-9, 0.5, 0.0)
    results = {s: Result(solver=s, case=case.name, t=t, channels={"tip_deflection": y})
               for s, y in (("exudyn-beam", ref), ("x", run))}
    got = [r for r in accuracy.rows(case, results, {}, {}) if r["channel"] == "tip_deflection"]
    assert len(got) == 1 and got[0]["rms"] == 0.0 and got[0]["max"] == 0.0 and got[0]["pass"] == "pass"
    whole = cases.load("pendulum", ["report.tolerances={tip_deflection=0.01}"])
    rms = [r for r in accuracy.rows(whole, results, {}, {}) if r["channel"] == "tip_deflection"][0]["rms"]
    assert rms == pytest.approx(np.sqrt(np.mean((run - ref) ** 2)) / 10.0, rel=1e-12) and rms > 0.01
