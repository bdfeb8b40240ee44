"""The bench's pieces on small sizes (the full run is `flexmbd bench`; no time is asserted here)."""

import numpy as np

from flexmbd import bench
from flexmbd.model import from_case


def test_chains_are_valid_trees():
    for flexible in (False, True):
        m = from_case(bench.chain_case(3, flexible))
        assert m.nb == 3 and list(m.parent[1:]) == [0, 1, 2]
        assert (m.jnt_node[2:] >= 0).all() == flexible


def test_rigid_and_flexible_chain_rows():
    rows = bench.rigid_chain((1, 2))
    assert [r["n"] for r in rows] == [1, 2]
    assert all(r["flexmbd_us"] > 0 and r["pinocchio_us"] > 0 and r["ratio"] > 0 for r in rows)
    rows, exponent = bench.flexible_chain((1, 4, 8))
    assert len(rows) == 3 and np.isfinite(exponent)


def test_matched_accuracy_picks_the_fastest_setting_that_meets_the_target():
    rows = [{"case": "c", "solver": "flexmbd", "error": 5e-4, "wall_s": 2.0},
            {"case": "c", "solver": "flexmbd", "error": 5e-5, "wall_s": 3.0},
            {"case": "c", "solver": "flexmbd", "error": 2e-3, "wall_s": 1.0},
            {"case": "c", "solver": "exudyn-ffrf", "error": 8e-4, "wall_s": 4.0},
            {"case": "c", "solver": "exudyn-ffrf", "error": np.nan, "wall_s": 0.1}]
    out = bench.matched_accuracy(rows)
    assert out[0] == {"case": "c", "error_target": 1e-3, "flexmbd_wall_s": 2.0, "exudyn_ffrf_wall_s": 4.0, "ratio": 0.5}
    assert out[1]["flexmbd_wall_s"] == 3.0 and np.isnan(out[1]["exudyn_ffrf_wall_s"])
