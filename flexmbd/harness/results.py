"""Results of one solver on one case: the run status, a CSV table (`t` plus channels) and a
JSON sidecar.

Every solver's run ends in one `Status` (ok / failed with why, when and its cause, diverged or
aborted / not applicable / unavailable), and one rule (`first_failure`) says when a run has
diverged. The CSV and the JSON are a pair: both are written to temporary files, then swapped in
with SIGINT and SIGTERM deferred, and the JSON records the CSV's SHA-256, so a reader sees the old
pair or the new one and `read` refuses a CSV that does not belong to its JSON.
"""

from __future__ import annotations

import dataclasses
import datetime
import functools
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

from flexmbd.core import resources
from flexmbd import version
from flexmbd.core.errors import InputError
from flexmbd.core.files import json_text, swap, temporary, unusable

DEPENDENCIES = ("numpy", "scipy", "pandas", "matplotlib", "numba", "exudyn", "pin", "mujoco")

# ---------------------------------------------------------------------------------------------
# the run status

KINDS = ("ok", "failed", "not applicable", "unavailable")

# the cause of a failed run (Status.cause), one word each: diverged (the divergence rule: a value not
# finite, a bound passed; `first_failure`, `diverged`), aborted (it stopped for any other reason: a step
# size too small, Newton, a solver's error or exception, instants out of order; `failed`)
CAUSES = ("diverged", "aborted")


@dataclass(frozen=True)
class Status:
    """What became of a run, the same for every solver: `kind` one of KINDS; `why` says why for
    every kind but ok; `t` (s) is when a failed run failed, None when that is not known; `cause`
    the class of a failed run, one of CAUSES, set where the failure is made ('' for every other
    kind; a failed status made without one is aborted). An ok run of a model outside its linear
    validity (`outside_validity`) carries what was exceeded in `why` and when in `t`. str() gives
    the one line shown in tables and stored in sidecars (the cause beside it: the sidecar's
    `cause`)."""

    kind: str = "ok"
    why: str = ""
    t: float | None = None
    cause: str = ""

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"status kind {self.kind!r}")
        if self.kind == "failed" and not self.cause:
            object.__setattr__(self, "cause", CAUSES[1])
        if self.cause not in (CAUSES if self.kind == "failed" else ("",)):
            raise ValueError(f"the cause {self.cause!r} of a {self.kind} run (a failed run's: "
                             f"{' or '.join(CAUSES)}; none for any other)")

    @property
    def ok(self) -> bool:
        return self.kind == "ok"

    @property
    def outside(self) -> bool:
        """An ok run outside its model's linear validity."""
        return self.kind == "ok" and bool(self.why)

    @property
    def unread(self) -> bool:
        """An unavailable status a reader gave a stored result it could not use or that was run
        for another version of the case (UNUSABLE, STALE): a reader's words, never a run's."""
        return self.kind == "unavailable" and self.why.startswith((UNUSABLE, STALE))

    def __str__(self) -> str:
        at = f" at t = {self.t:.6g} s" if self.t is not None else ""
        if self.kind == "ok":
            return f"ok, outside linear validity ({self.why}{at})" if self.why else "ok"
        return f"{self.kind}: {self.why}{at}"

    @classmethod
    def parse(cls, text: str) -> "Status":
        """The Status whose str() is `text`; a failed run's cause, which the line does not hold,
        as `derived_cause` reads it from the why (a reader that has the cause, a sidecar's
        `cause`, puts it in: `read`)."""
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
        why, t = (m.group(1), float(m.group(2))) if m else (rest, None)
        return cls(kind, why, t, derived_cause(why) if kind == "failed" else "")


def derived_cause(why: str) -> str:
    """The cause of a failed run whose status was stored as its line alone (a sidecar written
    before sidecars held `cause`, an imported result's metadata): diverged when its why begins as
    the divergence rule's whys began ("diverged ...", "non-finite ..."), else aborted. Never for
    a run made here: its cause is set where its failure is made."""
    return CAUSES[0] if why.startswith(("diverged", "non-finite")) else CAUSES[1]


def failed(why: str, t: float | None = None, cause: str = CAUSES[1]) -> Status:
    """A failed run, aborted unless `cause` says otherwise (`diverged` for the divergence rule)."""
    return Status("failed", why, None if t is None else float(t), cause)


