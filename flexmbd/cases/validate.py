"""Reading and checking a case file: TOML in, the plain dicts of the file with every default
filled in out. Loading fills defaults, checks types, signs and ranges, resolves references
between sections, and rejects unknown keys with a "did you mean" hint. Any failure raises
`InputError` with one line: ``FILE: dotted.key: what was expected``.

Solver names and the `[solvers.NAME]` tables are checked by the solver registry
(`registry.check`), where the solvers are known: loading a case imports no solver.
"""

from __future__ import annotations

import copy
import difflib
import math
import tomllib
from pathlib import Path

from flexmbd.fe import flexbody
from flexmbd.cases.schema import (BEAM, CASE, CHANNEL_KEYS, CURVE, DERIVED, JOINT_DOFS, LARGEST, MAX_SHAPE_POINTS,
                                  MAX_SNAPSHOTS, NAME_CHARS, POINT_MASS, POINT_MASS_JOINTS, REQUIRED, RIGID, SOLID,
                                  STRESS_KINDS)
from flexmbd.fe import modes as fe_modes
from flexmbd.core.errors import InputError, printable
from flexmbd.fe.solid import fits_rigid
from flexmbd.core.resources import CASES as CASES_DIR      # the shipped cases (core/resources.py)

# ---------------------------------------------------------------------------------------------
# finding and reading


def find(name_or_path: str) -> Path:
    """A case name from `cases/` or a path to a TOML file."""
    p = Path(name_or_path)
    if p.suffix == ".toml" or p.exists():
        if not p.is_file():
            raise InputError(f"{name_or_path}: no such case file")
        return p
    q = CASES_DIR / f"{name_or_path}.toml"
    if not q.is_file():
        names = available()
        raise InputError(f"{name_or_path}: unknown case{hint(name_or_path, names)} (known: {', '.join(names)})")
    return q


def available() -> list[str]:
    """Names of the cases shipped in `cases/`."""
    return sorted(p.stem for p in CASES_DIR.glob("*.toml"))


def read_text(path: Path) -> str:
    """A case file's text: UTF-8, else InputError naming the first undecodable byte."""
    try:
        raw = path.read_bytes()
    except OSError as e:
        raise InputError(f"{path}: cannot read the case file ({e.strerror})") from None
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as e:
        line = raw[:e.start].count(b"\n") + 1
        raise InputError(f"{path}: not UTF-8 text (byte 0x{raw[e.start]:02x} on line {line}); "
                         f"a case file is TOML in UTF-8") from None


def parse_toml(text: str, path) -> dict:
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise InputError(f"{path}: not valid TOML: {e}") from None
    except RecursionError:
        raise InputError(f"{path}: not valid TOML: arrays or tables nested too deeply") from None


def apply_override(raw: dict, item: str, path) -> None:
    """Set a dotted key from a `KEY=VALUE` string; VALUE is read as a TOML value, else a string."""
    if any(0xD800 <= ord(ch) <= 0xDFFF for ch in item):          # undecodable bytes of the argument
        raise InputError(f"{path}: --set '{printable(item)}': not valid UTF-8 text (an undecodable byte); "
                         f"expected KEY=VALUE in UTF-8")
    key, sep, value = item.partition("=")
    key = key.strip()
    if not sep or not key:
        raise InputError(f"{path}: --set {item!r}: expected KEY=VALUE")
    parts = key.split(".")
    if not all(p.strip() for p in parts):
        raise InputError(f"{path}: --set {key}: empty name in the dotted key (expected names joined by dots, "
                         f"e.g. materials.steel.E)")
    try:
        doc = tomllib.loads(f"v = {value.strip()}")
    except (tomllib.TOMLDecodeError, RecursionError):
        doc = {}
    parsed = doc["v"] if list(doc) == ["v"] else value.strip()     # more than one value: the text itself
    node = raw
    for i, part in enumerate(parts[:-1]):
        nxt = node.setdefault(part, {})
        if not isinstance(nxt, dict):
            where = ".".join(parts[: i + 1])
            raise InputError(f"{path}: --set {key}: {where} is a value, not a table")
        node = nxt
    node[parts[-1]] = parsed


# ---------------------------------------------------------------------------------------------
# validation


def validate(raw: dict, where: str) -> dict:
    """Check a raw case dict against the schema and the cross-references; return a filled copy."""
    data = check_table(copy.deepcopy(raw), CASE, where, "")
    _check_references(data, where)
    _loop_method(data, "method" in (raw.get("integrator") or {}), where)
    return data


LOOP_METHOD = "dopri5"      # a case with a loop and no integrator.method: one that restarts after each projection
# the methods that restart after each projection onto a loop's constraints (`integrate.PROJECTED`)
LOOP_METHODS = ("dopri5", "fox-goodwin", "rk45", "dop853", "rk4")


def _loop_method(d: dict, named: bool, where: str) -> None:
    """A case with a loop joint integrates it with one of LOOP_METHODS: LOOP_METHOD when it names
    no `integrator.method`; another method named is refused. The `[integrator]` table is flexmbd's
    settings (no other solver reads its method), and, as a `[solvers.NAME]` table of a solver not
    run is checked all the same (`registry.check`), it is checked whichever solver runs the case."""
    loop = next((name for name, j in d["joints"].items() if j["loop"]), None)
    if loop is None:
        return
    method = d["integrator"]["method"]
    if not named:
        d["integrator"]["method"] = LOOP_METHOD
    elif method not in LOOP_METHODS:
        _fail(where, "integrator.method", f"{method!r} cannot integrate a closed loop (joint {loop!r} closes one): "
              f"expected {', '.join(LOOP_METHODS[:-1])} or {LOOP_METHODS[-1]}")


def hint(word: str, choices) -> str:
    """' (did you mean ...?)' for the closest of `choices`, or ''."""
    close = difflib.get_close_matches(word, list(choices), n=1, cutoff=0.6)
    return f" (did you mean '{close[0]}'?)" if close else ""


def _fail(where: str, key: str, msg: str):
    raise InputError(f"{where}: {key}: {msg}")


