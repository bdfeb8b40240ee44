"""The capability table: generated from each solver's own `applies` on probe cases, and the table
of docs/solvers.md is that table."""

import json
import re
from pathlib import Path

import pytest

from flexmbd.harness import capabilities, registry
from flexmbd import cli

pytestmark = pytest.mark.kernel_free

DOC = Path(__file__).resolve().parents[2] / "docs" / "solvers.md"


def doc_table() -> str:
    """The Markdown table of docs/solvers.md (its lines that start with '|')."""
    return "".join(line + "\n" for line in DOC.read_text().splitlines() if line.startswith("|"))


def test_docs_table_is_the_generated_one():
    missing = [s for s in registry.BUILT_IN if registry.unavailable_reason(s)]
    if missing:
        pytest.skip(f"not installed here: {', '.join(missing)}")
    assert doc_table() == capabilities.markdown(capabilities.table(registry.BUILT_IN))


def test_table_follows_applies():
    tab = capabilities.table(["flexmbd", "mujoco-rod", "pinocchio"])
    assert all(v == "yes" for v in tab["flexmbd"].values())          # the in-house solver models every feature
    if tab["mujoco-rod"]["beams"] != "unavailable":
        assert tab["mujoco-rod"]["prescribed motion"] == "no"          # its applies: "prescribed motion is not modelled"
        assert tab["mujoco-rod"]["rigid bodies"] == "no"
    if tab["pinocchio"]["beams"] != "unavailable":
        assert tab["pinocchio"]["beams"] == "rigid" and tab["pinocchio"]["stress"] == "no"


def test_probes_are_valid_cases():
    for feature, probes in capabilities.FEATURES.items():
        for p in probes:
            case = capabilities.case_of(p)
            assert case.bodies, feature


def test_list_solvers(capsys):
    assert cli.main(["list", "--solvers", "--json"]) == 0
    tab = json.loads(capsys.readouterr().out)
    assert set(tab) == set(registry.NAMES)
    assert all(set(row) == set(capabilities.FEATURES) for row in tab.values())
    assert cli.main(["list", "--solvers"]) == 0
    out = capsys.readouterr().out
    assert re.search(r"^\| `flexmbd` \| yes", out, re.M)
