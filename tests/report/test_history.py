"""History (report/history.py): a report's record per machine and commit, the page of accuracy and
time across commits, another folder's records brought in, the stored bench runs."""

import json
import re
from pathlib import Path

import pytest

from flexmbd.core import files, resources
from flexmbd.harness import results, registry
from flexmbd.cli import main
from flexmbd.report import accuracy, history
from flexmbd.version import __version__


@pytest.fixture(scope="module")
def report(cantilever_report):
    """A report of cantilever_step by analytic and its reference fe-linear (the session's: conftest.py)."""
    return cantilever_report


def outcome(case: str, solver: str, verdict: str = "pass", worst: float = 0.004, wall: float = 0.5):
    return accuracy.Outcome(case, solver, results.Status("ok"), accuracy.Verdict(verdict, verdict), worst, wall)


def row(case: str, solver: str, channel: str = "tip", rms: float = 0.004, tolerance: float = 0.01) -> dict:
    return {"case": case, "solver": solver, "channel": channel, "rms": rms, "tolerance": tolerance}


def fake(monkeypatch, rev: str, when: str, host: str = "box-000000") -> None:
    """The next record is of commit `rev` (e.g. 'abc1234' or 'abc1234+dirty') on machine `host`, at `when`."""
    monkeypatch.setattr(results, "git_commit", lambda: rev)
    monkeypatch.setattr(history, "now", lambda: when)
    monkeypatch.setattr(history, "machine", lambda: {"name": host, "hostname": host.split("-")[0], "cpu": "test cpu",
                                                     "cores": 2, "memory_gb": 4.0, "os": "test", "python": "3"})


def commits_table(md: str) -> list:
    """The commit column of the page's "Commits, oldest first" table, in its order."""
    block = md.split("## Commits, oldest first\n\n")[1].split("\n\n")[0]
    return [line.split("|")[1].strip() for line in block.splitlines()[2:]]


def test_a_report_records_each_run_of_this_commit_on_this_machine(report):
    """OUT/history/MACHINE/COMMIT.json holds the machine, the commit and, for each judged run, the
    same verdict, channel differences, tolerances and wall time as the case page's record; the
    index links the history page, which says there is one commit so far."""
    me, rev = history.machine(), results.git_commit()
    commit = rev.removesuffix("+dirty") or f"{__version__}-{registry.source_sha256()[:12]}"
    path = report / "history" / me["name"] / f"{commit}{'+dirty' if rev.endswith('+dirty') else ''}.json"
    rec = json.loads(path.read_text())
    assert rec["machine"]["name"] == me["name"] and rec["machine"]["cores"] == me["cores"]
    assert {"hostname", "cpu", "memory_gb", "os", "python"} <= rec["machine"].keys()
    assert rec["commit"]["id"] == commit and rec["commit"]["dirty"] == rev.endswith("+dirty")
    assert history.seconds(rec["recorded"]) is not None

    page = json.loads((report / "cantilever_step" / "page.json").read_text())
    runs = {e["solver"]: e for e in rec["runs"]}
    assert sorted(runs) == sorted(o["solver"] for o in page["runs"])
    for o in page["runs"]:
        e = runs[o["solver"]]
        assert (e["case"], e["status"], e["verdict"], e["wall_s"]) == (o["case"], o["status"][0], o["verdict"][0],
                                                                       o["wall_s"])
    mine = [r for r in page["accuracy"] if r["solver"] == "analytic"]
    assert mine and runs["analytic"]["channels"] == {r["channel"]: {"rms": r["rms"], "tolerance": r["tolerance"]}
                                                     for r in mine}
    assert runs["analytic"]["worst_over_tolerance"] == max(r["rms"] / r["tolerance"] for r in mine)
    assert runs["fe-linear"]["verdict"] == "reference" and runs["fe-linear"]["worst_over_tolerance"] is None

    assert "<a href='history.html'>history</a>" in (report / "index.html").read_text()
    assert "[history](history.md)" in (report / "index.md").read_text()
    text = (report / "history.html").read_text()
    assert "Only one commit has report records so far" in text and "<h2>cantilever_step</h2>" in text
    for src in re.findall(r"src='([^']+)'", text):
        assert (report / src).is_file() and (report / src).with_suffix(".svg").is_file(), src
    from markdown_it import MarkdownIt                 # every Markdown table renders as one
    md = (report / "history.md").read_text()
    assert MarkdownIt("commonmark").enable("table").render(md).count("<table>") == md.count("\n|---") > 3


