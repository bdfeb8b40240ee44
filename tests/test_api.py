"""The Python API: every code block of docs/api.md and every script in examples/ runs."""

import re
import runpy
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
BLOCKS = re.findall(r"```python\n(.*?)```", (ROOT / "docs" / "api.md").read_text(), re.S)
EXAMPLES = sorted((ROOT / "examples").glob("*.py"))


def test_import_is_cheap():
    import subprocess
    import sys
    out = subprocess.run([sys.executable, "-c", "import flexmbd, sys; print('numba' in sys.modules, "
                          "'flexmbd.solvers' in sys.modules)"], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False"]


@pytest.mark.parametrize("code", BLOCKS, ids=[f"api.md block {k + 1}" for k in range(len(BLOCKS))])
def test_docs_api_block_runs(code):
    assert len(BLOCKS) >= 3
    exec(compile(code, "docs/api.md", "exec"), {})


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.name for p in EXAMPLES])
def test_example_runs(path):
    runpy.run_path(str(path), run_name="__main__")
