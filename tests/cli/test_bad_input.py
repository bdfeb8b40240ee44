"""Bad input, checked before any work starts: every case file, motion table, `--set` override and
cost beyond the limits stops with exactly one line on stderr naming the file and the key, exit
status 2, no traceback and nothing written. Property-based tests: random TOML and random
overrides either load or raise InputError with one printable line, never anything else."""

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from flexmbd import cases
from flexmbd.harness import cost, registry
from flexmbd.cli import main, parser
from flexmbd.core.errors import InputError

CANTILEVER = (cases.CASES_DIR / "cantilever_step.toml").read_text()
PENDULUM = (cases.CASES_DIR / "pendulum.toml").read_text()

# a rigid body hanging from the pendulum's beam tip (its inertia is edited by the cases below)
RIGID_TIP = PENDULUM + """
[bodies.tip]
type = "rigid"
mass = 0.5
inertia = [1e-3, 1e-3, 1e-3, 0.0, 0.0, 0.0]

[joints.weld]
type = "fixed"
parent = "beam"
child = "tip"
at = 1.5
"""

# the pendulum's beam closed into a loop: a rigid link from its tip back to ground (the joint
# `back` closes it; the cases below spoil the declaration)
LOOP = PENDULUM + """
[bodies.link]
type = "rigid"
mass = 0.5
inertia = [1e-3, 1e-3, 1e-3, 0.0, 0.0, 0.0]

[joints.tip_pin]
type = "revolute"
parent = "beam"
child = "link"
at = 1.5

[joints.back]
type = "revolute"
parent = "ground"
child = "link"
at = [1.5, 1.0, 0.0]
child_at = [0.0, 1.0, 0.0]
loop = true
"""

# the pendulum driven through a motion table q.csv written beside it
DRIVEN = PENDULUM.replace("qd0 = 0.0", 'qd0 = 0.0\nmotion = { type = "table", file = "q.csv" }')
GOOD_TABLE = "t,q\n0,0\n0.5,0.1\n1,0.2\n1.5,0.3\n2,0.4\n"


def _in_process(tmp_path, capsys, argv):
    """Run the command in-process with an output folder; (status, stderr, files written)."""
    out = tmp_path / "out"
    code = main(argv + ["--out", str(out)])
    err = capsys.readouterr().err
    return code, err, sorted(p.name for p in out.rglob("*")) if out.exists() else []


def _refused(code, err, written, words):
    lines = err.splitlines()
    assert code == 2, err
    assert len(lines) == 1, err
    assert "Traceback" not in err and lines[0].startswith("flexmbd: ")
    assert lines[0].isprintable()
    assert not written
    for w in words:
        assert w in lines[0], (w, lines[0])


# ---------------------------------------------------------------------------------------------
# case files and overrides: (id, case text (or bytes), table file or None, --set items, solver, words)

C, P = CANTILEVER, PENDULUM
FMAP = """
[frequency_map]
key = "bodies.beam.section.h"
start = 0.01
stop = 0.02
values = 3
set = []
"""

