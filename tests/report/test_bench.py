"""The bench's pieces on small sizes (the full run is `flexmbd bench`; no time is asserted here)."""

import numpy as np
import pytest

from flexmbd.report import bench
from flexmbd.solvers.build import from_case


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


def test_the_timed_flexible_state_is_physical():
    """The state the evaluations are timed at gives finite accelerations with stiffening on."""
    f, _ = bench.evaluation(from_case(bench.chain_case(4, flexible=True)))
    assert np.isfinite(f()).all()


def row(solver, scheme, setting, error, wall, error_reference=np.nan):
    return {"case": "c", "solver": solver, "scheme": scheme, "setting": setting, "error": error,
            "error_reference": error_reference, "wall_s": wall}


def test_matched_accuracy_compares_the_same_model_at_its_fastest_setting():
    """flexmbd-linear (without stiffening) against exudyn-ffrf; flexmbd's stiffened rows are another model."""
    rows = [row("flexmbd-linear", "dopri5", "rtol=1e-4", 5e-4, 2.0), row("flexmbd-linear", "adams", "rtol=1e-6", 5e-5, 3.0),
            row("flexmbd-linear", "dopri5", "rtol=1e-3", 2e-3, 1.0), row("flexmbd", "dopri5", "rtol=1e-3", 1e-5, 0.5),
            row("exudyn-ffrf", "fox-goodwin", "dt=1e-4", 8e-4, 4.0), row("exudyn-ffrf", "fox-goodwin", "dt=1e-3", np.nan, 0.1)]
    out = bench.matched_accuracy(rows)
    assert out[0] == {"case": "c", "error_target": 1e-3, "flexmbd_wall_s": 2.0, "exudyn_ffrf_wall_s": 4.0, "ratio": 0.5,
                      "flexmbd_setting": "dopri5 rtol=1e-4", "exudyn_ffrf_setting": "fox-goodwin dt=1e-4",
                      "model": "flexmbd-linear"}
    assert out[1]["flexmbd_wall_s"] == 3.0 and np.isnan(out[1]["exudyn_ffrf_wall_s"])


def test_against_reference_gives_each_model_its_floor():
    """The floor is the most converged setting's error against the reference; a coarse run that
    lands nearer the reference by chance (own error 0.07) sets neither the floor nor a target's
    fastest setting."""
    rows = [row("flexmbd", "dopri5", "rtol=1e-4", 1e-6, 2.0, 5e-5), row("flexmbd", "dopri5", "rtol=1e-3", 1e-4, 1.0, 4e-4),
            row("flexmbd", "exp-adams", "dt=3.2e-2", 0.07, 0.01, 1e-5),
            row("exudyn-ffrf", "fox-goodwin", "dt=1e-4", 1e-7, 4.0, 0.2), row("exudyn-ffrf", "fox-goodwin", "dt=1e-3", 1e-3, 0.1)]
    out = {r["solver"]: r for r in bench.against_reference(rows)}
    assert out["flexmbd"]["floor"] == 5e-5
    assert out["flexmbd"]["wall_s_at_1e-03"] == 1.0 and out["flexmbd"]["wall_s_at_1e-04"] == 2.0
    assert out["exudyn-ffrf"]["floor"] == 0.2 and np.isnan(out["exudyn-ffrf"]["wall_s_at_1e-03"])


def test_a_stored_run_read_back_gives_the_same_summaries():
    """A stored run's JSON holds a diverged row's nan as null: the summaries read it as nan."""
    import json
    rows = [row("flexmbd-linear", "exp-adams", "dt=4e-3", np.nan, 0.01, np.nan),
            row("flexmbd-linear", "dopri5", "rtol=1e-4", 5e-4, 2.0, 3e-2),
            row("exudyn-ffrf", "fox-goodwin", "dt=8e-4", np.nan, 0.04), row("exudyn-ffrf", "fox-goodwin", "dt=1e-4", 8e-4, 4.0, 3e-2)]
    stored = json.loads(json.dumps(rows).replace("NaN", "null"))
    assert stored[0]["error"] is None
    assert bench.matched_accuracy(stored)[0]["ratio"] == bench.matched_accuracy(rows)[0]["ratio"] == 0.5
    assert bench.against_reference(stored)[0]["floor"] == bench.against_reference(rows)[0]["floor"] == 3e-2
    assert bench.convergence(stored, "c", "fox-goodwin")["smallest"] == 8e-4