def test_a_machine_s_name_and_the_page_s_key(monkeypatch):
    """A machine's name ends in the digest of its CPU model and core count it had before every key
    went through `version.cache_key` (its records' folder); the history page's key
    (`history_page_key`) changes with a record, the order of the commits and the source."""
    monkeypatch.setattr(history, "cpu_model", lambda: "Test CPU 3000")
    monkeypatch.setattr(history.os, "cpu_count", lambda: 8)
    assert history.machine()["name"].endswith("-911d5b")
    assert not hasattr(history, "page_key")                 # one name per meaning: report.build.page_key is a case page's
    recs = [{"file": "a.json", "x": 1}]
    key = history.history_page_key(recs, ["abc"])
    assert re.fullmatch("[0-9a-f]{64}", key) and key == history.history_page_key([dict(recs[0])], ["abc"])
    assert key not in {history.history_page_key([{"file": "a.json", "x": 2}], ["abc"]),
                       history.history_page_key(recs, ["abd"])}
    monkeypatch.setattr(registry, "source_sha256", lambda: "0" * 64)
    assert history.history_page_key(recs, ["abc"]) != key


def test_two_commits_are_ordered_by_git_and_others_by_record_time(tmp_path, monkeypatch):
    """Commits git knows follow its topology whatever their record times; the others fall in by
    the time they were first recorded; a dirty record right after its commit."""
    known = [("aaaa111" + "0" * 33, 1000.0, "1970-01-01T00:16:40+00:00", "the first"),
             ("bbbb222" + "0" * 33, 2000.0, "1970-01-01T00:33:20+00:00", "the second")]
    monkeypatch.setattr(history, "topology", lambda: known)
    first = {"bbbb222": 10.0, "aaaa111": 3000.0, "aaaa111+dirty": 3100.0, "cccc333": 1500.0, "dddd444": 9000.0,
             "eeee555": 500.0}
    assert history.order(first, known) == ["eeee555", "aaaa111", "aaaa111+dirty", "cccc333", "bbbb222", "dddd444"]

    out = tmp_path / "rep"
    for rev, hour, wall in [("bbbb222", 10, 0.5), ("aaaa111", 11, 0.8)]:
        fake(monkeypatch, rev, f"2026-12-02T{hour}:00:00+00:00")
        history.record(out, [outcome("beam", "flexmbd", wall=wall), outcome("beam", "ref", "reference", wall=2.0)],
                       [row("beam", "flexmbd")])
    history.page(out)
    md = (out / "history.md").read_text()
    shown = commits_table(md)
    assert shown.index("aaaa111") < shown.index("bbbb222")           # newer record, older commit
    assert "| aaaa111 | 1970-01-01 00:16 | the first |" in md          # date and subject from git
    assert "Only one commit" not in md
    latest = next(line for line in md.splitlines() if line.startswith("| flexmbd | box-000000"))
    assert "| bbbb222 |" in latest and "-38 %" in latest and latest.rstrip(" |").endswith("aaaa111")


def test_this_checkout_s_head_is_in_git_s_order():
    rev = results.git_commit().removesuffix("+dirty")
    if not rev:
        pytest.skip("not a git checkout")
    assert any(sha.startswith(rev) for sha, *_ in history.topology())