def check_table(raw, schema: dict, where: str, prefix: str) -> dict:
    """A table checked against a schema (see above), defaults filled; `prefix` is its dotted key
    with a trailing dot. Also for schemas declared elsewhere (solver settings)."""
    if not isinstance(raw, dict):
        _fail(where, prefix.rstrip(".") or "(top level)", "expected a table")
    if "*" in schema:                                   # a table of named items
        for name in raw:
            if not name or not set(name) <= NAME_CHARS:
                _fail(where, f"{prefix}{name}", "expected a name of letters, digits, '_' and '-' "
                      "(a dotted key must be able to address it)")
        return {name: _check_value(val, schema["*"], where, f"{prefix}{name}")
                for name, val in raw.items()}
    for key in raw:
        if key not in schema:
            _fail(where, prefix + key, f"unknown key{hint(key, schema)}")
    out = {}
    for key, (kind, default) in schema.items():
        if key in raw:
            out[key] = _check_value(raw[key], kind, where, prefix + key)
        elif default is REQUIRED:
            _fail(where, prefix + key, "missing (required)")
        elif isinstance(kind, dict) and isinstance(default, dict):
            out[key] = check_table(default, kind, where, prefix + key + ".")
        else:
            out[key] = copy.deepcopy(default)
    return out


def _number(v, where, key):
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        _fail(where, key, f"expected a number, got {v!r}")
    if not math.isfinite(v):
        _fail(where, key, f"expected a finite number, got {v!r}")
    if abs(v) > LARGEST:
        _fail(where, key, f"expected a number of magnitude at most {LARGEST:g}, got {v!r}")
    return float(v)


def _check_value(v, kind, where: str, key: str):
    """v checked against its schema kind (`cases.schema`): a nested table (dict), one of a tuple of
    words, or a named kind (KINDS); the value as the case holds it."""
    if isinstance(kind, dict):
        return check_table(v, kind, where, key + ".")
    if isinstance(kind, tuple):
        if v not in kind:
            _fail(where, key, f"expected one of {', '.join(kind)}, got {v!r}{hint(str(v), kind)}")
        return v
    if kind not in KINDS:
        raise AssertionError(f"schema kind {kind!r}")
    return KINDS[kind](v, where, key)


def _real(sign: str):
    """A number's checker: any finite number, or > 0 ('+'), or >= 0 ('0+')."""
    def check(v, where, key):
        x = _number(v, where, key)
        if sign == "+" and x <= 0:
            _fail(where, key, f"must be positive, got {v!r}")
        if sign == "0+" and x < 0:
            _fail(where, key, f"must not be negative, got {v!r}")
        return x
    return check


def _poisson(v, where, key):
    x = _number(v, where, key)
    if not -1.0 < x < 0.5:
        _fail(where, key, f"Poisson's ratio must lie in (-1, 0.5), got {v!r}")
    return x


def _whole(least: int):
    """A whole number's checker, at least `least` (1: positive, 0: non-negative)."""
    def check(v, where, key):
        if isinstance(v, bool) or not isinstance(v, int):
            _fail(where, key, f"expected a whole number, got {v!r}")
        if abs(v) > LARGEST:
            _fail(where, key, f"expected a whole number of magnitude at most {LARGEST:g}, got {v!r}")
        if v < least:
            _fail(where, key, f"must be {'positive' if least else 'non-negative'}, got {v}")
        return v
    return check


def _words(what: str):
    """A list of strings' checker (`what`: what the message calls it)."""
    def check(v, where, key):
        if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
            _fail(where, key, f"expected a list of {what}, got {v!r}")
        return list(v)
    return check


def _text(line: bool):
    """A string's checker; with `line`, one non-empty printable line."""
    def check(v, where, key):
        if not isinstance(v, str):
            _fail(where, key, f"expected a string, got {v!r}")
        if line and (not v.strip() or not v.isprintable()):
            _fail(where, key, f"expected one non-empty line of text, got {v!r}")
        return v
    return check


def _bool(v, where, key):
    if not isinstance(v, bool):
        _fail(where, key, f"expected true or false, got {v!r}")
    return v


def _numbers(kind: str):
    """A list of numbers' checker: `vec3` three, `inertia` six with positive principal moments,
    `vec` any count, `floats` any count or one number alone."""
    want = {"vec3": 3, "inertia": 6}.get(kind)

    def check(v, where, key):
        items = [v] if kind == "floats" and not isinstance(v, list) else v
        if not isinstance(items, list):
            _fail(where, key, f"expected a list of numbers, got {v!r}")
        xs = [_number(x, where, key) for x in items]
        if want and len(xs) != want:
            _fail(where, key, f"expected {want} numbers, got {len(xs)}")
        if kind == "inertia" and min(xs[:3]) <= 0:
            _fail(where, key, "principal moments Ixx, Iyy, Izz must be positive")
        return xs
    return check


def _point(v, where, key):
    """A position: [x, y, z], a solid's interface name (checked with the body) or a distance >= 0."""
    if isinstance(v, list):
        return _check_value(v, "vec3", where, key)
    if isinstance(v, str):
        return v
    return _check_value(v, "float0+", where, key)


def _solver(v, where, key):
    if not isinstance(v, str):
        _fail(where, key, f"expected a solver name, got {v!r}")
    return v


def _table_of(kind: str, what: str):
    """A table's checker whose every value is of `kind` (`what`: the message's description)."""
    def check(v, where, key):
        if not isinstance(v, dict):
            _fail(where, key, f"expected a table {what}")
        return {k: _check_value(x, kind, where, f"{key}.{k}") for k, x in v.items()}
    return check


def _solver_settings(v, where, key):
    if not isinstance(v, dict):
        _fail(where, key, "expected a table of solver names")
    for name, settings in v.items():
        if not isinstance(settings, dict):
            _fail(where, f"{key}.{name}", "expected a table of settings")
    return copy.deepcopy(v)


