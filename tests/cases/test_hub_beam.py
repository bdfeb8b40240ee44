"""A user's case written from cases/README.md alone (tests/data/hub_beam.toml: a 2 m aluminium
beam clamped to a driven hub, no [report] table, no solver settings) runs with `flexmbd run`,
`compare` and `report` on every solver that applies to it, graded against its default reference,
and the flexible solvers agree on the tip deflection."""

import json
from pathlib import Path

import numpy as np
import pytest

from flexmbd import cases, cli
from flexmbd.harness import results, registry

HUB_BEAM = Path(__file__).resolve().parents[1] / "data" / "hub_beam.toml"
FLEXIBLE = ("flexmbd", "exudyn-ffrf", "exudyn-beam")


def applying(overrides=()) -> list:
    """The solvers that run the case here (`registry.status_for`: the capability table's source)."""
    case = cases.load(str(HUB_BEAM), list(overrides))
    return [s for s in registry.NAMES if registry.status_for(case, s) == "" and s in registry.BUILT_IN]


def compared(tmp_path, capsys, overrides=()) -> dict:
    """`flexmbd compare` on every solver that applies: {solver: tip_deflection RMS row}, runs."""
    names = applying(overrides)
    missing = [s for s in FLEXIBLE if s not in names]
    if missing:
        pytest.skip(f"not available here: {', '.join(missing)}")
    sets = [a for o in overrides for a in ("--set", o)]
    code = cli.main(["compare", str(HUB_BEAM), "--solvers", ",".join(names), "--out", str(tmp_path),
                     "--workers", "1", "--json", *sets])
    got = json.loads(capsys.readouterr().out)
    assert code == cli.OK
    return got




def check(got, ref_tol=0.01):
    runs = {r["solver"]: r for r in got["runs"]}
    assert runs["exudyn-beam"]["verdict"] == "reference"                  # the default reference
    assert all(r["verdict"] not in ("failed", "unavailable") for r in runs.values()), runs
    rms = {a["solver"]: a["rms"] for a in got["accuracy"] if a["channel"] == "tip_deflection"}
    for s in ("flexmbd", "exudyn-ffrf"):
        assert rms[s] < ref_tol, (s, rms[s])                                 # within 1 % RMS of the reference
    return rms


def test_hub_beam_short(tmp_path, capsys):
    """The first 0.5 s of the spin-up: the fast check of the whole path."""
    got = compared(tmp_path, capsys, ["duration=0.5"])
    check(got)
    page = (tmp_path / "compare" / "hub_beam" / "index.html").read_text()
    assert "Defaults, not the case file" in page


@pytest.mark.slow
def test_hub_beam_whole(tmp_path, capsys):
    """The whole 4 s on every solver that applies, then `run` and `report` on the same folder; flexmbd
    without geometric stiffening (the linear floating frame's model) against exudyn-ffrf within 0.5 %."""
    check(compared(tmp_path, capsys))
    assert cli.main(["run", str(HUB_BEAM), "--solver", "flexmbd", "--out", str(tmp_path)]) == cli.OK
    assert cli.main(["report", "--cases", str(HUB_BEAM), "--solvers", ",".join(applying()), "--out", str(tmp_path),
                     "--workers", "1", "--json"]) == cli.OK
    capsys.readouterr()
    a = cases.load(str(HUB_BEAM), ["bodies.beam.stiffening=false"])
    x, y = registry.run(a, "flexmbd"), registry.run(a, "exudyn-ffrf")
    ref = y.channels["tip_deflection"]
    d = np.interp(y.t, x.t, x.channels["tip_deflection"]) - ref
    assert np.sqrt(np.mean(d ** 2)) / np.abs(ref).max() < 0.005