def test_a_dirty_tree_is_marked_and_a_tree_outside_git_named_by_version_and_source(tmp_path, monkeypatch):
    out = tmp_path / "rep"
    fake(monkeypatch, "abc1234+dirty", "2026-12-02T10:00:00+00:00")
    path = history.record(out, [outcome("beam", "flexmbd")], [row("beam", "flexmbd")])
    assert path == out / "history" / "box-000000" / "abc1234+dirty.json"
    rec = json.loads(path.read_text())
    assert rec["commit"]["id"] == "abc1234" and rec["commit"]["dirty"] is True
    history.page(out)
    assert "abc1234+dirty" in commits_table((out / "history.md").read_text())

    monkeypatch.setattr(results, "git_commit", lambda: "")
    path = history.record(out, [outcome("beam", "flexmbd")], [row("beam", "flexmbd")])
    assert path.name == f"{__version__}-{registry.source_sha256()[:12]}.json"
    assert json.loads(path.read_text())["commit"]["dirty"] is False


def test_a_later_report_at_the_same_commit_replaces_its_runs_and_keeps_the_others(tmp_path, monkeypatch):
    out = tmp_path / "rep"
    fake(monkeypatch, "abc1234", "2026-12-02T10:00:00+00:00")
    path = history.record(out, [outcome("beam", "flexmbd", wall=1.0), outcome("plate", "flexmbd", wall=3.0)],
                          [row("beam", "flexmbd"), row("plate", "flexmbd")])
    fake(monkeypatch, "abc1234", "2026-12-02T11:00:00+00:00")
    history.record(out, [outcome("beam", "flexmbd", wall=2.0)], [row("beam", "flexmbd")])
    rec = json.loads(path.read_text())
    assert {(e["case"], e["wall_s"]) for e in rec["runs"]} == {("beam", 2.0), ("plate", 3.0)}
    assert rec["recorded"] == "2026-12-02T11:00:00+00:00"
    before = path.read_bytes()
    fake(monkeypatch, "abc1234", "2026-12-02T12:00:00+00:00")       # nothing changed: the record stays
    history.record(out, [outcome("beam", "flexmbd", wall=2.0)], [row("beam", "flexmbd")])
    assert path.read_bytes() == before


