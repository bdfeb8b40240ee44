"""Results of one solver on one case: the run status, a CSV table (`t` plus channels) and a
JSON sidecar.

Every solver's run ends in one `Status` (ok / failed with why and when / not applicable /
unavailable), and one rule (`first_failure`) says when a run has diverged. The CSV and the JSON
are a pair: both are written to temporary files, then swapped in with SIGINT and SIGTERM
deferred, and the JSON records the CSV's SHA-256, so a reader sees the old pair or the new one and
`read` refuses a CSV that does not belong to its JSON.
"""

from __future__ import annotations

import datetime
import hashlib
import io
import json
import os
import platform
import re
import subprocess
import sys
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path

import numpy as np
import pandas as pd

from flexmbd.errors import InputError
from flexmbd.files import signals_held, temporary, unusable

DEPENDENCIES = ("numpy", "scipy", "pandas", "matplotlib", "numba", "exudyn", "pin", "mujoco")

# ---------------------------------------------------------------------------------------------
# the run status

KINDS = ("ok", "failed", "not applicable", "unavailable")


@dataclass(frozen=True)
class Status:
    """What became of a run, the same for every solver: `kind` one of KINDS; `why` says why for
    every kind but ok; `t` (s) is when a failed run failed, None when that is not known. An ok
    run of a model outside its linear validity (`outside_validity`) carries what was exceeded in
    `why` and when in `t`. str() gives the one line shown in tables and stored in sidecars."""

    kind: str = "ok"
    why: str = ""
    t: float | None = None

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"status kind {self.kind!r}")

    @property
    def ok(self) -> bool:
        return self.kind == "ok"

    @property
    def outside(self) -> bool:
        """An ok run outside its model's linear validity."""
        return self.kind == "ok" and bool(self.why)

    def __str__(self) -> str:
        at = f" at t = {self.t:.6g} s" if self.t is not None else ""
        if self.kind == "ok":
            return f"ok, outside linear validity ({self.why}{at})" if self.why else "ok"
        return f"{self.kind}: {self.why}{at}"

    @classmethod
    def parse(cls, text: str) -> "Status":
        """The Status whose str() is `text`."""
        if text.startswith("ok, outside linear validity (") and text.endswith(")"):
            inner = text[len("ok, outside linear validity ("):-1]
            m = re.fullmatch(r"(.*) at t = ([-+0-9.eE]+|nan|inf) s", inner, re.S)
            return cls("ok", m.group(1), float(m.group(2))) if m else cls("ok", inner)
        kind, _, rest = text.partition(": ")
        if kind == "ok" and not rest:
            return cls()
        if kind not in KINDS[1:]:
            raise ValueError(f"not a run status: {text!r}")
        m = re.fullmatch(r"(.*) at t = ([-+0-9.eE]+|nan|inf) s", rest, re.S)
        return cls(kind, m.group(1), float(m.group(2))) if m else cls(kind, rest)


def failed(why: str, t: float | None = None) -> Status:
    return Status("failed", why, None if t is None else float(t))


def outside_validity(why: str, t: float | None = None) -> Status:
    """An ok run whose model left its linear validity: `why` names the limit passed (the largest
    excess), `t` when."""
    return Status("ok", why, None if t is None else float(t))


def not_applicable(why: str) -> Status:
    return Status("not applicable", why)


def unavailable(why: str) -> Status:
    return Status("unavailable", why)


# the divergence rule, one for every solver: see `first_failure`
DIVERGED_V = 1e8            # |v| of a solver's velocity state (rad/s, m/s, modal units)
DIVERGED_LENGTHS = 2.0      # a deflection beyond twice its beam's length


