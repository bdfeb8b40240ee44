"""Frames end to end (flexmbd/fe/flexbody.py `frame_body`, cases, channels, fe-linear's full-order
frame): a straight CBAR pendulum runs as the case's own beam does; turned anywhere in a turned
world it swings the same; clamped, its modal model approaches the full-order frame as modes are
added; Craig-Bampton and free-free mode sets; the solvers that cannot take a frame say so; case
errors name their key."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from flexmbd import cases
from flexmbd.fe import flexbody
from flexmbd.harness import registry
from flexmbd.cli import main
from flexmbd.fe import section

SEC = section.rectangle(b=0.015, h=0.01)
TURN = Rotation.from_rotvec([0.3, -0.7, 1.1]).as_matrix()

FRAME = """title = "frame"
duration = {duration}
gravity = {gravity}
materials = {{}}
[bodies.rod]
type = "solid"
mesh = {{ file = "bar.bdf" }}
frame = "root"
modes = {{ count = {count}, boundary = "{boundary}" }}
[bodies.rod.interfaces.root]
set = "set1"
kind = "rigid"
[bodies.rod.interfaces.tip]
set = "set2"
kind = "rigid"
[joints.pivot]
type = "{joint}"
parent = "ground"
child = "rod"
{axis}
[channels.angle]
kind = "{angle}"
{angle_of}
[channels.tip_x]
kind = "deflection"
body = "rod"
at = "tip"
component = "x"
[channels.tip_y]
kind = "deflection"
body = "rod"
at = "tip"
component = "y"
[channels.tip_z]
kind = "deflection"
body = "rod"
at = "tip"
component = "z"
{extra}
[integrator]
output_dt = 1e-3
"""

BEAM = """title = "beam"
duration = 0.3
gravity = [0.0, -9.81, 0.0]
[materials.steel]
E = 2.1e11
nu = 0.3
rho = 7850.0
[bodies.rod]
type = "beam"
material = "steel"
length = 1.5
elements = 20
section = { shape = "rectangle", b = 0.015, h = 0.01 }
modes = { count = 6, boundary = "clamped-free" }
stiffening = false
[joints.pivot]
type = "revolute"
parent = "ground"
child = "rod"
axis = [0.0, 0.0, 1.0]
[channels.angle]
kind = "joint_angle"
joint = "pivot"
[channels.tip_y]
kind = "deflection"
body = "rod"
at = 1.5
component = "y"
[integrator]
output_dt = 1e-3
"""


def bar_file(folder, turn=np.eye(3), n=20, length=1.5, extra="", g0=False) -> None:
    """bar.bdf: a straight rod of n CBARs from the origin along turn's x, plane 1 turn's x-y (by
    the vector, or with `g0` by an orientation grid 999 on no element); SET1 1 its root node, SET1
    2 its tip node, SET1 3 its first two, SET1 4 the grid 999."""
    X = np.c_[np.linspace(0.0, length, n + 1), np.zeros(n + 1), np.zeros(n + 1)] @ turn.T
    r = lambda x: repr(float(x))
    v = turn @ [0.0, 1.0, 0.0]
    lines = ["BEGIN BULK"] + [f"GRID,{i + 1},,{r(x)},{r(y)},{r(z)}" for i, (x, y, z) in enumerate(X)]
    lines += ["GRID,999,,{},{},{}".format(*map(r, turn @ [0.0, 5.0, 0.0])), "SET1,4,999"]
    lines += [f"CBAR,{e + 1},7,{e + 1},{e + 2},999" if g0 else f"CBAR,{e + 1},7,{e + 1},{e + 2},{r(v[0])},{r(v[1])},{r(v[2])}"
              for e in range(n)]
    lines += [f"PBAR,7,3,{r(SEC.A)},{r(SEC.Iz)},{r(SEC.Iy)},{r(SEC.J)}", "MAT1,3,2.1e11,,0.3,7850.",
              "SET1,1,1", f"SET1,2,{n + 1}", "SET1,3,1,2", extra, "ENDDATA"]
    (folder / "bar.bdf").write_text("\n".join(lines) + "\n")


def frame_case(folder, turn=np.eye(3), joint="revolute", count=6, boundary="clamped-interface", duration=0.3,
               extra="", name="frame", gravity=(0.0, -9.81, 0.0), overrides=()):
    axis = "axis = " + repr([float(a) for a in turn @ [0.0, 0.0, 1.0]]) if joint == "revolute" else ""
    angle = ("joint_angle", 'joint = "pivot"') if joint == "revolute" else ("energy", "")
    text = FRAME.format(duration=duration, gravity=repr([float(g) for g in turn @ gravity]), count=count,
                        boundary=boundary, joint=joint, axis=axis, angle=angle[0], angle_of=angle[1], extra=extra)
    path = folder / f"{name}.toml"
    path.write_text(text)
    return cases.load(str(path), list(overrides))


def test_a_straight_frame_pendulum_runs_as_the_beam_does(tmp_path):
    """The CBAR rod hinged at its root node against the case's own 20-element beam with the same
    section, material and lumped mass: the same modes, so the same motion to round-off (the
    frame's sums run over two more, massless, nodes)."""
    bar_file(tmp_path)
    frame = registry.run(frame_case(tmp_path), "flexmbd")
    (tmp_path / "beam.toml").write_text(BEAM)
    beam = registry.run(cases.load(str(tmp_path / "beam.toml")), "flexmbd")
    assert frame.status.ok and beam.status.ok
    for c in ("angle", "tip_y"):
        scale = np.abs(beam.channels[c]).max()
        assert np.abs(frame.channels[c] - beam.channels[c]).max() <= 1e-9 * scale, c   # seen: 0


def test_an_orientation_grid_on_no_element_gives_the_same_frame(tmp_path):
    """The rod oriented by a G0 grid (on no element: the body's mesh drops it) against the same
    rod oriented by the vector: the same body."""
    bodies = []
    for g0 in (False, True):
        folder = tmp_path / str(g0)
        folder.mkdir()
        bar_file(folder, TURN, g0=g0)
        bodies.append(frame_case(folder, TURN).reduced("rod"))
    a, b = bodies
    assert a.x0.shape == b.x0.shape == (23, 3)
    # the two triads agree to round-off, which moves the lowest eigenvalues by up to eps times
    # the highest over the lowest (about 1e8 here: axial against first bending) relative
    assert np.abs(a.freq_hz / b.freq_hz - 1.0).max() < 1e-8         # seen: 4e-11
    assert np.abs(a.Phi - b.Phi).max() < 1e-8 * np.abs(a.Phi).max()


def test_a_turned_frame_in_a_turned_world_swings_the_same(tmp_path):
    """The rod, its hinge axis and gravity all turned by one rotation: the hinge angle is the
    same and the tip's deflection is the same vector turned (body axes are the mesh's). Both run
    at rtol 1e-11: their adaptive steps differ by round-off, so the runs differ by about the
    tolerance times the state's scale (1.5 m, 1 rad), which is 300 times the deflection's; the
    bound 1e-7 of the channel's largest value is that with a margin of about 100."""
    results = {}
    for k, turn in enumerate((np.eye(3), TURN)):
        folder = tmp_path / str(k)
        folder.mkdir()
        bar_file(folder, turn)
        case = frame_case(folder, turn, overrides=["integrator.rtol=1e-11", "integrator.atol=1e-13"])
        results[k] = registry.run(case, "flexmbd")
        assert results[k].status.ok
    a, b = results[0].channels, results[1].channels
    assert np.abs(a["angle"] - b["angle"]).max() <= 1e-7 * np.abs(a["angle"]).max()
    d0 = np.stack([a[f"tip_{c}"] for c in "xyz"], axis=1)
    d1 = np.stack([b[f"tip_{c}"] for c in "xyz"], axis=1)
    assert np.abs(d1 - d0 @ TURN.T).max() <= 1e-7 * np.abs(d0).max()       # seen: 1.2e-9 (angle: 4.6e-12 rad)


STEP = """[loads.push]
type = "point_force"
body = "rod"
at = "tip"
force = [0.0, 4.0, -12.0]
profile = { type = "step" }
[channels.stress]
kind = "stress_vm"
body = "rod"
point = [0.03, 0.004, 0.006]
"""


def test_clamped_frame_against_the_full_order_frame(tmp_path):
    """The rod clamped at its root, a tip step load and gravity: flexmbd's modal frame against
    fe-linear's every DOF (modal scheme: exact between samples). The difference falls as modes
    are added: it is the truncation."""
    bar_file(tmp_path)
    errors = {}
    for count in (2, 12):
        case = frame_case(tmp_path, joint="fixed", count=count, extra=STEP, name=f"c{count}")
        a, b = registry.run(case, "flexmbd"), registry.run(case, "fe-linear")
        assert a.status.ok and b.status.ok
        errors[count] = {c: np.sqrt(np.mean((a.channels[c] - b.channels[c]) ** 2)) / np.abs(b.channels[c]).max()
                         for c in ("tip_y", "tip_z", "stress")}
    print(errors)
    for c in ("tip_y", "tip_z", "stress"):
        assert errors[12][c] < errors[2][c], c
    assert errors[12]["tip_z"] < 1e-3 and errors[12]["stress"] < 0.03


@pytest.mark.parametrize("boundary, count", [("craig-bampton", 8), ("free-free", 6)])
def test_other_mode_sets_hold_the_frame_node(tmp_path, boundary, count):
    """Craig-Bampton (the tip's six constraint modes and two normal modes) and free-free modes of
    the hinged rod: the frame node's block is zero in every mode and the modes are orthonormal in
    the lumped mass (I9 = 1); the hinged rod swings."""
    bar_file(tmp_path)
    case = frame_case(tmp_path, count=count, boundary=boundary)
    fb = case.reduced("rod")
    assert np.abs(fb.Phi[0]).max() == 0.0 and np.abs(fb.Phi[2]).max() == 0.0    # the frame's interface, its node
    I9 = np.einsum("pam,pab,pbn->mn", fb.Phi[:, :3], fb.J, fb.Phi[:, :3]) + \
        np.einsum("p,pam,pan->mn", fb.m, fb.Phi[:, 3:], fb.Phi[:, 3:])
    assert np.abs(I9 - np.eye(count)).max() < 1e-10
    assert registry.run(case, "flexmbd").status.ok
    if boundary == "craig-bampton":                 # the tip's constraint modes: any static tip load exactly
        K, _ = flexbody.frame_matrices(case.bodies["rod"])
        free = np.arange(6, K.shape[0])
        f = np.zeros(K.shape[0])
        f[6 * 20:6 * 20 + 6] = [1.0, -2.0, 3.0, 0.1, 0.2, -0.3]         # the tip node's force and moment
        u = np.zeros(K.shape[0])
        u[free] = np.linalg.solve(K.toarray()[np.ix_(free, free)], f[free])
        P = np.concatenate([fb.Phi[2:, 3:], fb.Phi[2:, :3]], axis=1).reshape(-1, count)   # FE order [u; theta]
        reduced = P @ np.linalg.solve(fb.Km, P.T @ f)
        assert np.abs(reduced - u).max() <= 1e-9 * np.abs(u).max()


CHILD = """[bodies.bob]
type = "rigid"
mass = 0.5
com = [0.1, 0.0, 0.0]
inertia = [1e-4, 2e-3, 2e-3, 0.0, 0.0, 0.0]
[joints.elbow]
type = "revolute"
parent = "rod"
child = "bob"
at = {at}
axis = [0.0, 0.0, 1.0]
q0 = 0.3
[channels.elbow]
kind = "joint_angle"
joint = "elbow"
"""


def test_a_body_hinged_on_a_frames_interface_moves_as_on_the_beams_tip(tmp_path):
    """A rigid bob hinged at the rod's tip, the joint on the frame's tip interface or on the
    beam's tip node: the same double pendulum to round-off."""
    bar_file(tmp_path)
    frame = registry.run(frame_case(tmp_path, extra=CHILD.format(at='"tip"')), "flexmbd")
    (tmp_path / "beam.toml").write_text(BEAM.replace("[integrator]", CHILD.format(at="1.5") + "[integrator]"))
    beam = registry.run(cases.load(str(tmp_path / "beam.toml")), "flexmbd")
    assert frame.status.ok and beam.status.ok
    for c in ("angle", "elbow", "tip_y"):
        scale = np.abs(beam.channels[c]).max()
        assert np.abs(frame.channels[c] - beam.channels[c]).max() <= 1e-9 * scale, c


def test_solvers_without_frames_say_so(tmp_path):
    bar_file(tmp_path)
    case = frame_case(tmp_path)
    assert registry.status_for(case, "exudyn-ffrf").startswith(("not applicable: body 'rod' is a frame", "unavailable"))
    assert registry.status_for(case, "flexmbd") == ""


@pytest.mark.parametrize("edit, key", [
    (('set = "set2"', 'set = "set3"'), "bodies.rod.interfaces.tip.set"),
    (('set = "set2"\nkind = "rigid"', 'set = "set2"\nkind = "averaging"'), "bodies.rod.interfaces.tip.kind"),
    (('mesh = { file = "bar.bdf" }', 'mesh = { file = "bar.bdf", mass = "bar.bdf" }'), "bodies.rod.mesh.mass"),
    (('set = "set2"', 'set = "set4"'), "bodies.rod.interfaces.tip.set"),
    (("[integrator]", '[channels.s]\nkind = "stress_vm"\nbody = "rod"\npoint = [0.5, 0.2, 0.0]\n[integrator]'),
     "channels.s.point"),
])
def test_frame_case_errors_name_their_key(tmp_path, capsys, edit, key):
    bar_file(tmp_path)
    frame_case(tmp_path)
    path = tmp_path / "frame.toml"
    text = path.read_text()
    assert edit[0] in text
    path.write_text(text.replace(edit[0], edit[1], 1))
    assert main(["run", str(path), "--solver", "flexmbd", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and key in err, err
    assert not (tmp_path / "out").exists()