def diverged(why: str, t: float | None = None) -> Status:
    """A failed run that broke the divergence rule (a value not finite, a bound passed)."""
    return failed(why, t, CAUSES[0])


STATE_NOT_FINITE = "non-finite state"  # the why of a peer's run whose state stopped being finite (diverged)


def outside_validity(why: str, t: float | None = None) -> Status:
    """An ok run whose model left its linear validity: `why` names the limit passed (the largest
    excess), `t` when."""
    return Status("ok", why, None if t is None else float(t))


def not_applicable(why: str) -> Status:
    return Status("not applicable", why)


def unavailable(why: str) -> Status:
    return Status("unavailable", why)


# the divergence rule, one for every solver: see `first_failure` (on a velocity state: `integrate.DIVERGED`)
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
            first = (int(hit[0]), diverged(why, t[hit[0]]))
    return first


def disorder(t) -> tuple[int, Status] | None:
    """The first output sample whose instant is not a finite number after the one before it, as
    `first_failure` gives a sample: (k, failed status, aborted, at the last instant in order,
    t[k - 1]); None when t (n,) s increases throughout."""
    t = np.asarray(t, dtype=float)
    bad = ~np.isfinite(t)
    bad[1:] |= ~(np.diff(t) > 0)
    hit = np.flatnonzero(bad)
    if not hit.size:
        return None
    k = int(hit[0])
    if not np.isfinite(t[k]):
        return k, failed(f"column t holds {t[k]} at index {k} (expected finite instants)", t[k - 1] if k else None)
    return k, failed(f"column t does not increase at index {k} ({t[k]:.6g} s after {t[k - 1]:.6g} s)", t[k - 1])


def misshapen(arrays: dict) -> str:
    """'' when each of `arrays` (name -> (value, the shape it must have)) is an array of numbers of
    its shape, else what the first that is not is, against what was expected."""
    for name, (value, want) in arrays.items():
        try:
            shape = np.asarray(value, dtype=float).shape
        except (TypeError, ValueError):
            return f"{name} is not an array of numbers (expected shape {want})"
        if shape != want:
            return f"{name} has shape {shape}, expected {want}"
    return ""


# ---------------------------------------------------------------------------------------------
# one run


@dataclass
class Result:
    """One run. `t` (n,) s; `channels` name -> (n,) array in SI units; a failed run keeps the
    samples computed before it failed. `trajectory` is the solver-neutral trajectory the
    channels were computed from, handed by a solver's run to `registry.run` (never stored)."""

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


@functools.cache
def git_commit() -> str:
    """The commit of the source tree, with '+dirty' when the code or the case files (flexmbd/,
    cases/, pyproject.toml: what a result depends on) have uncommitted changes ('' outside a git
    checkout, `resources.CHECKOUT`: an installed package); read once per process."""
    root = resources.CHECKOUT
    if root is None:
        return ""
    try:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=root, capture_output=True,
                             text=True, timeout=5).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--",
                                "flexmbd", "cases", "pyproject.toml"], cwd=root,
                               capture_output=True, text=True, timeout=5).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return ""
    return rev + ("+dirty" if rev and dirty else "")


@functools.cache
def _versions() -> tuple:
    """(name, version or None) of each of DEPENDENCIES installed here, read once per process."""
    out = []
    for name in DEPENDENCIES:
        try:
            out.append((name, metadata.version(name)))
        except metadata.PackageNotFoundError:
            out.append((name, None))
    return tuple(out)


def environment() -> dict:
    """Python, dependency versions, flexmbd's version and source hash (`version.source_sha256`: what
    pins the code where there is no git commit, an installed package), the git commit, machine:
    provenance stored with every result (the process that ran it: an executor's worker stamps its
    own, `executor.compute`)."""
    return {"python": sys.version.split()[0], "versions": dict(_versions()), "flexmbd_version": version.__version__,
            "source_sha256": version.source_sha256(), "git_commit": git_commit(),
            "machine": f"{platform.machine()} {platform.system()} {os.cpu_count()} cpu",
            "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")}