def first_failure(t, channels: dict, bounds: dict) -> tuple[int, Status] | None:
    """The first output sample at which a run has failed, and why; None when it has not.

    A run fails where any channel is not finite, or where a channel exceeds its bound in
    `bounds` (channel -> largest plausible magnitude: a deflection bound is DIVERGED_LENGTHS
    times its beam's length, which no beam reaches without stretching).
    t (n,) s; channels: name -> (n,).
    """
    first = None
    for name, y in channels.items():
        y = np.asarray(y, dtype=float)
        bad = ~np.isfinite(y)
        if bounds.get(name) is not None:
            bad |= np.abs(np.where(bad, 0.0, y)) > bounds[name]
        hit = np.flatnonzero(bad)
        if hit.size and (first is None or hit[0] < first[0]):
            why = (f"non-finite {name}" if not np.isfinite(y[hit[0]]) else
                   f"diverged (|{name}| beyond {bounds[name]:g} m, {DIVERGED_LENGTHS:g} beam lengths)")
            first = (int(hit[0]), failed(why, t[hit[0]]))
    return first


# ---------------------------------------------------------------------------------------------
# one run


@dataclass
class Result:
    """One run. `t` (n,) s; `channels` name -> (n,) array in SI units; a failed run keeps the
    samples computed before it failed. `trajectory` is the solver-neutral trajectory the
    channels were computed from, handed by a solver's run to `solvers.run` (never stored)."""

    solver: str
    case: str
    t: np.ndarray = field(default_factory=lambda: np.zeros(0))
    channels: dict = field(default_factory=dict)
    status: Status = field(default_factory=Status)
    solver_version: str = ""
    settings: dict = field(default_factory=dict)
    wall_s: float = 0.0           # solve only
    setup_s: float = 0.0          # pre-processing, model building
    steps: int = 0
    rhs_evals: int = 0
    case_sha256: str = ""
    extra: dict = field(default_factory=dict)
    trajectory: object = field(default=None, repr=False, compare=False)

    @property
    def ok(self) -> bool:
        return self.status.ok

    def truncate(self, n: int) -> None:
        """Keep the first n samples."""
        self.t = np.asarray(self.t)[:n]
        self.channels = {k: np.asarray(v)[:n] for k, v in self.channels.items()}

    def table(self) -> pd.DataFrame:
        cols = {"t": np.asarray(self.t)}
        cols.update({k: np.asarray(v) for k, v in self.channels.items()})
        return pd.DataFrame(cols)


def git_commit() -> str:
    """The commit of the source tree, with '+dirty' when the code or the case files (flexmbd/,
    cases/, pyproject.toml: what a result depends on) have uncommitted changes ('' outside git)."""
    root = Path(__file__).resolve().parent.parent
    try:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=root, capture_output=True,
                             text=True, timeout=5).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--",
                                "flexmbd", "cases", "pyproject.toml"], cwd=root,
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


def sidecar(r: Result, csv_sha256: str | None = None) -> dict:
    """The JSON sidecar of a result; `csv_sha256` is the SHA-256 of its CSV (None: no CSV). The
    environment is this process's, unless the result carries its own (`r.extra`: a result read
    back, or one brought in by `flexmbd import`)."""
    return {"solver": r.solver, "solver_version": r.solver_version, "case": r.case,
            "case_sha256": r.case_sha256, "status": str(r.status), "failed_at_s": r.status.t,
            "settings": r.settings, "wall_s": r.wall_s, "setup_s": r.setup_s, "steps": r.steps,
            "rhs_evals": r.rhs_evals, "samples": int(len(r.t)), "channels": list(r.channels),
            "csv_sha256": csv_sha256, **environment(), **r.extra}


SIDECAR_KEYS = {"solver", "solver_version", "case", "case_sha256", "status", "failed_at_s", "settings", "wall_s",
                "setup_s", "steps", "rhs_evals", "samples", "channels", "csv_sha256"}