# the named kinds of cases/schema.py, each checked by one small function
KINDS = {"body": lambda v, where, key: _check_body(v, where, key),
         "float": _real(""), "float+": _real("+"), "float0+": _real("0+"), "poisson": _poisson,
         "int+": _whole(1), "int0+": _whole(0), "strings": _words("strings"), "str": _text(False),
         "line": _text(True), "bool": _bool, **{k: _numbers(k) for k in ("vec3", "vec", "floats", "inertia")},
         "point": _point, "solver": _solver, "solvers": _words("solver names"),
         "tolerances": _table_of("float+", "channel = relative tolerance"),
         "explanations": _table_of("str", "solver = explanation"), "solver_settings": _solver_settings,
         "curve": lambda v, where, key: _check_curve(v, where, key)}


def _check_curve(v, where, key):
    """An S-N curve: a name (checked against the curves known, `durability.check`) or a CURVE
    table of segments with positive slopes, one constant and one lower range each, highest first."""
    if isinstance(v, str):
        return v
    if not isinstance(v, dict):
        _fail(where, key, f"expected a curve's name or a table (m, log_a, lower), got {v!r}")
    c = check_table(v, CURVE, where, key + ".")
    if min(c["m"]) <= 0:
        _fail(where, f"{key}.m", f"slopes must be positive, got {c['m']}")
    if not len(c["m"]) == len(c["log_a"]) == len(c["lower"]):
        _fail(where, key, "m, log_a and lower need one value per segment")
    if min(c["lower"]) < 0 or c["lower"] != sorted(c["lower"], reverse=True):
        _fail(where, f"{key}.lower", f"expected ranges >= 0, highest first, got {c['lower']}")
    return c


def _check_body(v, where, key):
    if not isinstance(v, dict):
        _fail(where, key, "expected a table")
    kind = v.get("type")
    types = {"beam": BEAM, "rigid": RIGID, "point_mass": POINT_MASS, "solid": SOLID}
    schema = types.get(kind) if isinstance(kind, str) else None
    if schema is None:
        _fail(where, key + ".type", f"expected {', '.join(types)}, got {kind!r}{hint(str(kind), types)}")
    return check_table(v, schema, where, key + ".")


# ---------------------------------------------------------------------------------------------
# cross-references


def _check_references(d: dict, where: str) -> None:
    bodies, joints = d["bodies"], d["joints"]
    for key in ("bodies", "channels"):
        if not d[key]:
            _fail(where, key, "expected at least one entry, the table is empty")
    _check_integrator(d, where)
    for name, b in bodies.items():
        k = f"bodies.{name}"
        if name == "ground":
            _fail(where, k, "'ground' is reserved for the inertial frame")
        if b["type"] == "beam":
            _check_beam(b, d, where, k)
        elif b["type"] == "solid":
            _check_solid(b, d, where, k)
        elif b["type"] == "point_mass":
            _check_derived(where, k, {"mass (kg)": b["mass"]}, "mass")
        else:
            _check_rigid(b, where, k)

    # every body has exactly one tree joint to its parent, and the tree joints form a tree rooted
    # at ground; a joint declared `loop = true` closes a loop between two bodies already on it
    children = {}
    for name, j in joints.items():
        k = f"joints.{name}"
        for side in ("parent", "child"):
            ref = j[side]
            if ref != "ground" and ref not in bodies:
                _fail(where, f"{k}.{side}", f"no body {ref!r}{hint(ref, list(bodies) + ['ground'])}")
        if j["child"] == "ground":
            _fail(where, f"{k}.child", "ground cannot be a child")
        _check_point_mass_joint(j, bodies, where, k)
        _check_attachment(j, bodies, where, k)
        if j["loop"]:
            _check_loop(j, bodies, where, k)
            continue
        if j["child"] in children:
            _fail(where, f"{k}.child", f"body {j['child']!r} already has joint {children[j['child']]!r}: a second "
                  f"joint on a body closes a kinematic loop, declared with loop = true on the joint that closes it "
                  f"(cases/README.md, Loops)")
        if j["child_at"] is not None:
            _fail(where, f"{k}.child_at", "only a loop joint (loop = true) sits at a point of its child; a tree "
                  "joint's child hangs at its own frame")
        children[j["child"]] = name
        _check_joint_values(j, where, k)
    for name in bodies:
        if name not in children:
            _fail(where, f"bodies.{name}", "no joint connects this body (add a joint with child = it; a loop joint "
                  "does not connect a body to the tree)")
    _check_tree({n: j for n, j in joints.items() if not j["loop"]}, where)

    for name, ld in d["loads"].items():
        k = f"loads.{name}"
        if ld["body"] not in bodies:
            _fail(where, f"{k}.body", f"no body {ld['body']!r}{hint(ld['body'], bodies)}")
        if bodies[ld["body"]]["type"] == "point_mass":
            _fail(where, f"{k}.body", f"{ld['body']!r} is a point mass: apply the load to its parent at the point "
                  f"where the mass sits (the same force on the same point)")
        _check_point(ld["at"], bodies[ld["body"]], where, f"{k}.at")
        p = ld["profile"]
        if p["type"] == "ramp" and (p["t1"] is None or p["t1"] <= p["t0"]):
            _fail(where, f"{k}.profile.t1", "a ramp needs t1 > t0")
        if p["type"] == "harmonic" and p["frequency"] is None:
            _fail(where, f"{k}.profile.frequency", "a harmonic load needs a frequency (Hz)")

    for name, c in d["channels"].items():
        _check_channel(name, c, bodies, joints, where)
    for ch in d["report"]["tolerances"] or {}:
        if ch not in d["channels"]:
            _fail(where, f"report.tolerances.{ch}", f"no channel {ch!r}{hint(ch, d['channels'])}")
    rep = d["report"]
    if rep["solvers"] and rep["reference"] is not None and rep["reference"] not in rep["solvers"]:
        _fail(where, "report.reference", f"{rep['reference']!r} is not among report.solvers {rep['solvers']}")
    if rep["graded_from"] >= d["duration"]:
        _fail(where, "report.graded_from", f"{rep['graded_from']:g} s leaves nothing of the run of "
              f"{d['duration']:g} s to grade")
    _check_snapshots(d, where)
    _check_durability(d, where)
    _check_frequency_map(d, where)


# the stress channels with a sign, which a rainflow count can read (von Mises folds each compressive
# half cycle into a tensile one)
SIGNED = ("stress_normal", "stress_signed_vm")


