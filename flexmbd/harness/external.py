"""Results computed elsewhere (a commercial code, a colleague's solver), brought into a report
with `flexmbd import CASE --solver NAME FILE.csv [--meta FILE.json]`.

The table is checked against the case before it is stored, so that an imported result can stand
beside a solver's run on every page, table and regression:

    columns   `t` [s] and any of the case's channels, by name, in the channels' SI units
              (deflection m, stress Pa, joint angle rad, energy J, reaction N / N m), each once;
              lines starting with '#' are comments. The header is checked before the table is
              read: a file of other columns is refused at once, unread
    t         starts at 0, evenly spaced (the spectra assume it), increasing, and ends at the
              case's duration (within one output interval), unless the metadata says the run
              failed earlier
    values    finite numbers; the divergence rule of every solver applies (results.first_failure)

The optional metadata (JSON object) may give only the keys of META (wall times it does not give
are unknown: NaN); the stored sidecar records
the imported file's name and SHA-256 (key `imported`), and the metadata's machine and date in place
of this machine's.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from flexmbd import cases
from flexmbd.harness import channels, results, registry
from flexmbd.core import files
from flexmbd.core.errors import InputError
from flexmbd.harness.results import Result

# key -> (what it must be, a check)
META = {
    "solver_version": ("a string", lambda v: isinstance(v, str)),
    "settings": ("a JSON object", lambda v: isinstance(v, dict)),
    "status": ("a run status: 'ok', 'ok, outside linear validity (...)' or 'failed: WHY [at t = T s]'",
               lambda v: isinstance(v, str)),
    "wall_s": ("a number >= 0 (s)", lambda v: _number(v) and v >= 0),
    "setup_s": ("a number >= 0 (s)", lambda v: _number(v) and v >= 0),
    "steps": ("an integer >= 0", lambda v: _number(v) and isinstance(v, int) and v >= 0),
    "rhs_evals": ("an integer >= 0", lambda v: _number(v) and isinstance(v, int) and v >= 0),
    "kinetic_max_J": ("a number > 0 (J): the run's largest kinetic energy, against which energy "
                      "differences are measured", lambda v: _number(v) and v > 0),
    "machine": ("a string", lambda v: isinstance(v, str)),
    "date": ("a string", lambda v: isinstance(v, str)),
    "description": ("a string", lambda v: isinstance(v, str)),
}


def _number(v) -> bool:
    """A finite number within the magnitude a stored result may hold (results.LARGEST)."""
    return isinstance(v, (int, float)) and not isinstance(v, bool) and abs(v) <= results.LARGEST


def check_name(case, name: str) -> None:
    """An imported result's name: a file-name-safe word (`results.bad_name`) that no solver of the
    registry uses."""
    if results.bad_name(name):
        raise InputError(f"--solver: an imported result's name: {results.bad_name(name)}")
    if name in registry.NAMES:
        raise InputError(f"--solver: {name} is one of flexmbd's solvers; name an imported result otherwise "
                         f"(for example {name}-external)")


def metadata(path: Path | None) -> dict:
    """The metadata file, checked against META; {} without one."""
    if path is None:
        return {}
    meta = results.read_json(path)
    if not isinstance(meta, dict):
        raise InputError(f"{path}: expected a JSON object with any of the keys {', '.join(META)}")
    for key, value in meta.items():
        if key not in META:
            raise InputError(f"{path}: {key}: not a key of an imported result's metadata (known: {', '.join(META)})")
        what, ok = META[key]
        if not ok(value):
            raise InputError(f"{path}: {key}: expected {what}, got {json.dumps(value)[:40]}")
    if "status" in meta:
        try:
            status = results.Status.parse(meta["status"])
        except ValueError:
            status = None
        if status is None or status.kind not in ("ok", "failed"):
            raise InputError(f"{path}: status: expected {META['status'][0]}, got {meta['status'][:40]!r}")
    return meta


def table(case, path: Path, failed: bool) -> tuple[np.ndarray, dict, str]:
    """(t (n,), channel -> (n,), the file's SHA-256) of an imported table, checked against the case;
    its header first (`header`), so that a file of other columns is refused before it is read."""
    cols = header(case, path)
    text = results.read_text(path)
    df = results.read_table(path, text, columns=cols, comment="#")
    names = [c for c in cols if c != "t"]
    t = df["t"].to_numpy(dtype=float)
    if len(t) < 2:
        raise InputError(f"{path}: {len(t)} row; at least two samples are needed")
    duration, dt_out = case.duration, case.integrator.output_dt
    dt = np.diff(t)
    if abs(t[0]) > 1e-9 * duration:
        raise InputError(f"{path}: column t starts at {t[0]:g} s; results start at 0")
    if np.max(np.abs(dt - dt.mean())) > 1e-6 * dt.mean():
        raise InputError(f"{path}: column t is not evenly spaced (steps {dt.min():.6g} ... {dt.max():.6g} s); "
                         f"resample onto the case's output grid (integrator.output_dt = {dt_out:g} s)")
    if t[-1] > duration + dt_out:
        raise InputError(f"{path}: column t ends at {t[-1]:g} s, after the case's duration {duration:g} s")
    if t[-1] < duration - dt_out and not failed:
        raise InputError(f"{path}: column t ends at {t[-1]:g} s, before the case's duration {duration:g} s "
                         f"(a run that failed early: give its status in --meta)")
    return t, {c: df[c].to_numpy(dtype=float) for c in names}, results.sha256(text)


HEADER_SLACK = 256          # bytes a header may hold beyond twice its names, quotes and commas


def header(case, path: Path) -> list[str]:
    """The columns of an imported table in the file's order, from its header (its first line that
    is neither blank nor a comment, as pandas reads it), read alone and checked: `t` and any of the
    case's channels, each once. A header longer than such a one can be (twice its names, quotes and
    commas, and HEADER_SLACK) is refused unread: a file of a million columns is refused at once."""
    limit = HEADER_SLACK + 2 * sum(len(c.encode()) + 3 for c in ("t", *case.channels))
    expected = f"expected `t` and any of {', '.join(case.channels)}"
    try:
        with open(path, "rb") as f:
            line = f.readline(limit + 1)
            while line and (line.startswith(b"#") or not line.strip()):
                while line and not line.endswith(b"\n"):           # the rest of a long comment
                    line = f.readline(1 << 16)
                line = f.readline(limit + 1)
    except OSError as e:
        raise files.unusable(path, e, "cannot be read") from None
    if not line:
        raise InputError(f"{path}: no header line ({expected})")
    if len(line) > limit:
        raise InputError(f"{path}: its header is longer than {limit} bytes, more than `t` and the channels of "
                         f"{case.name} take: not a table of its channels ({expected})")
    try:
        text = line.decode("utf-8").removeprefix("\ufeff").split("#")[0].rstrip("\r\n")
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a text file (undecodable bytes)") from None
    try:
        cols = next(csv.reader([text]), [])
    except csv.Error as e:
        raise InputError(f"{path}: not a table ({e})") from None
    for k, c in enumerate(cols):
        if c == "t" or c in case.channels:
            if c in cols[:k]:
                raise InputError(f"{path}: column {c} appears twice")
        else:
            raise InputError(f"{path}: column {k + 1} has no name ({expected})" if not c.strip() else
                             f"{path}: column {c}: not a channel of {case.name}{cases.hint(c, case.channels)} "
                             f"(channels: {', '.join(case.channels)})")
    if "t" not in cols:
        raise InputError(f"{path}: no `t` column ({expected})")
    if len(cols) < 2:
        raise InputError(f"{path}: no channel columns ({expected})")
    return cols


def load(case, name: str, path: Path, meta_path: Path | None = None) -> Result:
    """An imported table as a Result of solver `name` on the case, checked (see the module's
    docstring); a run that breaks the divergence rule is cut and failed, as any solver's."""
    check_name(case, name)
    meta = metadata(meta_path)
    status = results.Status.parse(meta.get("status", "ok"))
    t, chans, digest = table(case, Path(path), status.kind == "failed")
    cut = results.first_failure(t, chans, channels.bounds(case))
    r = Result(solver=name, case=case.name, t=t, channels=chans, status=status,
               solver_version=meta.get("solver_version", ""), settings=meta.get("settings", {}),
               wall_s=float(meta.get("wall_s", np.nan)), setup_s=float(meta.get("setup_s", np.nan)),
               steps=meta.get("steps", 0), rhs_evals=meta.get("rhs_evals", 0), case_sha256=case.sha256)
    if cut is not None:
        r.truncate(cut[0])
        r.status = cut[1]
    r.extra["imported"] = {"file": Path(path).name, "sha256": digest,
                           "meta": Path(meta_path).name if meta_path else None,
                           "description": meta.get("description", "")}
    r.extra["overrides"] = list(case.overrides)
    r.extra.update({"machine": meta.get("machine", "imported"), "versions": {}, "python": ""})
    r.extra["date"] = meta.get("date", "")
    if "kinetic_max_J" in meta:
        r.extra["kinetic_max_J"] = float(meta["kinetic_max_J"])
    return r