def sidecar(r: Result, csv_sha256: str | None = None) -> dict:
    """The JSON sidecar of a result; `csv_sha256` is the SHA-256 of its CSV (None: no CSV). The
    environment is this process's, unless the result carries its own (`r.extra`: a result read
    back, or one brought in by `flexmbd import`)."""
    return {"solver": r.solver, "solver_version": r.solver_version, "case": r.case,
            "case_sha256": r.case_sha256, "status": str(r.status), "failed_at_s": r.status.t,
            "cause": r.status.cause, "settings": r.settings, "wall_s": r.wall_s, "setup_s": r.setup_s,
            "steps": r.steps, "rhs_evals": r.rhs_evals, "samples": int(len(r.t)), "channels": list(r.channels),
            "csv_sha256": csv_sha256, **environment(), **r.extra}


SIDECAR_KEYS = {"solver", "solver_version", "case", "case_sha256", "status", "failed_at_s", "cause", "settings",
                "wall_s", "setup_s", "steps", "rhs_evals", "samples", "channels", "csv_sha256"}


def sha256(text: str) -> str:
    """SHA-256 (hex) of a stored table's text: what its sidecar records of it (`version.cache_key`)."""
    return version.cache_key(text)


# a solver's (or an imported result's) name names its files, SOLVER.csv and SOLVER.json: a word
# that is a file name in any file system, never a path
NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._+-]{0,63}")


def bad_name(name) -> str:
    """'' when `name` can name a result's files (registered solvers, plug-ins, `import --solver`),
    else why not: a word of letters, digits and . _ + -, starting with a letter or digit, so that
    no name is a path (`../x`, `a/b`), hidden (`.x`) or holds spaces or control characters."""
    if isinstance(name, str) and NAME.fullmatch(name):
        return ""
    return (f"{name!r} cannot name a result file (letters, digits and . _ + -, at most 64, starting with a "
            f"letter or digit)")


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
            meta = read_json(js)
        except InputError:
            continue
        if isinstance(meta, dict) and "imported" in meta and meta.get("solver") == js.stem:
            names.append(js.stem)
    return names


def write(r: Result, out_dir: Path) -> tuple[Path, Path]:
    """Write `out_dir/CASE/SOLVER.csv` and `.json` as a pair; return both paths. A run without
    samples (unavailable, or failed before the first output) has no CSV. Both are written to
    temporaries and swapped in together (`files.swap`): after any fault or signal the old pair
    is there as it was, and no temporary is left."""
    base = Path(out_dir) / r.case
    csv, js = base / f"{r.solver}.csv", base / f"{r.solver}.json"
    table = r.table().to_csv(index=False, float_format="%.10g") if len(r.t) else None
    meta = json_text(sidecar(r, sha256(table) if table is not None else None), indent=2) + "\n"
    with temporary(js, meta) as new_js:
        if table is None:
            swap([(None, csv), (new_js, js)])
            return csv, js
        with temporary(csv, table) as new_csv:
            swap([(new_csv, csv), (new_js, js)])
    return csv, js


def read_text(path: Path) -> str:
    """A stored file's text; an InputError naming it when it is missing, unreadable or not text."""
    try:
        return Path(path).read_bytes().decode("utf-8")
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a text file (undecodable bytes)") from None
    except OSError as e:
        raise unusable(path, e, "cannot be read") from None


# the largest magnitude of a stored or imported value, as of a case's numbers (cases.LARGEST): the
# comparisons square differences of two values and sum them over the samples, at most
# (2e100)^2 = 4e200 each, which no number of samples brings near the largest double (1.8e308)
LARGEST = 1e100
MAX_DEPTH = 100         # lists and objects nested deeper in a JSON file are refused (`read_json`)


def read_json(path: Path, what: str = "not JSON"):
    """A JSON file's value (a sidecar, an imported result's metadata); an InputError naming it when
    it cannot be read, is not text, is not JSON (`what` says what it is then not), or nests lists
    and objects deeper than MAX_DEPTH (deeper would exhaust the parser's or the writer's recursion)."""
    text = read_text(path)
    deep = InputError(f"{path}: {what} (lists or objects nested more than {MAX_DEPTH} deep)")
    try:
        value = json.loads(text)
    except json.JSONDecodeError as e:
        raise InputError(f"{path}: {what} ({e.msg}, line {e.lineno})") from None
    except ValueError as e:                             # an integer of more digits than Python converts
        raise InputError(f"{path}: {what} ({' '.join(str(e).split())[:80]})") from None
    except RecursionError:
        raise deep from None
    if depth(value) > MAX_DEPTH:
        raise deep
    return value