def _check_frequency_map(d, where):
    """A [frequency_map] table: at least two values, and each `set` item KEY=VALUE (the solvers in
    `peers` are checked where the map is taken, against the solvers this installation has)."""
    fm = d["frequency_map"]
    if fm is None:
        return
    if fm["values"] < 2:
        _fail(where, "frequency_map.values", f"{fm['values']} value: a map needs at least 2")
    for item in fm["set"]:
        if "=" not in item or not item.partition("=")[0].strip():
            _fail(where, "frequency_map.set", f"{item!r}: expected KEY=VALUE")


def _check_durability(d, where):
    """A `[durability]` table's channels (signed stress channels of the case, each once), its
    discarded start-up (shorter than the run) and its mean-stress correction's material value."""
    dur = d["durability"]
    if dur is None:
        return
    if not dur["channels"]:
        _fail(where, "durability.channels", "expected at least one signed stress channel")
    for name in dur["channels"]:
        c = d["channels"].get(name)
        if c is None:
            _fail(where, "durability.channels", f"no channel {name!r}{hint(name, d['channels'])}")
        if c["kind"] not in SIGNED:
            _fail(where, "durability.channels", f"{name!r} is a {c['kind']} channel, not a signed stress "
                  f"({' or '.join(SIGNED)}): von Mises has no sign, and counted it folds each compressive half "
                  "cycle into a tensile one")
        if dur["channels"].count(name) > 1:
            _fail(where, "durability.channels", f"{name!r} listed twice")
    if dur["discard"] >= d["duration"]:
        _fail(where, "durability.discard", f"{dur['discard']:g} s discards the whole run of {d['duration']:g} s")
    if (dur["correction"] == "goodman") != (dur["ultimate"] is not None):
        _fail(where, "durability.ultimate", "the Goodman correction needs the material's ultimate strength (Pa)"
              if dur["ultimate"] is None else f"only read by correction = \"goodman\", not {dur['correction']!r}")


def _check_integrator(d, where):
    ig = d["integrator"]
    if ig["output_dt"] > d["duration"]:
        _fail(where, "integrator.output_dt", f"{ig['output_dt']} s is longer than the duration {d['duration']} s "
              f"(expected at most the duration)")
    for key in ("rtol", "atol"):
        if ig[key] >= 1.0:
            _fail(where, f"integrator.{key}", f"expected a tolerance below 1, got {ig[key]}")


def snapshot_instants(duration: float) -> list:
    """The default instants of the deformed-shape snapshots: duration x (1/4, 1/2, 3/4, 1). Not
    t = 0: every case starts undeformed (a beam's modal coordinates start at zero), so a shape
    at t = 0 is zero for every solver. Rounded to 12 digits (0.3, not 0.30000000000000004): the
    snapshot is taken at the output sample nearest to the instant anyway."""
    return [float(f"{duration * k / 4:.12g}") for k in range(1, 5)]


def _check_snapshots(d, where):
    """report.snapshots: 1 to MAX_SNAPSHOTS distinct instants within [0, duration] (sorted; the
    default `snapshot_instants`); report.shape_points: 0 (no snapshots) or 2 to MAX_SHAPE_POINTS
    (the root and the tip at least)."""
    rep, T = d["report"], d["duration"]
    n = rep["shape_points"]
    if n == 1 or n > MAX_SHAPE_POINTS:
        _fail(where, "report.shape_points", f"expected 0 (no snapshots) or 2 to {MAX_SHAPE_POINTS} points along each "
              f"beam (the root and the tip at least), got {n}")
    ts = rep["snapshots"]
    if ts is None:
        rep["snapshots"] = snapshot_instants(T)
        return
    if not 1 <= len(ts) <= MAX_SNAPSHOTS:
        _fail(where, "report.snapshots", f"expected 1 to {MAX_SNAPSHOTS} instants in s (one panel each), got {len(ts)}"
              + ("; report.shape_points = 0 turns the snapshots off" if not ts else ""))
    for t in ts:
        if not 0.0 <= t <= T:
            _fail(where, "report.snapshots", f"instant {t:g} s lies outside the run [0, {T:g}] s (the duration)")
    if len(set(ts)) < len(ts):
        t = next(t for t in ts if ts.count(t) > 1)
        _fail(where, "report.snapshots", f"instant {t:g} s is listed twice")
    rep["snapshots"] = sorted(ts)


def _check_rigid(b, where, k):
    """A rigid body's inertia is one a mass distribution can have: positive definite principal
    moments that satisfy the triangle inequalities I1 + I2 >= I3; its derived sizes are finite."""
    import numpy as np
    xx, yy, zz, xy, xz, yz = b["inertia"]
    lam = np.linalg.eigvalsh(np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]))
    moments = ", ".join(f"{x:.6g}" for x in lam)
    if not lam[0] > 1e-12 * abs(lam[2]):
        _fail(where, f"{k}.inertia", f"expected a positive definite inertia, its principal moments are {moments} kg m^2")
    if lam[0] + lam[1] < lam[2] * (1.0 - 1e-9):
        _fail(where, f"{k}.inertia", f"principal moments {moments} kg m^2 break the triangle inequality "
              f"I1 + I2 >= I3 (no mass distribution has them)")
    _check_derived(where, k, {"mass times |com|^2 (kg m^2)": b["mass"] * sum(x * x for x in b["com"]) or 1.0,
                              "largest principal moment (kg m^2)": float(lam[2]),
                              "mass (kg)": b["mass"]}, "mass, com and inertia")


def _beam_sizes(b, mat) -> dict:
    """What a beam's stiffness and mass matrices are made of (infinite where they overflow)."""
    le, E, rho = b["length"] / b["elements"], mat["E"], mat["rho"]
    try:
        sec = flexbody.section_of(**b["section"])
        I_lo, I_hi = min(sec.Iy, sec.Iz), max(sec.Iy, sec.Iz)
        return {
            "section area (m^2)": sec.A, "smallest second moment of area (m^4)": I_lo,
            "torsion constant (m^4)": sec.J, "element axial stiffness E A / le (N/m)": E * sec.A / le,
            "largest element bending stiffness 12 E I / le^3 (N/m)": 12.0 * E * I_hi / le ** 3,
            "smallest element bending stiffness 12 E I / le^3 (N/m)": 12.0 * E * I_lo / le ** 3,
            "element mass rho A le (kg)": rho * sec.A * le, "element rotary inertia rho Ip le (kg m^2)": rho * sec.Ip * le,
            "highest element frequency squared 12 E I / (rho A le^4) (1/s^2)": 12.0 * E * I_hi / (rho * sec.A * le ** 4),
            "total mass (kg)": rho * sec.A * b["length"]}
    except (ArithmeticError, ValueError):           # overflow, a zero from underflow
        return {"section and element properties": math.inf}


