"""Figures of the report, drawn from small synthetic histories: what each figure holds, read off the
matplotlib Figure before it is saved."""

import numpy as np
import pytest

from flexmbd import cases
from flexmbd.report import figures
from flexmbd.results import Result


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