def test_linear_turns_stiffening_off_on_every_flexible_beam():
    from flexmbd import cases
    over = bench.linear("double_pendulum")
    assert len(over) == 2
    case = cases.load("double_pendulum", over)
    assert not any(b.stiffening for b in case.bodies.values() if b.type == "beam")
    assert any(b.stiffening for b in cases.load("double_pendulum").bodies.values() if b.type == "beam")


def test_convergence_follows_exudyn_rows_only():
    """flexmbd's own fox-goodwin rows share the scheme name and must not break Exudyn's sequence."""
    def row(solver, error):
        return {"case": "c", "solver": solver, "scheme": "fox-goodwin", "error": error}
    rows = [row("flexmbd", 1e-3), row("flexmbd", 1e-5), row("exudyn-ffrf", np.nan), row("exudyn-ffrf", 1e-3),
            row("exudyn-ffrf", 1e-4)]
    c = bench.convergence(rows, "c", "fox-goodwin")
    assert c["decreasing"] and c["smallest"] == 1e-4 and len(c["errors"]) == 3
    assert not bench.convergence(rows + [row("exudyn-ffrf", 2e-4)], "c", "fox-goodwin")["decreasing"]


def test_solid_mesh_rows_reduce_and_evaluate_a_small_mesh():
    rows = bench.solid_mesh({"tiny": [6, 1, 1]})
    assert rows[0]["dofs"] == 3 * bench.solid_case([6, 1, 1]).reduced("bar").n_nodes - 6
    assert rows[0]["flexmbd_us"] > 0 and rows[0]["reduce_s"] > 0


def test_the_duty_cycle_grades_each_setting_against_the_solver_s_own_converged_count():
    """bench.duty_cycle on slider_crank (two revolutions, the second counted) with two exudyn-beam
    steps and one flexmbd tolerance: each row's S_eq at m = 5 and its difference from the
    solver's last (converged) setting's, which is 0 there; the reference's (exudyn-beam's)
    converged S_eq is what error_reference is against; the fastest setting within 1 % of the
    solver's own converged S_eq is named with its time (the converged one at least qualifies)."""
    grid = {"exudyn-beam": [("dt=5e-5", ["solvers.exudyn-beam.dt=5e-5"]), ("dt=2.5e-5", ["solvers.exudyn-beam.dt=2.5e-5"])],
            "flexmbd": [("rtol=1e-8", ["integrator.rtol=1e-8", "integrator.atol=1e-9"])]}
    got = bench.duty_cycle(settings=grid, name="slider_crank")
    rows = {(r["solver"], r["setting"]): r for r in got["rows"]}
    assert got["reference"] == "exudyn-beam" and len(rows) == 3
    assert rows[("exudyn-beam", "dt=2.5e-5")]["error"] == 0.0 == rows[("flexmbd", "rtol=1e-8")]["error"]
    fine, coarse = rows[("exudyn-beam", "dt=2.5e-5")], rows[("exudyn-beam", "dt=5e-5")]
    assert coarse["error"] == pytest.approx(abs(coarse["seq5_MPa"] / fine["seq5_MPa"] - 1), rel=1e-12)
    mine = rows[("flexmbd", "rtol=1e-8")]
    assert mine["error_reference"] == pytest.approx(abs(mine["seq5_MPa"] / fine["seq5_MPa"] - 1), rel=1e-12)
    assert mine["error_reference"] < 0.05                    # the case's own S_eq verdict: flexmbd 3.1 % off
    best = {r["solver"]: r for r in got["fastest"]}
    assert best["flexmbd"]["setting"] == "rtol=1e-8" and best["exudyn-beam"]["setting"] in ("dt=5e-5", "dt=2.5e-5")


