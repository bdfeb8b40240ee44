"""Figures of the report, drawn from small synthetic histories: what each figure holds, read off the
matplotlib Figure before it is saved."""

from pathlib import Path

import numpy as np
import pytest

from flexmbd import cases
from flexmbd.report import figures
from flexmbd.harness.results import Result

pytestmark = pytest.mark.kernel_free


@pytest.fixture(scope="module")
def pendulum():
    return cases.load("pendulum")


def run(solver, t, **channels):
    return Result(solver=solver, case="pendulum", t=np.asarray(t), channels=channels)


def axes_of(fig) -> list:
    """A figure's axes (a channel figure: overview, differences, then the zoom windows), the figure
    closed."""
    figures.plt.close(fig)
    return fig.axes


def test_a_long_vibrating_history_gets_zoom_windows_of_its_first_and_last_periods(pendulum):
    """2 s of a 24 Hz vibration riding on a slow swing (48 periods): two zoom panels below the
    overview, each ZOOM_PERIODS periods long, at the start and at the end, shaded on the overview."""
    t = np.linspace(0.0, 2.0, 2001)
    y = 2e-3 * np.sin(2 * np.pi * 0.4 * t) + 1e-3 * np.sin(2 * np.pi * 24.0 * t)
    res = {"flexmbd": run("flexmbd", t, tip_deflection=y),
           "exudyn-beam": run("exudyn-beam", t, tip_deflection=1.01 * y)}
    top, bottom, first, last = axes_of(figures.channel_figure(pendulum, "tip_deflection", res, "flexmbd"))
    width = figures.ZOOM_PERIODS / 24.0
    assert first.get_xlim() == pytest.approx((0.0, width), rel=0.01)
    assert last.get_xlim() == pytest.approx((2.0 - width, 2.0), rel=0.01)
    assert len(top.patches) == 2 and len(bottom.patches) == 2                 # the windows, shaded
    assert [l.get_color() for l in first.lines] == [figures.style(s)["color"] for s in res]


@pytest.mark.parametrize("t_end, y", [
    (0.5, lambda t: 1e-3 * np.sin(2 * np.pi * 24.0 * t)),                          # 12 periods: short
    (2.0, lambda t: 1e-3 * t ** 2),                                                 # no vibration
    (2.0, lambda t: np.sin(2 * np.pi * 0.4 * t) + 1e-4 * np.sin(2 * np.pi * 24.0 * t)),   # invisible one
])
def test_a_short_or_quiet_history_keeps_the_two_panel_figure(pendulum, t_end, y):
    t = np.linspace(0.0, t_end, int(1000 * t_end) + 1)
    res = {"flexmbd": run("flexmbd", t, tip_deflection=y(t)), "exudyn-beam": run("exudyn-beam", t, tip_deflection=y(t))}
    assert len(axes_of(figures.channel_figure(pendulum, "tip_deflection", res, "flexmbd"))) == 2


def test_energy_is_drawn_as_its_change_from_the_start_and_labelled_so(pendulum):
    """Two solvers whose total energies sit at different levels (another datum of potential
    energy) and drift: each is drawn from 0, the axis says so, and a vibrating energy is not zoomed."""
    t = np.linspace(0.0, 2.0, 2001)
    wobble = 1e-6 * np.sin(2 * np.pi * 24.0 * t)
    ref = Result(solver="flexmbd", case="pendulum", t=t, channels={"energy": 5.0 + wobble},
                 extra={"kinetic_max_J": 12.9})
    res = {"flexmbd": ref, "mujoco-rod": run("mujoco-rod", t, energy=-3.0 + 1e-3 * t + wobble)}
    axes = axes_of(figures.channel_figure(pendulum, "energy", res, "flexmbd"))
    assert len(axes) == 2
    top, bottom = axes
    assert top.get_ylabel() == "energy change from t = 0 [J]"
    assert "change of the total energy" in top.get_title() and "12.9 J" in top.get_title()
    flexmbd_line, mujoco_line = top.lines
    assert flexmbd_line.get_ydata()[0] == 0.0 and mujoco_line.get_ydata()[0] == 0.0
    assert mujoco_line.get_ydata()[-1] == pytest.approx(2e-3, rel=1e-6)
    assert np.nanmax(bottom.lines[0].get_ydata()) == pytest.approx(2e-3, rel=1e-3)   # the drifts' difference


