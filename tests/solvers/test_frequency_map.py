"""`flexmbd modes CASE --system --sweep KEY=START:STOP:N` (solvers/linearize.py: `sweep`,
`physical`, `tracked`): the system linearized at each value of a case key, its modes followed by
their shapes, not their order."""

import csv
import json

import numpy as np
import pytest

from flexmbd import cases
from flexmbd.cli import main
from flexmbd.solvers import linearize

H = np.linspace(0.008, 0.012, 9)          # m: the section's h about b = 0.01 m: the two planes cross at 0.01


@pytest.fixture(scope="module")
def crossing():
    """cantilever_step with 4 modes, its section's h swept through b: bending in x-y (I = b h^3/12,
    mass b h: f proportional to h) crosses bending in x-z (I = h b^3/12: f independent of h)."""
    case = cases.load("cantilever_step", ["bodies.beam.modes.count=4"])
    return linearize.tracked(linearize.sweep(case, "bodies.beam.section.h", H))


def test_two_modes_that_cross_keep_their_tracks(crossing):
    """The x-y track rises as h through the crossing: proportional to it but for the section's
    rotary inertia (rho I_z, growing as h^3 against the mass's h), which lowers it by about
    (h / L)^2 / 10 (measured 6.9e-6 at h = 0.012 m; bound 1e-4 = 1.5 (h / L)^2); the x-z track
    stays (rotary inertia rho I_y, stiffness and mass all grow as h: constant but for the central
    differences' error on a frequency, 1e-6); sorted by frequency they would trade places at h = b."""
    xy, xz = crossing[0], crossing[1]
    assert xy["label"] == "beam: bending xy 1 (100 %) of the strain energy"
    assert xz["label"] == "beam: bending xz 1 (100 %) of the strain energy"
    assert np.allclose(xy["freq_hz"] / xy["freq_hz"][0], H / H[0], rtol=1e-4, atol=0)
    assert np.allclose(xz["freq_hz"], xz["freq_hz"][0], rtol=1e-6, atol=0)
    lowest = np.minimum(xy["freq_hz"], xz["freq_hz"])
    assert not np.allclose(lowest / lowest[0], H / H[0], rtol=1e-3)          # what sorting would give
    away = np.abs(H - 0.01) > 1e-9                                          # at h = b the two are one
    assert (xy["mac"][away] > 0.9).all() and (xz["mac"][away] > 0.9).all()


def test_the_map_is_written_as_a_table_and_a_figure(tmp_path, capsys):
    """--out: OUT/CASE_sweep.csv, one row per value and track (the numbers in full), and the figure;
    the terminal shows one line per value."""
    assert main(["modes", "cantilever_step", "--system", "--sweep", "bodies.beam.section.h=0.008:0.012:3",
                 "--set", "bodies.beam.modes.count=2", "--out", str(tmp_path)]) == 0
    rows = list(csv.DictReader((tmp_path / "cantilever_step_sweep.csv").open()))
    assert len(rows) == 3 * 2 and {r["track"] for r in rows} == {"1", "2"}
    assert (tmp_path / "cantilever_step_sweep.png").is_file()
    out = capsys.readouterr().out
    assert "tracked by shape" in out and len([ln for ln in out.splitlines() if ln.strip().startswith("0.01")]) == 2


@pytest.mark.parametrize("args, said", [
    (["--system", "--sweep", "bodies.beam.section.h=0.008:0.012"], "KEY=START:STOP:N"),
    (["--system", "--sweep", "bodies.beam.section.h=0.008:0.012:1"], "N >= 2"),
    (["--system", "--sweep", "=1:2:3"], "a case key first"),
    (["--system", "--sweep", "bodies.beam.section.h=0.008:0.012:0"], "N >= 2"),
    (["--system", "--sweep", "bodies.beam.section.h=a:b:3"], "numbers"),
    (["--sweep", "bodies.beam.section.h=0.008:0.012:3"], "add --system"),
    (["--system", "--sweep", "bodies.beam.section.h=0.008:0.012:3", "--peers", "nosuch"], "unknown solver"),
    (["--peers", "fe-linear"], "add --system")])
