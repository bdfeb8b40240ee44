"""A planar mechanism's natural frequencies from the full-order frame of all its beams
(`fe_linear.system_frequencies`): beams against the Euler-Bernoulli closed forms, held by a clamp,
pins to ground and a pin between two beams; the Kitis-Lindenberg four-bar (cases/four_bar.toml)
against flexmbd's linearization of the same assembly (docs/formulation.md §10); a case that is not
planar refused."""

import numpy as np
import pytest

from flexmbd import cases
from flexmbd.core.errors import InputError
from flexmbd.solvers import fe_linear, linearize

# (beta L) of the Euler-Bernoulli beam's modes: clamped-free (cos cosh = -1) and clamped-pinned
# (tan = tanh); pinned-pinned is n pi
CLAMPED_FREE = np.array([1.87510406871196, 4.69409113297418, 7.85475743823761, 10.9955407348755])
CLAMPED_PINNED = np.array([3.92660231204792, 7.06858274562873])

STEEL = """
title = "{title}"
duration = 1.0
gravity = [0.0, 0.0, 0.0]

[materials.steel]
E = 2.06e11
nu = 0.29
rho = 7820.0

[channels.energy]
kind = "energy"
"""

BEAM = """
[bodies.{name}]
type = "beam"
material = "steel"
length = {length}
elements = 8
section = {{ shape = "rectangle", b = 0.01, h = 0.015, h_axis = "y" }}
modes = {{ count = 4, boundary = "hinged-hinged" }}
"""

# a 1.5 m beam on a pin at each end: the tree's pin at the origin, the loop's at x = 1.5 m
PINNED_PINNED = STEEL.format(title="hinged-hinged") + BEAM.format(name="beam", length=1.5) + """
[joints.a]
type = "revolute"
parent = "ground"
child = "beam"
axis = [0.0, 0.0, 1.0]
q0 = 0.0

[joints.b]
type = "revolute"
parent = "ground"
child = "beam"
at = [1.5, 0.0, 0.0]
child_at = 1.5
axis = [0.0, 0.0, 1.0]
loop = true
"""

# two collinear 0.75 m beams, each clamped at its outer end, pinned to each other in the middle
CLAMPED_PIN_CLAMPED = STEEL.format(title="clamped-pin-clamped") + BEAM.format(name="left", length=0.75) + \
    BEAM.format(name="right", length=0.75) + """
[joints.root]
type = "fixed"
parent = "ground"
child = "left"

[joints.hinge]
type = "revolute"
parent = "left"
child = "right"
at = 0.75
axis = [0.0, 0.0, 1.0]
q0 = 0.0

[joints.wall]
type = "fixed"
parent = "ground"
child = "right"
at = [1.5, 0.0, 0.0]
child_at = 0.75
loop = true
"""


def euler_bernoulli(beam, beta_l: np.ndarray) -> np.ndarray:
    """The in-plane (x-y) bending frequencies of the Euler-Bernoulli beam, Hz:
    (beta L)^2 / (2 pi L^2) sqrt(E Iz / (rho A))."""
    sec, mat = beam.geometry, beam.material
    return beta_l ** 2 / (2.0 * np.pi * beam.length ** 2) * np.sqrt(mat.E * sec.Iz / (mat.rho * sec.A))


def check_discretization(f: np.ndarray, closed: np.ndarray, beta_h: np.ndarray) -> None:
    """The Hermite element with consistent mass errs from above by its h^4 term,
    f / f_closed - 1 = (beta h)^4 / 1440 less the higher-order terms, which at beta h <= 1.6 take
    0.5 % to 9.6 % of it (measured: the ratio to the term falls from 0.994 at beta h = 0.23 to 0.904
    at 1.37 and 0.934 at 1.57). Held between 0.8 (twice the largest measured shortfall) and 1.01
    (the eigensolution's round-off, below 1e-9 of f here against errors of 2e-6 and more) of the term:
    a missing or wrong stiffness, mass or tie would change it by far more than 20 %."""
    term = beta_h ** 4 / 1440.0
    ratio = (f / closed - 1.0) / term
    assert np.all(ratio > 0.8) and np.all(ratio < 1.01), ratio


def test_a_cantilever_has_the_closed_form_frequencies():
    """cantilever_step at 8 elements, clamped by its fixed joint: the first four in-plane bending
    frequencies (5.527 to 190.1 Hz; its axial mode, 855 Hz, and the x-z bending are not in the
    planar frame or above them). Measured errors 2.1e-6, 8.0e-5, 6.1e-4, 2.2e-3."""
    case = cases.load("cantilever_step", ["bodies.beam.elements=8"])
    beam = case.bodies["beam"]
    f = fe_linear.system_frequencies(case, 4)
    check_discretization(f, euler_bernoulli(beam, CLAMPED_FREE), CLAMPED_FREE / beam.elements)


def test_a_beam_on_two_pins_to_ground_has_the_hinged_hinged_frequencies(tmp_path):
    """Pins to ground hold the two translations of the end nodes and leave their rotations free:
    the hinged-hinged beam, beta L = n pi (its ends also held along the axis, which in a linear model
    without geometric stiffness changes no bending frequency). Measured errors 1.6e-5 to 3.9e-3."""
    path = tmp_path / "pinned_pinned.toml"
    path.write_text(PINNED_PINNED)
    case = cases.load(str(path))
    beam = case.bodies["beam"]
    beta_l = np.pi * np.arange(1, 5)
    f = fe_linear.system_frequencies(case, 4)
    check_discretization(f, euler_bernoulli(beam, beta_l), beta_l / beam.elements)


