"""Case loading and validation: the shipped cases load; malformed ones fail with one clear line."""

import re
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from flexmbd import cases
from flexmbd.cli import main
from flexmbd.core.errors import InputError

pytestmark = pytest.mark.kernel_free

PAPER = ["cantilever_step", "pendulum", "double_pendulum"]


@pytest.mark.parametrize("name", PAPER)
def test_paper_cases_load_with_paper_parameters(name):
    c = cases.load(name)
    assert c.duration == 2.0
    for b in c.bodies.values():
        assert (b.length, b.section.b, b.section.h) == (1.5, 0.01, 0.015)
        assert b.damping_ratio == 0.0
        assert b.modes.count == 12
        assert b.material is c.materials["steel"]
    assert c.materials["steel"] == cases.Material(name="steel", E=2.06e11, nu=0.29, rho=7820.0)
    assert c.gravity == ((0.0, 0.0, 0.0) if name == "cantilever_step" else (0.0, -9.81, 0.0))


def test_paper_case_specifics():
    c = cases.load("cantilever_step")
    ld = c.loads["tip_force"]
    assert ld.force == (0.0, -12.0, 0.0) and ld.point.x == 1.5 and ld.profile["t0"] == 0.0
    d = cases.load("double_pendulum")
    assert d.bodies["beam1"].modes.boundary == "hinged-hinged"
    assert d.bodies["beam2"].modes.boundary == "clamped-free"
    assert d.joints["pivot2"].parent == "beam1" and d.joints["pivot2"].point.x == 1.5


def test_override_changes_value_and_hash():
    a = cases.load("cantilever_step")
    b = cases.load("cantilever_step", ["materials.steel.E=2.06e9"])
    assert b.materials["steel"].E == 2.06e9 and b.bodies["beam"].material.E == 2.06e9
    assert a.sha256 != b.sha256


def _write(tmp_path, text):
    base = (cases.CASES_DIR / "cantilever_step.toml").read_text()
    p = tmp_path / "bad.toml"
    p.write_text(text(base))
    return p


# (edit of the cantilever file, dotted key expected in the message, words expected in it)
MALFORMED = [
    (lambda s: s.replace("length = 1.5", "length = -1.5"), "bodies.beam.length", "positive"),
    (lambda s: s.replace("length = 1.5", "lenght = 1.5"), "bodies.beam.lenght", "did you mean 'length'"),
    (lambda s: s.replace("length = 1.5", 'length = "long"'), "bodies.beam.length", "expected a number"),
    (lambda s: s.replace("count = 12", "count = 1000"), "bodies.beam.modes.count", "free DOFs"),
    (lambda s: s.replace('material = "steel"', 'material = "stell"'), "bodies.beam.material", "did you mean 'steel'"),
    (lambda s: s.replace('child = "beam"', 'child = "bean"'), "joints.clamp.child", "no body 'bean'"),
    (lambda s: s.replace('type = "fixed"', 'type = "hinge"'), "joints.clamp.type", "expected one of"),
    (lambda s: s.replace('reference = "fe-linear"', 'reference = "fe-linaer"'), "report.reference", "did you mean 'fe-linear'"),
    (lambda s: s.replace('kind = "stress_vm"', 'kind = "stress"'), "channels.stress_vm.kind", "expected one of"),
    (lambda s: s.replace("nu = 0.29", "nu = 0.7"), "materials.steel.nu", "Poisson"),
    (lambda s: s.replace("duration = 2.0", ""), "duration", "missing"),
    (lambda s: s.replace("at = 1.5 ", "at = 2.5 "), "loads.tip_force.at", "beyond"),
    (lambda s: s.replace("force = [0.0, -12.0, 0.0]", "force = [0.0, -12.0]"), "loads.tip_force.force", "3 numbers"),
    (lambda s: s + "\n[solvers.analytic]\nmodez = 10\n", "solvers.analytic.modez", "did you mean 'modes'"),
    (lambda s: s.replace("[bodies.beam]", "[bodies.beam"), "", "not valid TOML"),
    (lambda s: s.replace("elements = 100", "elements = 0"), "bodies.beam.elements", "positive"),
    (lambda s: s.replace("h = 0.015, ", ""), "bodies.beam.section.h", "needs h"),
]


