"""Shell completion (completion.py): the generated bash script completes what the parser takes."""

from __future__ import annotations

import shutil
import subprocess

import pytest

from flexmbd import cases
from flexmbd.cli import completion
from flexmbd.harness import registry
from flexmbd.cli import parser

pytestmark = [pytest.mark.kernel_free, pytest.mark.skipif(shutil.which("bash") is None, reason="no bash")]


def complete(tmp_path, *words) -> list[str]:
    """COMPREPLY of the script for the command line `words` (the last one being completed)."""
    script = tmp_path / "flexmbd.bash"
    script.write_text(completion.bash(parser(), cases.available(), registry.NAMES))
    line = " ".join(f"'{w}'" for w in words)
    run = (f"source {script}; COMP_WORDS=({line}); COMP_CWORD={len(words) - 1}; _flexmbd; "
           "printf '%s\\n' \"${COMPREPLY[@]}\"")
    out = subprocess.run(["bash", "-c", run], capture_output=True, text=True, cwd=tmp_path, check=True).stdout
    return [w for w in out.splitlines() if w]


def test_commands_options_and_choices(tmp_path):
    assert complete(tmp_path, "flexmbd", "re") == ["report", "regress"]
    assert complete(tmp_path, "flexmbd", "run", "pendulum", "--so") == ["--solver"]
    assert complete(tmp_path, "flexmbd", "modes", "pendulum", "--about", "e") == ["equilibrium"]
    assert complete(tmp_path, "flexmbd", "completion", "") == ["bash"]       # a positional's choices


def test_cases_and_solvers_and_comma_lists(tmp_path):
    assert complete(tmp_path, "flexmbd", "run", "--json", "pend") == ["pendulum"]
    assert complete(tmp_path, "flexmbd", "run", "pendulum", "--solver", "exudyn-") == ["exudyn-ffrf", "exudyn-beam"]
    assert complete(tmp_path, "flexmbd", "report", "--solvers", "flexmbd,exudyn-b") == ["flexmbd,exudyn-beam"]
    assert complete(tmp_path, "flexmbd", "report", "--cases", "canti") == ["cantilever_solid", "cantilever_step"]


def test_file_names_where_a_path_goes(tmp_path):
    (tmp_path / "mine.csv").write_text("t\n")
    (tmp_path / "my_case.toml").write_text("")
    assert complete(tmp_path, "flexmbd", "import", "pendulum", "mi") == ["mine.csv"]
    assert complete(tmp_path, "flexmbd", "import", "pendulum", "mine.csv", "--meta", "mi") == ["mine.csv"]
    assert complete(tmp_path, "flexmbd", "run", "my") == ["my_case.toml"]


def test_every_option_of_the_parser_is_offered(tmp_path):
    for name, (opts, _, _, _) in completion.options(parser()).items():
        assert set(complete(tmp_path, "flexmbd", name, "--")) == {o for o in opts if o.startswith("--")}, name
