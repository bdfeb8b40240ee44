"""Durability (flexmbd/harness/durability.py) and the signed stress channels it counts, against what
they did not compute: the worked example of
ASTM E1049-85, the published S-N curves' numbers, and closed forms of Miner damage."""

from pathlib import Path

import numpy as np
import pytest

from flexmbd.harness import durability as d

pytestmark = pytest.mark.kernel_free

ASTM = [-2, 1, -3, 5, -1, 3, -4, 4, -2]      # ASTM E1049-85 (2017), Fig. 6: the rainflow example


def by_range(c: d.Cycles) -> dict:
    """range -> total count."""
    out = {}
    for r, n in zip(c.ranges, c.counts):
        out[float(r)] = out.get(float(r), 0.0) + float(n)
    return out


def test_the_astm_example_counts_as_the_standard_does():
    """ASTM E1049-85 Table 4: ranges 3, 4, 6, 8 and 9 counted 0.5, 1.5, 0.5, 1.0 and 0.5 times."""
    assert by_range(d.cycles(ASTM)) == {3.0: 0.5, 4.0: 1.5, 6.0: 0.5, 8.0: 1.0, 9.0: 0.5}


def test_the_astm_example_repeated_closes_into_whole_cycles():
    """As a repeating duty cycle the residue pairs up: one cycle each of 3, 4, 7 and 9, and each
    cycle's samples are the history's own (the 9 runs between the largest and the smallest)."""
    c = d.cycles(ASTM, repeat=True)
    assert by_range(c) == {3.0: 1.0, 4.0: 1.0, 7.0: 1.0, 9.0: 1.0}
    big = c.ranges == 9.0
    assert {ASTM[i] for i in np.concatenate([c.starts[big], c.ends[big]])} == {5, -4}


def test_a_history_without_reversals_has_no_cycles():
    assert d.cycles([1.0, 1.0]).counts.sum() == 0.0
    c = d.cycles([0.0, 2.0, 4.0])                                   # a rise: one half cycle
    assert (c.ranges.tolist(), c.counts.tolist(), c.starts.tolist(), c.ends.tolist()) == ([4.0], [0.5], [0], [2])


def test_the_eurocode_category_71_curve_has_its_published_knees():
    """EN 1993-1-9 Fig. 7.1 for detail category 71: 2e6 cycles at 71 MPa, the constant-amplitude
    limit 52.3 MPa at 5e6 and the cut-off 28.7 MPa at 1e8 (the standard's values to 0.1 MPa; here
    to 0.01 MPa: they are (2/5)^(1/3) 71 = 52.31 and (5/100)^(1/5) 52.31 = 28.73)."""
    ec = d.CURVES["ec3-71"]
    assert d.life(ec, [71.0])[0] == pytest.approx(2e6, rel=1e-12)
    (s1, n1), (s2, n2) = ec.knees()
    assert (s1, n1) == (pytest.approx(52.3, abs=0.02), pytest.approx(5e6, rel=1e-12))
    assert (s2, n2) == (pytest.approx(28.7, abs=0.04), pytest.approx(1e8, rel=1e-12))
    assert abs(s1 - 52.31) < 0.01 and abs(s2 - 28.73) < 0.01
    assert np.isinf(d.life(ec, [28.0])[0])                          # below the cut-off: no damage
    assert d.life(ec, [40.0])[0] == pytest.approx(5e6 * (s1 / 40.0) ** 5, rel=1e-12)    # slope 5


@pytest.mark.parametrize("name, category, m1", [("ec9-71-7", 71.0, 7.0), ("ec9-40-4.3", 40.0, 4.3)])
def test_an_eurocode_9_curve_has_its_slopes_and_knees(name, category, m1):
    """EN 1999-1-3 §6.2.1 (aluminium): 2e6 cycles at the category, slope m1 to 5e6 cycles, m1 + 2
    to the cut-off at 1e8, no damage below it; the curve continuous at both knees (to 1e-12, the
    rounding of powers of numbers of order 1e8)."""
    ec = d.CURVES[name]
    assert ec.m == (m1, m1 + 2.0) and ec.cutoff
    assert d.life(ec, [category])[0] == pytest.approx(2e6, rel=1e-12)
    (s1, n1), (s2, n2) = ec.knees()
    assert s1 == pytest.approx(category * 0.4 ** (1 / m1), rel=1e-12) and n1 == pytest.approx(5e6, rel=1e-12)
    assert s2 == pytest.approx(s1 * 0.05 ** (1 / (m1 + 2)), rel=1e-12) and n2 == pytest.approx(1e8, rel=1e-12)
    assert d.life(ec, [s1 * (1 - 1e-13)])[0] == pytest.approx(5e6, rel=1e-11)       # continuous at the knee
    assert d.life(ec, [0.5 * (s1 + s2)])[0] == pytest.approx(5e6 * (s1 / (0.5 * (s1 + s2))) ** (m1 + 2), rel=1e-12)
    assert np.isinf(d.life(ec, [s2 * 0.999])[0])


