"""Solver plug-ins: the example in examples/plugin_solver, installed as pip installs it (a
dist-info with its entry points on the path), runs beside the built-in solvers."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from flexmbd import cases, solvers

PLUGIN = Path(__file__).resolve().parent.parent / "examples" / "plugin_solver"


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


def test_example_plugin_runs_beside_the_built_in_solvers(tmp_path):
    env = install(tmp_path / "site", "[flexmbd.solvers]\nexample-pendulum = flexmbd_example_solver\n")
    listed = flexmbd(["list"], env)
    assert "example-pendulum" in listed.stdout.split("pendulum ")[-1]
    r = flexmbd(["run", "pendulum", "--solver", "example-pendulum", "--out", str(tmp_path / "out")], env)
    assert r.returncode == 0 and "ok" in r.stdout, r.stderr
    got = pd.read_csv(tmp_path / "out" / "results" / "pendulum" / "example-pendulum.csv")
    rigid = solvers.run(cases.load("pendulum"), "pinocchio")
    np.testing.assert_allclose(got["t"], rigid.t)
    assert np.abs(got["joint_angle"] - rigid.channels["joint_angle"]).max() < 1e-3   # slender rod: no section inertia


def test_a_plugin_does_not_replace_a_built_in_and_a_broken_one_is_unavailable(tmp_path):
    env = install(tmp_path / "site", "[flexmbd.solvers]\nflexmbd = flexmbd_example_solver\n"
                                     "broken = no_such_module_here\n", module=None)
    code = ("from flexmbd import solvers; print(solvers.MODULES['flexmbd']); "
            "print(solvers.unavailable_reason('broken'))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True).stdout
    assert out.splitlines()[0] == "flexmbd.solver" and out.splitlines()[1].startswith("unavailable:")
