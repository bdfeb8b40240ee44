"""report/animation.py and the commands `animate` and `export`: the frames' instants, the case
that records its shapes (and the stress along its beams) at them, the drawn factor, the bodies'
places in the global frame (a rigid pendulum's tip against its joint angle, a four-bar's loop
closing in its ParaView series, the stress there against the stress channel), an animation and a
ParaView series from stored shapes and from runs, read back (PIL, meshio), and bad input refused
in one line."""

import json
import shutil
import xml.etree.ElementTree as ET

import meshio
import numpy as np
import pytest
from PIL import Image, ImageChops

from flexmbd import cases
from flexmbd.harness import channels, results, registry
from flexmbd.cases.schema import MAX_SNAPSHOTS
from flexmbd.cli import main
from flexmbd.core.errors import InputError
from flexmbd.report import animation
from flexmbd.harness.results import Result

T_END, FRAMES = 0.02, 5             # s, instants: the pendulum's runs kept short (0, 5, ..., 20 ms)


TURN = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])     # 90 degrees about z
ORIGIN = np.array([0.2, 0.3, 0.0])


def shaped(solver: str, ts, tip, placed: bool = False) -> Result:
    """A result whose beam `beam` holds 3 shape points bending as tip * (x / L)^2 in y at the
    instants ts, the tip displacement tip(t) m; `placed`: with their global positions, the beam
    turned by TURN about its root at ORIGIN."""
    x = [0.0, 0.75, 1.5]
    u = np.array([[[0.0, tip(t) * (xi / 1.5) ** 2, 0.0] for xi in x] for t in ts])
    s = {"x": x, "t": list(ts), "u": u.tolist()}
    if placed:
        s["r"] = (ORIGIN + (u + np.column_stack([x, np.zeros((3, 2))])) @ TURN.T).tolist()
    return Result(solver=solver, case="pendulum", t=np.asarray(ts), extra={"shapes": {"beam": s}})


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
    assert len(animation.instants(case, None, None)) == animation.FRAMES
    every = animation.instants(case, 0.002, None)       # 5 samples in 2 ms: each once, by default
    assert every == pytest.approx([0.0, 0.0005, 0.001, 0.0015, 0.002], abs=1e-12)
    assert animation.instants(case, 0.002, 5) == every
    assert animation.instants(case, 0.0013, 3) == pytest.approx([0.0, 0.0005, 0.001], abs=1e-12)
    assert animation.instants(case, None, 1) == [0.0]


def test_more_frames_than_output_samples_are_refused():
    case = cases.load("pendulum")
    with pytest.raises(InputError, match=r"--frames 6: the run has 5 output samples \(0 to 0.002 s, every "
                                         r"integrator.output_dt = 0.0005 s\), at most one frame each: give at most 5"):
        animation.instants(case, 0.002, 6)
    with pytest.raises(InputError, match="--frames 1000000000: .* give at most 4001"):
        animation.instants(case, None, 10 ** 9)


def test_framed_case_records_shapes_and_their_stress_beyond_the_snapshot_limit():
    case = cases.load("pendulum", ["report.shape_points=5"])
    shipped = dict(case.channels)
    times = animation.instants(case, 0.01, 21)
    fr = animation.framed(case, times)
    assert len(fr.report.snapshots) == 21 > MAX_SNAPSHOTS
    assert fr.report.shape_points == animation.POINTS
    xs = channels.shape_positions(fr, "beam")
    assert len(xs) == fr.report.shape_points
    added = {n: c for n, c in fr.channels.items() if n not in case.channels}
    assert sorted((c.kind, c.body, c.at, c.fibre) for c in added.values()) == [("stress_vm", "beam", x, None) for x in xs]
    assert case.report.snapshots != fr.report.snapshots and dict(case.channels) == shipped     # left as it was
    assert fr.name == case.name and fr.overrides[0] == "report.shape_points=5"


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