def _check_derived(where, k, quantities: dict, inputs: str) -> None:
    lo, hi = DERIVED
    for what, x in quantities.items():
        if not (math.isfinite(x) and lo <= abs(x) <= hi):
            _fail(where, k, f"its {what} = {x:.3g} lies outside [{lo:g}, {hi:g}], the range in which the solvers' "
                  f"products stay finite: check its {inputs}")


def _check_beam(b, d, where, k):
    if b["material"] not in d["materials"]:
        _fail(where, f"{k}.material", f"no material {b['material']!r}{hint(b['material'], d['materials'])}")
    s = b["section"]
    need = ("b", "h") if s["shape"] == "rectangle" else ("d",)
    for dim in need:
        if s[dim] is None:
            _fail(where, f"{k}.section.{dim}", f"a {s['shape']} section needs {dim} (m)")
    for dim in ("b", "h", "d"):
        if dim not in need and s[dim] is not None:
            _fail(where, f"{k}.section.{dim}", f"not used by a {s['shape']} section")
    _check_derived(where, k, _beam_sizes(b, d["materials"][b["material"]]),
                   f"material {b['material']!r}, length, elements and section")
    n = b["segments"]
    if b["elements"] % n:
        _fail(where, f"{k}.segments",
              f"{n} segments need a number of elements divisible by {n}, got elements = {b['elements']}")
    m = b["modes"]
    elements, length = b["elements"] // n, b["length"] / n          # of one segment (the beam if n = 1)
    mesh = f"the {elements}-element mesh" + (f" of each of the {n} segments" if n > 1 else "")
    fixed = {"clamped-free": 6, "hinged-hinged": 6, "free-free": 0, "craig-bampton": 0}[m["boundary"]]
    free = 6 * (elements + 1) - fixed - (6 if m["boundary"] in ("free-free", "craig-bampton") else 0)
    if m["count"] > free:
        _fail(where, f"{k}.modes.count",
              f"{m['count']} modes requested but {mesh} with {m['boundary']} boundaries has only {free} free DOFs")
    if m["boundary"] == "craig-bampton":
        if not m["interfaces"]:
            _fail(where, f"{k}.modes.interfaces", "craig-bampton needs interface positions along the beam (m)")
        for x in m["interfaces"]:
            if not 0.0 <= x <= length:
                what = "each segment" if n > 1 else "the beam"
                _fail(where, f"{k}.modes.interfaces", f"position {x} m lies outside {what} [0, {length}]")
    elif m["interfaces"] is not None:
        _fail(where, f"{k}.modes.interfaces", "only used with boundary = \"craig-bampton\"")
    if m["static"] is not None:
        _check_static(m, length, elements, n, where, f"{k}.modes.static")
    if m["kinds"] is not None:
        _check_kinds(m, elements, mesh, where, f"{k}.modes.kinds")


def _check_static(m, length, elements, n, where, key):
    """Static correction positions: a clamped-free or hinged-hinged mode set (whose supports hold
    the beam still under a load), on the beam (each segment if n > 1), at a node the supports leave
    free to move, each once."""
    if m["boundary"] not in ("clamped-free", "hinged-hinged"):
        _fail(where, key, f"static correction needs boundary = \"clamped-free\" or \"hinged-hinged\", got {m['boundary']!r}")
    what = "each segment" if n > 1 else "the beam"
    nodes = {flexbody.node_index(length, elements, x) for x in m["static"]}
    for x in m["static"]:
        if not 0.0 <= x <= length or flexbody.node_index(length, elements, x) == 0:
            _fail(where, key, f"position {x} m lies outside {what} (0, {length}] or on its root node, which is held")
    if len(nodes) < len(m["static"]):
        _fail(where, key, f"two positions fall on the same node of the {elements}-element mesh")


def _check_kinds(m, elements, mesh, where, key):
    """Mode kinds: known, each once, and enough modes of them in the mesh for `count`
    (`fe.modes.modes_per_family`)."""
    kinds, known = m["kinds"], fe_modes.modes_per_family(elements)
    if not kinds:
        _fail(where, key, f"expected at least one of {', '.join(known)} (leave kinds out to keep modes of every kind)")
    for kind in kinds:
        if kind not in known:
            _fail(where, key, f"unknown mode kind {kind!r}{hint(kind, known)}; expected some of {', '.join(known)}")
        if kinds.count(kind) > 1:
            _fail(where, key, f"kind {kind!r} is listed twice")
    have = sum(known[kind] for kind in kinds)
    if m["count"] > have:
        _fail(where, key, f"{m['count']} modes of kinds {', '.join(kinds)} requested but {mesh} has only {have} "
              f"({', '.join(f'{kind} {known[kind]}' for kind in kinds)})")


def _check_point(at, body, where, key):
    if body["type"] == "solid":
        if not isinstance(at, str):
            _fail(where, key, "on a solid give the name of one of its interfaces")
        if at not in body["interfaces"]:
            _fail(where, key, f"no interface {at!r} on the solid{hint(at, body['interfaces'])}")
        return
    if isinstance(at, str):
        _fail(where, key, f"an interface name ({at!r}) locates a point on a solid only; on a "
              f"{body['type']} body give " + ("a position along it in m" if body["type"] == "beam" else "a point [x, y, z] in m"))
    if body["type"] == "beam":
        if isinstance(at, list):
            _fail(where, key, "on a beam give a position along it in m, not a point")
        if at > body["length"]:
            _fail(where, key, f"position {at} m lies beyond the beam's length {body['length']} m")
    elif not isinstance(at, list):
        _fail(where, key, "on a rigid body give a point [x, y, z] in m in its frame")