def test_the_loops_section_grades_each_setting_against_the_solver_s_own_converged_run():
    """bench.loops on slider_crank with two settings each of flexmbd and exudyn-ffrf and a converged
    run given: each row's error is its worst deflection channel's RMS difference from that
    converged run (`deflection_error`, recomputed here), a converged setting repeated as a row has
    error 0, the fastest setting within 1e-3 is named, and flexmbd's time over exudyn-ffrf's is
    the ratio of those fastest times."""
    from flexmbd import cases
    from flexmbd.harness import registry
    tight = ["integrator.method=dopri5", "integrator.rtol=1e-10", "integrator.atol=1e-12"]
    grid = {"flexmbd": [("fox-goodwin dt=1e-4", ["integrator.method=fox-goodwin", "integrator.dt=1e-4",
                                                 "integrator.rtol=1e-4", "integrator.atol=1e-6"]),
                        ("dopri5 rtol=1e-10", tight)],
            "exudyn-ffrf": [("dt=1e-4", ["solvers.exudyn-ffrf.dt=1e-4"]), ("dt=5e-5", ["solvers.exudyn-ffrf.dt=5e-5"])]}
    got = bench.loops(settings=grid, converged={"flexmbd": tight, "exudyn-ffrf": ["solvers.exudyn-ffrf.dt=5e-5"]},
                      names=("slider_crank",))
    rows = {(r["solver"], r["setting"]): r for r in got["rows"]}
    assert len(rows) == 4 and rows[("flexmbd", "dopri5 rtol=1e-10")]["error"] == 0.0
    assert rows[("exudyn-ffrf", "dt=5e-5")]["error"] == 0.0
    case = cases.load("slider_crank", grid["flexmbd"][0][1])
    own = registry.run(cases.load("slider_crank", tight), "flexmbd")
    again = bench.deflection_error(case, own, registry.run(case, "flexmbd"))
    assert rows[("flexmbd", "fox-goodwin dt=1e-4")]["error"] == pytest.approx(again, rel=1e-6, abs=1e-12)
    best = {r["solver"]: r for r in got["fastest"]}
    assert all(best[s]["setting"] for s in grid)
    (ratio,) = got["ratios"]
    assert ratio["peer"] == "exudyn-ffrf" and ratio["ratio"] == best["flexmbd"]["wall_s"] / best["exudyn-ffrf"]["wall_s"]


def test_the_plots_draw_the_loops_section_and_skip_a_failed_setting(tmp_path):
    """bench.plots with a loops section: loops.png beside the others, a failed setting (error None,
    as a stored run's JSON holds it) left out of the figure, the JSON on the index page."""
    rows = [{"case": c, "solver": s, "setting": f"dt={dt:g}", "error": e, "error_reference": e, "wall_s": w}
            for c in ("four_bar", "slider_crank") for s, dt, e, w in
            (("flexmbd", 1e-4, None, 0.01), ("flexmbd", 5e-5, 7e-5, 1.1), ("exudyn-beam", 5e-5, 1.6e-3, 10.7))]
    result = {"rigid_chain": [{"n": 1, "flexmbd_us": 1.0, "pinocchio_us": 0.5}],
              "flexible_chain": [{"n": 1, "flexmbd_us": 2.0}], "flexible_chain_exponent": 1.0,
              "loops": {"target": 1e-3, "rows": rows, "fastest": [], "ratios": []}}
    names = bench.plots(result, tmp_path)
    assert "loops.png" in names and (tmp_path / "loops.png").stat().st_size > 0
    assert "loops.png" in (tmp_path / "index.html").read_text()