def test_the_dnv_c_curve_in_air_has_its_published_knee():
    """DNV-RP-C203 Table 2-1, C in air: log a = 12.592 (m = 3) to 1e7 cycles, where the table
    gives 73.10 MPa. log a is printed to 3 decimals, which moves the knee by up to 0.028 MPa
    (0.0005 ln10 / 3 of it): bound 0.03. The curve goes on with slope 5 (log a 16.320) and is
    continuous there to the same rounding."""
    c = d.CURVES["dnv-c"]
    (s, n), = c.knees()
    assert n == pytest.approx(1e7, rel=1e-12) and s == pytest.approx(73.10, abs=0.03)
    below = d.life(c, [s * 0.999])[0]
    assert below == pytest.approx(1e7 / 0.999 ** 5, rel=3e-3) and np.isfinite(d.life(c, [1.0])[0])


@pytest.mark.parametrize("cycles_n", [1, 7, 40])
def test_a_sinusoid_does_n_cycles_of_its_double_amplitude(cycles_n):
    """A sinusoid of amplitude A over n whole periods: n cycles of 2A, Miner damage n (2A)^m / C on
    a single-slope curve. From a peak, its 2n half cycles; from zero, as a repeating duty cycle
    (counted once, its start and end would be half cycles of A). Bound 1e-9: a sum of n equal
    terms and one power."""
    A, m = 60.0, 3.0                                        # MPa
    t = np.linspace(0.0, cycles_n, 64 * cycles_n + 1)
    curve = d.SNCurve("one slope", "a test", m=(m,), log_a=(12.0,), lower=(0.0,), cutoff=False)
    for c in (d.cycles(A * np.cos(2 * np.pi * t)), d.cycles(A * np.sin(2 * np.pi * t), repeat=True)):
        assert c.counts.sum() == pytest.approx(cycles_n, rel=1e-12)
        assert np.allclose(c.ranges, 2 * A, rtol=1e-12)
        assert d.damage(c, curve) == pytest.approx(cycles_n * (2 * A) ** m / 1e12, rel=1e-9)


def test_scaling_the_stress_scales_damage_by_its_power_and_the_equivalent_range_one_to_one():
    """Every stress times 1.01: single-slope damage times 1.01^m (to 1e-12), the damage-equivalent
    range times 1.01; the life ratio a 5 % stress error makes is (1.05)^m: 16 % at m = 3."""
    rng = np.random.default_rng(3)
    s = np.cumsum(rng.normal(size=2000)) * 10.0
    c, c2 = d.cycles(s), d.cycles(1.01 * s)
    for m in (3.0, 5.0):
        curve = d.SNCurve("one slope", "a test", m=(m,), log_a=(13.0,), lower=(0.0,), cutoff=False)
        assert d.damage(c2, curve) / d.damage(c, curve) == pytest.approx(1.01 ** m, rel=1e-12)
        assert d.equivalent_range(c2, m) / d.equivalent_range(c, m) == pytest.approx(1.01, rel=1e-12)
    assert 1.05 ** 3 - 1 == pytest.approx(0.158, abs=1e-3)


def test_the_equivalent_range_does_the_same_damage_in_its_reference_cycles():
    c = d.cycles(np.cumsum(np.random.default_rng(4).normal(size=500)))
    m, n_ref = 4.0, 2e6
    S = d.equivalent_range(c, m, n_ref)
    curve = d.SNCurve("one slope", "a test", m=(m,), log_a=(9.0,), lower=(0.0,), cutoff=False)
    assert n_ref / d.life(curve, [S])[0] == pytest.approx(d.damage(c, curve), rel=1e-12)


def test_mean_stress_corrections_raise_tensile_cycles_and_leave_zero_mean_ones():
    c = d.Cycles(ranges=np.array([100.0, 100.0, 100.0]), means=np.array([0.0, 200.0, -200.0]),
                 counts=np.ones(3), starts=np.zeros(3, int), ends=np.zeros(3, int))
    g = d.corrected(c, "goodman", ultimate=400.0)
    assert g.tolist() == [100.0, 200.0, 100.0]                     # S / (1 - 200 / 400); compression not credited
    w = d.corrected(c, "walker", gamma=0.5)
    assert w[0] == pytest.approx(100.0) and w[1] == pytest.approx(2 * 250.0 ** 0.5 * 50.0 ** 0.5) and w[2] == 0.0


