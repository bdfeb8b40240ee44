"""The pure-Python mode (NUMBA_DISABLE_JIT=1) runs the same algorithm uncompiled: the
Pinocchio-agreement and Lagrangian-oracle tests pass in it, and it gives the compiled numbers."""

import pytest
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from flexmbd import cases
from flexmbd.solvers.build import from_case
from flexmbd.mbd.compiled.entry import forward_dynamics
from flexmbd.mbd.model import make_data

pytestmark = pytest.mark.heavy(6)       # seconds, measured with both cores busy (tests/conftest.py)

ROOT = Path(__file__).resolve().parents[2]
SMALL = ["bodies.beam1.elements=8", "bodies.beam1.modes.count=3", "bodies.beam2.elements=8",
         "bodies.beam2.modes.count=4"]
STATE = """
import json, sys
import numpy as np
from flexmbd import cases
from flexmbd.solvers.build import from_case
from flexmbd.mbd.compiled import jit
from flexmbd.mbd.compiled.entry import forward_dynamics
from flexmbd.mbd.model import make_data
m = from_case(cases.load("double_pendulum", json.loads(sys.argv[1])))
rng = np.random.default_rng(3)
q, v = m.q0 + 0.1 * rng.standard_normal(m.nq), 0.5 * rng.standard_normal(m.nv)
print(json.dumps({"pure": jit.PURE_PYTHON, "qdd": forward_dynamics(m, make_data(m), q, v, t=0.1).tolist()}))
"""


def pure_env() -> dict:
    return {**os.environ, "NUMBA_DISABLE_JIT": "1"}


def test_oracle_and_pinocchio_tests_pass_uncompiled():
    out = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-x",
                          "tests/mbd/test_dynamics.py", "tests/mbd/test_oracle_lagrange.py"],
                         cwd=ROOT, env=pure_env(), capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stdout[-2000:] + out.stderr[-2000:]
    assert " passed" in out.stdout and "failed" not in out.stdout


def test_uncompiled_forward_dynamics_gives_the_compiled_numbers():
    out = subprocess.run([sys.executable, "-c", STATE, json.dumps(SMALL)], env=pure_env(),
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    got = json.loads(out.stdout)
    assert got["pure"] is True
    m = from_case(cases.load("double_pendulum", SMALL))
    rng = np.random.default_rng(3)
    q, v = m.q0 + 0.1 * rng.standard_normal(m.nq), 0.5 * rng.standard_normal(m.nv)
    ref = forward_dynamics(m, make_data(m), q, v, t=0.1)
    np.testing.assert_allclose(got["qdd"], ref, rtol=1e-12, atol=1e-12 * np.abs(ref).max())
