"""report/animation.py and the commands `animate` and `export`: the frames' instants, the case
that records its shapes at them, the drawn factor, an animation and a ParaView series from stored
shapes and from the pendulum's runs, read back (PIL, meshio), and bad input refused in one line."""

import shutil
import xml.etree.ElementTree as ET

import meshio
import numpy as np
import pytest
from PIL import Image, ImageChops

from flexmbd import cases, channels
from flexmbd.cases.schema import MAX_SNAPSHOTS
from flexmbd.cli import main
from flexmbd.report import animation
from flexmbd.results import Result

T_END, FRAMES = 0.02, 5             # s, instants: the pendulum's runs kept short (0, 5, ..., 20 ms)


def shaped(solver: str, ts, tip) -> Result:
    """A result whose beam `beam` holds 3 shape points bending as tip * (x / L)^2 in y at the
    instants ts, the tip displacement tip(t) m."""
    x = [0.0, 0.75, 1.5]
    u = [[[0.0, tip(t) * (xi / 1.5) ** 2, 0.0] for xi in x] for t in ts]
    return Result(solver=solver, case="pendulum", t=np.asarray(ts),
                  extra={"shapes": {"beam": {"x": x, "t": list(ts), "u": u}}})


def frames_of(path) -> list:
    im = Image.open(path)
    out = []
    for k in range(im.n_frames):
        im.seek(k)
        out.append(im.convert("RGB"))
    return out


# ---------------------------------------------------------------------------------------------
# the frames


def test_instants_lie_on_output_samples_evenly_without_repeats():
    case = cases.load("pendulum")                       # output_dt 5e-4 s, duration 2 s
    got = animation.instants(case, None, 5)
    assert got == pytest.approx([0.0, 0.5, 1.0, 1.5, 2.0], abs=1e-12)
    many = animation.instants(case, 0.002, 100)         # 5 samples in 2 ms: each once
    assert many == pytest.approx([0.0, 0.0005, 0.001, 0.0015, 0.002], abs=1e-12)
    assert animation.instants(case, 0.0013, 3) == pytest.approx([0.0, 0.0005, 0.001], abs=1e-12)
    assert animation.instants(case, None, 1) == [0.0]


def test_framed_case_records_shapes_beyond_the_snapshot_limit():
    case = cases.load("pendulum")
    times = animation.instants(case, 0.01, 21)
    fr = animation.framed(case, times)
    assert len(fr.report.snapshots) == 21 > MAX_SNAPSHOTS
    assert fr.report.shape_points == max(case.report.shape_points, animation.POINTS)
    assert len(channels.shape_positions(fr, "beam")) == fr.report.shape_points
    assert case.report.snapshots != fr.report.snapshots         # the loaded case is left as it was
    assert fr.content_sha256 == case.content_sha256 and fr.name == case.name


@pytest.mark.parametrize("peak, length, factor", [(0.0, 1.5, 1.0), (0.2, 1.5, 1.0), (0.15, 1.5, 1.0),
                                                  (2.3e-3, 1.5, 50.0), (1e-3, 1.5, 100.0), (4e-3, 1.0, 20.0),
                                                  (7e-6, 1.0, 1e4)])
def test_magnification_is_a_round_factor_up_to_a_tenth_of_the_length(peak, length, factor):
    got = animation.magnification(peak, length)
    assert got == pytest.approx(factor)
    assert got * peak <= animation.SHARE * length * (1 + 1e-12) or got == 1.0


# ---------------------------------------------------------------------------------------------
# from stored shapes


def test_animation_of_two_runs_one_ending_early(tmp_path):
    """Two runs overlaid: one frame per instant of either, frames differing as the beam bends;
    the run that ended at 0.01 s is drawn up to its end only."""
    case = cases.load("pendulum")
    ts = [0.0, 0.005, 0.01, 0.015, 0.02]
    got = {"exudyn-beam": shaped("exudyn-beam", ts, lambda t: 0.1 * t),
           "flexmbd": shaped("flexmbd", ts[:3], lambda t: 0.1 * t)}
    n = animation.animate(case, got, tmp_path / "a.gif", "exudyn-beam", 20)
    frames = frames_of(tmp_path / "a.gif")
    assert n == len(frames) == 5
    assert ImageChops.difference(frames[0], frames[-1]).getbbox() is not None
    assert [p.name for p in tmp_path.iterdir()] == ["a.gif"]                     # no temporary left