def depth(value) -> int:
    """How deeply lists and objects nest in a JSON value (0: a number, string or null), counted
    without recursion."""
    deepest, todo = 0, [(value, 0)]
    while todo:
        v, d = todo.pop()
        if isinstance(v, (list, dict)):
            deepest = max(deepest, d + 1)
            todo.extend((e, d + 1) for e in (v.values() if isinstance(v, dict) else v))
    return deepest


def read_table(path: Path, text: str, columns: list | None = None, samples: int | None = None,
               comment: str | None = None) -> pd.DataFrame:
    """A stored table (`t` and channels) from its text, checked: parseable, a `t` column
    (and exactly `columns` when given), `samples` rows when given and at least one row, every cell
    a finite number of magnitude at most LARGEST, `t` increasing. An InputError naming `path` and
    the first problem otherwise."""
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
    if not len(df):
        raise InputError(f"{path}: no rows (a header without values)")
    for c in df.columns:
        if not pd.api.types.is_numeric_dtype(df[c]) or pd.api.types.is_bool_dtype(df[c]):
            bad = pd.to_numeric(df[c], errors="coerce").isna() & df[c].notna()
            row = int(np.flatnonzero(bad.to_numpy())[0]) if bad.any() else 0
            raise InputError(f"{path}: column {c}, row {row + 1}: not a number ({str(df[c].iloc[row])[:20]!r})")
        y = df[c].to_numpy(dtype=float)
        if not np.all(np.isfinite(y)):
            row = int(np.flatnonzero(~np.isfinite(y))[0])
            raise InputError(f"{path}: column {c}, row {row + 1}: {y[row]} (every value must be a finite number)")
        if np.abs(y).max() > LARGEST:
            row = int(np.argmax(np.abs(y) > LARGEST))
            raise InputError(f"{path}: column {c}, row {row + 1}: {y[row]:g} is beyond {LARGEST:g} in magnitude "
                             f"(the comparisons square differences of values, which would overflow)")
    if len(df) > 1 and not np.all(np.diff(df["t"].to_numpy(dtype=float)) > 0):
        raise InputError(f"{path}: column t is not increasing")
    return df


# what the unavailable result of a stored result that cannot be used says, and of one run for
# another version of the case (`report.loading.load_results`): a reader's words, never a run's status
UNUSABLE, STALE = "stored result unusable", "stale stored result"