def test_mode_shapes_draw_one_panel_per_mode_and_torsion_or_axial_only_where_they_lead():
    """The flexible pendulum's 5 cm segment keeps bending, torsion and axial modes: one panel each,
    every mode scaled to a largest value of 1, the torsion angle only on the torsion mode, the axial
    displacement only on the axial one, the cubic through the node values."""
    fb = cases.load("flexible_pendulum").split.reduced("rod:1")
    axes = axes_of(figures.mode_shapes_figure(fb, "rod:1"))
    assert len(axes) == fb.n_modes == 8
    for j, ax in enumerate(axes):
        label = str(fb.labels[j])
        drawn = {l.get_label(): l for l in ax.lines if not l.get_label().startswith("_")}
        extra = {"torsion about x"} if label.startswith("torsion") else {"axial x"} if label.startswith("axial") else set()
        assert set(drawn) == {"transverse y", "transverse z"} | extra, label
        assert max(np.max(np.abs(l.get_ydata())) for l in drawn.values()) == pytest.approx(1.0)
        assert label in ax.get_title() and f"{fb.freq_hz[j]:.4g} Hz" in ax.get_title()
    x, v = figures.mode_curves(fb, 0)["transverse y"]
    nodes = np.isin(x, fb.x0[:, 0])
    assert nodes.sum() == fb.n_nodes and len(x) > 10 * fb.n_nodes
    assert v[nodes] / v[nodes][-1] == pytest.approx(fb.Phi[:, 4, 0] / fb.Phi[-1, 4, 0])


def test_hermite_reproduces_a_cubic():
    x = np.array([0.0, 0.3, 1.0])
    f, df = (lambda s: 2 * s ** 3 - s ** 2 + 0.5), (lambda s: 6 * s ** 2 - 2 * s)
    xs, v = figures.hermite(x, f(x), df(x))
    assert v == pytest.approx(f(xs), abs=1e-12)


def test_work_precision_draws_a_panel_per_case_and_a_line_per_solver_and_scheme():
    row = lambda case, s, scheme, e, w: {"case": case, "solver": s, "scheme": scheme, "setting": "", "error": e, "wall_s": w}
    rows = [row("a", "flexmbd", "dopri5", 1e-3, 0.1), row("a", "flexmbd", "dopri5", 1e-5, 0.3),
            row("a", "exudyn-ffrf", "fox-goodwin", np.nan, 0.2), row("a", "exudyn-ffrf", "fox-goodwin", 1e-4, 1.0),
            row("b", "flexmbd", "dopri5", 1e-4, 0.2), row("b", "flexmbd", "adams", 1e-6, 0.5)]
    a, b = axes_of(figures.work_precision_figure(rows))
    assert a.get_title() == "a" and b.get_title() == "b"
    assert a.get_xscale() == a.get_yscale() == "log"
    lines = {l.get_label(): l for l in a.lines}
    assert set(lines) == {"flexmbd (dopri5)", "exudyn-ffrf (fox-goodwin)"}
    assert list(lines["exudyn-ffrf (fox-goodwin)"].get_xdata()) == [1.0]          # the diverged setting left out
    assert lines["flexmbd (dopri5)"].get_color() == figures.style("flexmbd")["color"]
    assert lines["exudyn-ffrf (fox-goodwin)"].get_color() == figures.style("exudyn-ffrf")["color"]
    assert {l.get_label() for l in b.lines} == {"flexmbd (dopri5)", "flexmbd (adams)"}


def labels_of(ax) -> list:
    return ax.get_legend_handles_labels()[1]


def test_a_near_constant_stress_draws_flat_with_whole_tick_labels_and_no_offset(pendulum, tmp_path):
    """A stress of 40.06 MPa carrying round-off (1e-12 of it, alternating): no axis of the saved
    figure has an offset label, the ticks carry the value itself, and the axis spans at least SPAN
    of the magnitude (and NOISE of Young's modulus, 2e-4 MPa), so the round-off does not fill it as
    a square wave."""
    t = np.linspace(0.0, 1.0, 1001)
    y = 40.06e6 * (1.0 + 1e-12 * (-1.0) ** np.arange(t.size))
    res = {"exudyn-beam": run("exudyn-beam", t, stress_vm=y), "flexmbd": run("flexmbd", t, stress_vm=y * (1 + 1e-9))}
    fig = figures.channel_figure(pendulum, "stress_vm", res, "exudyn-beam")
    figures.save(fig, tmp_path / "stress_vm.png")
    top = fig.axes[0]
    assert all(ax.yaxis.get_offset_text().get_text() == "" and ax.xaxis.get_offset_text().get_text() == ""
               for ax in fig.axes)
    lo, hi = top.get_ylim()
    assert hi - lo >= figures.SPAN * 40.06 * (1 - 1e-9)
    ticks = [lab.get_text() for lab in top.get_yticklabels() if lo <= lab.get_position()[1] <= hi]
    assert len(ticks) >= 3 and len(set(ticks)) == len(ticks)
    assert all(abs(float(tick) - 40.06) < 1e-3 for tick in ticks)            # each tick: the value itself
    assert np.ptp(top.lines[0].get_ydata()) < 0.01 * (hi - lo)               # the round-off: a straight line


