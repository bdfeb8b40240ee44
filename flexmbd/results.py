"""Results of one solver on one case: a CSV table (`t` plus channels) and a JSON sidecar.

Both files are written atomically (temporary file in the same folder, then `os.replace`), so an
interrupted run never leaves a half-written result behind.
"""

from __future__ import annotations

import datetime
import json
import os
import platform
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path

import numpy as np
import pandas as pd

DEPENDENCIES = ("numpy", "scipy", "pandas", "matplotlib", "exudyn", "pin", "mujoco")


@dataclass
class Result:
    """One run. `t` (n,) s; `channels` name -> (n,) array in SI units; `status` 'ok' or 'failed: why'."""

    solver: str
    case: str
    t: np.ndarray = field(default_factory=lambda: np.zeros(0))
    channels: dict = field(default_factory=dict)
    status: str = "ok"
    solver_version: str = ""
    settings: dict = field(default_factory=dict)
    wall_s: float = 0.0           # solve only
    setup_s: float = 0.0          # pre-processing, model building
    steps: int = 0
    rhs_evals: int = 0
    case_sha256: str = ""
    extra: dict = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def table(self) -> pd.DataFrame:
        cols = {"t": np.asarray(self.t)}
        cols.update({k: np.asarray(v) for k, v in self.channels.items()})
        return pd.DataFrame(cols)


def git_commit() -> str:
    """The commit of the source tree, with '+dirty' when it has uncommitted changes ('' outside git)."""
    root = Path(__file__).resolve().parent.parent
    try:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=root, capture_output=True,
                             text=True, timeout=5).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=root,
                               capture_output=True, text=True, timeout=5).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return ""
    return rev + ("+dirty" if rev and dirty else "")


def environment() -> dict:
    """Python, dependency versions, machine: provenance stored with every result."""
    versions = {}
    for name in DEPENDENCIES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = None
    return {"python": sys.version.split()[0], "versions": versions, "git_commit": git_commit(),
            "machine": f"{platform.machine()} {platform.system()} {os.cpu_count()} cpu",
            "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")}


def sidecar(r: Result) -> dict:
    """The JSON sidecar of a result."""
    return {"solver": r.solver, "solver_version": r.solver_version, "case": r.case,
            "case_sha256": r.case_sha256, "status": r.status, "settings": r.settings,
            "wall_s": r.wall_s, "setup_s": r.setup_s, "steps": r.steps, "rhs_evals": r.rhs_evals,
            "samples": int(len(r.t)), "channels": list(r.channels), **r.extra, **environment()}


def _atomic_write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as f:
            f.write(text)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write(r: Result, out_dir: Path) -> tuple[Path, Path]:
    """Write `out_dir/CASE/SOLVER.csv` and `.json`; return both paths. A run without samples
    (unavailable, or failed before the first output) writes the sidecar only."""
    base = Path(out_dir) / r.case
    csv, js = base / f"{r.solver}.csv", base / f"{r.solver}.json"
    if len(r.t):
        _atomic_write(csv, r.table().to_csv(index=False, float_format="%.10g"))
    else:
        csv.unlink(missing_ok=True)
    _atomic_write(js, json.dumps(sidecar(r), indent=2) + "\n")
    return csv, js


def read(out_dir: Path, case: str, solver: str) -> Result:
    """Read a stored result back."""
    base = Path(out_dir) / case
    meta = json.loads((base / f"{solver}.json").read_text())
    csv = base / f"{solver}.csv"
    df = pd.read_csv(csv) if csv.exists() else pd.DataFrame({"t": []})
    known = set(sidecar(Result(solver=solver, case=case)))
    return Result(solver=solver, case=case, t=df["t"].to_numpy(),
                  channels={c: df[c].to_numpy() for c in df.columns if c != "t"},
                  status=meta["status"], solver_version=meta.get("solver_version", ""),
                  settings=meta.get("settings", {}), wall_s=meta.get("wall_s", 0.0),
                  setup_s=meta.get("setup_s", 0.0), steps=meta.get("steps", 0),
                  rhs_evals=meta.get("rhs_evals", 0), case_sha256=meta.get("case_sha256", ""),
                  extra={k: v for k, v in meta.items() if k not in known})