BAD = [
    # undecodable input
    ("latin1-case-file", C.replace("Cantilever beam", "Caf\u00e9 beam").encode("latin-1"), None, [], "analytic",
     ["case.toml", "not UTF-8", "byte 0xa7 on line 1"]),
    ("binary-case-file", bytes(range(256)) * 4, None, [], "analytic", ["case.toml", "not UTF-8"]),
    ("set-undecodable-title", C, None, ["title=caf\udce9"], "analytic", ["--set", "caf\\xe9", "UTF-8"]),
    ("set-undecodable-key", C, None, ["dura\udce9tion=1"], "analytic", ["--set", "UTF-8"]),
    # NaN / inf anywhere
    ("nan-in-case", C.replace("E = 2.06e11", "E = nan"), None, [], "analytic", ["materials.steel.E", "finite"]),
    ("inf-in-case", P.replace("[0.0, -9.81, 0.0]", "[0.0, -inf, 0.0]"), None, [], "flexmbd", ["gravity", "finite"]),
    ("overflowing-literal", C.replace("E = 2.06e11", "E = 1e400"), None, [], "analytic", ["materials.steel.E", "finite"]),
    ("nan-via-set", C, None, ["duration=nan"], "analytic", ["duration", "finite"]),
    ("inf-via-set", C, None, ["loads.tip_force.force=[0, -inf, 0]"], "analytic", ["loads.tip_force.force", "finite"]),
    ("nan-solver-setting", C, None, ["solvers.fe-linear.dt=nan"], "fe-linear", ["solvers.fe-linear.dt", "finite"]),
    ("nan-tolerance", C, None, ["report.tolerances.tip_deflection=nan"], "analytic", ["report.tolerances.tip_deflection"]),
    # motion tables
    ("table-nan", DRIVEN, "t,q\n0,0\n0.5,nan\n1,0.2\n1.5,0.3\n", [], "flexmbd", ["joints.pivot.motion.file", "not finite"]),
    ("table-inf-time", DRIVEN, "t,q\n0,0\n0.5,0.1\ninf,0.2\n1.5,0.3\n", [], "flexmbd", ["joints.pivot.motion.file", "finite"]),
    ("table-not-increasing", DRIVEN, "t,q\n0,0\n1,0.1\n0.5,0.2\n1.5,0.3\n", [], "flexmbd", ["motion.file", "increase strictly"]),
    ("table-repeated-time", DRIVEN, "t,q\n0,0\n1,0.1\n1,0.2\n1.5,0.3\n", [], "flexmbd", ["motion.file", "increase strictly"]),
    ("table-header-only", DRIVEN, "t,q\n", [], "flexmbd", ["joints.pivot.motion.file", "no rows"]),
    ("table-empty-file", DRIVEN, "", [], "flexmbd", ["joints.pivot.motion.file", "no rows"]),
    ("table-three-columns", DRIVEN, "t,q,x\n0,0,0\n1,1,1\n2,2,2\n3,3,3\n", [], "flexmbd", ["motion.file", "columns t, q"]),
    ("table-too-short", DRIVEN, "t,q\n0,0\n1,1\n", [], "flexmbd", ["motion.file", "at least 4 rows"]),
    ("table-garbage", DRIVEN, "t,q\n0,0\n1,x\n2,2\n3,3\n", [], "flexmbd", ["motion.file", "not a CSV of numbers"]),
    ("table-binary", DRIVEN, b"t,q\n\xff\xfe\x00\x01\n", [], "flexmbd", ["motion.file"]),
    ("table-huge-value", DRIVEN, "t,q\n0,0\n1,1e300\n2,2\n3,3\n", [], "flexmbd", ["motion.file", "magnitude"]),
    # rigid inertias
    ("inertia-not-positive-definite", RIGID_TIP, None, ["bodies.tip.inertia=[1e-3, 1e-3, 1e-3, 2e-3, 0, 0]"],
     "flexmbd", ["bodies.tip.inertia", "positive definite"]),
    ("inertia-triangle", RIGID_TIP, None, ["bodies.tip.inertia=[1e-3, 1e-3, 3e-3, 0, 0, 0]"],
     "flexmbd", ["bodies.tip.inertia", "triangle inequality"]),
    ("inertia-triangle-rotated", RIGID_TIP, None, ["bodies.tip.inertia=[2e-3, 2e-3, 1e-3, 1.5e-3, 0, 0]"],
     "flexmbd", ["bodies.tip.inertia", "triangle inequality"]),
    ("inertia-negative-moment", RIGID_TIP, None, ["bodies.tip.inertia=[-1e-3, 1e-3, 1e-3, 0, 0, 0]"],
     "flexmbd", ["bodies.tip.inertia", "positive"]),
    ("inertia-five-numbers", RIGID_TIP, None, ["bodies.tip.inertia=[1e-3, 1e-3, 1e-3, 0, 0]"],
     "flexmbd", ["bodies.tip.inertia", "6 numbers"]),
    # stress points outside their section
    ("fibre-outside-rectangle", C, None, ["channels.stress_vm.fibre=[0.0, 0.006]"], "analytic",
     ["channels.stress_vm.fibre", "outside", "rectangle"]),
    ("fibre-outside-h-axis-z", C.replace('h_axis = "y"', 'h_axis = "z"'), None, ["channels.stress_vm.fibre=[0.007, 0.0]"],
     "analytic", ["channels.stress_vm.fibre", "|y| <= 0.005"]),
    ("fibre-outside-circle", C.replace('shape = "rectangle", b = 0.01, h = 0.015, h_axis = "y"', 'shape = "circle", d = 0.012'),
     None, ["channels.stress_vm.fibre=[0.005, 0.005]"], "analytic", ["channels.stress_vm.fibre", "circle"]),
    ("fibre-one-number", C, None, ["channels.stress_vm.fibre=[0.001]"], "analytic", ["channels.stress_vm.fibre", "[y, z]"]),
    # a normal stress's direction: a solid's, of nonzero length
    ("direction-on-a-beam", C, None, ['channels.sn={kind="stress_normal", body="beam", at=0.03, direction=[0, 1, 0]}'],
     "analytic", ["channels.sn.direction", "along its axis"]),
    ("direction-zero", (cases.CASES_DIR / "cantilever_solid.toml").read_text(), None,
     ['channels.sn={kind="stress_normal", body="beam", point=[0.03, 0.0075, 0.0], direction=[0, 0, 0]}'],
     "flexmbd", ["channels.sn.direction", "nonzero length"]),
    ("direction-on-von-mises", C, None, ["channels.stress_vm.direction=[1, 0, 0]"], "analytic",
     ["channels.stress_vm.direction", "not used by a stress_vm channel"]),
    # absurd magnitudes
    ("E-1e308", C, None, ["materials.steel.E=1e308"], "analytic", ["materials.steel.E", "at most 1e+100"]),
    ("E-rho-overflowing-frequency", C, None, ["materials.steel.E=1e100", "materials.steel.rho=1e-100"], "analytic",
     ["bodies.beam", "highest element frequency"]),
    ("section-underflowing", C, None, ["bodies.beam.section.b=1e-90"], "analytic", ["bodies.beam", "outside [1e-200"]),
    ("gravity-1e300", P, None, ["gravity=[0, -1e300, 0]"], "flexmbd", ["gravity", "magnitude"]),
    ("rigid-mass-overflow", RIGID_TIP, None, ["bodies.tip.mass=1e99", "bodies.tip.com=[1e99, 0, 0]"], "flexmbd",
     ["bodies.tip", "mass times |com|^2"]),
    ("count-beyond-magnitude", C, None, ["bodies.beam.modes.count=1000000000000000000000000000000000000000000000000000"
                                         "0000000000000000000000000000000000000000000000000000000000"],
     "analytic", ["bodies.beam.modes.count", "magnitude"]),
    # malformed keys
    ("set-leading-dot", C, None, [".duration=1"], "analytic", ["--set .duration", "empty name"]),
    ("set-trailing-dot", C, None, ["duration.=1"], "analytic", ["--set duration.", "empty name"]),
    ("set-double-dot", C, None, ["materials..steel.E=1"], "analytic", ["--set materials..steel.E", "empty name"]),
    ("set-blank-part", C, None, ["materials. .E=1"], "analytic", ["empty name"]),
    ("set-no-equals", C, None, ["duration"], "analytic", ["--set 'duration'", "KEY=VALUE"]),
    ("set-no-key", C, None, ["=1"], "analytic", ["KEY=VALUE"]),
    ("set-into-a-value", C, None, ["duration.x=1"], "analytic", ["--set duration.x", "not a table"]),
    ("set-unknown-nested-key", C, None, ["integrator.methd='rk4'"], "analytic", ["integrator.methd", "did you mean 'method'"]),
    ("set-table-over-value", C, None, ["duration={a=1}"], "analytic", ["duration", "expected a number"]),
    # more of our own
    ("title-two-lines", C, None, ['title="one\\ntwo"'], "analytic", ["title", "one non-empty line"]),
    ("title-empty", C, None, ['title=" "'], "analytic", ["title", "one non-empty line"]),
    ("no-channels", C, None, ["channels={}", "report.tolerances={}"], "analytic", ["channels", "at least one"]),
    ("no-bodies", C, None, ["bodies={}", "joints={}", "loads={}"], "analytic", ["bodies", "at least one"]),
    ("channel-named-t", C.replace("[channels.tip_deflection]", "[channels.t]").replace(
        "tolerances = { tip_deflection = 0.01, ", "tolerances = { "), None, [], "analytic", ["channels.t", "time column"]),
    ("name-with-a-dot", C.replace("[materials.steel]", '[materials."st.eel"]').replace('material = "steel"',
                                                                                      'material = "st.eel"'),
     None, [], "analytic", ["materials.st.eel", "letters, digits"]),
    ("output-dt-beyond-duration", C, None, ["integrator.output_dt=5"], "analytic", ["integrator.output_dt", "longer than"]),
    ("rtol-not-below-one", C, None, ["integrator.rtol=2"], "flexmbd", ["integrator.rtol", "below 1"]),
    ("dt-zero", C, None, ["integrator.dt=0"], "flexmbd", ["integrator.dt", "positive"]),
    ("dt-negative", C, None, ["integrator.max_step=-1e-3"], "flexmbd", ["integrator.max_step", "positive"]),
    ("duration-zero", C, None, ["duration=0"], "analytic", ["duration", "positive"]),
    ("modes-count-negative", C, None, ["bodies.beam.modes.count=-1"], "analytic", ["bodies.beam.modes.count", "non-negative"]),
    ("modes-count-fraction", C, None, ["bodies.beam.modes.count=2.5"], "analytic", ["bodies.beam.modes.count", "whole number"]),
    ("elements-negative", C, None, ["bodies.beam.elements=-5"], "analytic", ["bodies.beam.elements", "positive"]),
    ("segments-not-dividing", C, None, ["bodies.beam.segments=7"], "flexmbd", ["bodies.beam.segments", "divisible"]),
    ("reference-not-among-solvers", C, None, ["report.solvers=['analytic', 'flexmbd']"], "analytic",
     ["report.reference", "not among report.solvers"]),
    ("channel-key-not-used", C, None, ["channels.tip_deflection.joint='clamp'"], "analytic",
     ["channels.tip_deflection.joint", "not used by a deflection channel"]),
    ("damping-inf", C, None, ["bodies.beam.damping_ratio=inf"], "analytic", ["bodies.beam.damping_ratio", "finite"]),
    ("nu-at-half", C, None, ["materials.steel.nu=0.5"], "analytic", ["materials.steel.nu", "Poisson"]),
    ("nested-too-deep", C + "\nx = " + "[" * 5000 + "]" * 5000 + "\n", None, [], "analytic", ["case.toml"]),
    ("joint-q0-nan", P, None, ["joints.pivot.q0=nan"], "flexmbd", ["joints.pivot.q0", "finite"]),
    ("solver-table-not-a-table", C, None, ["solvers.analytic=3"], "analytic", ["solvers.analytic", "table"]),
    ("gravity-two-numbers", P, None, ["gravity=[0, -9.81]"], "flexmbd", ["gravity", "3 numbers"]),
    # closed loops
    ("loop-undeclared", LOOP.replace("loop = true\n", ""), None, [], "flexmbd",
     ["joints.back.child", "body 'link' already has joint 'tip_pin'", "closes a kinematic loop", "loop = true"]),
    ("loop-on-no-body", LOOP, None, ['joints.back.child="lnk"'], "flexmbd",
     ["joints.back.child", "no body 'lnk'", "did you mean 'link'"]),
    ("loop-parent-no-body", LOOP, None, ['joints.back.parent="grund"'], "flexmbd",
     ["joints.back.parent", "no body 'grund'"]),
    ("loop-with-q0", LOOP, None, ["joints.back.q0=0.1"], "flexmbd",
     ["joints.back.q0", "no coordinates of its own"]),
    ("loop-driven", LOOP, None, ['joints.back.motion={type="constant_rate", rate=1.0}'], "flexmbd",
     ["joints.back.motion", "no coordinates of its own"]),
    ("loop-to-itself", LOOP, None, ['joints.back.parent="link"'], "flexmbd", ["joints.back.child", "two different bodies"]),
    ("loop-child-at-beyond-beam", LOOP, None, ['joints.back.child="beam"', "joints.back.child_at=2.0"], "flexmbd",
     ["joints.back.child_at", "beyond the beam's length"]),
    ("loop-on-a-split-beam", LOOP, None, ['joints.back.child="beam"', "joints.back.child_at=1.0", "bodies.beam.segments=2"],
     "flexmbd", ["joints.back.child", "split into segments"]),
    ("child-at-on-a-tree-joint", LOOP, None, ["joints.tip_pin.child_at=[0.0, 0.0, 0.0]"], "flexmbd",
     ["joints.tip_pin.child_at", "only a loop joint"]),
    ("loop-cannot-close", LOOP, None, ["joints.back.at=[3.5, 1.0, 0.0]"], "flexmbd",
     ["joints.back", "cannot close from the initial values", "tip_pin, pivot", "residual of 1.1"]),
    ("loop-joint-angle", LOOP, None, ['channels.joint_angle.joint="back"'], "flexmbd",
     ["channels.joint_angle.joint", "closes a loop", "tree joint"]),
    ("loop-the-only-joint", LOOP.replace('child = "link"\nat = 1.5', 'child = "link"\nat = 1.5\nloop = true'), None,
     [], "flexmbd", ["bodies.link", "no joint connects this body", "a loop joint does not"]),
    # deformed-shape snapshots
    ("snapshot-beyond-duration", C, None, ["report.snapshots=[0.5, 2.5]"], "analytic",
     ["report.snapshots", "instant 2.5 s lies outside the run [0, 2] s"]),
    ("snapshot-beyond-a-shorter-duration", C, None, ["report.snapshots=[1.5]", "duration=1"], "analytic",
     ["report.snapshots", "instant 1.5 s lies outside the run [0, 1] s"]),
    ("snapshot-negative", C, None, ["report.snapshots=[-0.1, 1.0]"], "analytic", ["report.snapshots", "instant -0.1 s"]),
    ("snapshot-nan", C, None, ["report.snapshots=[nan]"], "analytic", ["report.snapshots", "finite"]),
    ("snapshot-twice", C, None, ["report.snapshots=[1.0, 0.5, 1.0]"], "analytic", ["report.snapshots", "1 s is listed twice"]),
    ("snapshots-empty", C, None, ["report.snapshots=[]"], "analytic", ["report.snapshots", "1 to 12 instants",
                                                                       "report.shape_points = 0"]),
    ("snapshots-too-many", C, None, [f"report.snapshots={[0.1 * k for k in range(13)]}"], "analytic",
     ["report.snapshots", "1 to 12 instants", "got 13"]),
    ("snapshots-not-a-list", C, None, ["report.snapshots=1.0"], "analytic", ["report.snapshots", "list of numbers"]),
    ("snapshot-a-string", C, None, ["report.snapshots=['end']"], "analytic", ["report.snapshots", "expected a number"]),
    ("shape-points-one", C, None, ["report.shape_points=1"], "analytic", ["report.shape_points", "0 (no snapshots) or 2 to 101"]),
    ("shape-points-many", C, None, ["report.shape_points=1000"], "analytic", ["report.shape_points", "got 1000"]),
    ("shape-points-negative", C, None, ["report.shape_points=-2"], "analytic", ["report.shape_points", "non-negative"]),
    ("shape-points-fraction", C, None, ["report.shape_points=5.5"], "analytic", ["report.shape_points", "whole number"]),
    ("graded-from-past-the-end", C, None, ["report.graded_from=5.0"], "analytic",
     ["report.graded_from", "leaves nothing", "5 s"]),
    ("graded-from-negative", C, None, ["report.graded_from=-1.0"], "analytic", ["report.graded_from"]),
    ("frequency-map-one-value", C + FMAP.replace("values = 3", "values = 1"), None, [], "analytic",
     ["frequency_map.values", "at least 2"]),
    ("frequency-map-set-not-key-value", C + FMAP.replace('set = []', 'set = ["held"]'), None, [], "analytic",
     ["frequency_map.set", "'held'", "KEY=VALUE"]),
    ("frequency-map-no-key", C + FMAP.replace('key = "bodies.beam.section.h"\n', ''), None, [], "analytic",
     ["frequency_map.key"]),
]