def _check_attachment(j, bodies, where, k):
    parent = j["parent"]
    if j["at"] is None:
        j["at"] = 0.0 if parent != "ground" and bodies[parent]["type"] == "beam" else [0.0, 0.0, 0.0]
    if parent == "ground":
        if not isinstance(j["at"], list):
            _fail(where, f"{k}.at", "on ground give a point [x, y, z] in m")
    elif bodies[parent]["type"] == "solid" and j["at"] == [0.0, 0.0, 0.0]:
        j["at"] = bodies[parent]["frame"]
    else:
        _check_point(j["at"], bodies[parent], where, f"{k}.at")
    if j["type"] in ("revolute", "prismatic") and math.hypot(*j["axis"]) < 1e-12:
        _fail(where, f"{k}.axis", "the joint axis must not be zero")




def _check_point_mass_joint(j, bodies, where, k):
    """A point mass hangs on one tree joint of POINT_MASS_JOINTS (schema.py says why) and carries
    nothing: a body that would hang on it hangs on its parent at the same point."""
    kind = lambda side: bodies.get(j[side], {}).get("type")
    if kind("parent") == "point_mass":
        _fail(where, f"{k}.parent", f"{j['parent']!r} is a point mass, which carries no joint: attach {j['child']!r} "
              f"to its parent at the point where the mass sits")
    if kind("child") != "point_mass":
        return
    if j["loop"]:
        _fail(where, f"{k}.child", f"{j['child']!r} is a point mass, which no loop joint reaches: it hangs on its "
              f"one tree joint")
    if j["type"] not in POINT_MASS_JOINTS:
        _fail(where, f"{k}.type", f"a {j['type']} joint would move point mass {j['child']!r} on its parent: a point "
              f"mass hangs on a {' or '.join(POINT_MASS_JOINTS)} joint (it has no rotational inertia; a body that "
              f"turns or slides on its joint is a rigid body, type = \"rigid\")")


def _check_loop(j, bodies, where, k):
    """A loop joint: two different bodies, neither split into segments, its point on the child
    (`child_at`, defaulting to the child's frame origin), no coordinates of its own (they follow
    from the tree), not driven."""
    if j["parent"] == j["child"]:
        _fail(where, f"{k}.child", "a loop joint joins two different bodies")
    for side in ("parent", "child"):
        if bodies.get(j[side], {}).get("segments", 1) > 1:
            _fail(where, f"{k}.{side}", f"body {j[side]!r} is split into segments, which a loop joint cannot reach yet")
    child = bodies[j["child"]]
    if j["child_at"] is None:
        j["child_at"] = 0.0 if child["type"] == "beam" else [0.0, 0.0, 0.0]
    _check_point(j["child_at"], child, where, f"{k}.child_at")
    for key in ("q0", "qd0", "motion"):
        if j[key] is not None:
            _fail(where, f"{k}.{key}", "a loop joint has no coordinates of its own: they follow from the tree joints "
                  "(give the initial values there)")
    j["q0"], j["qd0"] = [], []


def _check_joint_values(j, where, k):
    n = JOINT_DOFS[j["type"]]
    for key in ("q0", "qd0"):
        v = j[key]
        if v is None:
            j[key] = [0.0] * n
        elif len(v) != n:
            _fail(where, f"{k}.{key}", f"a {j['type']} joint takes {n} value(s), got {len(v)}")
    m = j["motion"]
    if m is None:
        return
    if n != 1:
        _fail(where, f"{k}.motion", f"prescribed motion needs a 1-DOF joint, not {j['type']}")
    need = {"constant_rate": ("rate",), "harmonic": ("amplitude", "frequency"),
            "spin_up": ("W", "T"), "table": ("file",)}[m["type"]]
    for key in need:
        if m[key] is None:
            _fail(where, f"{k}.motion.{key}", f"the {m['type']} profile needs {key}")
    if m["type"] == "table":
        f = Path(where).parent / m["file"]
        if not f.is_file():
            _fail(where, f"{k}.motion.file", f"no such file {str(f)!r}")
        _check_table_file(f, where, f"{k}.motion.file")
        m["file"] = str(f)


def _check_table_file(f: Path, where, key):
    """A motion table: header line, then rows 't, q' of finite numbers with strictly increasing t
    (at least 4 rows)."""
    import warnings

    import numpy as np
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")                 # numpy warns about an empty table: said below
            data = np.loadtxt(f, delimiter=",", skiprows=1, ndmin=2, encoding="utf-8")
    except (ValueError, OSError) as e:                      # UnicodeDecodeError is a ValueError
        _fail(where, key, f"{f.name}: not a CSV of numbers after the header line ({e})")
    if data.size == 0:
        _fail(where, key, f"{f.name}: no rows after the header line (expected rows t, q, at least 4)")
    if data.shape[1] != 2 or data.shape[0] < 4:
        _fail(where, key, f"{f.name}: expected columns t, q and at least 4 rows, got {data.shape[0]} rows of "
              f"{data.shape[1]} columns")
    bad = np.flatnonzero(~np.isfinite(data).all(axis=1))
    if bad.size:
        _fail(where, key, f"{f.name}: row {bad[0] + 1} after the header is not finite ({data[bad[0]].tolist()}); "
              f"expected finite t, q")
    if np.abs(data).max() > LARGEST:
        _fail(where, key, f"{f.name}: expected values of magnitude at most {LARGEST:g}")
    back = np.flatnonzero(np.diff(data[:, 0]) <= 0)
    if back.size:
        _fail(where, key, f"{f.name}: t must increase strictly, row {back[0] + 2} after the header has "
              f"t = {data[back[0] + 1, 0]:g} after {data[back[0], 0]:g}")


def _check_tree(joints, where):
    parent_of = {j["child"]: j["parent"] for j in joints.values()}
    for child in parent_of:
        seen, b = set(), child
        while b != "ground":
            if b in seen:
                _fail(where, "joints", f"the joints form a loop through body {b!r} (a tree is needed)")
            seen.add(b)
            b = parent_of[b]


