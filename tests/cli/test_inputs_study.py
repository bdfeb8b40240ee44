"""Bad input to `study` and `import`, and what a killed command leaves, answered as the contract
says: a key varied twice and a grid beyond the cost limits refused before the grid is built; an
imported table of other columns refused from its header, unread; a staging folder left by a killed
process removed by the next generation in its folder, and one a live process builds in kept; a
`--scheduler` where nothing listens refused at once. The study's table keeps integer settings as
integers, and its figures' labels and legend do not overlap."""

import socket
import subprocess
import sys
import time

import numpy as np
import pandas as pd
import pytest

from flexmbd.core import files
from flexmbd.harness import results
from flexmbd.cli import main
from flexmbd.report import study
from tests.cli.test_faults import child, cli

pytestmark = pytest.mark.kernel_free

CASE = "cantilever_step"


def never(*a, **k):
    raise AssertionError("called, though the input is refused before")


# ---------------------------------------------------------------------------------------------
# the grid


@pytest.mark.parametrize("vary, names", [
    (["solvers.analytic.modes=2,4", "solvers.analytic.modes=8"], ["--vary: solvers.analytic.modes is varied twice"]),
    (["solvers.analytic.modes+bodies.beam.modes.count=4,8", "bodies.beam.modes.count=12"],
     ["--vary: bodies.beam.modes.count is varied twice", "solvers.analytic.modes+bodies.beam.modes.count"]),
], ids=["the same key twice", "a key and a tied key holding it"])
def test_a_key_varied_twice_is_refused_before_any_point(tmp_path, monkeypatch, vary, names):
    monkeypatch.setattr(study, "loaded", never)
    out = tmp_path / "st"
    cli(["study", CASE, *[a for v in vary for a in ("--vary", v)], "--solvers", "analytic", "--out", out], 2,
        names=names)
    assert not out.exists()


def test_a_key_varied_twice_in_a_study_file_names_the_file(tmp_path):
    f = tmp_path / "s.toml"
    f.write_text(f'[study]\ncases = ["{CASE}"]\n[study.vary]\n"a.n+b.n" = [1, 2]\n"b.n" = [3]\n')
    cli(["study", "--file", f, "--out", tmp_path / "st"], 2, names=[f"{f}: study.vary: b.n is varied twice"])


def test_a_grid_of_a_million_points_is_refused_at_once_naming_vary_and_its_points(tmp_path, monkeypatch):
    monkeypatch.setattr(study, "grid", never)                   # refused before the grid is built
    modes, elements = (",".join(str(k) for k in range(first, first + 1000)) for first in (1, 100))
    out = tmp_path / "st"
    t0 = time.monotonic()
    msg = cli(["study", CASE, "--vary", f"solvers.analytic.modes={modes}", "--vary", f"bodies.beam.elements={elements}",
               "--solvers", "analytic", "--out", out], 2, names=["--vary", "1,000,000 points", "--allow-large"])
    assert time.monotonic() - t0 < 5 and "GB of memory" in msg[0]
    assert not out.exists()


def test_a_grid_within_the_limits_passes_and_one_of_a_few_thousand_points_is_over(tmp_path):
    from flexmbd.harness import cost
    from flexmbd.cli import _case

    def over(n):
        st = study.Study((CASE,), (("solvers.analytic.modes", tuple(map(str, range(1, n + 1)))),), ("analytic",))
        return [bool(cost.excess(s)) for s in study.stages(st, _case)]
    assert over(100) == [False, False]
    assert over(5000) == [False, True]                          # its table: 10,000 runs, beyond 10 s


# ---------------------------------------------------------------------------------------------
# imports


def test_an_import_of_a_million_columns_is_refused_from_its_header_unread(tmp_path, monkeypatch):
    f = tmp_path / "wide.csv"
    f.write_text(",".join(["t", *(f"c{k}" for k in range(10 ** 6))]) + "\n" + ",".join(["0"] * (10 ** 6 + 1)) + "\n")
    monkeypatch.setattr(results, "read_text", never)
    monkeypatch.setattr(pd, "read_csv", never)
    out = tmp_path / "rep"
    t0 = time.monotonic()
    cli(["import", CASE, f, "--solver", "mine", "--out", out], 2,
        names=[str(f), "header is longer than", "expected `t` and any of tip_deflection, stress_vm"])
    assert time.monotonic() - t0 < 5
    assert not out.exists()


@pytest.mark.parametrize("head, names", [
    ("t,tip_deflection,stress_vm,tip_deflection", ["column tip_deflection appears twice"]),
    ("t,,tip_deflection", ["column 2 has no name"]),
    ("tip_deflection,stress_vm", ["no `t` column"]),
    ("t,c1,c2", ["column c1: not a channel of cantilever_step"]),
], ids=["a channel twice", "a column without a name", "no t", "another column"])
def test_a_header_of_other_columns_is_refused_before_the_table_is_read(tmp_path, monkeypatch, head, names):
    f = tmp_path / "mine.csv"
    f.write_text("# from elsewhere\n\n" + head + "\n" + ",".join(["0"] * (head.count(",") + 1)) + "\n")
    monkeypatch.setattr(results, "read_text", never)
    cli(["import", CASE, f, "--solver", "mine", "--out", tmp_path / "rep"], 2, names=[str(f), *names])