@pytest.mark.parametrize("values, text", [
    ([0.0, 0.25, 0.5], ["0", "0.25", "0.50"]),
    ([-2e5, 0.0, 2e5, 4e5], ["-2e5", "0", "2e5", "4e5"]),
    ([1.5e-7, 2.0e-7, 2.5e-7], ["1.5e-7", "2.0e-7", "2.5e-7"]),
    ([40.060127, 40.0601272, 40.0601274], ["40.0601270", "40.0601272", "40.0601274"]),
    ([0.0, 500.0, 1000.0], ["0", "500", "1000"]),
])
def test_plain_tick_labels_carry_their_whole_value(values, text):
    assert figures.Plain().format_ticks(values) == text


@pytest.mark.parametrize("solvers", [["exudyn-beam"], ["flexmbd", "mujoco-rod"]])
def test_no_empty_difference_panel_without_a_solver_to_compare(pendulum, solvers):
    """The reference alone, or no reference among the runs: the overview alone, its x axis labelled."""
    t = np.linspace(0.0, 1.0, 101)
    res = {s: run(s, t, tip_deflection=1e-3 * np.sin(3 * t)) for s in solvers}
    (top,) = axes_of(figures.channel_figure(pendulum, "tip_deflection", res, "exudyn-beam"))
    assert top.get_xlabel() == "t [s]" and len(top.lines) == len(solvers)


def test_every_solver_looks_different_on_one_figure_and_the_same_on_every_figure():
    """The registered solvers keep their own colours; 40 further names on one figure are 48 distinct
    looks; a name's look depends on its name only, unless a name sorted before it took it."""
    others = [f"plug-in-{k}" for k in range(40)]
    looks = figures.looks(list(figures.STYLE) + others)
    assert len(set(looks.values())) == len(looks) == len(figures.STYLE) + 40
    assert all(looks[s][:2] == figures.STYLE[s] for s in figures.STYLE)
    assert {s: figures.looks(["flexmbd", s])[s] for s in others} == {s: figures.looks([s])[s] for s in others}
    assert figures.looks(list(reversed(others))) == figures.looks(others)
    assert not set(c for c, _, _ in looks.values() if c in figures.EXTRA_COLOURS) & {c for c, _ in figures.STYLE.values()}
    alone = {s: figures.looks([s])[s] for s in (f"plug-in-{k}" for k in range(100))}
    clash = [(a, b) for a in alone for b in alone if a < b and alone[a] == alone[b]]
    assert clash                                              # 100 names in 192 looks: some hash alike
    a, b = clash[0]                                           # on one figure, the later one moves on
    both = figures.looks([a, b])
    assert both[a] == figures.looks([a])[a] and both[b] != both[a] and both[b][0] != both[a][0]


def test_a_failed_run_is_drawn_up_to_its_failure_and_named_so(pendulum):
    """A run that diverged at t = 0.6 s keeps its samples before: drawn to 0.59 s, its difference
    from the reference too, named 'diverged at t = 0.6 s' in both legends with a dotted line at
    0.6 s; the overview's limits are the other runs', not its 100 m."""
    from flexmbd.harness import results
    t = np.linspace(0.0, 1.0, 101)
    y = 1e-3 * np.sin(2 * np.pi * t)
    bad = Result(solver="exudyn-ffrf", case="pendulum", t=t[:60], channels={"tip_deflection": y[:60] + np.exp(t[:60] * 30) * 1e-6},
                 status=results.diverged("diverged (|tip_deflection| beyond 8 m, 2 beam lengths)", 0.6))
    res = {"exudyn-beam": run("exudyn-beam", t, tip_deflection=y), "flexmbd": run("flexmbd", t, tip_deflection=1.01 * y),
           "exudyn-ffrf": bad}
    top, bottom = axes_of(figures.channel_figure(pendulum, "tip_deflection", res, "exudyn-beam"))
    assert labels_of(top) == ["exudyn-beam (reference)", "flexmbd", "exudyn-ffrf (diverged at t = 0.6 s)"]
    assert labels_of(bottom) == ["flexmbd - exudyn-beam (reference)", "exudyn-ffrf - exudyn-beam (reference)"]
    drawn = {l.get_label(): l for l in top.lines}
    assert drawn["exudyn-ffrf (diverged at t = 0.6 s)"].get_xdata()[-1] == pytest.approx(0.59)
    assert max(bottom.lines[1].get_xdata()) == pytest.approx(0.59)
    assert top.get_ylim()[1] < 1.2 * 1.01 * 1e3 * max(y)                       # mm: the ok runs' range
    assert [l.get_xdata()[0] for a in (top, bottom) for l in a.lines if l.get_linestyle() == ":"] == [0.6, 0.6]
    assert figures.drawable({**res, "none": Result(solver="none", case="pendulum",
                                                   status=results.failed("no samples"))}).keys() == res.keys()