def _check_solid(b, d, where, k):
    """A solid: a material (its own or the mesh file's one), a box or a mesh file that reads, its
    interfaces on node sets of the mesh (a solid's: at least 3 nodes not on one line, `fits_rigid`;
    a frame's: one node), the frame's interface rigid and every other averaging,
    and no more modes than the held mesh has free DOFs."""
    mesh = _solid_mesh(b["mesh"], where, k)
    if b["material"] is None:
        if len(mesh.materials) != 1:
            found = f"defines {len(mesh.materials)} materials" if mesh.materials else "defines no material"
            _fail(where, f"{k}.material", f"missing, and the mesh file {found}: name one of the case's materials")
    elif b["material"] not in d["materials"]:
        _fail(where, f"{k}.material", f"no material {b['material']!r}{hint(b['material'], d['materials'])}")
    if b["frame"] not in b["interfaces"]:
        _fail(where, f"{k}.frame", f"no interface {b['frame']!r}{hint(b['frame'], b['interfaces'])}")
    taken = {}
    for name, i in b["interfaces"].items():
        _check_interface(mesh, b, name, i, taken, where, f"{k}.interfaces.{name}")
    _check_solid_modes(mesh, b, where, k)


def _solid_mesh(m, where, k):
    """The mesh of a solid's `mesh` table (a box, or a file with its matrix files, found beside the
    case file), read and checked once (`flexbody.solid_mesh`: a file's error names its line)."""
    if (m["file"] is None) == (m["box"] is None):
        _fail(where, f"{k}.mesh", "give either file (a mesh file) or box ([L, h, b] in m), not both or neither")
    if m["box"] is not None:
        for key in ("stiffness", "mass"):
            if m[key] is not None:
                _fail(where, f"{k}.mesh.{key}", "a matrix file belongs to a mesh file (`file`), not to a box")
        v = m["divisions"]
        if v is None or any(x != int(x) or x < 1 for x in v):
            _fail(where, f"{k}.mesh.divisions", f"a box needs divisions = [nx, ny, nz], whole numbers >= 1, got {v}")
        if any(x <= 0 for x in m["box"]):
            _fail(where, f"{k}.mesh.box", f"expected positive sizes [L, h, b] in m, got {m['box']}")
        m["divisions"] = [int(x) for x in m["divisions"]]
    else:
        if m["divisions"] is not None:
            _fail(where, f"{k}.mesh.divisions", "only used with box")
        for key in ("file", "stiffness", "mass"):
            if m[key] is not None:
                f = Path(where).parent / m[key]
                if not f.is_file():
                    _fail(where, f"{k}.mesh.{key}", f"no such file {str(f)!r}")
                m[key] = str(f)
    mesh = flexbody.solid_mesh(**m)                 # an import error is an InputError naming the file and line
    for key in ("stiffness", "mass"):               # read (and checked) once here, kept by content
        if m[key] is not None and mesh.is_frame:
            _fail(where, f"{k}.mesh.{key}", f"{mesh.source} is a frame (bar elements): its matrices come from "
                  "its cards, not from matrix files")
        if m[key] is not None:
            flexbody.matrix_file(m[key], m["units"], tuple(mesh.node_ids), key)
    return mesh


def _check_interface(mesh, b, name, i, taken: dict, where, key):
    """Interface `name` (its table i) of a solid on `mesh`: its set there and on elements, able to
    carry a rigid motion (a solid's) or one node (a frame's), its kind as the modes hold the frame,
    and a rigid set's nodes its own (`taken`: node -> interface, filled)."""
    boundary, nodes = b["modes"]["boundary"], mesh.node_sets.get(i["set"])
    if nodes is None:
        _fail(where, f"{key}.set", f"no node set {i['set']!r} in {mesh.source} (it has: "
              f"{', '.join(sorted(mesh.node_sets)) or 'none'})")
    if not len(nodes):
        _fail(where, f"{key}.set", f"node set {i['set']!r} has no node on an element (an RBE's reference grid "
              "or an orientation grid alone): name the set of the nodes it ties, and its point")
    if not mesh.is_frame and not fits_rigid(mesh.nodes[nodes]):
        n_ = len(nodes)
        _fail(where, f"{key}.set", f"node set {i['set']!r} has {n_} node{'s' * (n_ > 1)}"
              f"{' on one line' * (n_ > 2)}: a solid's interface needs at least 3 nodes not on one line (its nodes "
              "carry no rotation: a rotation about their line is neither held by a rigid interface nor fitted by "
              "an averaging one)")
    if mesh.is_frame:                               # a frame's interface is a node: its six DOFs
        if len(nodes) != 1:
            _fail(where, f"{key}.set", f"a frame's interface is one node (its rotations are the interface's); "
                  f"set {i['set']!r} has {len(nodes)}")
        if i["kind"] != "rigid" or i["point"] is not None:
            _fail(where, f"{key}.kind" if i["kind"] != "rigid" else f"{key}.point",
                  "a frame's interface moves with its one node: kind = \"rigid\" and no point")
    elif name == b["frame"] and boundary != "free-free" and i["kind"] != "rigid":
        _fail(where, f"{key}.kind", f"{boundary} modes hold the frame's interface, so it moves rigidly: "
              "kind = \"rigid\"")
    elif name == b["frame"] and boundary == "free-free" and i["kind"] != "averaging":
        _fail(where, f"{key}.kind", "free-free modes leave the frame's interface free: its reference point is "
              "their rigid fit, kind = \"averaging\" (a rigid frame interface makes them clamped-interface modes)")
    if i["kind"] == "rigid":                        # a rigid set's nodes are its reference point's: no other's
        for n_ in nodes:
            if n_ in taken:
                _fail(where, f"{key}.set", f"node {int(mesh.node_ids[n_])} of set {i['set']!r} is also in "
                      f"interface {taken[n_]!r}: a rigid interface's nodes belong to it alone")
            taken[int(n_)] = name