def test_vtk_series_of_stored_shapes_in_the_global_frame(tmp_path):
    """The beam at its global positions (turned 90 degrees about its root at ORIGIN), its bending
    in global components: the displacement u turned the same way (`elastic` finds the turn)."""
    case = cases.load("pendulum")
    r = shaped("flexmbd", [0.0, 0.01], lambda t: 0.1 * t, placed=True)
    pvd, n = animation.vtk(case, r, tmp_path)
    assert n == 2 and pvd.name == "pendulum_flexmbd.pvd"
    m = meshio.read(tmp_path / "beam_00001.vtu")
    assert np.allclose(m.points, ORIGIN + np.array([[0.0, 0.0, 0.0], [0.75, 0.00025, 0.0], [1.5, 0.001, 0.0]]) @ TURN.T,
                       rtol=0.0, atol=1e-15)
    assert m.cells_dict["line"].tolist() == [[0, 1], [1, 2]]
    assert m.point_data["displacement"] == pytest.approx(np.array([[0.0, 0.0, 0.0], [0.0, 0.00025, 0.0],
                                                                   [0.0, 0.001, 0.0]]) @ TURN.T, abs=1e-15)
    assert "stress_vm" not in m.point_data                      # not recorded: not written


def test_a_beam_without_global_positions_is_not_exported(tmp_path):
    with pytest.raises(InputError, match="recorded no body it can place in the global frame"):
        animation.vtk(cases.load("pendulum"), shaped("flexmbd", [0.0], lambda t: 0.0), tmp_path)
    assert not list(tmp_path.iterdir())


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
    n = max(cases.load("pendulum").report.shape_points, animation.POINTS)
    tips = []
    for d in sets:
        m = meshio.read(folder / d.get("file"))
        u, vm = m.point_data["displacement"], m.point_data["stress_vm"]
        assert m.points.shape == (n, 3) and m.cells_dict["line"].shape == (n - 1, 2) and vm.shape == (n,)
        assert np.all(np.isfinite(m.points)) and np.all(np.isfinite(u)) and np.all(vm >= 0.0)
        assert m.points[0] == pytest.approx([0.0, 0.0, 0.0], abs=1e-12)                  # on the pivot
        assert np.linalg.norm(m.points[-1]) == pytest.approx(1.5, rel=1e-3)             # as long as it is
        tips.append(u[-1])
    assert np.abs(tips[0]).max() == 0.0 and abs(tips[-1][1]) > 1e-5   # starts straight, bends as it falls
    m = meshio.read(folder / sets[0].get("file"))
    assert m.points == pytest.approx(np.column_stack([np.linspace(0.0, 1.5, n), np.zeros((n, 2))]), abs=1e-12)


def test_a_rigid_pendulums_tip_is_where_its_joint_angle_puts_it():
    """The beam declared rigid, run by flexmbd (its kinematics) and by the rigid peers: at every
    frame the tip drawn from the run's stored pose (`animation.mechanism`) is L (cos q, sin q) of
    the joint angle channel at that sample (an independent quantity: the joint's coordinate)."""
    case = cases.load("pendulum", ["bodies.beam.rigid=true"])
    fr = animation.framed(case, animation.instants(case, 0.3, 7))
    for name in ("flexmbd", "pinocchio", "mujoco"):
        r = registry.run(fr, name, 0.3)
        t, pts, stress = animation.mechanism(case, r, 1.0)["beam"]
        assert len(t) == 7 and stress is None and "shapes" not in r.extra
        q = r.channels["joint_angle"][[int(np.argmin(np.abs(r.t - ti))) for ti in t]]
        assert abs(q[-1]) > 0.4                                          # it swung
        assert pts[:, -1] == pytest.approx(1.5 * np.column_stack([np.cos(q), np.sin(q), 0.0 * q]), abs=1e-12), name
        assert pts[:, 0] == pytest.approx(np.zeros((7, 3)), abs=1e-15)