def _real(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _unknown(v) -> bool:
    """A sidecar's number that is not known: null (as written), or NaN (as older sidecars hold)."""
    return v is None or (_real(v) and v != v)


# the sidecar keys whose unknown value (null) reads as NaN
UNKNOWN_NAN = ("wall_s", "setup_s", "compile_s", "kinetic_max_J")

_TEXT = ("a string", lambda v: isinstance(v, str))
_TABLE = ("a JSON object", lambda v: isinstance(v, dict))
_COUNT = ("a whole number >= 0", lambda v: type(v) is int and 0 <= v <= LARGEST)
_SECONDS = ("a number >= 0 (s), or null when not known", lambda v: _unknown(v) or (_real(v) and 0 <= v <= LARGEST))
_NAMES = ("a list of strings", lambda v: isinstance(v, list) and all(isinstance(c, str) for c in v))

# a sidecar key -> (what it must be, a check), for every key a page, a table or a comparison uses:
# `read` refuses any other value, naming the key, so that none of them meets a value it cannot use
SIDECAR = {
    "solver": _TEXT, "case": _TEXT, "status": _TEXT, "channels": _NAMES, "samples": _COUNT,
    "cause": (f"{' or '.join(CAUSES)} for a failed run, else an empty string", lambda v: v in ("", *CAUSES)),
    "steps": _COUNT, "rhs_evals": _COUNT, "wall_s": _SECONDS, "setup_s": _SECONDS, "compile_s": _SECONDS,
    "failed_at_s": ("a finite number (s), or null", lambda v: v is None or (_real(v) and abs(v) <= LARGEST)),
    "kinetic_max_J": ("a number >= 0 (J), or null when not known", lambda v: _unknown(v) or (_real(v) and 0 <= v <= LARGEST)),
    "csv_sha256": ("a SHA-256 in hex, or null", lambda v: v is None or isinstance(v, str)),
    "solver_version": _TEXT, "case_sha256": _TEXT, "python": _TEXT, "git_commit": _TEXT, "date": _TEXT,
    "machine": _TEXT, "settings": _TABLE, "versions": _TABLE, "imported": _TABLE, "overrides": _NAMES,
    "key": ("a SHA-256 in hex, or null", lambda v: v is None or (isinstance(v, str) and bool(re.fullmatch("[0-9a-f]{64}", v)))),
}


def read(out_dir: Path, case: str, solver: str) -> Result:
    """Read a stored result back, checked: the JSON sidecar parses and belongs to (case,
    solver), each of its keys holds what SIDECAR says, its CSV belongs to it (the SHA-256) and is
    a table of `t` and the sidecar's channels with its number of samples, every value finite
    (`read_table`). Anything else is an InputError naming the file (and the key)."""
    base = Path(out_dir) / case
    if bad_name(solver):
        raise InputError(f"{base}: solver {bad_name(solver)}")
    js, csv = base / f"{solver}.json", base / f"{solver}.csv"
    if not js.is_file():
        raise InputError(f"{js}: missing (no stored result of {solver} on {case})")
    meta = read_json(js, "not a result sidecar: not JSON")
    if not isinstance(meta, dict) or not {"status", "solver", "case", "samples", "channels"} <= set(meta):
        raise InputError(f"{js}: not a result sidecar (expected the keys status, solver, case, samples, channels)")
    for key, (what, ok) in SIDECAR.items():
        if key in meta and not ok(meta[key]):
            raise InputError(f"{js}: {key}: expected {what}, got {json.dumps(meta[key])[:40]}")
    if (meta["case"], meta["solver"]) != (case, solver):
        raise InputError(f"{js}: holds {meta['solver']} on {meta['case']}, not {solver} on {case}")
    meta.update({k: float("nan") for k in UNKNOWN_NAN if k in meta and meta[k] is None})
    try:
        status = Status.parse(meta["status"])
    except ValueError:
        raise InputError(f"{js}: status: not a run status: {meta['status'][:60]!r}") from None
    if status.unread:
        raise InputError(f"{js}: status: {meta['status'][:60]!r} is what a report says of a stored result, "
                         f"not the status of a run")
    samples, chans = meta["samples"], meta["channels"]
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
    if "fields" in meta:
        check_fields(js, meta["fields"])
    if "poses" in meta:
        check_poses(js, meta["poses"])
    if status.kind == "failed" and meta.get("failed_at_s") is not None:
        status = dataclasses.replace(status, t=float(meta["failed_at_s"]))
    if status.kind == "failed" and meta.get("cause"):   # older sidecars have none: Status.parse derives it
        status = dataclasses.replace(status, cause=meta["cause"])
    return Result(solver=solver, case=case, t=df["t"].to_numpy(dtype=float),
                  channels={c: df[c].to_numpy(dtype=float) for c in df.columns if c != "t"},
                  status=status, solver_version=meta.get("solver_version", ""),
                  settings=meta.get("settings", {}), wall_s=meta.get("wall_s", 0.0),
                  setup_s=meta.get("setup_s", 0.0), steps=meta.get("steps", 0),
                  rhs_evals=meta.get("rhs_evals", 0), case_sha256=meta.get("case_sha256", ""),
                  extra={k: v for k, v in meta.items() if k not in SIDECAR_KEYS})


SHAPE_LISTS = {"x": "[x]", "t": "[t]", "u": "[t][x][3]", "r": "[t][x][3]", "stress": "[t][x]"}  # keys, nesting
POSE_LISTS = {"t": "[t]", "R": "[t][3][3]", "p": "[t][3]"}


def check_shapes(path: Path, shapes) -> None:
    """A sidecar's deformed-shape snapshots (`channels.shapes`): per beam, x (nx,) m and t (k,) s
    lists and u (k, nx, 3) nested lists, and where recorded r (k, nx, 3) m and stress (k, nx) Pa,
    of finite numbers. An InputError naming the file and the key otherwise."""
    if not isinstance(shapes, dict):
        raise InputError(f"{path}: shapes: expected a table of beams, each with x, t and u")
    for body, s in shapes.items():
        key = f"shapes.{body}"
        if not isinstance(s, dict) or not {"x", "t", "u"} <= set(s) <= set(SHAPE_LISTS):
            raise InputError(f"{path}: {key}: expected a table with the keys x, t and u (and r, stress)")
        finite_lists(path, key, s, SHAPE_LISTS)
        names = ["len(t)", "len(x)", "3"]
        for k in ("u", "r", "stress"):
            if k in s:
                d = SHAPE_LISTS[k].count("[")
                sized(path, f"{key}.{k}", s[k], [len(s["t"]), len(s["x"]), 3][:d], names[:d],
                      not s["t"] or len(s["x"]) < 2, " (at least one instant and two points)")


def check_poses(path: Path, poses) -> None:
    """A sidecar's body poses (`channels.poses`): per body, t (k,) s, R (k, 3, 3) and p (k, 3) m
    nested lists of finite numbers. An InputError naming the file and the key otherwise."""
    if not isinstance(poses, dict):
        raise InputError(f"{path}: poses: expected a table of bodies, each with t, R and p")
    for body, s in poses.items():
        key = f"poses.{body}"
        if not isinstance(s, dict) or set(s) != set(POSE_LISTS):
            raise InputError(f"{path}: {key}: expected a table with the keys t, R and p")
        finite_lists(path, key, s, POSE_LISTS)
        for k, want in (("R", [len(s["t"]), 3, 3]), ("p", [len(s["t"]), 3])):
            sized(path, f"{key}.{k}", s[k], want, ["len(t)", "3", "3"][:len(want)], not s["t"],
                  " (at least one instant)")


def finite_lists(path: Path, key: str, table: dict, nesting: dict) -> None:
    """Each value of `table` a list nested as `nesting` says ("[t][x][3]": three deep), of finite
    numbers; an InputError naming the file and KEY.NAME otherwise."""
    def finite(v, depth: int) -> bool:
        if depth == 0:
            return (isinstance(v, float) and bool(np.isfinite(v))) or (type(v) is int and abs(v) < 1e300)
        return isinstance(v, list) and all(finite(e, depth - 1) for e in v)

    for k, v in table.items():
        depth = nesting[k].count("[")
        if not finite(v, depth):
            raise InputError(f"{path}: {key}.{k}: expected {'a list' if depth == 1 else 'nested lists ' + nesting[k]} "
                             f"of finite numbers")


def sized(path: Path, key: str, v: list, want: list, names: list, empty: bool, least: str) -> None:
    """Nested lists v with the sizes `want` at each level (named `names`), none of them `empty`;
    an InputError naming the file and the key otherwise."""
    expected = f"{' x '.join(names)} = {' x '.join(map(str, want))}{least}"
    sizes, level = [], [v]
    for _ in want:
        sizes.append({len(e) for e in level})
        level = [e for row in level for e in row]
    if any(len(n) > 1 for n in sizes):
        raise InputError(f"{path}: {key}: rows of unequal lengths, expected {expected}")
    got = [n.pop() if n else 0 for n in sizes]
    if got != want or empty:
        raise InputError(f"{path}: {key}: {' x '.join(map(str, got))} numbers, expected {expected}")


def check_fields(path: Path, fields) -> None:
    """A sidecar's surface fields (`channels.fields`): per solid, t (k,) s and vm (k, nf) nested
    lists of finite numbers (Pa), one row per instant. An InputError naming the file and key
    otherwise."""
    if not isinstance(fields, dict):
        raise InputError(f"{path}: fields: expected a table of solids, each with t and vm")
    for body, f in fields.items():
        key = f"fields.{body}"
        if not isinstance(f, dict) or set(f) != {"t", "vm"}:
            raise InputError(f"{path}: {key}: expected a table with the keys t and vm")
        try:
            t, vm = np.asarray(f["t"], dtype=float), np.asarray(f["vm"], dtype=float)
        except (TypeError, ValueError):
            raise InputError(f"{path}: {key}: expected lists of numbers (vm: one row per instant)") from None
        if t.ndim != 1 or not t.size or vm.ndim != 2 or vm.shape[0] != t.size or not np.isfinite(vm).all() \
                or not np.isfinite(t).all():
            raise InputError(f"{path}: {key}.vm: expected {t.size} rows (one per instant) of finite numbers, "
                             f"got an array of shape {vm.shape}")


def stale(r: Result, case_sha256: str, channels) -> str:
    """Why a stored result does not belong to the current case ('' when it does): another case
    hash (the case changed since the run), or a channel the case does not have."""
    extra = [c for c in r.channels if c not in channels]
    if extra:
        return f"channel {extra[0]} is not one of the case's channels"
    if r.case_sha256 != case_sha256:
        return f"run for another version of the case (case sha256 {r.case_sha256 or 'none'}, now {case_sha256})"
    return ""