@pytest.mark.parametrize("edit,key,words", MALFORMED)
def test_malformed_case_is_one_line_exit_2_no_result(tmp_path, capsys, edit, key, words):
    p = _write(tmp_path, edit)
    out = tmp_path / "out"
    code = main(["run", str(p), "--solver", "analytic", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1, err
    assert str(p) in err and key in err and words in err, err
    assert not out.exists()


BAD_SETS = [
    ("bodies.beam.length=-2", "bodies.beam.length", "positive"),
    ("bodies.beam.modes.count=2.5", "bodies.beam.modes.count", "whole number"),
    ("bodies.beam.colour=1", "bodies.beam.colour", "unknown key"),
    ("materials.steel.E", "--set", "KEY=VALUE"),
    ("duration.x=1", "duration", "not a table"),
    ("integrator.method=euler", "integrator.method", "expected one of"),
]


@pytest.mark.parametrize("item,key,words", BAD_SETS)
def test_bad_set_is_one_line_exit_2(tmp_path, capsys, item, key, words):
    out = tmp_path / "out"
    code = main(["run", "cantilever_step", "--solver", "analytic", "--set", item, "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1, err
    assert key in err and words in err, err
    assert not out.exists()


def test_unknown_case_and_solver(capsys, tmp_path):
    assert main(["run", "cantilver_step", "--solver", "analytic", "--out", str(tmp_path)]) == 2
    assert "did you mean 'cantilever_step'" in capsys.readouterr().err
    assert main(["run", "cantilever_step", "--solver", "analytik", "--out", str(tmp_path)]) == 2
    assert "did you mean 'analytic'" in capsys.readouterr().err
    assert main(["run", "pendulum", "--solver", "analytic", "--out", str(tmp_path)]) == 2
    assert "not applicable" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_tree_errors():
    raw = tomllib.loads((cases.CASES_DIR / "double_pendulum.toml").read_text())
    raw["joints"]["pivot1"]["parent"] = "beam2"
    with pytest.raises(InputError, match="loop"):
        cases.validate(raw, "x.toml")
    raw = tomllib.loads((cases.CASES_DIR / "double_pendulum.toml").read_text())
    del raw["joints"]["pivot2"]
    with pytest.raises(InputError, match="bodies.beam2: no joint"):
        cases.validate(raw, "x.toml")


def test_no_traceback_from_the_console_script(tmp_path):
    p = _write(tmp_path, lambda s: s.replace("length = 1.5", "length = -1.5"))
    r = subprocess.run([sys.executable, "-m", "flexmbd", "run", str(p), "--solver", "fe-linear"],
                       capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 2
    assert "Traceback" not in r.stderr and r.stderr.count("\n") == 1
    assert not (tmp_path / "reports").exists()


def test_motion_table_file_is_checked(tmp_path):
    case = (cases.CASES_DIR / "pendulum.toml").read_text()
    p = tmp_path / "c.toml"
    p.write_text(case.replace("qd0 = 0.0", 'qd0 = 0.0\nmotion = { type = "table", file = "q.csv" }'))
    (tmp_path / "q.csv").write_text("t,q\n0,0\n0.1,0.1\n0.1,0.2\n0.3,0.3\n")
    with pytest.raises(InputError, match="t must increase"):
        cases.load(str(p))
    (tmp_path / "q.csv").write_text("t,q\n0,0\n0.1,0.1\n0.2,0.2\n0.3,0.3\n")
    c = cases.load(str(p))
    from flexmbd.mbd import profiles
    q, qd, qdd = profiles.motion(c.joints["pivot"].motion, 0.15)
    assert q == pytest.approx(0.15) and qd == pytest.approx(1.0)


# ---------------------------------------------------------------------------------------------
# the resolved case


def test_the_resolved_case_of_the_double_pendulum():
    """Tree order, kinds, parents, the joint on beam1's snapped tip node, the stress channels'
    snapped points, and nq / nv equal to the Model's (built separately)."""
    from flexmbd.solvers.build import from_case
    case = cases.load("double_pendulum", ["bodies.beam1.elements=10", "joints.pivot2.at=1.46"])
    assert isinstance(case.resolved, cases.Resolved)
    assert case.order == ["beam1", "beam2"]
    assert [(b.index, b.kind, b.parent, b.nodes) for b in case.tree] == [(1, "beam", 0, 11), (2, "beam", 1, 101)]
    elbow = case.joints["pivot2"]
    assert (elbow.parent_index, elbow.child_index, elbow.node, elbow.x, elbow.nq, elbow.nv) == (1, 2, 10, 1.5, 1, 1)
    assert (elbow.parent, elbow.child, elbow.point.x) == ("beam1", "beam2", 1.46)
    assert case.joints["pivot1"].node == -1 and case.joints["pivot1"].x is None
    tilted = cases.load("double_pendulum", ["joints.pivot1.rpy=[0.0, 0.0, 0.5]", "joints.pivot1.axis=[0.0, 3.0, 4.0]"])
    j = tilted.joints["pivot1"]
    assert j.axis == (0.0, 0.6, 0.8)
    assert np.allclose(j.triad, [[np.cos(0.5), -np.sin(0.5), 0.0], [np.sin(0.5), np.cos(0.5), 0.0], [0.0, 0.0, 1.0]])
    stress = {n: c.point for n, c in case.channels.items() if c.kind == "stress_vm"}
    assert stress and all(p is not None and (p.body, p.x) == (case.channels[n].body, case.channels[n].at)
                          for n, p in stress.items())
    assert all(p.node == round(p.x_node / 1.5 * (case.link(p.body).nodes - 1)) for p in stress.values())
    m = from_case(case)
    assert (case.nq, case.nv) == (m.nq, m.nv)


def test_the_resolved_case_is_immutable_and_shares_its_reductions():
    case = cases.load("pendulum")
    with pytest.raises(AttributeError):
        case.resolved.nq = 3
    with pytest.raises(TypeError):
        case.resolved.joints["pivot"] = None
    again = cases.load("pendulum")
    with pytest.raises(AttributeError):
        case.bodies["beam"].length = 3.0
    assert again.reduced("beam") is case.reduced("beam")
    assert again.reduced("beam").stress_x.tolist() == [0.03]


BENCHMARKS = {   # case: (EA N, EI N m^2 in the x-y plane, rho A kg/m, length m)
    "spinup_beam": (2.8e7, 1.4e4, 1.2, 10.0),
    "slewing_beam": (5.03e6, 566.0, 0.201, 8.0),
    "rotating_cantilever": (2.8e7, 1.4e4, 1.2, 10.0),
    "flexible_pendulum": (5e6 * np.pi * 0.005 ** 2, 5e6 * np.pi * 0.005 ** 4 / 4, 1100 * np.pi * 0.005 ** 2, 1.0),
}


@pytest.mark.parametrize("name", list(BENCHMARKS))
def test_benchmark_cases_load_with_their_parameters_and_provenance(name):
    """The benchmark beams reproduce the quoted EA, EI (bending plane x-y) and rho A; the file
    header names its source and separates derived values from what is read in a paper."""
    from flexmbd.fe import flexbody
    c = cases.load(name)
    (body,) = c.bodies.values()
    mat = c.materials[body.material.name]
    assert body.material == mat
    sec = flexbody.beam_section(body)
    EA, EI, rhoA, L = BENCHMARKS[name]
    assert (mat.E * sec.A, mat.E * sec.Iz, mat.rho * sec.A) == pytest.approx((EA, EI, rhoA), rel=1e-9)
    assert body.length == L
    text = (cases.CASES_DIR / f"{name}.toml").read_text()
    assert text.startswith("#") and "Source" in text and "derived here" in text


def test_snapshot_instants_default_to_quarters_of_the_duration():
    """report.snapshots: duration x (1/4, 1/2, 3/4, 1) by default (following --set duration), sorted when given."""
    assert cases.load("cantilever_step").report.snapshots == (0.5, 1.0, 1.5, 2.0)
    assert cases.load("cantilever_step", ["duration=0.4"]).report.snapshots == (0.1, 0.2, 0.3, 0.4)
    assert cases.load("cantilever_step", ["report.snapshots=[2.0, 0.0, 1.25]"]).report.snapshots == (0.0, 1.25, 2.0)
    assert cases.load("cantilever_step").report.shape_points == 11



# ---------------------------------------------------------------------------------------------
# the case is read typed outside flexmbd/cases; equal segments reduce once


# a case read as the file's dicts: indexed (`case["`), its `data` in any form (`case.data[`, `at = case.data`,
# `graded_case.data.get(`, `getattr(case, "data")`)
RAW_READ = re.compile(r"""case\[["']|\b\w*case\w*\.data\b|getattr\(\s*\w*case\w*\s*,\s*["']data["']""")


def test_no_case_is_indexed_as_a_dict_outside_the_cases_package():
    """Every consumer reads the resolved case (`case.bodies`, `case.joints`, ...), never the file's
    dicts: no `case["` and no `case.data`, under any name, in flexmbd/ outside flexmbd/cases/."""
    root = Path(cases.__file__).resolve().parent.parent
    found = [f"{path.relative_to(root.parent)}:{k}: {line.strip()}"
             for path in sorted(root.rglob("*.py")) if root / "cases" not in path.parents
             for k, line in enumerate(path.read_text().splitlines(), 1) if RAW_READ.search(line)]
    assert not found, "a case read as a dict:\n" + "\n".join(found)
    caught = ['x = case["bodies"]', "at = case.data", "d = case.data[key]", "case.data.get('bodies')",
              "graded_case.data", 'getattr(case, "data")', "at = self.case.data"]
    missed = ["c.data[on]", "P.data[upper]", "block.data", "case.database", "case.resolved.bodies"]
    assert all(RAW_READ.search(s) for s in caught) and not any(RAW_READ.search(s) for s in missed)


def test_the_flexible_pendulums_twenty_segments_are_reduced_once():
    from flexmbd.fe import flexbody
    flexbody._named.cache_clear()                   # both caches: a test run before in this process
    flexbody._reduced.cache_clear()                 # may have reduced the segments under their names
    bodies = cases.load("flexible_pendulum").split.flexible()
    assert len(bodies) == 20
    assert flexbody._reduced.cache_info().misses == 1


HUB_BEAM = Path(__file__).resolve().parents[1] / "data" / "hub_beam.toml"


def test_report_table_is_optional_with_tolerances_by_channel_kind():
    c = cases.load(str(HUB_BEAM))
    assert c.report.reference is None and c.report.defaults == ("tolerances",)
    assert dict(c.report.tolerances) == {"tip_deflection": cases.TOLERANCES["deflection"],
                                         "hub_angle": cases.TOLERANCES["joint_angle"]}
    assert set(cases.TOLERANCES) == set(cases.schema.CHANNEL["kind"][0])       # one default per channel kind


def test_given_tolerances_are_kept_and_grade_only_their_channels():
    c = cases.load(str(HUB_BEAM), ["report.tolerances.tip_deflection=0.001"])
    assert dict(c.report.tolerances) == {"tip_deflection": 0.001} and c.report.defaults == ()
    shipped = cases.load("slider_crank")                    # its energy and forces are shown, not graded
    assert "energy" not in shipped.report.tolerances and shipped.report.defaults == ()