def test_vtk_series_of_stored_shapes(tmp_path):
    case = cases.load("pendulum")
    r = shaped("flexmbd", [0.0, 0.01], lambda t: 0.1 * t)
    pvd, n = animation.vtk(case, r, tmp_path)
    assert n == 2 and pvd.name == "pendulum_flexmbd.pvd"
    m = meshio.read(tmp_path / "beam_00001.vtu")
    assert np.allclose(m.points, [[0.0, 0.0, 0.0], [0.75, 0.00025, 0.0], [1.5, 0.001, 0.0]], rtol=1e-12, atol=0.0)
    assert m.cells_dict["line"].tolist() == [[0, 1], [1, 2]]
    assert m.point_data["displacement"][:, 1] == pytest.approx([0.0, 0.00025, 0.001])


def test_animation_path_finds_the_default_file(tmp_path):
    assert animation.animation_path(tmp_path, "pendulum") is None
    (tmp_path / "animations").mkdir()
    (tmp_path / "animations" / "pendulum.gif").write_bytes(b"GIF89a")
    assert animation.animation_path(tmp_path, "pendulum") == tmp_path / "animations" / "pendulum.gif"
    title, html, md = animation.section(tmp_path, cases.load("pendulum"))
    assert "src='../animations/pendulum.gif'" in html and "(../animations/pendulum.gif)" in md
    assert animation.section(tmp_path, cases.load("cantilever_step")) is None


# ---------------------------------------------------------------------------------------------
# the commands on the pendulum's runs


def test_animate_pendulum_flexmbd_and_exudyn_beam(tmp_path, capsys):
    pytest.importorskip("exudyn")
    out = tmp_path / "p.gif"
    code = main(["animate", "pendulum", "--solvers", "flexmbd,exudyn-beam", "--t-end", str(T_END),
                 "--frames", str(FRAMES), "--out", str(out)])
    assert code == 0, capsys.readouterr().err
    assert f"{FRAMES} frames of flexmbd, exudyn-beam -> {out}" in capsys.readouterr().out
    frames = frames_of(out)
    assert len(frames) == FRAMES
    assert ImageChops.difference(frames[0], frames[-1]).getbbox() is not None      # the beam moved


def test_export_pendulum_reads_back_as_a_series(tmp_path, capsys):
    folder = tmp_path / "vtk"
    code = main(["export", "pendulum", "--solver", "flexmbd", "--vtk", str(folder), "--t-end", str(T_END),
                 "--frames", str(FRAMES)])
    assert code == 0, capsys.readouterr().err
    sets = ET.parse(folder / "pendulum_flexmbd.pvd").getroot().find("Collection").findall("DataSet")
    times = [float(d.get("timestep")) for d in sets]
    assert times == pytest.approx(np.linspace(0.0, T_END, FRAMES), abs=1e-12)
    assert sorted(p.name for p in folder.glob("*.vtu")) == sorted(d.get("file") for d in sets)
    n = cases.load("pendulum").report.shape_points
    tips = []
    for d in sets:
        m = meshio.read(folder / d.get("file"))
        u = m.point_data["displacement"]
        npts = max(n, animation.POINTS)
        assert m.points.shape == (npts, 3) and m.cells_dict["line"].shape == (npts - 1, 2)
        assert np.all(np.isfinite(m.points)) and np.all(np.isfinite(u))
        assert m.points[:, 0] - u[:, 0] == pytest.approx(np.linspace(0.0, 1.5, npts))   # undeformed + u
        tips.append(u[-1, 1])
    assert tips[0] == 0.0 and abs(tips[-1]) > 1e-5              # starts straight, bends as it falls


