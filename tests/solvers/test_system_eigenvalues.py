"""The Exudyn adapters' system natural frequencies (`system_frequencies`): Exudyn's own eigenvalue
solver on the constrained model each adapter builds for a run, its prescribed joints held.

Checked against what Exudyn did not compute: a clamped-free beam against the Euler-Bernoulli
closed form (and, for exudyn-ffrf, against its reduced body's own modal frequencies), and the
Kitis-Lindenberg four-bar with its crank held at 0, 90 and 180 degrees against flexmbd's own
linearization (`flexmbd.solvers.linearize.for_case`), each adapter against the other too.
"""

import numpy as np
import pytest

pytest.importorskip("exudyn")

from flexmbd import cases  # noqa: E402
from flexmbd.core.errors import InputError  # noqa: E402
from flexmbd.fe import flexbody  # noqa: E402
from flexmbd.solvers import exudyn_beam, exudyn_ffrf, linearize  # noqa: E402

ADAPTERS = {"exudyn-beam": exudyn_beam, "exudyn-ffrf": exudyn_ffrf}

# beta_n L of a clamped-free beam's first four bending modes (roots of cos x cosh x = -1)
CLAMPED_FREE = np.array([1.875104068711961, 4.694091132974175, 7.854757438237613, 10.995540734875467])
UNLOADED = ["loads.tip_force.force=[0.0, 0.0, 0.0]"]    # a load acting at t = 0 is refused (xc.loaded)


def euler_bernoulli(case) -> np.ndarray:
    """The closed-form clamped-free frequencies (4,) of the case's beam in its x-y plane, Hz."""
    b = case.bodies["beam"]
    ei_rho_a = b.material.E * b.geometry.Iz / (b.material.rho * b.geometry.A)
    return CLAMPED_FREE ** 2 / (2.0 * np.pi * b.length ** 2) * np.sqrt(ei_rho_a)


def test_a_clamped_beam_of_beam_elements_has_the_closed_form_frequencies():
    n = 32
    case = cases.load("cantilever_step", [*UNLOADED, f"solvers.exudyn-beam.elements={n}"])
    f, exact = exudyn_beam.system_frequencies(case, 4), euler_bernoulli(case)
    # The beam element's discretisation error: above the closed form, falling as 1 / n^2 (from 16 to
    # 32 elements by 4.9, 4.8, 4.8 on modes 2 to 4); at 32 elements measured 4.0e-5, 1.85e-3,
    # 5.57e-3, 1.15e-2 = 0.012, 0.086, 0.093, 0.097 times (beta_n L / n)^2. Allowed: (beta_n L / n)^2 / 8,
    # a margin of 1.3 on mode 4 and more below; the shear and rotary inertia the element has (the
    # Timoshenko beam's, -(beta_n r)^2 (1 + E / k G) / 2 = -6e-5 .. -2e-3 here) lie within it.
    assert np.all(np.abs(f / exact - 1.0) <= (CLAMPED_FREE / n) ** 2 / 8.0)


def test_a_clamped_reduced_body_has_its_modes_and_the_closed_form_frequencies():
    case = cases.load("cantilever_step", [*UNLOADED, 'bodies.beam.modes.kinds=["bending xy"]',
                                          "bodies.beam.modes.count=4"])
    f = exudyn_ffrf.system_frequencies(case, 4)
    fb = flexbody.for_case(case)["beam"]
    own = np.sort(np.sqrt(np.linalg.eigvalsh(np.asarray(fb.Km, dtype=float)))) / (2.0 * np.pi)
    # clamped at its reference node, the reduced body vibrates in its retained modes: Exudyn's
    # constrained eigenvalue problem (Euler parameters, null-space projection) adds nothing
    np.testing.assert_allclose(f, own, rtol=1e-9)
    # flexmbd's FE beam (100 elements, lumped masses, rotary inertia) lies below the closed form by
    # 6.5e-5, 2.9e-4, 5.8e-4, 9.6e-4 (measured): a margin of 2 at 2e-3
    np.testing.assert_allclose(f, euler_bernoulli(case), rtol=2e-3)