def _check_solid_modes(mesh, b, where, k):
    """A solid's mode count: six a Craig-Bampton interface besides the frame's, and no more than
    the held mesh's free DOFs."""
    boundary, count = b["modes"]["boundary"], b["modes"]["count"]
    if boundary == "craig-bampton" and count < 6 * (len(b["interfaces"]) - 1):
        _fail(where, f"{k}.modes.count", f"craig-bampton modes hold six per interface besides the frame's: at least "
              f"{6 * (len(b['interfaces']) - 1)}, got {count}")
    held = len(mesh.node_sets[b["interfaces"][b["frame"]]["set"]]) if boundary != "free-free" else 0
    dofs = 6 if mesh.is_frame else 3
    free = dofs * (mesh.n_nodes - held) - (6 if boundary == "free-free" else 0)
    if count > free:
        _fail(where, f"{k}.modes.count", f"{count} modes requested but the mesh has {free} free DOFs")


def _check_solid_channel(c, body, where, k):
    """A deflection at one of the solid's interfaces; a stress at a point [x, y, z] of the body frame."""
    if c["fibre"] is not None:
        _fail(where, f"{k}.fibre", "a fibre is a beam section's point; on a solid give point = [x, y, z] (m)")
    if c["kind"] == "deflection":
        if c["at"] is None:
            _fail(where, f"{k}.at", "needs the name of one of the solid's interfaces")
        _check_point(c["at"], body, where, f"{k}.at")
        if c["point"] is not None:
            _fail(where, f"{k}.point", "not used by a deflection channel (it is measured at the interface `at`)")
        return
    if c["at"] is not None:
        _fail(where, f"{k}.at", "a solid's stress is at a point: give point = [x, y, z] (m, body frame)")
    if c["point"] is None:
        _fail(where, f"{k}.point", "needs a point [x, y, z] in m, body frame, inside the solid")
    if c["direction"] is not None and not any(abs(v) > 0 for v in c["direction"]):
        _fail(where, f"{k}.direction", "a direction [x, y, z] of nonzero length (body frame)")
    mesh = flexbody.solid_mesh(**body["mesh"])
    frame = body["interfaces"][body["frame"]]
    origin = flexbody.reference_point(mesh, frame["set"], frame["point"])
    x = [v + o for v, o in zip(c["point"], origin)]
    if mesh.is_frame and not flexbody.in_frame(mesh, x):
        _fail(where, f"{k}.point", f"point {c['point']} m lies in no bar of the frame (farther from every axis "
              "than twice its section's radius of gyration)")
    if not mesh.is_frame and flexbody.element_at(mesh, x) is None:
        _fail(where, f"{k}.point", f"point {c['point']} m lies in no element of the solid's mesh")


def _check_fibre(fibre, body, where, key):
    """A stress point (y, z) in the body axes that lies in the beam's section (round-off allowed)."""
    if len(fibre) != 2:
        _fail(where, key, "expected [y, z] in m")
    y, z = fibre
    s, slack = body["section"], 1.0 + 1e-9
    if s["shape"] == "circle":
        if math.hypot(y, z) > s["d"] / 2 * slack:
            _fail(where, key, f"point ({y:g}, {z:g}) m lies outside the circle section of diameter {s['d']:g} m "
                  f"(expected y^2 + z^2 <= (d/2)^2)")
        return
    ey, ez = (s["h"] / 2, s["b"] / 2) if s["h_axis"] == "y" else (s["b"] / 2, s["h"] / 2)
    if abs(y) > ey * slack or abs(z) > ez * slack:
        _fail(where, key, f"point ({y:g}, {z:g}) m lies outside the {s['b']:g} x {s['h']:g} m rectangle section "
              f"(h along {s['h_axis']}; expected |y| <= {ey:g} m and |z| <= {ez:g} m)")




def _check_channel(name, c, bodies, joints, where):
    k = f"channels.{name}"
    if name == "t":
        _fail(where, k, "'t' is the time column of a result; expected another channel name")
    for key in ("body", "joint", "at", "fibre", "direction"):
        if c[key] is not None and key not in CHANNEL_KEYS[c["kind"]]:
            _fail(where, f"{k}.{key}", f"not used by a {c['kind']} channel")
    if c["kind"] in ("deflection", *STRESS_KINDS):
        b = c["body"]
        if b is None:
            _fail(where, f"{k}.body", f"a {c['kind']} channel needs a body")
        if b not in bodies:
            _fail(where, f"{k}.body", f"no body {b!r}{hint(b, bodies)}")
        if bodies[b]["type"] in ("rigid", "point_mass"):
            _fail(where, f"{k}.body", f"{c['kind']} needs a beam or a solid, {b!r} is "
                  f"{'rigid' if bodies[b]['type'] == 'rigid' else 'a point mass'}")
        if bodies[b]["type"] == "solid":
            _check_solid_channel(c, bodies[b], where, k)
            return
        if c["point"] is not None:
            _fail(where, f"{k}.point", "a stress point [x, y, z] is for a solid; on a beam give `at` (m) and `fibre`")
        if c["direction"] is not None:
            _fail(where, f"{k}.direction", "a beam's normal stress is along its axis; a direction is for a solid")
        if c["at"] is None:
            _fail(where, f"{k}.at", "needs a position along the beam (m)")
        if not isinstance(c["at"], (int, float)):
            _fail(where, f"{k}.at", "on a beam give a position along it in m")
        if c["at"] > bodies[b]["length"]:
            _fail(where, f"{k}.at", f"position {c['at']} m lies beyond the beam's length {bodies[b]['length']} m")
        if c["fibre"] is not None:
            _check_fibre(c["fibre"], bodies[b], where, f"{k}.fibre")
    if c["kind"] in ("joint_angle", "reaction_force", "reaction_moment"):
        j = c["joint"]
        if j is None:
            _fail(where, f"{k}.joint", f"a {c['kind']} channel needs a joint")
        if j not in joints:
            _fail(where, f"{k}.joint", f"no joint {j!r}{hint(j, joints)}")
        if c["kind"] == "joint_angle" and joints[j]["loop"]:
            _fail(where, f"{k}.joint", f"{j!r} closes a loop and has no coordinate of its own: measure the angle at "
                  f"a tree joint")
        if c["kind"] == "joint_angle" and joints[j]["type"] not in ("revolute", "prismatic"):
            _fail(where, f"{k}.joint", f"joint_angle needs a revolute or prismatic joint, {j!r} is {joints[j]['type']}")