# ---------------------------------------------------------------------------------------------
# the signed stress channels (flexmbd/harness/channels.py)

SIGNED = ['channels.top={kind="stress_normal", body="beam", at=0.03}',
          'channels.bottom={kind="stress_normal", body="beam", at=0.03, fibre=[-0.0075, 0.0]}',
          'channels.signed={kind="stress_signed_vm", body="beam", at=0.03, fibre=[-0.0075, 0.0]}']


@pytest.mark.parametrize("solver", ["analytic", "fe-linear"])
def test_a_cantilever_bent_down_is_in_tension_on_top_and_in_compression_below(solver):
    """cantilever_step (12 N down at the tip, from rest): the normal stress at 0.03 m from the clamp
    has the time mean of the static P (L - x) c / I = +47.04 MPa on the top fibre and -47.04 below
    (references/README.md; an undamped step response's mean is within 0.5 % of the static value:
    bound 1 %); the signed von Mises below is the normal stress (no torsion), von Mises its size."""
    from flexmbd import cases
    from flexmbd.harness import registry
    r = registry.run(cases.load("cantilever_step", SIGNED), solver)
    assert r.ok, r.status
    top, bottom = r.channels["top"], r.channels["bottom"]
    assert top.mean() == pytest.approx(47.04e6, rel=0.01) and bottom.mean() == pytest.approx(-47.04e6, rel=0.01)
    assert np.allclose(r.channels["signed"], bottom, rtol=1e-12, atol=1e-6 * np.abs(bottom).max())
    assert np.allclose(r.channels["stress_vm"], np.abs(top), rtol=1e-12, atol=1e-6 * np.abs(top).max())


def test_the_sign_of_a_solid_s_stress_is_its_largest_principal_stress_s():
    from flexmbd.harness import channels
    S = np.array([[100.0, 0, 0, 0, 0, 0], [-100.0, 0, 0, 0, 0, 0], [10.0, -50.0, 0, 0, 0, 0], [0, 0, 0, 0, 0, 30.0]])
    assert channels.principal_sign(S).tolist() == [1.0, -1.0, -1.0, 1.0]         # pure shear: + (equal sizes)
    vm = channels.solid_vm(S)
    assert np.allclose(channels.solid_stress("stress_signed_vm", S), [vm[0], -vm[1], -vm[2], vm[3]])
    assert channels.solid_stress("stress_normal", S).tolist() == [100.0, -100.0, 10.0, 0.0]


# ---------------------------------------------------------------------------------------------
# a case's fatigue count (`table`, `settings`) and its [durability] table's input

def settings(curve="dnv-c", discard=0.0, tolerance=0.05) -> d.Settings:
    return d.Settings(("s",), d.CURVES[curve], "none", np.inf, 0.5, False, discard, tolerance)


def sine(amplitude_mpa: float, periods: int = 20, n: int = 4001):
    """(t, s): a sinusoid in Pa of `amplitude_mpa` over `periods` periods of 1 s, from its peak."""
    t = np.linspace(0.0, float(periods), n)
    return t, amplitude_mpa * 1e6 * np.cos(2 * np.pi * t)


@pytest.mark.parametrize("factor, verdict", [(1.01, "pass"), (1.06, "fail")])
def test_a_scaled_history_has_its_scale_as_s_eq_ratio_and_its_power_as_damage_ratio(factor, verdict):
    """Two runs of one sinusoid, one scaled: S_eq's ratio is the scale at both slopes, damage's
    its power m = 5 (every range, 20 MPa, below DNV C's knee at 73 MPa: one segment), the damage
    ratio predicted from S_eq equals the computed one to 1e-12 (both are sums of the same powers),
    and the S_eq verdict holds the 5 % tolerance."""
    t, s = sine(10.0)
    rows, cyc = d.table(settings(), {"ref": (t, {"s": s}), "other": (t, {"s": factor * s})}, "ref")
    other = next(r for r in rows if r["solver"] == "other")
    assert abs(other["seq3_ratio"] / factor - 1) < 1e-12 and abs(other["seq5_ratio"] / factor - 1) < 1e-12
    assert abs(other["damage_ratio"] / factor ** 5 - 1) < 1e-12
    assert abs(other["predicted_ratio"] / other["damage_ratio"] - 1) < 1e-12 and not other["mixed"]
    assert other["slope"] == 5.0 and other["verdict"] == verdict
    # RMS of (f - 1) s over max |s|: (f - 1) / sqrt 2 over whole periods (the 4001 samples hold
    # both ends: a bias of 1 / 4000)
    assert other["rms"] == pytest.approx((factor - 1) / np.sqrt(2), rel=1e-3)
    assert other["band_low"] < 1 < other["band_high"]
    ref = next(r for r in rows if r["solver"] == "ref")
    assert ref["cycles"] == 20 and ref["largest_MPa"] == pytest.approx(20.0, rel=1e-9) and ref["verdict"] == ""
    assert len(cyc["ref"]) == len(cyc["other"]) and {c["channel"] for c in cyc["ref"]} == {"s"}


