"""The solver registry's default reference (`registry.graded`): a case without report.reference is
compared with the first independent solver of `registry.REFERENCES` that can run it, never flexmbd."""

from pathlib import Path

import pytest

from flexmbd import cases
from flexmbd.harness import registry

pytestmark = pytest.mark.kernel_free

HUB_BEAM = Path(__file__).resolve().parents[1] / "data" / "hub_beam.toml"


def test_default_reference_is_the_first_independent_solver_that_applies():
    case = cases.load(str(HUB_BEAM))
    first = next(n for n in registry.REFERENCES if registry.status_for(case, n) == "")
    graded = registry.graded(case)
    assert graded.report.reference == first != "flexmbd"
    assert graded.report.defaults == ("reference", "tolerances")
    assert graded.content_sha256 == case.content_sha256          # a default reference changes no run
    if not registry.unavailable_reason("exudyn-beam"):
        assert first == "exudyn-beam"                            # a planar beam on a driven hub


def test_default_reference_keeps_to_report_solvers_and_a_given_reference():
    case = cases.load(str(HUB_BEAM), ['report.solvers=["flexmbd", "mujoco-rod", "pinocchio"]'])
    assert registry.graded(case).report.reference == ("pinocchio" if not registry.unavailable_reason("pinocchio")
                                                     else None)
    given = cases.load("pendulum")
    assert registry.graded(given) is given


def test_flexmbd_is_never_a_default_reference():
    assert "flexmbd" not in registry.REFERENCES
    only = cases.load(str(HUB_BEAM), ['report.solvers=["flexmbd"]'])
    assert registry.graded(only).report.reference is None


def test_exudyn_beam_newton_atol_default():
    xb = pytest.importorskip("flexmbd.solvers.exudyn_beam")
    driven, still = cases.load(str(HUB_BEAM)), cases.load("pendulum")
    opt = {"newton_rtol": 1e-5, "newton_atol": None}
    assert xb.newton_atol(driven, opt) == 1e-5                  # the rotating beams' setting
    assert xb.newton_atol(still, opt) == opt["newton_rtol"] * 1e-2   # newton_rtol / 100, as before
    assert xb.newton_atol(driven, {**opt, "newton_atol": 3e-4}) == 3e-4