def loop(folder, k: int) -> dict:
    return {b: meshio.read(folder / f"{b}_{k:05d}.vtu") for b in ("crank", "coupler", "rocker")}


def test_export_four_bar_rigid_closes_its_loop(tmp_path, capsys):
    """The ParaView series of the rigid four-bar: at every instant the crank's tip is the coupler's
    root, the coupler's far end the rocker's tip (the cut joint) within the closure flexmbd keeps
    (constraints.CLOSED: Newton to 1e-12, a state beyond 1e-9 refused; measured 1.3e-13 m), and
    the rocker's root on its ground pivot (0.5, 0, 0)."""
    code = main(["export", "four_bar_swing_rigid", "--solver", "flexmbd", "--vtk", str(tmp_path), "--t-end", "0.1",
                 "--frames", "6"])
    assert code == 0, capsys.readouterr().err
    angles = set()
    for k in range(6):
        m = loop(tmp_path, k)
        crank, coupler, rocker = (m[b].points for b in ("crank", "coupler", "rocker"))
        assert np.linalg.norm(crank[-1] - coupler[0]) <= 1e-12
        assert np.linalg.norm(coupler[-1] - rocker[-1]) <= 1e-9
        assert rocker[0] == pytest.approx([0.5, 0.0, 0.0], abs=1e-15) and crank[0] == pytest.approx([0, 0, 0], abs=1e-15)
        assert np.linalg.norm(coupler[-1] - coupler[0]) == pytest.approx(0.45, abs=1e-12)
        angles.add(round(float(np.arctan2(crank[-1][1], crank[-1][0])), 3))
    assert len(angles) == 6                                             # it moved


def test_export_four_bar_stress_is_the_stress_channel(tmp_path):
    """The flexible four-bar by flexmbd: the coupler's far end on the rocker's tip, its bending in
    the series' displacement (as long as the chord-frame displacement, and the deformed points
    minus it on the straight chord), and its point data stress_vm at the channel's position
    (0.225 m, a shape point) equal to the stress_vm channel at that sample. The loop closes to
    1e-14 m in flexmbd's model; the points a modal solver reports (`channels.modal_points`, x0 +
    Phi_t eta) leave out the stiffened coupler's second-order foreshortening, which sets the gap
    seen here (measured 1.2e-5 m up to 0.05 s; 6e-15 m with stiffening = false)."""
    case = cases.load("four_bar_swing")
    fr = animation.framed(case, animation.instants(case, 0.05, 6))
    r = registry.run(fr, "flexmbd", 0.05)
    animation.vtk(case, r, tmp_path)
    shape = r.extra["shapes"]["coupler"]
    at = channels.shape_positions(fr, "coupler").index(0.225)
    for k, t in enumerate(shape["t"]):
        m = loop(tmp_path, k)
        coupler, rocker = m["coupler"].points, m["rocker"].points
        assert np.linalg.norm(coupler[-1] - rocker[-1]) <= 3e-5
        i = int(np.argmin(np.abs(r.t - t)))
        assert m["coupler"].point_data["stress_vm"][at] == r.channels["stress_vm"][i]
        d = m["coupler"].point_data["displacement"]
        assert np.linalg.norm(d, axis=1) == pytest.approx(np.linalg.norm(shape["u"][k], axis=1), rel=1e-9, abs=1e-15)
        line = coupler - d - coupler[0]                                 # the undeformed chord, straight
        assert np.abs(np.cross(line, line[-1])).max() <= 1e-12
    assert np.abs(m["coupler"].point_data["displacement"]).max() > 1e-5     # it bent


def test_the_drawing_plane_is_the_one_the_motion_lies_in():
    x = np.random.default_rng(0).normal(size=(50, 3))
    assert animation.plane(x * [1.0, 1.0, 0.0]) == (0, 1)
    assert animation.plane(x * [1.0, 0.0, 1.0]) == (0, 2)
    assert animation.plane(x * [0.0, 1.0, 1.0]) == (1, 2)
    assert animation.plane(x * [1.0, 0.0, 0.0]) == (0, 1)              # a line: x-y
    assert animation.plane(x * [1.0, 1.0, 0.01]) == (0, 1)