# ---------------------------------------------------------------------------------------------
# bad input: one line, exit 2, nothing written


def refused(code, capsys, *words):
    err = capsys.readouterr().err
    lines = err.splitlines()
    assert code == 2 and len(lines) == 1 and lines[0].startswith("flexmbd: "), err
    assert "Traceback" not in err
    for w in words:
        assert w in lines[0], (w, lines[0])


def test_animate_unknown_solver(tmp_path, capsys):
    refused(main(["animate", "pendulum", "--solvers", "flexmbd,exudyn-bean", "--out", str(tmp_path / "a.gif")]),
            capsys, "--solvers", "exudyn-bean")
    assert not list(tmp_path.iterdir())


def test_animate_solver_that_does_not_apply(tmp_path, capsys):
    refused(main(["animate", "pendulum", "--solvers", "analytic", "--out", str(tmp_path / "a.gif")]),
            capsys, "analytic", "not applicable")


def test_animate_into_an_unwritable_place(tmp_path, capsys):
    (tmp_path / "file").write_text("")
    refused(main(["animate", "pendulum", "--solvers", "flexmbd", "--out", str(tmp_path / "file" / "a.gif")]),
            capsys, "--out", "a file is there")


def test_animate_to_a_file_of_another_kind(tmp_path, capsys):
    refused(main(["animate", "pendulum", "--solvers", "flexmbd", "--out", str(tmp_path / "a.avi")]),
            capsys, "a.avi", ".gif or .mp4")


@pytest.mark.skipif(shutil.which("ffmpeg") is not None, reason="ffmpeg is installed here")
def test_animate_mp4_without_ffmpeg(tmp_path, capsys):
    refused(main(["animate", "pendulum", "--solvers", "flexmbd", "--out", str(tmp_path / "a.mp4")]),
            capsys, "a.mp4", "ffmpeg")
    assert not list(tmp_path.iterdir())


def test_export_unknown_solver_and_unwritable_folder(tmp_path, capsys):
    refused(main(["export", "pendulum", "--solver", "nope", "--vtk", str(tmp_path / "v")]), capsys, "--solver", "nope")
    (tmp_path / "file").write_text("")
    refused(main(["export", "pendulum", "--solver", "flexmbd", "--vtk", str(tmp_path / "file")]), capsys,
            "--vtk", "a file is there")
    assert not (tmp_path / "v").exists()


def test_export_needs_its_folder(capsys):
    refused(main(["export", "pendulum", "--solver", "flexmbd"]), capsys, "--vtk")


def test_vtk_series_of_a_solids_surface_stress(tmp_path):
    """A solid's stored field: its boundary faces (hex20: quadrilaterals on the corner nodes) with
    each face's von Mises stress as cell data, on the undeformed mesh in its body frame."""
    from flexmbd.report.fields import surface
    case = cases.load("cantilever_solid")
    x, faces = surface(case.bodies["beam"])
    vm = [list(np.arange(len(faces), dtype=float)), list(2.0 * np.arange(len(faces)))]
    r = Result(solver="flexmbd", case="cantilever_solid", extra={"fields": {"beam": {"t": [0.0, 0.5], "vm": vm}}})
    pvd, n = animation.vtk(case, r, tmp_path)
    assert n == 2
    m = meshio.read(tmp_path / "beam_00001.vtu")
    assert m.points.min(axis=0) == pytest.approx([0.0, -0.0075, -0.005])
    assert m.points.max(axis=0) == pytest.approx([1.5, 0.0075, 0.005])
    assert [b.type for b in m.cells] == ["quad"] and len(m.cells[0].data) == len(faces)
    assert m.cell_data["von_mises"][0] == pytest.approx(vm[1])


def test_animate_without_a_beam_shape(tmp_path):
    case = cases.load("cantilever_solid")
    with pytest.raises(Exception, match="no solver's run recorded a deformed shape"):
        animation.animate(case, {"flexmbd": Result(solver="flexmbd", case=case.name)}, tmp_path / "a.gif", None, 20)
    assert not list(tmp_path.iterdir())
