"""Solver plug-ins: the example in examples/plugin_solver, installed by pip into a folder of its
own (flexmbd's environment holds no plug-in), runs beside the built-in solvers; entry points
planted as pip installs them (a dist-info on the path) load, or are unavailable, as they should."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import pandas as pd

from flexmbd import cases
from flexmbd.harness import registry

PLUGIN = Path(__file__).resolve().parents[2] / "examples" / "plugin_solver"


def install(site: Path, entry_points: str, module: str | None = "flexmbd_example_solver.py") -> dict:
    """Put a distribution with these entry points on a fresh path entry; the environment to use it."""
    info = site / "flexmbd_example_solver-0.1.0.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: flexmbd-example-solver\nVersion: 0.1.0\n")
    (info / "entry_points.txt").write_text(entry_points)
    if module:
        shutil.copy(PLUGIN / module, site / module)
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(site), os.environ.get("PYTHONPATH", "")])}


def flexmbd(args, env):
    return subprocess.run([sys.executable, "-m", "flexmbd.cli", *args], capture_output=True, text=True, env=env)


@pytest.fixture(scope="module")
def example(tmp_path_factory) -> dict:
    """The example plug-in installed by pip (from a copy of examples/plugin_solver, so that the
    build leaves nothing in the checkout) into a folder of its own; the environment to use it."""
    tmp = tmp_path_factory.mktemp("example")
    shutil.copytree(PLUGIN, tmp / "src", ignore=shutil.ignore_patterns("build", "*.egg-info", "__pycache__"))
    subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--no-build-isolation",
                    "--no-index", "--target", str(tmp / "site"), str(tmp / "src")], check=True, capture_output=True)
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp / "site"), os.environ.get("PYTHONPATH", "")])}


def test_example_plugin_runs_beside_the_built_in_solvers(tmp_path, example):
    env = example
    listed = flexmbd(["list"], env)
    assert "example-pendulum" in listed.stdout.split("pendulum ")[-1]
    r = flexmbd(["run", "pendulum", "--solver", "example-pendulum", "--out", str(tmp_path / "out")], env)
    assert r.returncode == 0 and "ok" in r.stdout, r.stderr
    got = pd.read_csv(tmp_path / "out" / "results" / "pendulum" / "example-pendulum.csv")
    # its trajectory holds the joint's angle and no energy: the channels formed from it are the angle
    # and the rigid beam's zero deflection and stress, no energy channel
    assert list(got.columns) == ["t", "joint_angle", "tip_deflection", "stress_vm", "stress_normal"]
    assert all((got[c] == 0).all() for c in ("tip_deflection", "stress_vm", "stress_normal"))
    rigid = registry.run(cases.load("pendulum"), "pinocchio")
    np.testing.assert_allclose(got["t"], rigid.t)
    assert np.abs(got["joint_angle"] - rigid.channels["joint_angle"]).max() < 1e-3   # slender rod: no section inertia


def test_a_plugin_does_not_replace_a_built_in_and_a_broken_one_is_unavailable(tmp_path):
    env = install(tmp_path / "site", "[flexmbd.solvers]\nflexmbd = flexmbd_example_solver\n"
                                     "broken = no_such_module_here\n", module=None)
    code = ("from flexmbd.harness import registry; print(registry.MODULES['flexmbd']); "
            "print(registry.unavailable_reason('broken'))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True).stdout
    assert out.splitlines()[0] == "flexmbd.solvers.inhouse" and out.splitlines()[1].startswith("unavailable:")


# ---------------------------------------------------------------------------------------------
# a plug-in that reports its trajectory only


def trajectory_only(case, t_end, tip, extent):
    """A run of the cantilever as a bare `channels.Trajectory`: the beam's tracked points at their
    undeformed positions but the tip, at `tip(t)` below it (m, along y); no strains but at the stress
    section (zero), and the deflection validity measure `extent(t)`."""
    from flexmbd.harness import channels
    t = np.arange(0.0, t_end + 1e-12, case.integrator.output_dt)
    L = case.bodies["beam"].length
    xs = channels.points_needed(case, "beam")
    x0 = {x: np.array([x, 0.0, 0.0]) for x in xs}
    points = {x: np.tile(x0[x], (t.size, 1)) for x in xs}
    points[L] = points[L] + np.outer(tip(t), [0.0, 1.0, 0.0])
    beam = channels.Beam(length=L, points=points, x0=x0, root=np.tile(np.eye(3), (t.size, 1, 1)),
                         strains={0.03: np.zeros((t.size, 4))}, extent={"deflection": extent(t)})
    return channels.Trajectory(t=t, beams={"beam": beam})


def plug(monkeypatch, name, run):
    """Register an in-process plug-in `name` whose run is `run` (what an installed entry point does)."""
    import types
    mod = types.ModuleType(f"plugin_{name.replace('-', '_')}")
    mod.SETTINGS, mod.version, mod.applies, mod.run = {}, lambda: "1", lambda case: "", run
    monkeypatch.setitem(sys.modules, mod.__name__, mod)
    monkeypatch.setitem(registry.MODULES, name, mod.__name__)
    monkeypatch.setattr(registry, "NAMES", registry.NAMES + (name,))


def test_a_plugin_reporting_only_a_trajectory_gets_channels_validity_and_the_divergence_cut(monkeypatch):
    case = cases.load("cantilever_step")
    L, dt = case.bodies["beam"].length, case.integrator.output_dt
    plug(monkeypatch, "bare", lambda c, t_end, s: trajectory_only(c, t_end, lambda t: -1e-3 * t, lambda t: 0.5 * t))
    r = registry.run(case, "bare", 0.5)
    np.testing.assert_allclose(r.channels["tip_deflection"], -1e-3 * r.t, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(r.channels["stress_vm"], np.zeros(r.t.size))
    # the deflection measure passes its limit (0.10) after 0.2 s: an ok run, outside validity, reported
    # at its largest excess (25 % at the end)
    assert r.status.kind == "ok" and r.status.outside and r.status.t == pytest.approx(0.5)
    assert r.status.why == "deflection 25 % of length"
    assert r.extra["validity"]["largest"]["beam"]["deflection"] == pytest.approx(0.25)
    # a tip beyond twice the beam's length at t >= 0.3 s: the run is cut there, failed
    plug(monkeypatch, "wild", lambda c, t_end, s: trajectory_only(c, t_end, lambda t: np.where(t < 0.3 - 1e-9, 0.0, 3 * L),
                                                                  lambda t: 0 * t))
    r = registry.run(case, "wild", 0.5)
    assert r.status.kind == "failed" and "diverged" in r.status.why and r.status.t == pytest.approx(0.3)
    assert r.t[-1] == pytest.approx(0.3 - dt) and len(r.channels["tip_deflection"]) == len(r.t)
    # neither a Result nor a Trajectory: the plug-in's failure, as a failed result
    plug(monkeypatch, "odd", lambda c, t_end, s: {"t": [0.0]})
    r = registry.run(case, "odd", 0.5)
    assert r.status.kind == "failed" and "not a Result or a channels.Trajectory" in r.status.why