def test_a_bad_sweep_is_one_line_and_exit_2(args, said, tmp_path, capsys):
    assert main(["modes", "cantilever_step", *args, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and ("--sweep" in err[0] or "--peers" in err[0]) and said in err[0], err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("case, key, said", [
    ("cantilever_step", "bodies.beam.section.shape", "bodies.beam.section.shape"),   # not a number
    ("pendulum", "joints.pivot.q0", "it is free"),                                   # nothing holds it
    ("four_bar", "joints.follower_pivot.q0", "the loop's closure sets it")])         # the loop sets it
def test_a_sweep_of_what_is_no_setting_is_one_line_and_exit_2(case, key, said, tmp_path, capsys):
    """A key whose values are not numbers is the loader's one line; a joint's coordinate that no
    motion holds (a free pendulum's, or one a loop's closure sets) is a state, not a setting."""
    assert main(["modes", case, "--system", "--sweep", f"{key}=0:1:3", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and said in err[0], err
    assert not (tmp_path / "out").exists()


def test_a_crank_turned_step_by_step_stays_on_its_branch():
    """four_bar_swing (crank 0.15 m from A = 0, coupler 0.45 m, rocker 0.40 m from D = (0.5, 0)), its crank held,
    its loop's guesses those of the crank at 0 (crank_pin 1.0195, rocker 1.8605 rad), its crank
    swept over a whole turn in 30-degree steps: each value starts from the loop closed at the value
    before, so the rocker follows the branch it was assembled on (C above AD), the closed form's
    circle intersection there to 1e-8 rad (the closure's tolerance; measured 1e-12), and the map
    closes on itself after the turn. Closed from those guesses at every value instead, the crank
    at 150 to 210 degrees lands on the mirror image (rocker 3.81 to 4.04 rad: C below AD)."""
    case = cases.load("four_bar_swing", ["joints.crank_pivot.qd0=0", 'joints.crank_pivot.motion={type="constant_rate", '
                                         'rate=0.0}', "joints.crank_pin.q0=1.0195", "joints.rocker_pivot.q0=1.8605"])
    th = np.linspace(0.0, 2 * np.pi, 13)
    steps = linearize.sweep(case, "joints.crank_pivot.q0", th)
    for x, _, at, _ in steps:
        B, D = 0.15 * np.array([np.cos(x), np.sin(x)]), np.array([0.5, 0.0])
        L = np.linalg.norm(D - B)
        a = (0.45 ** 2 - 0.40 ** 2 + L ** 2) / (2 * L)
        u = (D - B) / L
        C = B + a * u + np.sqrt(0.45 ** 2 - a ** 2) * np.array([-u[1], u[0]])    # left of B -> D: y > 0
        assert C[1] > 0 and abs(at["rocker_pivot"] - np.arctan2(C[1], C[0] - 0.5)) < 1e-8, x
    first, last = steps[0][1], steps[-1][1]
    assert np.allclose([m.freq_hz for m in first], [m.freq_hz for m in last], rtol=1e-6)


def test_peers_at_one_state_are_set_beside_flexmbd_s_frequencies(capsys):
    """`modes --system --peers fe-linear` on cantilever_step: the frame's own frequencies printed
    after flexmbd's, its lowest 3 (in-plane: the planar frame has no x-z bending) each against the
    nearest of flexmbd's, within 1e-3 (the 100-element frame against the reduced beam: measured
    5e-5); in JSON under "peers"."""
    assert main(["modes", "cantilever_step", "--system", "--peers", "fe-linear"]) == 0
    line = [ln for ln in capsys.readouterr().out.splitlines() if "fe-linear (its own eigen-solve)" in ln]
    assert len(line) == 1 and float(line[0].rsplit(" ", 1)[1]) < 1e-3, line
    assert main(["modes", "cantilever_step", "--system", "--peers", "fe-linear", "--json"]) == 0
    got = json.loads(capsys.readouterr().out)
    assert len(got["peers"]["fe-linear"]) == len(got["modes"])