def test_a_corrupt_record_is_one_line_naming_it(tmp_path, monkeypatch, capsys):
    out = tmp_path / "rep"
    bad = out / "history" / "box-000000" / "abc1234.json"
    bad.parent.mkdir(parents=True)
    bad.write_text("{not json")
    assert main(["history", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and str(bad) in err and "not a history record" in err
    assert "Traceback" not in err

    said = []                                          # a report's page: left out, with a warning
    history.page(out, said.append)
    assert len(said) == 1 and str(bad) in said[0] and (out / "history.html").is_file()

    other = tmp_path / "other" / "history" / "box-111111"
    other.mkdir(parents=True)
    (other / "abc1234.json").write_text(json.dumps({"machine": {"name": "box-111111"}, "commit": {"id": "abc1234"},
                                                    "recorded": "2026-12-02T10:00:00+00:00"}))
    assert main(["history", "--out", str(out), "--add", str(tmp_path / "other")]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and str(other / "abc1234.json") in err and "runs is not a list" in err
    assert not (out / "history" / "box-111111").exists()


def test_another_machine_s_records_are_added_and_drawn_beside_ours(tmp_path, monkeypatch, capsys):
    ours, theirs = tmp_path / "ours", tmp_path / "theirs"
    fake(monkeypatch, "abc1234", "2026-12-02T10:00:00+00:00")
    history.record(ours, [outcome("beam", "flexmbd")], [row("beam", "flexmbd")])
    fake(monkeypatch, "abc1234", "2026-12-02T09:00:00+00:00", host="far-222222")
    history.record(theirs, [outcome("beam", "flexmbd", wall=9.0)], [row("beam", "flexmbd")])
    monkeypatch.undo()
    assert main(["history", "--out", str(ours), "--add", str(theirs)]) == 0
    assert "1 record added" in capsys.readouterr().out
    assert (ours / "history" / "far-222222" / "abc1234.json").is_file()
    md = (ours / "history.md").read_text()
    assert "| flexmbd | far-222222 | abc1234 |" in md and "| flexmbd | box-000000 | abc1234 |" in md
    assert main(["history", "--out", str(ours), "--add", str(theirs / "history")]) == 0   # the same, not newer
    assert "0 records added" in capsys.readouterr().out


def test_the_stored_bench_runs_are_read_and_a_bench_run_kept_beside_them(tmp_path, monkeypatch):
    stored = history.stored_bench(resources.HISTORY)
    got = {history.label(r): r for r in stored}
    assert "9af03fa" in got and got["9af03fa"]["machine"]["name"] == history.PROJECT
    assert got["9af03fa"]["recorded"] == "2026-12-01" and "b5ab8cc" in got       # DATE_COMMIT_NOTE.json
    assert got["a1f709f"]["recorded"] == "2026-12-03T2103"                     # DATETHHMM_COMMIT.json
    order = [history.label(r) for r in stored]                                  # oldest first, by date and time
    assert order.index("9af03fa") < order.index("d7370be") < order.index("8fd4385") < order.index("a1f709f")
    raw = json.loads((resources.HISTORY / "2026-12-01_9af03fa.json").read_text())
    series = history.bench_series(stored)
    assert series["exponent"][("flexible chain", history.PROJECT)]["9af03fa"] == raw["flexible_chain_exponent"]
    assert series["compile"][("first (empty cache)", history.PROJECT)]["9af03fa"] == raw["compile_s"]["cold_s"]
    n = raw["rigid_chain"][-1]["n"]
    assert series["rigid"][(f"n = {n}", history.PROJECT)]["9af03fa"] == raw["rigid_chain"][-1]["ratio"]

    out = tmp_path / "rep"
    fake(monkeypatch, "abc1234", "2026-12-02T10:00:00+00:00")
    path = history.keep_bench(out, {**raw, "flexible_chain_exponent": 1.5})
    assert path.name == "abc1234-bench.json"
    history.page(out)
    md = (out / "history.md").read_text()
    assert "## Benchmarks" in md and "| abc1234 | box-000000 |" in md and "| 9af03fa | project machine |" in md

    fake(monkeypatch, "abc1234", "2026-12-02T11:00:00+00:00")       # a new record: the page drawn again,
    history.record(out, [outcome("beam", "flexmbd")], [row("beam", "flexmbd")])
    monkeypatch.setattr(history, "bench_figure", lambda *a: pytest.fail("bench figure drawn again"))
    history.page(out)                                                # the unchanged bench figure copied
    assert "## beam" in (out / "history.md").read_text()


def test_a_bench_run_written_to_a_report_folder_is_kept_in_its_history(tmp_path, monkeypatch, capsys):
    from flexmbd.report import bench
    raw = json.loads((resources.HISTORY / "2026-12-01_9af03fa.json").read_text())
    monkeypatch.setattr(bench, "run", lambda **k: raw)
    monkeypatch.setattr(bench, "plots", lambda result, folder: [])
    fake(monkeypatch, "abc1234", "2026-12-02T10:00:00+00:00")
    assert main(["bench", "--out", str(tmp_path / "rep" / "bench")]) == 0
    kept = tmp_path / "rep" / "history" / "box-000000" / "abc1234-bench.json"
    assert history.read(kept)["bench"] == files.jsonable(raw)                  # NaN (a diverged run) as null
    assert main(["bench", "--out", str(tmp_path / "elsewhere")]) == 0          # not a report folder's bench
    assert [p.name for p in tmp_path.rglob("*-bench.json")] == [kept.name]