def test_cycles_that_straddle_the_cut_off_make_no_prediction():
    """Ranges on both sides of Eurocode 3 category 71's cut-off (28.7 MPa): damage jumps as a
    cycle crosses it, so the S_eq ratio predicts nothing (mixed, NaN)."""
    t, s = sine(14.0)                                            # 28 MPa: just below the cut-off
    rows, _ = d.table(settings("ec3-71"), {"ref": (t, {"s": s}), "other": (t, {"s": 1.04 * s})}, "ref")
    other = next(r for r in rows if r["solver"] == "other")
    assert other["mixed"] and np.isnan(other["predicted_ratio"])
    assert next(r for r in rows if r["solver"] == "ref")["damage"] == 0.0 and np.isnan(other["damage_ratio"])


def test_ripples_far_below_the_cut_off_leave_the_prediction_to_the_damaging_cycles():
    """100 MPa cycles (slope 3 on Eurocode 3 category 71) with 1 MPa ripples between them, far
    below the cut-off in both counts: they do no damage in either, so the S_eq ratio over the
    damaging cycles predicts the damage ratio, 1.03^3, to 1e-12."""
    t = np.linspace(0.0, 10.0, 20001)
    s = 50e6 * np.cos(2 * np.pi * t) + 0.5e6 * np.sin(2 * np.pi * 37 * t)     # from a peak to a peak
    rows, _ = d.table(settings("ec3-71"), {"ref": (t, {"s": s}), "other": (t, {"s": 1.03 * s})}, "ref")
    other = next(r for r in rows if r["solver"] == "other")
    assert not other["mixed"] and other["slope"] == 3.0
    assert other["damage_ratio"] == pytest.approx(1.03 ** 3, rel=1e-12)
    assert other["predicted_ratio"] == pytest.approx(other["damage_ratio"], rel=1e-12)


def test_the_start_up_is_discarded_and_each_cycle_keeps_its_times():
    """discard = 5 s of a 20-period history: 15 cycles, each starting and ending after 5 s."""
    t, s = sine(10.0)
    rows, cyc = d.table(settings(discard=5.0), {"ref": (t, {"s": s})}, "ref")
    assert rows[0]["cycles"] == 15
    assert min(c["t_start"] for c in cyc["ref"]) >= 5.0 and max(c["t_end"] for c in cyc["ref"]) <= 20.0
    assert rows[0]["life_h"] == pytest.approx(15.0 / rows[0]["damage"] / 3600.0, rel=1e-12)


BAD = [
    ('durability.curve="ec3-70"', "durability.curve", "unknown curve 'ec3-70'"),
    ('durability.curve={m = [-3.0], log_a = [12.0], lower = [0.0]}', "durability.curve.m", "slopes must be positive"),
    ('durability.channels=["stress_vm"]', "durability.channels", "von Mises has no sign"),
    ('durability.channels=["nothing"]', "durability.channels", "no channel 'nothing'"),
    ("durability.discard=3.0", "durability.discard", "discards the whole run"),
    ('durability.correction="goodman"', "durability.ultimate", "ultimate strength"),
]


CASE = str(Path(__file__).resolve().parents[1] / "data" / "pendulum_durability.toml")


@pytest.mark.parametrize("override, key, why", BAD)
def test_bad_durability_input_is_one_line_naming_the_key(override, key, why, capsys, tmp_path):
    """Each is refused before any run: exit 2, one line on stderr naming the case file and the key."""
    from flexmbd import cli
    assert cli.main(["run", CASE, "--solver", "flexmbd", "--set", override, "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"pendulum_durability.toml: {key}: " in err[0] and why in err[0], err
    assert not any(tmp_path.iterdir())