def test_a_spectrum_marks_only_the_system_modes_near_its_peaks_within_its_band(pendulum):
    """A vibration at 5 and 31 Hz against 160 system frequencies: two dotted lines, those nearest the
    peaks; none beyond the band; the reference named in the legend."""
    t = np.linspace(0.0, 4.0, 4001)
    y = 1e-3 * np.sin(2 * np.pi * 5.0 * t) + 3e-4 * np.sin(2 * np.pi * 31.0 * t)
    system = list(np.linspace(1.3, 800.0, 160)) + [5.02, 31.1]
    res = {"exudyn-beam": run("exudyn-beam", t, tip_deflection=y), "flexmbd": run("flexmbd", t, tip_deflection=y)}
    (ax,) = axes_of(figures.spectra_figure(pendulum, "tip_deflection", res, system, 500.0))
    dotted = sorted(l.get_xdata()[0] for l in ax.lines if l.get_linestyle() == ":")
    assert dotted == [5.02, 31.1]
    assert labels_of(ax) == ["exudyn-beam (reference)", "flexmbd"]
    assert figures.marked(system, [5.0, 31.0, 650.0], fmax=600.0) == [5.02, 31.1]
    assert figures.marked(system, [2.6], fmax=600.0) == []                       # nearest 6 % away: none


def test_a_deflection_that_is_only_round_off_draws_as_a_straight_line(pendulum):
    """A rigid peer's tip deflection of 1e-14 m (round-off, alternating sign): the axis spans at least
    NOISE times the beam's length (1 m: 1e-6 mm), so the noise is a straight line at 0."""
    t = np.linspace(0.0, 1.0, 101)
    y = 1e-14 * (-1.0) ** np.arange(t.size)
    (top,) = axes_of(figures.channel_figure(pendulum, "tip_deflection", {"mujoco": run("mujoco", t, tip_deflection=y)},
                                            "exudyn-beam"))
    lo, hi = top.get_ylim()
    assert hi - lo >= 1e-9 * 1e3 * (1 - 1e-9) and np.ptp(top.lines[0].get_ydata()) < 0.1 * (hi - lo)


def test_a_figure_drawn_from_the_same_bytes_is_taken_from_the_cache(tmp_path, monkeypatch):
    """`figures.kept` draws once per source: the second call copies the PNG and SVG (the same bytes),
    another source draws again, and a cache that cannot be written is drawn around."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    drawn = []

    def make():
        drawn.append(1)
        fig, ax = figures.plt.subplots()
        ax.plot([0, 1], [0, len(drawn)])
        return fig

    a, b, c = (tmp_path / n for n in ("a", "b", "c"))
    for d in (a, b, c):
        d.mkdir()
    assert figures.kept(a / "f.png", b"rows 1", make) == "f.png" and len(drawn) == 1
    assert figures.kept(b / "f.png", b"rows 1", make) == "f.png" and len(drawn) == 1
    for suffix in (".png", ".svg"):
        assert (a / "f").with_suffix(suffix).read_bytes() == (b / "f").with_suffix(suffix).read_bytes()
    figures.kept(c / "f.png", b"rows 2", make)
    assert len(drawn) == 2
    monkeypatch.setenv("XDG_CACHE_HOME", str(a / "f.png"))     # a file where the cache's folder would be
    figures.kept(c / "g.png", b"rows 3", make)
    assert len(drawn) == 3 and (c / "g.png").stat().st_size > 1000 and (c / "g.svg").is_file()
    import hashlib                                              # its key: the recipe it had before `version.cache_key`
    key = hashlib.sha256(b"rows 1" + Path(figures.__file__).read_bytes() + figures.matplotlib.__version__.encode())
    assert (tmp_path / "cache" / "flexmbd" / "figures" / f"{key.hexdigest()[:24]}.png").is_file()


def test_a_failed_run_is_named_by_its_cause_in_a_legend():
    """The legend says of a failed run what its verdict says (`results.Status.cause`): diverged or
    aborted, never 'failed'; the reference keeps its mark first."""
    from flexmbd.harness import results
    t = np.linspace(0.0, 0.5, 51)
    aborted = Result(solver="s", case="c", t=t, status=results.failed("Exudyn: Newton did not converge", 0.5))
    assert figures.label("s", aborted) == "s (aborted at t = 0.5 s)"
    assert figures.label("s", Result(solver="s", case="c", status=results.failed("no time"))) == "s (aborted)"
    diverged = Result(solver="s", case="c", t=t, status=results.diverged("its watch stopped it", 0.5))
    assert figures.label("s", diverged, "s") == "s (reference, diverged at t = 0.5 s)"
    assert figures.label("s", run("s", t, x=t)) == "s" and figures.label("s", None, "s") == "s (reference)"
