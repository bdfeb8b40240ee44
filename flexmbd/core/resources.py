"""Where flexmbd's own files are: the shipped cases and baselines, and the source checkout.

The cases (`cases/`: the case files, their meshes and convergence tables) and the reference
baselines (`references/baselines/`) are package data under `flexmbd/data`, found through
importlib.resources: in a source checkout `flexmbd/data/cases` and `flexmbd/data/references` are
links to the top-level `cases/` and `references/` (resolved here, so paths read as the checkout's),
in an installed wheel copies of them. The checkout itself (git's commit, the stored benchmark runs
`benchmarks/history`) exists only when flexmbd runs from one; an installed package has none.
"""

from importlib.resources import files
from pathlib import Path

DATA = Path(str(files("flexmbd") / "data"))
CASES = (DATA / "cases").resolve()                            # CASE.toml, meshes/, convergence/
BASELINES = (DATA / "references" / "baselines").resolve()     # CASE/SOLVER.csv


def _checkout() -> Path | None:
    """The git checkout flexmbd runs from (the folder holding the package and `.git`), or None."""
    root = Path(__file__).resolve().parents[2]
    return root if (root / ".git").exists() and (root / "pyproject.toml").is_file() else None


CHECKOUT = _checkout()
HISTORY = CHECKOUT / "benchmarks" / "history" if CHECKOUT else None    # the stored `flexmbd bench` runs