def test_two_clamped_beams_pinned_together_split_into_their_halves_modes(tmp_path):
    """Two equal beams of length a, clamped at their outer ends, pinned to each other: the pin ties
    the two translations and transmits no moment. A mode symmetric about the pin has equal and
    opposite pin forces on the halves by symmetry, which equilibrium makes zero: each half clamped-
    free. An antisymmetric one has the pin's deflection zero: each half clamped-pinned. So the
    frequencies are the union of the two beams' of length a, beta a = 1.875, 3.927, 4.694, 7.069,
    7.855 (22.1 to 388 Hz, the axial modes at 1711 Hz and above). Measured errors 2.1e-6 to 5.8e-4."""
    path = tmp_path / "clamped_pin_clamped.toml"
    path.write_text(CLAMPED_PIN_CLAMPED)
    case = cases.load(str(path))
    half = case.bodies["left"]
    beta_a = np.sort(np.concatenate([CLAMPED_FREE[:3], CLAMPED_PINNED]))
    f = fe_linear.system_frequencies(case, 5)
    check_discretization(f, euler_bernoulli(half, beta_a), beta_a / half.elements)


# the four-bar's link lengths, m (cases/four_bar.toml): crank AB, coupler BC, follower DC, ground AD
AB, BC, DC, AD = 0.10795, 0.2794, 0.27051, 0.254


def crank_rocker(theta: float) -> tuple:
    """(crank_pin, follower_pivot) q0, rad, of the four-bar closed at crank angle theta, on the
    branch it is assembled on (C to the left of B -> D; at theta = 0, C above AD): C where the
    circles of radius BC about B and DC about D meet. The coupler's q0 is its angle less the
    crank's, the follower's its angle from x (its pivot D on ground)."""
    B, D = AB * np.array([np.cos(theta), np.sin(theta)]), np.array([AD, 0.0])
    d = float(np.linalg.norm(D - B))
    e = (D - B) / d
    s = (BC ** 2 - DC ** 2 + d ** 2) / (2.0 * d)          # C's distance along B -> D
    C = B + s * e + np.sqrt(BC ** 2 - s ** 2) * np.array([-e[1], e[0]])
    return float(np.arctan2(C[1] - B[1], C[0] - B[0]) - theta), float(np.arctan2(C[1] - D[1], C[0] - D[0]))


@pytest.mark.parametrize("degrees", [0, 90, 180])
def test_the_four_bar_frame_agrees_with_flexmbds_linearization(degrees):
    """The crank held at its angle (its pivot's motion at rate 0: clamped), the loop closed on its
    assembled branch (at 180 degrees the guesses of the file's angle 0 close it on the mirror image
    below AD, whose frequencies are the same by the reflection about AD, as at 0 degrees: the
    closed form's values are passed all the same). The first three frequencies of flexmbd's
    linearization (its modal sets: crank 2, coupler 3, follower 3 in-plane bending modes, lumped
    masses) agree with the full-order frame's (consistent masses) to 1 %; measured, frame against
    flexmbd:
        0 deg:   42.933, 48.650, 61.055 Hz against 43.016, 48.654, 61.093 (+0.19 %, +0.007 %, +0.063 %)
        90 deg:  46.591, 50.110, 81.041 Hz against 46.604, 50.116, 81.139 (+0.027 %, +0.011 %, +0.12 %)
        180 deg: 47.286, 50.281, 86.872 Hz against 47.289, 50.286, 86.981 (+0.006 %, +0.010 %, +0.13 %)
    each of flexmbd's above the frame's. Of the largest, 0.19 % at 0 degrees (the mode flexmbd
    labels `joint crank_pin`, 35 % of its energy), about half is the links' axial flexibility,
    which the frame holds and flexmbd's bending-only mode sets do not (the frame with its EA a
    thousandfold: +0.093 %), the rest flexmbd's truncation (with crank 4, coupler 6, follower 6
    modes: +0.11 %)."""
    theta = float(np.radians(degrees))
    pin, pivot = crank_rocker(theta)
    case = cases.load("four_bar", ["joints.crank_pivot.motion.rate=0.0", f"joints.crank_pivot.q0={theta!r}",
                                   f"joints.crank_pin.q0={pin!r}", f"joints.follower_pivot.q0={pivot!r}"])
    assert case.joints["crank_pin"].q0[0] == pytest.approx(pin, abs=1e-9)
    assert case.joints["follower_pivot"].q0[0] == pytest.approx(pivot, abs=1e-9)
    frame = fe_linear.system_frequencies(case, 3)
    flexmbd = np.array([m.freq_hz for m in linearize.for_case(case)][:3])
    assert np.all(np.abs(flexmbd / frame - 1.0) < 0.01), (frame, flexmbd)


@pytest.mark.parametrize("name, overrides, key", [
    ("cantilever_step", ["joints.clamp.rpy=[0.0, 0.3, 0.0]"], "bodies.beam: not planar"),   # the beam tilted out
    ("pendulum", ["joints.pivot.axis=[0.0, 1.0, 0.0]"], "joints.pivot: not planar"),         # a pin about y
])
def test_a_case_that_is_not_planar_is_refused(name, overrides, key):
    case = cases.load(name, overrides)
    with pytest.raises(InputError) as e:
        fe_linear.system_frequencies(case, 3)
    message = str(e.value)
    assert message.startswith(f"{case.path}: {key}") and "\n" not in message, message