def sha256(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()


def folder(out) -> Path:
    """Where the results of a report folder OUT live: OUT/results/CASE/SOLVER.{csv,json}, the one
    layout of `run`, `import`, `compare`, `report` and `regress --results`."""
    return Path(out) / "results"


def imported(out_dir: Path, case: str) -> list[str]:
    """Names of the results of a case brought in with `flexmbd import` (their sidecar has the key
    `imported`), in name order; unreadable sidecars are left to `read` to report."""
    names = []
    for js in sorted((Path(out_dir) / case).glob("*.json")):
        try:
            meta = json.loads(js.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            continue
        if isinstance(meta, dict) and "imported" in meta and meta.get("solver") == js.stem:
            names.append(js.stem)
    return names


def write(r: Result, out_dir: Path) -> tuple[Path, Path]:
    """Write `out_dir/CASE/SOLVER.csv` and `.json` as a pair; return both paths. A run without
    samples (unavailable, or failed before the first output) has no CSV."""
    base = Path(out_dir) / r.case
    csv, js = base / f"{r.solver}.csv", base / f"{r.solver}.json"
    table = r.table().to_csv(index=False, float_format="%.10g") if len(r.t) else None
    meta = json.dumps(sidecar(r, sha256(table) if table is not None else None), indent=2) + "\n"
    tmps = []
    try:
        tmps = [temporary(csv, table) if table is not None else None, temporary(js, meta)]
        with signals_held():
            if table is not None:
                os.replace(tmps[0], csv)
            else:
                csv.unlink(missing_ok=True)
            os.replace(tmps[1], js)
    finally:
        for tmp in tmps:
            if tmp is not None:
                Path(tmp).unlink(missing_ok=True)
    return csv, js


def read_text(path: Path) -> str:
    """A stored file's text; an InputError naming it when it is missing, unreadable or not text."""
    try:
        return Path(path).read_bytes().decode("utf-8")
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a text file (undecodable bytes)") from None
    except OSError as e:
        raise unusable(path, e, "cannot be read") from None


def read_table(path: Path, text: str, columns: list | None = None, samples: int | None = None,
               comment: str | None = None) -> pd.DataFrame:
    """A stored table (`t` and channels) from its text, checked: parseable, a `t` column
    (and exactly `columns` when given), `samples` rows when given, every cell a finite number,
    `t` increasing. An InputError naming `path` and the first problem otherwise."""
    try:
        df = pd.read_csv(io.StringIO(text), comment=comment)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, ValueError) as e:
        raise InputError(f"{path}: not a table ({' '.join(str(e).split()) or type(e).__name__})") from None
    if "t" not in df.columns:
        raise InputError(f"{path}: no `t` column (columns: {', '.join(map(str, df.columns)) or 'none'})")
    if columns is not None and list(df.columns) != list(columns):
        raise InputError(f"{path}: columns {', '.join(map(str, df.columns))}, expected {', '.join(columns)}")
    if samples is not None and len(df) != samples:
        raise InputError(f"{path}: {len(df)} rows, expected {samples} (truncated or extended)")
    for c in df.columns:
        if not pd.api.types.is_numeric_dtype(df[c]) or pd.api.types.is_bool_dtype(df[c]):
            bad = pd.to_numeric(df[c], errors="coerce").isna() & df[c].notna()
            row = int(np.flatnonzero(bad.to_numpy())[0]) if bad.any() else 0
            raise InputError(f"{path}: column {c}, row {row + 1}: not a number ({str(df[c].iloc[row])[:20]!r})")
        y = df[c].to_numpy(dtype=float)
        if not np.all(np.isfinite(y)):
            row = int(np.flatnonzero(~np.isfinite(y))[0])
            raise InputError(f"{path}: column {c}, row {row + 1}: {y[row]} (every value must be a finite number)")
    if len(df) > 1 and not np.all(np.diff(df["t"].to_numpy(dtype=float)) > 0):
        raise InputError(f"{path}: column t is not increasing")
    return df


def read(out_dir: Path, case: str, solver: str) -> Result:
    """Read a stored result back, checked: the JSON sidecar parses and belongs to (case,
    solver), its CSV belongs to it (the SHA-256) and is a table of `t` and the sidecar's
    channels with its number of samples, every value finite. Anything else is an InputError
    naming the file."""
    base = Path(out_dir) / case
    js, csv = base / f"{solver}.json", base / f"{solver}.csv"
    if not js.is_file():
        raise InputError(f"{js}: missing (no stored result of {solver} on {case})")
    try:
        meta = json.loads(read_text(js))
    except json.JSONDecodeError as e:
        raise InputError(f"{js}: not a result sidecar (JSON error: {e.msg}, line {e.lineno})") from None
    if not isinstance(meta, dict) or not {"status", "solver", "case", "samples", "channels"} <= set(meta):
        raise InputError(f"{js}: not a result sidecar (expected the keys status, solver, case, samples, channels)")
    if (meta["case"], meta["solver"]) != (case, solver):
        raise InputError(f"{js}: holds {meta['solver']} on {meta['case']}, not {solver} on {case}")
    try:
        status = Status.parse(str(meta["status"]))
        samples, chans = int(meta["samples"]), [str(c) for c in meta["channels"]]
    except (TypeError, ValueError) as e:
        raise InputError(f"{js}: not a result sidecar ({e})") from None
    want = meta.get("csv_sha256")
    if want is None and samples == 0:
        df = pd.DataFrame({"t": []})
    else:
        if not csv.is_file():
            raise InputError(f"{csv}: missing (its sidecar {js.name} lists {samples} samples)")
        text = read_text(csv)
        if want is not None and sha256(text) != want:
            raise InputError(f"{csv}: does not belong to {js.name} (written by another run, or changed)")
        df = read_table(csv, text, ["t"] + chans, samples)
    if "shapes" in meta:
        check_shapes(js, meta["shapes"])
    if status.kind == "failed" and meta.get("failed_at_s") is not None:
        status = Status("failed", status.why, float(meta["failed_at_s"]))
    return Result(solver=solver, case=case, t=df["t"].to_numpy(dtype=float),
                  channels={c: df[c].to_numpy(dtype=float) for c in df.columns if c != "t"},
                  status=status, solver_version=meta.get("solver_version", ""),
                  settings=meta.get("settings", {}), wall_s=meta.get("wall_s", 0.0),
                  setup_s=meta.get("setup_s", 0.0), steps=meta.get("steps", 0),
                  rhs_evals=meta.get("rhs_evals", 0), case_sha256=meta.get("case_sha256", ""),
                  extra={k: v for k, v in meta.items() if k not in SIDECAR_KEYS})


def check_shapes(path: Path, shapes) -> None:
    """A sidecar's deformed-shape snapshots (`channels.shapes`): per beam, x (nx,) m and t (k,) s
    lists and u (k, nx, 3) nested lists, of finite numbers. An InputError naming the file and
    the key otherwise."""
    def finite(v, depth: int) -> bool:
        if depth == 0:
            return (isinstance(v, float) and bool(np.isfinite(v))) or (type(v) is int and abs(v) < 1e300)
        return isinstance(v, list) and all(finite(e, depth - 1) for e in v)

    if not isinstance(shapes, dict):
        raise InputError(f"{path}: shapes: expected a table of beams, each with x, t and u")
    for body, s in shapes.items():
        key = f"shapes.{body}"
        if not isinstance(s, dict) or set(s) != {"x", "t", "u"}:
            raise InputError(f"{path}: {key}: expected a table with the keys x, t and u")
        for k, depth in (("x", 1), ("t", 1), ("u", 3)):
            if not finite(s[k], depth):
                raise InputError(f"{path}: {key}.{k}: expected {'nested lists [t][x][3]' if depth == 3 else 'a list'} "
                                 f"of finite numbers")
        want = f"len(t) x len(x) x 3 = {len(s['t'])} x {len(s['x'])} x 3 (at least one instant and two points)"
        sizes = [{len(s["u"])}, {len(row) for row in s["u"]}, {len(p) for row in s["u"] for p in row}]
        if any(len(n) > 1 for n in sizes):
            raise InputError(f"{path}: {key}.u: rows of unequal lengths, expected {want}")
        got = [n.pop() if n else 0 for n in sizes]
        if got != [len(s["t"]), len(s["x"]), 3] or not s["t"] or len(s["x"]) < 2:
            raise InputError(f"{path}: {key}.u: {' x '.join(map(str, got))} numbers, expected {want}")


def stale(r: Result, case_sha256: str, channels) -> str:
    """Why a stored result does not belong to the current case ('' when it does): another case
    hash (the case changed since the run), or a channel the case does not have."""
    extra = [c for c in r.channels if c not in channels]
    if extra:
        return f"channel {extra[0]} is not one of the case's channels"
    if r.case_sha256 != case_sha256:
        return f"run for another version of the case (case sha256 {r.case_sha256 or 'none'}, now {case_sha256})"
    return ""