@pytest.mark.parametrize("text,table,sets,solver,words", [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_bad_input_is_one_line_exit_2_nothing_written(tmp_path, capsys, text, table, sets, solver, words):
    p = tmp_path / "case.toml"
    p.write_bytes(text if isinstance(text, bytes) else text.encode())
    if table is not None:
        (tmp_path / "q.csv").write_bytes(table if isinstance(table, bytes) else table.encode())
    argv = ["run", str(p), "--solver", solver] + [x for s in sets for x in ("--set", s)]
    _refused(*_in_process(tmp_path, capsys, argv), words)


def test_a_declared_loop_loads_and_every_solver_without_loops_says_so(tmp_path):
    """The loop joint is out of the tree (no coordinates) and in `case.loops`, placed on both
    bodies; a built-in solver whose module does not say LOOPS = True says it does not model
    loops (not a wrong result); flexmbd models them."""
    p = tmp_path / "loop.toml"
    p.write_text(LOOP)
    case = cases.load(str(p))
    assert list(case.loops) == ["back"] and "back" not in case.joints
    back = case.loops["back"]
    assert back.loop and back.offset == (1.5, 1.0, 0.0) and back.child_offset == (0.0, 1.0, 0.0)
    assert (back.nq, back.nv, back.q0) == (0, 0, ())
    assert case.nv == cases.load("pendulum").nv + 1                  # the link's pin only
    assert registry.status_for(case, "flexmbd") == ""
    for name in registry.BUILT_IN:
        mod, why = registry.load(name)
        if not why and not getattr(mod, "LOOPS", False):
            assert registry.status_for(case, name) == \
                "not applicable: closed kinematic loops are not modelled (joint 'back' closes one)", name


def test_case_path_is_a_directory(tmp_path, capsys):
    (tmp_path / "d.toml").mkdir()
    _refused(*_in_process(tmp_path, capsys, ["run", str(tmp_path / "d.toml"), "--solver", "analytic"]),
             ["d.toml", "no such case file"])


# ---------------------------------------------------------------------------------------------
# cost guards: refused before the work, in well under a second each

COSTLY = [
    ("elements-1e7", "cantilever_step", "flexmbd", ["bodies.beam.elements=10000000"], [],
     ["bodies.beam.elements", "GB of memory"]),
    ("elements-1e7-rigid-limit", "pendulum", "pinocchio", ["bodies.beam.elements=10000000"], [],
     ["bodies.beam.elements", "GB of memory"]),
    ("elements-1e7-fe-linear", "cantilever_step", "fe-linear", ["bodies.beam.elements=10000000"], [],
     ["bodies.beam.elements", "limit"]),
    ("elements-20000-eigensolver", "cantilever_step", "flexmbd", ["bodies.beam.elements=20000"], [],
     ["bodies.beam.elements", "without progress shown"]),
    ("analytic-modes-1e6", "cantilever_step", "analytic", ["solvers.analytic.modes=1000000"], [],
     ["solvers.analytic.modes", "GB of memory"]),
    ("duration-1e6", "cantilever_step", "flexmbd", ["duration=1e6"], [], ["duration", "limit"]),
    ("duration-1e6-analytic", "cantilever_step", "analytic", ["duration=1e6"], [], ["duration", "limit"]),
    ("t-end-1e7", "pendulum", "flexmbd", [], ["--t-end", "1e7"], ["--t-end", "limit"]),
    ("modes-3000", "cantilever_step", "flexmbd", ["bodies.beam.elements=1000", "bodies.beam.modes.count=3000"], [],
     ["bodies.beam.modes.count", "GB of memory"]),
    ("fe-linear-dt-1e-12", "cantilever_step", "fe-linear", ["solvers.fe-linear.dt=1e-12"], [],
     ["solvers.fe-linear.dt", "days"]),
    ("fe-linear-2000-elements", "cantilever_step", "fe-linear", ["bodies.beam.elements=2000"], [],
     ["bodies.beam.elements", "GB of memory"]),
    ("exudyn-beam-elements", "pendulum", "exudyn-beam", ["solvers.exudyn-beam.elements=10000000"], [],
     ["solvers.exudyn-beam.elements", "limit"]),
    ("exudyn-beam-dt", "pendulum", "exudyn-beam", ["solvers.exudyn-beam.dt=1e-10"], [], ["solvers.exudyn-beam.dt"]),
    ("exudyn-ffrf-dt", "pendulum", "exudyn-ffrf", ["solvers.exudyn-ffrf.dt=1e-11"], [], ["solvers.exudyn-ffrf.dt"]),
    ("mujoco-rod-edges", "pendulum", "mujoco-rod", ["solvers.mujoco-rod.edges=10000000"], [],
     ["solvers.mujoco-rod.edges", "limit"]),
    ("mujoco-dt", "pendulum", "mujoco", ["solvers.mujoco.dt=1e-10"], [], ["solvers.mujoco.dt"]),
    ("rk4-dt-1e-10", "pendulum", "flexmbd", ["integrator.method='rk4'", "integrator.dt=1e-10"], [],
     ["integrator.dt", "with progress shown"]),
    ("rk45-silent", "pendulum", "flexmbd", ["integrator.method='rk45'", "integrator.max_step=1e-7"], [],
     ["integrator.max_step", "without progress shown"]),
    ("output-dt-1e-8", "pendulum", "flexmbd", ["integrator.output_dt=1e-8"], [], ["integrator.output_dt", "samples"]),
    ("stiff-beam-adams", "cantilever_step", "flexmbd", ["materials.steel.E=1e90"], [],
     ["duration", "highest retained frequency of beam 'beam'", "with progress shown"]),
    ("many-short-segments", "pendulum", "flexmbd", ["bodies.beam.segments=50", "bodies.beam.modes.count=6",
                                                     "duration=60"], [], ["duration", "highest retained frequency"]),
]


@pytest.mark.parametrize("case,solver,sets,extra,words", [c[1:] for c in COSTLY], ids=[c[0] for c in COSTLY])
def test_costly_run_is_refused_before_the_work(tmp_path, capsys, case, solver, sets, extra, words):
    if registry.status_for(cases.load(case, sets), solver).startswith("unavailable"):
        pytest.skip(f"{solver} is not installed here")
    argv = ["run", case, "--solver", solver] + [x for s in sets for x in ("--set", s)] + extra
    _refused(*_in_process(tmp_path, capsys, argv), words + ["--allow-large"])


def test_compare_and_modes_refuse_too(tmp_path, capsys):
    big = tmp_path / "big.toml"
    big.write_text(CANTILEVER.replace("elements = 100", "elements = 10000000"))
    for argv in (["compare", str(big), "--solvers", "analytic,flexmbd"], ["modes", str(big)]):
        code = main(argv + (["--out", str(tmp_path / "out")] if argv[0] == "compare" else []))
        err = capsys.readouterr().err
        assert code == 2 and len(err.splitlines()) == 1 and "bodies.beam.elements" in err, err
    assert not (tmp_path / "out").exists()


def test_every_shipped_case_is_within_the_limits():
    for name in cases.available():
        cost.check([(cases.load(name), s) for s in registry.NAMES])


def test_allow_large_lifts_the_refusal_and_is_accepted_by_every_command(capsys):
    c = cases.load("cantilever_step", ["solvers.analytic.modes=1000000"])
    with pytest.raises(InputError):
        cost.check([(c, "analytic")])
    cost.check([(c, "analytic")], allow_large=True)
    note = capsys.readouterr().err.splitlines()
    assert len(note) == 1 and note[0].startswith("flexmbd: note: cantilever_step / analytic: solvers.analytic.modes")
    for argv in (["run", "x", "--solver", "flexmbd"], ["report"], ["compare", "x"], ["regress"], ["modes", "x"]):
        assert parser().parse_args(argv + ["--allow-large"]).allow_large


# ---------------------------------------------------------------------------------------------
# modes.count = 0: the rigid limit of the beam


def test_zero_modes_is_the_rigid_limit(tmp_path, capsys):
    """A pendulum without modes swings as the rigid pendulum (flexmbd against Pinocchio with the
    inertia of the beam's lumped mesh, which flexmbd integrates: `beam_mass = "lumped"`), a clamped
    beam without modes stays at rest, and exudyn-ffrf, which needs modes, declines it."""
    out = tmp_path / "out"
    for solver in ("flexmbd", "pinocchio"):
        assert main(["run", "pendulum", "--solver", solver, "--t-end", "0.3", "--out", str(out),
                     "--set", "bodies.beam.modes.count=0", "--set", 'solvers.pinocchio.beam_mass="lumped"']) == 0
    a, b = (json.loads((out / "results" / "pendulum" / f"{s}.json").read_text()) for s in ("flexmbd", "pinocchio"))
    assert a["status"] == "ok" and b["status"] == "ok"
    import pandas as pd
    fa, fb = (pd.read_csv(out / "results" / "pendulum" / f"{s}.csv") for s in ("flexmbd", "pinocchio"))
    assert abs(fa["joint_angle"] - fb["joint_angle"]).max() < 1e-8
    assert fa["joint_angle"].iloc[-1] < -0.3                      # it did swing
    assert main(["run", "cantilever_step", "--solver", "flexmbd", "--t-end", "0.1", "--out", str(out),
                 "--set", "bodies.beam.modes.count=0"]) == 0
    rest = pd.read_csv(out / "results" / "cantilever_step" / "flexmbd.csv")
    assert len(rest) == 101 and (rest["tip_deflection"] == 0).all()
    c = cases.load("pendulum", ["bodies.beam.modes.count=0"])
    why = registry.status_for(c, "exudyn-ffrf")
    assert why.startswith(("not applicable: body 'beam' retains no modes", "unavailable")), why
    capsys.readouterr()


# ---------------------------------------------------------------------------------------------
# the real process


def _process(args, **kw):
    kw.setdefault("timeout", 120)
    return subprocess.run([sys.executable, "-m", "flexmbd.cli"] + args, capture_output=True, **kw)


def test_process_undecodable_set_argument(tmp_path):
    """argv bytes that are not UTF-8 arrive as surrogates: one printable line, exit 2."""
    r = _process([b"run", b"cantilever_step", b"--solver", b"analytic", b"--set", b"title=caf\xe9",
                  b"--out", os.fsencode(tmp_path / "out")])
    err = r.stderr.decode()
    assert r.returncode == 2 and len(err.splitlines()) == 1 and "caf\\xe9" in err and "Traceback" not in err, err
    assert not (tmp_path / "out").exists()


def test_process_latin1_case_file(tmp_path):
    p = tmp_path / "latin.toml"
    p.write_bytes(CANTILEVER.replace("Cantilever", "Caf\u00e9").encode("latin-1"))
    r = _process(["run", str(p), "--solver", "analytic", "--out", str(tmp_path / "out")], text=True)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "not UTF-8" in r.stderr, r.stderr
    assert not (tmp_path / "out").exists()


def test_process_header_only_motion_table_has_no_numpy_warning(tmp_path):
    (tmp_path / "case.toml").write_text(DRIVEN)
    (tmp_path / "q.csv").write_text("t,q\n")
    r = _process(["run", str(tmp_path / "case.toml"), "--solver", "flexmbd", "--out", str(tmp_path / "out")], text=True)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "no rows" in r.stderr, r.stderr


def test_process_ten_million_elements_refused_promptly_and_small(tmp_path):
    """The refusal comes from the estimate: well under the time and memory the work would take."""
    r = _process(["run", "cantilever_step", "--solver", "flexmbd", "--set", "bodies.beam.elements=10000000",
                  "--out", str(tmp_path / "out")], text=True, timeout=30)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "--allow-large" in r.stderr, r.stderr


# ---------------------------------------------------------------------------------------------
# property-based: the loader and --set never raise anything but a one-line InputError


def _load_or_input_error(path, overrides=()):
    try:
        c = cases.load(str(path), list(overrides))
        registry.check(c)
        cost.check([(c, s) for s in registry.NAMES])
    except InputError as e:
        msg = str(e)
        assert msg and msg.isprintable(), msg
        return None
    return c


def _toml(v) -> str:
    """A value as a TOML inline literal (tables inline)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v == math.inf else "-inf" if v == -math.inf else repr(v))
    if isinstance(v, int):
        return str(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(_toml(x) for x in v) + "]"
    return "{" + ", ".join(f"{json.dumps(k)} = {_toml(x)}" for k, x in v.items()) + "}"


def _paths(d, prefix=()):
    for k, v in d.items():
        yield prefix + (k,)
        if isinstance(v, dict):
            yield from _paths(v, prefix + (k,))


BASE = cases.parse_toml(CANTILEVER, "cantilever_step")
PATHS = sorted(_paths(BASE)) + sorted(_paths(cases.parse_toml(PENDULUM, "pendulum")))
KEYS = [".".join(p) for p in PATHS]
SCALARS = st.one_of(st.integers(-10 ** 30, 10 ** 30), st.floats(allow_nan=True, allow_infinity=True),
                    st.booleans(), st.text(max_size=12), st.sampled_from([0, 1, -1, 0.0, 1e-300, 1e300, "", "beam"]))
VALUES = st.recursive(SCALARS, lambda inner: st.one_of(st.lists(inner, max_size=4),
                                                       st.dictionaries(st.text(max_size=6), inner, max_size=3)),
                      max_leaves=8)
FAST = settings(max_examples=int(os.environ.get("FLEXMBD_EXAMPLES", 60)), deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


@FAST
@given(key=st.one_of(st.sampled_from(KEYS), st.text(max_size=20),
                     st.builds(lambda k, s: k + s, st.sampled_from(KEYS), st.sampled_from([".", "..", ".x", " ", ""]))),
       value=st.one_of(VALUES.map(_toml), st.text(max_size=20)))
def test_any_override_loads_or_is_one_input_error(key, value):
    _load_or_input_error(cases.CASES_DIR / "cantilever_step.toml", [f"{key}={value}"])


@FAST
@given(edits=st.lists(st.tuples(st.sampled_from(PATHS), VALUES), min_size=1, max_size=4))
def test_any_values_anywhere_in_a_case_file_load_or_are_one_input_error(tmp_path, edits):
    data = json.loads(json.dumps(BASE))
    for path, value in edits:
        node = data
        for k in path[:-1]:                             # the pendulum's paths may be new here
            node[k] = node[k] if isinstance(node.get(k), dict) else {}
            node = node[k]
        node[path[-1]] = value
    p = tmp_path / "random.toml"
    p.write_text("\n".join(f"{json.dumps(k)} = {_toml(v)}" for k, v in data.items()) + "\n")
    _load_or_input_error(p)


@FAST
@given(blob=st.binary(max_size=300))
def test_any_bytes_as_a_case_file_are_one_input_error(tmp_path, blob):
    p = tmp_path / "bytes.toml"
    p.write_bytes(blob)
    assert _load_or_input_error(p) is None


def test_a_loop_case_without_an_integrator_method_gets_one_that_runs_it(tmp_path):
    """`adams`, the default, cannot restart after each projection onto a loop: a loop case that
    names no method gets dopri5; one that names adams is refused (tests/harness/test_run_faults.py)."""
    p = tmp_path / "loop.toml"
    p.write_text(LOOP)
    assert cases.load(str(p)).integrator.method == "dopri5"
    with pytest.raises(InputError, match="integrator.method: 'adams' cannot integrate a closed loop"):
        cases.load(str(p), ['integrator.method="adams"'])
    assert cases.load("pendulum").integrator.method == "adams"