def crank_held(angle: float) -> list:
    """Overrides of the four-bar: its crank held at `angle` (rad), the loop's dependent joints
    guessed at the closed form on the branch it is assembled on (C on the left of B -> D; from the
    file's guesses both adapters and flexmbd close onto the mirror image at 180 degrees)."""
    case = cases.load("four_bar")
    a, b, c = (case.bodies[n].length for n in ("crank", "coupler", "follower"))
    B, D = a * np.exp(1j * angle), case.joints["follower_pivot"].offset[0]
    e = D - B
    x = (abs(e) ** 2 + b ** 2 - c ** 2) / (2.0 * abs(e))
    C = B + e / abs(e) * (x + 1j * np.sqrt(b ** 2 - x ** 2))
    return ["joints.crank_pivot.motion.rate=0.0", f"joints.crank_pivot.q0={angle!r}",
            f"joints.crank_pin.q0={float(np.angle(C - B) - angle)!r}",
            f"joints.follower_pivot.q0={float(np.angle(C - D) % (2.0 * np.pi))!r}"]


# 16 elements per link: the beam mesh's first three frequencies lie 0.06 .. 0.5 % above flexmbd's
# (at 32 elements 0.03 .. 0.15 %), in 0.7 s per angle instead of 2.2 s
FOUR_BAR_ELEMENTS = 16


@pytest.mark.parametrize("degrees", [0.0, 90.0, 180.0])
def test_the_four_bar_with_its_crank_held_has_flexmbds_frequencies(degrees):
    case = cases.load("four_bar", [*crank_held(float(np.radians(degrees))),
                                   f"solvers.exudyn-beam.elements={FOUR_BAR_ELEMENTS}"])
    beam, ffrf = (ADAPTERS[n].system_frequencies(case, 3) for n in ADAPTERS)
    ours = np.array([m.freq_hz for m in linearize.for_case(case)[:3]])
    for f in (beam, ffrf):
        np.testing.assert_allclose(f, ours, rtol=0.01)
    np.testing.assert_allclose(beam, ffrf, rtol=0.01)


def test_a_driven_joint_is_held_at_its_start():
    """The four-bar as the file gives it (crank at 40 rad/s): its frequencies are those of the
    crank held at its start angle."""
    driven = cases.load("four_bar", [f"solvers.exudyn-beam.elements={FOUR_BAR_ELEMENTS}"])
    held = cases.load("four_bar", [*crank_held(0.0), f"solvers.exudyn-beam.elements={FOUR_BAR_ELEMENTS}"])
    for mod in ADAPTERS.values():
        np.testing.assert_allclose(mod.system_frequencies(driven, 3), mod.system_frequencies(held, 3), rtol=1e-9)


@pytest.mark.parametrize("name", list(ADAPTERS))
@pytest.mark.parametrize("overrides, why", [
    ([], "load 'tip_force' acts at t = 0"),
    ([*UNLOADED, "gravity=[0.0, -9.81, 0.0]"], "gravity acts on it"),
    ([*UNLOADED, "joints.clamp.type=\"revolute\"", "joints.clamp.qd0=1.0"], "its initial state moves"),
])
def test_what_the_eigenvalue_solver_cannot_take_is_an_input_error(name, overrides, why):
    case = cases.load("cantilever_step", overrides)
    with pytest.raises(InputError) as e:
        ADAPTERS[name].system_frequencies(case, 4)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith(f"{case.path}: {name} system frequencies: ") and why in msg


def test_a_case_the_adapter_cannot_build_is_an_input_error():
    case = cases.load("cantilever_step", [*UNLOADED, "loads.tip_force.force=[0.0, 0.0, 1.0]",
                                          "loads.tip_force.profile.t0=1.0"])
    with pytest.raises(InputError, match="planar beam model only"):
        exudyn_beam.system_frequencies(case, 4)
