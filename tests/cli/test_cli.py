"""The command line: list, modes and the frequencies the acceptance criteria name."""

import json

import numpy as np
import pytest

from flexmbd.solvers import analytic
from flexmbd.cli import main

E, RHO, B, H, L = 2.06e11, 7820.0, 0.01, 0.015, 1.5


def test_list_json(capsys):
    assert main(["list", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    names = {r["case"] for r in rows}
    assert {"cantilever_step", "pendulum", "double_pendulum"} <= names
    cant = next(r for r in rows if r["case"] == "cantilever_step")
    assert cant["solvers"]["analytic"] == "ok" and cant["solvers"]["fe-linear"] == "ok"


def test_modes_cantilever_first_six_within_0p3_percent(capsys):
    assert main(["modes", "cantilever_step", "--json"]) == 0
    modes = json.loads(capsys.readouterr().out)["bodies"]["beam"]["modes"]
    assert len(modes) == 12
    f = np.array([m["freq_hz"] for m in modes[:6]])
    ref = np.array([3.685, 5.527, 23.09, 34.64, 64.66, 96.99])
    assert np.all(np.abs(f / ref - 1) < 0.003), f


def test_modes_double_pendulum_hinged_hinged_in_plane(capsys):
    assert main(["modes", "double_pendulum", "--json"]) == 0
    modes = json.loads(capsys.readouterr().out)["bodies"]["beam1"]["modes"]
    inplane = [m["freq_hz"] for m in modes if m["label"].startswith("bending xy")]
    ref = analytic.pinned_pinned_frequencies(E, B * H ** 3 / 12, RHO, B * H, L, len(inplane))
    assert len(inplane) >= 3
    assert np.all(np.abs(np.array(inplane) / ref - 1) < 0.003), (inplane, ref)


def test_modes_save_roundtrip(tmp_path, capsys):
    from flexmbd.fe import flexbody
    assert main(["modes", "pendulum", "--save", str(tmp_path)]) == 0
    fb = flexbody.load(tmp_path / "pendulum_beam.npz")
    assert fb.n_modes == 12 and fb.n_nodes == 101 and fb.boundary == "clamped-free"


def test_run_outside_linear_validity_warns_in_one_line(tmp_path, capsys):
    """The paper's printed E = 2.06e9 Pa: the pendulum bends far beyond a linear modal model's
    range; the run is ok, its status says so, and stderr carries exactly one warning line."""
    code = main(["run", "pendulum", "--solver", "flexmbd", "--set", "materials.steel.E=2.06e9", "--t-end", "0.4",
                 "--set", "bodies.beam.stiffening=false", "--out", str(tmp_path)])
    out, err = capsys.readouterr()
    warnings = [line for line in err.splitlines() if line.startswith("flexmbd: warning:")]
    assert code == 0 and len(warnings) == 1 and "linear validity" in warnings[0]
    status = json.loads((tmp_path / "results" / "pendulum" / "flexmbd.json").read_text())["status"]
    assert status.startswith("ok, outside linear validity (node rotation 0.52 rad")


def test_a_stiffened_beam_bent_too_far_fails_saying_why(tmp_path, capsys):
    """With stiffening, the E = 2.06e9 Pa pendulum stops once its mass matrix loses positive
    definiteness; the failure says it left the model's validity, names the beam, how far it was
    bent, and what to do."""
    code = main(["run", "pendulum", "--solver", "flexmbd", "--set", "materials.steel.E=2.06e9", "--t-end", "0.4",
                 "--out", str(tmp_path)])
    status = json.loads((tmp_path / "results" / "pendulum" / "flexmbd.json").read_text())["status"]
    assert code == 0 and status.startswith("failed: outside linear validity: the stiffened mass matrix stops being positive "
                                     "definite (beam 'beam' bent 3.7 % of its length") and "segments" in status
    strict = main(["run", "pendulum", "--solver", "flexmbd", "--set", "materials.steel.E=2.06e9", "--t-end", "0.4",
                   "--out", str(tmp_path), "--strict"])
    assert strict == 1, "with --strict a failed solver is exit status 1"


def test_modes_system_json(capsys):
    assert main(["modes", "pendulum", "--system", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    inplane = [m for m in out["modes"] if "xy" in m["label"]]
    assert out["about"] == "initial" and inplane[0]["freq_hz"] == pytest.approx(24.23, abs=0.01)
    assert all(m["damping"] == 0.0 and 0.0 < m["damping_resolution"] < 1e-9 for m in out["modes"])   # undamped
    named = {round(m["freq_hz"]): m["label"] for m in out["modes"]}      # the pinned-free beam's, not the hinge's
    assert [named[f] for f in (79, 164, 281, 700)] == [f"beam: bending xy {k}" for k in (2, 3, 4, 5)]


def test_version_and_help_text_for_every_option(capsys):
    from flexmbd.cli import parser
    import argparse
    import flexmbd
    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0 and capsys.readouterr().out.strip() == f"flexmbd {flexmbd.__version__}"
    p = parser()
    subs = next(a for a in p._actions if isinstance(a, argparse._SubParsersAction)).choices
    for name, sp in subs.items():
        for a in sp._actions:
            assert a.help, (name, a.dest)
    help_text = subs["run"].format_help()
    assert "(default: reports)" in help_text and "OUT/results/CASE" in help_text and "one of: flexmbd, fe-linear" in help_text


# ---------------------------------------------------------------------------------------------
# stored results kept when nothing they depend on changed (report, compare)


def test_a_stored_result_with_the_runs_key_is_kept_and_any_change_runs_again(tmp_path, monkeypatch):
    from flexmbd import cases, cli
    from flexmbd.harness import results, registry
    out, ran, real = tmp_path / "rep", [], registry.run
    monkeypatch.setattr(registry, "run", lambda c, s, t_end=None: ran.append((c.name, s)) or real(c, s, t_end))
    case = cases.load("cantilever_step")
    stored = results.folder(out) / case.name / "analytic.json"
    cli.run_checked([(case, "analytic")], out, keep=True)
    key = json.loads(stored.read_text())["key"]
    assert len(ran) == 1 and key == registry.content_key(case, "analytic") and len(key) == 64
    before = (stored.stat().st_ino, stored.read_bytes())
    cli.run_checked([(cases.load("cantilever_step"), "analytic")], out, keep=True)    # unchanged: kept
    assert len(ran) == 1 and (stored.stat().st_ino, stored.read_bytes()) == before
    cli.run_checked([(case, "analytic")], out, keep=False)                             # --rerun
    assert len(ran) == 2
    stiffer = cases.load("cantilever_step", ["materials.steel.E=2.1e11"])            # the case's content
    cli.run_checked([(stiffer, "analytic")], out, keep=True)
    cli.run_checked([(cases.load("cantilever_step", ["solvers.analytic.modes=8"]), "analytic")], out, keep=True)
    assert len(ran) == 4                                                               # a setting
    csv = stored.with_suffix(".csv")
    csv.write_text(csv.read_text().replace("\n0.5,", "\n0.5000001,"))                # not its CSV any more
    cli.run_checked([(cases.load("cantilever_step", ["solvers.analytic.modes=8"]), "analytic")], out, keep=True)
    assert len(ran) == 5
    cli.run_checked([(case, "mujoco")], out, keep=True)          # not applicable: no key, kept by its status
    assert len(ran) == 6 and registry.content_key(case, "mujoco") is None
    na = results.folder(out) / case.name / "mujoco.json"
    before = (na.stat().st_ino, na.read_bytes())
    cli.run_checked([(case, "mujoco")], out, keep=True)
    assert len(ran) == 6 and (na.stat().st_ino, na.read_bytes()) == before


def test_a_short_run_is_not_kept_as_the_whole_case_and_report_runs_it_again(tmp_path, capsys):
    """The run key holds the end time: a `run --t-end` result is another run than the case's."""
    from flexmbd import cases
    from flexmbd.harness import results, registry
    out = tmp_path / "rep"
    case = cases.load("cantilever_step")
    assert registry.content_key(case, "analytic", 0.5) != registry.content_key(case, "analytic")
    assert registry.content_key(case, "analytic", case.duration) == registry.content_key(case, "analytic")
    assert main(["run", "cantilever_step", "--solver", "analytic", "--t-end", "0.5", "--out", str(out)]) == 0
    assert results.read(results.folder(out), case.name, "analytic").t[-1] == pytest.approx(0.5)
    capsys.readouterr()
    assert main(["report", "--cases", "cantilever_step", "--solvers", "analytic", "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert "analytic (stored, unchanged)" not in err, err
    assert results.read(results.folder(out), case.name, "analytic").t[-1] == pytest.approx(case.duration)


def test_a_case_s_content_hash_ignores_comments_and_follows_values(tmp_path):
    from flexmbd import cases
    text = (cases.CASES_DIR / "cantilever_step.toml").read_text()
    (tmp_path / "a.toml").write_text("# a comment\n" + text)
    a, b = cases.load("cantilever_step"), cases.load(str(tmp_path / "a.toml"))
    assert a.sha256 != b.sha256 and a.content_sha256 == b.content_sha256
    assert cases.load("cantilever_step", ["materials.steel.E=2.1e11"]).content_sha256 != a.content_sha256
