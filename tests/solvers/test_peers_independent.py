"""The rigid peers check flexmbd rather than repeat it: an error planted in `build.from_case`
(flexmbd's case -> Model) makes their agreement check with flexmbd fail, and the peers' own
results do not move, since they build their models from the case (`common.rigid_bodies`).

The check is tests/solvers/test_peers.py's `agreement` / `agrees` (the same runs, measures and bounds
as `test_rigid_peers_agree_with_flexmbd_on_beams_declared_rigid`: end angles within 1e-7 rad,
energies within 1e-8 J), on shipped cases with every beam declared rigid, over 0.5 s. Planted:

- an inertia error: the spatial inertia of one beam declared rigid scaled by 1.1 (beam2 of the
  double pendulum; in a single pendulum a uniform scaling of its only body would not change its
  motion), and the rotational part alone (about the body origin) of the pendulum's beam;
- a joint-offset error: the double pendulum's pivot2 moved 3 % of beam1's length (4.5 cm)
  towards beam1's root.
"""

import numpy as np
import pytest

pytest.importorskip("pinocchio")
pytest.importorskip("mujoco")

from flexmbd.solvers import build
from flexmbd.harness import registry
from flexmbd.mbd import spatial  # noqa: E402
from tests.solvers.test_peers import LUMPED, agreement, agrees, rigid  # noqa: E402

T_END = 0.5                         # s


def scaled_inertia(monkeypatch, beam: str, block: slice, factor: float = 1.1):
    """Plant: `build.rigid_inertia_of_beam` of `beam` with its rows and columns `block` scaled."""
    original = build.rigid_inertia_of_beam

    def planted(fb):
        I = original(fb).copy()
        if fb.name == beam:
            I[block, block] *= factor
        return I
    monkeypatch.setattr(build, "rigid_inertia_of_beam", planted)


def shifted_joint(monkeypatch, child: str, dx: float):
    """Plant: the input triad of the joint whose child is `child` moved by dx along the parent's x."""
    original = build.triad

    def planted(j, on_node):
        X = original(j, on_node)
        if j.child == child:
            r, R = spatial.plux_parts(X)                               # origin, triad -> parent rotation
            X = spatial.plux(R.T, r + np.array([dx, 0.0, 0.0]))
        return X
    monkeypatch.setattr(build, "triad", planted)


def peers(case) -> dict:
    return {s: registry.run(case, s, T_END).channels for s in ("pinocchio", "mujoco")}


PLANTS = {                          # name: (case, plant)
    "double_pendulum: beam2's spatial inertia x 1.1":
        ("double_pendulum", lambda mp: scaled_inertia(mp, "beam2", slice(0, 6))),
    "pendulum: the beam's rotational inertia x 1.1":
        ("pendulum", lambda mp: scaled_inertia(mp, "beam", slice(0, 3))),
    "double_pendulum: pivot2 moved 3 % of L":
        ("double_pendulum", lambda mp: shifted_joint(mp, "beam2", -0.03 * 1.5)),
}


@pytest.mark.parametrize("plant", list(PLANTS))
def test_agreement_check_fails_with_a_planted_error_and_passes_without(plant, monkeypatch):
    name, apply = PLANTS[plant]
    case = rigid(name, LUMPED)
    clean = agreement(case, T_END)
    assert agrees(clean), clean
    before = peers(case)

    apply(monkeypatch)
    planted = agreement(case, T_END)
    assert not agrees(planted), planted
    # the peers saw nothing of it: their results are the same to the last bit
    after = peers(case)
    for s in before:
        for ch, x in before[s].items():
            assert np.array_equal(after[s][ch], x), (s, ch)
    # and they still agree with each other: the disagreement is flexmbd's
    assert planted["peers_angle"] < 1e-7 and planted["peers_energy"] < 1e-8, planted
    assert planted["pinocchio_angle"] > 1e3 * 1e-7, planted
