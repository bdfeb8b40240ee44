"""The two reference solvers on cantilever_step, against closed-form statics and each other."""

import json

import numpy as np
import pytest

from flexmbd import cases
from flexmbd.harness import results
from flexmbd.solvers import analytic
from flexmbd.cli import main

pytestmark = pytest.mark.kernel_free

STATIC_TIP = -12.0 * 1.5 ** 3 / (3 * 2.06e11 * 0.01 * 0.015 ** 3 / 12)     # -23.30 mm
STATIC_STRESS = 12.0 * (1.5 - 0.03) * 0.0075 / (0.01 * 0.015 ** 3 / 12)   # 47.04 MPa


@pytest.fixture(scope="module")
def runs(cantilever_run):
    """Both solvers' runs of the shipped cantilever_step (the session's: conftest.py)."""
    return {s: cantilever_run(s) for s in ("analytic", "fe-linear")}


def test_static_reference_numbers():
    assert STATIC_TIP == pytest.approx(-23.30e-3, rel=2e-4)
    assert STATIC_STRESS == pytest.approx(47.0e6, rel=1e-3)


@pytest.mark.parametrize("solver", ["analytic", "fe-linear"])
def test_step_response_statistics(runs, solver):
    r = runs[solver]
    assert r.ok, r.status
    tip, vm = r.channels["tip_deflection"], r.channels["stress_vm"]
    assert tip.mean() == pytest.approx(STATIC_TIP, rel=0.01)
    assert 1.9 <= tip.min() / STATIC_TIP <= 2.05
    assert 1.00 <= vm.mean() / STATIC_STRESS <= 1.05
    assert vm.min() >= 0.0


def test_analytic_and_fe_linear_agree(runs):
    a, f = runs["analytic"].channels["tip_deflection"], runs["fe-linear"].channels["tip_deflection"]
    assert np.sqrt(np.mean((a - f) ** 2)) < 0.01 * np.abs(f).max()


def test_closed_form_frequencies_and_static_deflection():
    E, rho, b, h, L = 2.06e11, 7820.0, 0.01, 0.015, 1.5
    f_weak = analytic.clamped_free_frequencies(E, h * b ** 3 / 12, rho, b * h, L, 3)
    f_strong = analytic.clamped_free_frequencies(E, b * h ** 3 / 12, rho, b * h, L, 3)
    assert f_weak == pytest.approx([3.685, 23.09, 64.66], rel=1e-3)
    assert f_strong == pytest.approx([5.527, 34.64, 96.99], rel=1e-3)
    assert analytic.static_tip_deflection(12.0, E, b * h ** 3 / 12, L) == pytest.approx(-STATIC_TIP)


def test_analytic_closed_forms():
    roots = analytic.clamped_free_roots(4)
    assert roots == pytest.approx([1.8751040687, 4.6940911330, 7.8547574382, 10.9955407349], rel=1e-9)
    # high modes stay exact: the shape keeps unit mean square and meets the boundary conditions
    x = np.linspace(0, 1.5, 20001)
    for z in analytic.clamped_free_roots(60)[[0, 29, 59]]:
        phi, d2 = analytic.cantilever_shapes(z, x, 1.5)
        assert np.trapezoid(phi ** 2, x) / 1.5 == pytest.approx(1.0, rel=1e-4)
        assert abs(phi[0]) < 1e-12 and abs(d2[-1]) < 1e-9


def test_run_writes_csv_and_sidecar(tmp_path, capsys):
    assert main(["run", "cantilever_step", "--solver", "analytic", "--out", str(tmp_path), "--t-end", "0.1",
                 "--json"]) == 0
    meta = json.loads(capsys.readouterr().out)
    assert meta["status"] == "ok" and meta["case"] == "cantilever_step" and meta["samples"] == 101
    for key in ("solver_version", "case_sha256", "settings", "wall_s", "setup_s", "steps", "rhs_evals",
                "python", "versions", "git_commit"):
        assert key in meta
    back = results.read(results.folder(tmp_path), "cantilever_step", "analytic")
    assert set(back.channels) == {"tip_deflection", "stress_vm"} and back.t[-1] == pytest.approx(0.1)
    assert not [p for p in (tmp_path / "results" / "cantilever_step").iterdir() if p.name.startswith(".")]


def test_fe_linear_modal_scheme_against_the_matrix_exponential():
    """fe-linear's two exact schemes on the same clamped beam matrices: every mode stepped on its
    own (`modal`, eigh) against the exponential of the whole first-order system (`exact`, expm).
    Both are exact for a step load, so they differ by round-off of the two factorizations only:
    a frequency's relative error ~1e-13 times the highest mode's w t = 3.5e3 radians over the run
    gives ~1e-10 (seen: 1.4e-10 of the peak); 1e-7 leaves three decades for other machines' LAPACK."""
    from flexmbd.fe import flexbody
    from flexmbd.mbd import profiles
    from flexmbd.solvers import fe_linear
    case = cases.load("cantilever_step", ["bodies.beam.elements=6"])
    nodes, elements, sec, K, M, _ = flexbody.fe_model(case.bodies["beam"])
    free = np.arange(6, K.shape[0])
    Kf, Mf = K[free][:, free].tocsc(), M[free][:, free].tocsc()
    (f, profile), = fe_linear.load_vectors(case, K.shape[0])
    g = lambda t: profiles.load_factor(profile, t)
    a = fe_linear.exact(Kf, Mf, None, [(f[free], g)], 1e-4, 10, 51)
    b = fe_linear.modal(Kf, Mf, [(f[free], g)], 1e-4, 10, 51)
    for x, y in zip(a, b):
        assert np.abs(x - y).max() < 1e-7 * np.abs(x).max()