def test_a_run_with_global_shapes_and_poses_reads_back(tmp_path):
    """What `registry.run` stores: shapes with r and stress, poses; a broken pose refused naming it."""
    r = shaped("flexmbd", [0.0, 0.01], lambda t: 0.1 * t, placed=True)
    r.extra["shapes"]["beam"]["stress"] = [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]
    r.extra["poses"] = {"crank": {"t": [0.0, 0.01], "R": [np.eye(3).tolist()] * 2, "p": [[0.0, 0.0, 0.0]] * 2}}
    r.t, r.channels = np.array([0.0, 0.01]), {"x": np.zeros(2)}
    _, js = results.write(r, tmp_path)
    back = results.read(tmp_path, "pendulum", "flexmbd")
    assert back.extra["shapes"] == r.extra["shapes"] and back.extra["poses"] == r.extra["poses"]
    meta = json.loads(js.read_text())
    meta["poses"]["crank"]["R"][1] = [[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]]
    js.write_text(json.dumps(meta))
    with pytest.raises(InputError, match=r"poses.crank.R: rows of unequal lengths"):
        results.read(tmp_path, "pendulum", "flexmbd")


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
    each face's von Mises stress as cell data, on the undeformed mesh at its pose (turned by TURN,
    its frame at ORIGIN)."""
    from flexmbd.report.fields import surface
    case = cases.load("cantilever_solid")
    x, faces = surface(case.bodies["beam"])
    vm = [list(np.arange(len(faces), dtype=float)), list(2.0 * np.arange(len(faces)))]
    pose = {"t": [0.0, 0.5], "R": [np.eye(3).tolist(), TURN.tolist()], "p": [[0.0] * 3, ORIGIN.tolist()]}
    r = Result(solver="flexmbd", case="cantilever_solid", extra={"fields": {"beam": {"t": [0.0, 0.5], "vm": vm}},
                                                                 "poses": {"beam": pose}})
    pvd, n = animation.vtk(case, r, tmp_path)
    assert n == 2
    m0, m = meshio.read(tmp_path / "beam_00000.vtu"), meshio.read(tmp_path / "beam_00001.vtu")
    assert m0.points.min(axis=0) == pytest.approx([0.0, -0.0075, -0.005])
    assert m0.points.max(axis=0) == pytest.approx([1.5, 0.0075, 0.005])
    assert m.points == pytest.approx(ORIGIN + m0.points @ TURN.T, abs=1e-15)
    assert [b.type for b in m.cells] == ["quad"] and len(m.cells[0].data) == len(faces)
    assert m.cell_data["von_mises"][0] == pytest.approx(vm[1])


def test_animate_with_nothing_to_draw(tmp_path):
    case = cases.load("cantilever_solid")
    with pytest.raises(InputError, match="no solver's run recorded where its bodies are or a deformed shape"):
        animation.animate(case, {"flexmbd": Result(solver="flexmbd", case=case.name)}, tmp_path / "a.gif", None, 20)
    assert not list(tmp_path.iterdir())


def test_animate_and_export_refuse_absurd_frame_counts_before_any_run(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(registry, "run", lambda *a, **k: pytest.fail("a solver ran"))
    refused(main(["animate", "pendulum", "--solvers", "flexmbd", "--frames", "1000000000",
                  "--out", str(tmp_path / "a.gif")]), capsys, "--frames 1000000000", "at most 4001")
    refused(main(["export", "pendulum", "--solver", "flexmbd", "--frames", "42", "--t-end", "0.01",
                  "--vtk", str(tmp_path / "v")]), capsys, "--frames 42", "21 output samples")
    assert not list(tmp_path.iterdir())