def test_a_header_after_comments_in_any_order_is_imported(tmp_path):
    t = np.linspace(0.0, 2.0, 2001)
    f = tmp_path / "mine.csv"
    f.write_text("# " + "x" * 100_000 + "\n\n" + pd.DataFrame({"stress_vm": 0 * t, "t": t}).to_csv(index=False))
    out = tmp_path / "rep"
    assert main(["import", CASE, str(f), "--solver", "mine", "--out", str(out)]) == 0
    r = results.read(results.folder(out), CASE, "mine")
    assert list(r.channels) == ["stress_vm"] and len(r.t) == 2001


# ---------------------------------------------------------------------------------------------
# staging folders

STAGER = """
import sys
from flexmbd.core import files
with files.generation(sys.argv[1]) as stage:
    print(stage, flush=True)
    sys.stdin.read()
"""


def test_a_staging_folder_of_a_killed_process_is_removed_and_a_live_one_kept(tmp_path):
    """A process stages into OUT and is killed outright (SIGKILL): its folder stays, until the next
    generation in OUT removes it; a folder of a live process (the stager while it runs, this
    test's own) and one not of flexmbd's form stay."""
    dest = tmp_path / "rep"
    own = dest / f"{files.staging_prefix()}mine"
    other = dest / ".new-abc123"
    with child([sys.executable, "-c", STAGER, dest], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True) as p:
        stage = dest / p.stdout.readline().strip()              # the child says it has staged
        assert stage.name.startswith(files.staging_prefix(p.pid)) and stage.is_dir()
        own.mkdir()
        other.mkdir()
        with files.generation(dest) as mine:                    # while the stager lives: its folder stays
            (mine / "page.html").write_text("new")
        assert stage.is_dir() and (dest / "page.html").read_text() == "new"
        p.kill()
        p.wait()
    assert stage.is_dir()                                       # SIGKILL: nothing could remove it
    with files.generation(dest) as mine:
        (mine / "page.html").write_text("newer")
    assert not stage.exists() and own.is_dir() and other.is_dir()
    assert (dest / "page.html").read_text() == "newer"
    assert sorted(q.name for q in dest.iterdir()) == sorted([own.name, other.name, "page.html"])


# ---------------------------------------------------------------------------------------------
# the scheduler


def test_a_scheduler_where_nothing_listens_is_refused_at_once(tmp_path):
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    out = tmp_path / "st"
    t0 = time.monotonic()
    cli(["study", CASE, "--vary", "solvers.analytic.modes=2,4", "--solvers", "fe-linear,analytic", "--out", out,
         "--scheduler", address], 2, names=[f"--scheduler {address}: no Dask scheduler answers there",
                                             "connection refused"])
    assert time.monotonic() - t0 < 5
    assert not out.exists()


# ---------------------------------------------------------------------------------------------
# the table and figures


def test_integer_settings_stay_integers_in_the_table(tmp_path):
    """The mode count is an integer column, beside the empty cells of the reference run once; a
    float setting stays float."""
    out = tmp_path / "st"
    assert main(["study", CASE, "--vary", "solvers.analytic.modes=2,8", "--vary", "duration=0.2,0.3",
                 "--solvers", "analytic", "--reference-at", "base", "--out", str(out), "--workers", "1"]) == 0
    df = pd.read_parquet(out / "study.parquet")
    assert str(df["solvers.analytic.modes"].dtype) == "Int64" and df["duration"].dtype == np.float64
    assert sorted(df["solvers.analytic.modes"].dropna().unique()) == [2, 8]
    assert df.loc[df["solver"] == "fe-linear", "solvers.analytic.modes"].isna().all()
    assert sorted(p.name for p in (out / "figures").glob("*.png"))


def test_a_long_tied_key_s_labels_and_legend_do_not_overlap():
    key = "bodies.beam1.modes.count+bodies.beam2.modes.count+bodies.beam3.modes.count"
    rows = [{"case": "c", key: x, "solver": s, "channel": ch, "metric": "rms_vs_reference", "tolerance": 4e-3,
             "value": v * (2 if s == "flexmbd" else 1)}
            for ch in ("tip1_deflection", "tip2_deflection", "stress_vm_beam1")
            for s in ("flexmbd", "a-long-named-reference-solver")
            for x, v in zip([4, 8, 12, 24], [1e-2, 5e-3, 2e-3, 1e-3])]
    fig = study.figure(pd.DataFrame(rows), "c", key, "rms_vs_reference", "a-long-named-reference-solver")
    try:
        fig.canvas.draw()
        r = fig.canvas.get_renderer()
        axes = [ax.get_window_extent(r) for ax in fig.axes]
        labels = [ax.xaxis.label.get_window_extent(r) for ax in fig.axes]
        legend = fig.legends[0].get_window_extent(r)
        page = fig.bbox
        assert fig.axes[0].get_xlabel().startswith("bodies.{beam1,beam2,beam3}.")
        assert not any(a.overlaps(b) for k, a in enumerate(labels) for b in labels[k + 1:])
        assert not any(legend.overlaps(a) for a in axes + labels)
        texts = labels + [legend, fig._suptitle.get_window_extent(r)]
        assert all(page.x0 <= b.x0 and b.x1 <= page.x1 and page.y0 <= b.y0 and b.y1 <= page.y1 for b in texts)
    finally:
        import matplotlib.pyplot as plt
        plt.close(fig)
