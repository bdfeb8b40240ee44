"""Case files: TOML in, a validated case out: the plain dicts of the file with every default
filled in (`Case.data`), and the resolved case built from them once (`Case.resolved`): bodies in
tree order with their kind and parent index, joints with their triads and coordinate counts,
every point on a beam snapped to its node by the one rule (`flexbody.node_index`), stress
sections keyed by channel, nq and nv, and the reduced flexible bodies (computed on first use,
cached by content: `flexbody.reduce`).

A beam with `segments = N` is split, once, into N beams joined rigidly (`split_segments`):
`Case.segmented` is the case of that expanded tree, which the modal solvers model, while
`Case.data` and `Case.resolved` keep the whole beam, which the channels measure and the
solvers that model the whole beam themselves read.

Every key a case may hold is declared once, in the schema below (`cases/README.md` documents
the same keys with units). Loading fills defaults, checks types, signs and ranges, resolves
references between sections, and rejects unknown keys with a "did you mean" hint. Any failure
raises `InputError` with one line: ``FILE: dotted.key: what was expected``.

Solver names and the `[solvers.NAME]` tables are checked by the solver registry
(`solvers.check`), where the solvers are known: loading a case imports no solver.
"""

from __future__ import annotations

import copy
import difflib
import hashlib
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

from flexmbd import flexbody
from flexmbd.errors import InputError, printable
from flexmbd.spatial import rotation_rpy

CASES_DIR = Path(__file__).resolve().parent.parent / "cases"

# ---------------------------------------------------------------------------------------------
# schema: a field is (kind, default); REQUIRED marks a field without default.
# kinds: "float+" (> 0), "float0+" (>= 0), "float", "int+", "int0+", "str", "bool", "vec3",
# "vec", a tuple of allowed strings, or a nested dict schema.

REQUIRED = object()

# every number of a case (and of a solver's settings) is finite and at most this in magnitude; the
# section, stiffness and mass properties derived from a beam's or a rigid body's numbers must in
# turn lie within DERIVED (`_check_derived`), so that the products the solvers form stay finite
LARGEST = 1e100
DERIVED = (1e-200, 1e200)

# names of materials, bodies, joints, loads and channels: what a dotted key can address
NAME_CHARS = set("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-")

MATERIAL = {
    "E": ("float+", REQUIRED),
    "nu": ("poisson", REQUIRED),
    "rho": ("float+", REQUIRED),
}

SECTION = {
    "shape": (("rectangle", "circle"), REQUIRED),
    "b": ("float+", None),          # rectangle width, along the axis that is not h_axis
    "h": ("float+", None),          # rectangle height, along h_axis
    "d": ("float+", None),          # circle diameter
    "h_axis": (("y", "z"), "y"),    # body axis along which h lies
}

MODES = {
    "count": ("int0+", REQUIRED),
    "boundary": (("clamped-free", "hinged-hinged", "free-free", "craig-bampton"), "clamped-free"),
    "interfaces": ("vec", None),    # craig-bampton: interface positions along the beam, m
}

BEAM = {
    "type": (("beam",), REQUIRED),
    "material": ("str", REQUIRED),
    "length": ("float+", REQUIRED),
    "elements": ("int+", 100),
    "section": (SECTION, REQUIRED),
    "modes": (MODES, REQUIRED),
    "damping_ratio": ("float0+", 0.0),
    "mass": (("lumped", "consistent"), "lumped"),
    "shear": ("bool", False),
    "rigid": ("bool", False),
    "stiffening": ("bool", True),   # geometric stiffening: the foreshortening of bent nodes (formulation §4b)
    "segments": ("int+", 1),        # modal solvers: N flexible beams of length L / N, joined rigidly
}

RIGID = {
    "type": (("rigid",), REQUIRED),
    "mass": ("float+", REQUIRED),
    "com": ("vec3", [0.0, 0.0, 0.0]),
    "inertia": ("inertia", REQUIRED),   # [Ixx, Iyy, Izz, Ixy, Ixz, Iyz] about the com, kg m^2
}

PROFILE = {
    "type": (("constant_rate", "harmonic", "spin_up", "table"), REQUIRED),
    "rate": ("float", None),            # constant_rate: rad/s or m/s
    "amplitude": ("float", None),       # harmonic
    "frequency": ("float+", None),      # harmonic, Hz
    "phase": ("float", 0.0),            # harmonic, rad
    "offset": ("float", 0.0),           # harmonic
    "W": ("float", None),               # spin_up: final rate
    "T": ("float+", None),              # spin_up: spin-up time
    "file": ("str", None),              # table: CSV with columns t, q (relative to the case file)
}

JOINT = {
    "type": (("revolute", "prismatic", "fixed", "spherical", "free"), REQUIRED),
    "parent": ("str", REQUIRED),
    "child": ("str", REQUIRED),
    "at": ("point", None),              # beam parent: position along it (m); else a point (vec3)
    "axis": ("vec3", [0.0, 0.0, 1.0]),  # revolute / prismatic axis in the input triad
    "rpy": ("vec3", [0.0, 0.0, 0.0]),   # input triad orientation in the parent frame, rad
    "q0": ("floats", None),
    "qd0": ("floats", None),
    "motion": (PROFILE, None),          # prescribed motion (1-DOF joints)
}

LOAD_PROFILE = {
    "type": (("constant", "step", "ramp", "harmonic"), "constant"),
    "t0": ("float0+", 0.0),             # step / ramp start, s
    "t1": ("float+", None),             # ramp end, s
    "frequency": ("float+", None),      # harmonic, Hz
    "phase": ("float", 0.0),            # harmonic, rad
}

LOAD = {
    "type": (("point_force",), REQUIRED),
    "body": ("str", REQUIRED),
    "at": ("point", REQUIRED),
    "force": ("vec3", REQUIRED),        # N
    "frame": (("body", "global"), "body"),
    "profile": (LOAD_PROFILE, {"type": "constant"}),
}

CHANNEL = {
    "kind": (("deflection", "stress_vm", "joint_angle", "energy", "reaction_force", "reaction_moment"), REQUIRED),
    "body": ("str", None),
    "joint": ("str", None),
    "at": ("float0+", None),            # m along the beam
    "component": (("x", "y", "z"), "y"),
    "fibre": ("vec", None),             # stress point (y, z) in the section, m; default outer fibre
}

INTEGRATOR = {
    "method": (("adams", "dopri5", "fox-goodwin", "rk45", "dop853", "rk4"), "adams"),
    "rtol": ("float+", 1e-8),
    "atol": ("float+", 1e-10),
    "max_step": ("float+", 1e-3),       # s
    "dt": ("float+", 1e-4),             # s, fixed-step methods
    "output_dt": ("float+", 1e-3),      # s, sampling of the result table
}

REPORT = {
    "reference": ("solver", None),
    "solvers": ("solvers", None),
    "tolerances": ("tolerances", {}),
    "snapshots": ("vec", None),         # s: instants of the deformed-shape snapshots (default `snapshot_instants`)
    "shape_points": ("int0+", 11),      # evenly spaced points along each flexible beam drawn in them (0: none)
}

# the deformed-shape snapshots: at most this many instants (one panel each) and shape points per beam
MAX_SNAPSHOTS = 12
MAX_SHAPE_POINTS = 101

CASE = {
    "title": ("line", REQUIRED),
    "duration": ("float+", REQUIRED),
    "gravity": ("vec3", [0.0, 0.0, 0.0]),
    "materials": ({"*": MATERIAL}, REQUIRED),
    "bodies": ({"*": "body"}, REQUIRED),
    "joints": ({"*": JOINT}, REQUIRED),
    "loads": ({"*": LOAD}, {}),
    "channels": ({"*": CHANNEL}, REQUIRED),
    "integrator": (INTEGRATOR, {}),
    "solvers": ("solver_settings", {}),
    "report": (REPORT, {}),
}


@dataclass(frozen=True)
class Body:
    name: str
    index: int          # 1..nb, parents before children (0: ground)
    kind: str           # "rigid", "beam" (flexible) or "rigid beam" (a beam declared rigid)
    parent: int         # parent body index, 0 for ground
    joint: str          # the joint to the parent
    nodes: int          # beam nodes (elements + 1); 0 for a rigid body
    modes: int          # modal coordinates (a flexible beam's mode count, else 0)


@dataclass(frozen=True)
class Joint:
    name: str
    type: str
    parent: int         # body index, 0 for ground
    child: int
    nq: int             # coordinates: revolute, prismatic 1; spherical 4 (quaternion); free 7
    nv: int             # velocities: 1, 1, 3, 6
    node: int           # node of a beam parent it sits on (snapped), -1 otherwise
    x: float | None     # that node's position along the beam, m (None off a beam)
    triad: tuple        # (3, 3) rotation of the input triad in the parent (or node) frame, rows
    axis: tuple         # (3,) unit joint axis in the input triad


@dataclass(frozen=True)
class Point:
    """A position x along a beam (as the case names it) and the node it snaps to."""

    body: str
    x: float
    node: int
    x_node: float


@dataclass(frozen=True)
class Resolved:
    bodies: tuple       # Body, in tree order (parents first)
    joints: MappingProxyType    # name -> Joint
    points: MappingProxyType    # deflection channel -> Point
    stress: MappingProxyType    # stress channel -> (Point, fibre (y, z) or None)
    nq: int
    nv: int
    segments: MappingProxyType  # split beam -> its segments' body names, root first (`split_segments`)
    _data: dict = field(repr=False)

    def place(self, body: str, x: float) -> tuple[str, float]:
        """(body, x) in the segmented tree of position x (m) along `body` (`place`)."""
        return place(self._data, body, x)

    def body(self, name: str) -> Body:
        return next(b for b in self.bodies if b.name == name)

    @property
    def order(self) -> list:
        """Body names, parents before children."""
        return [b.name for b in self.bodies]

    def stress_sections(self, body: str) -> list:
        """Positions x of a beam's stress channels, sorted, without repeats (FlexBody.stress_x)."""
        return sorted({p.x for p, _ in self.stress.values() if p.body == body})

    def reduced(self, name: str) -> flexbody.FlexBody:
        """The reduced flexible beam `name` (computed once per content, `flexbody.reduce`)."""
        body = self._data["bodies"][name]
        return flexbody.reduce(name, body, self._data["materials"][body["material"]], self.stress_sections(name))

    def flexible(self) -> dict:
        """Every flexible beam, reduced, by name, in tree order."""
        return {b.name: self.reduced(b.name) for b in self.bodies if b.kind == "beam"}


@dataclass(frozen=True)
class Case:
    """A validated case: `data` is the case as nested dicts with every default filled in,
    `resolved` what is derived from it once, `segmented` the case of the tree the modal solvers
    model (every beam split into its `segments`; the case itself when none is)."""

    name: str
    path: Path
    data: dict
    sha256: str = ""
    overrides: tuple = field(default_factory=tuple)
    resolved: Resolved | None = field(default=None, repr=False, compare=False)
    segmented: Case | None = field(default=None, repr=False, compare=False)

    def __post_init__(self):
        if self.resolved is None:
            object.__setattr__(self, "resolved", resolve(self.data))
        if self.segmented is None:
            data = split_segments(self.data)
            object.__setattr__(self, "segmented", self if data is self.data else
                               Case(name=self.name, path=self.path, data=data, sha256=self.sha256,
                                    overrides=self.overrides))

    def __getitem__(self, key):
        return self.data[key]


# ---------------------------------------------------------------------------------------------
# loading


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


def load(name_or_path: str, overrides: list[str] | tuple = ()) -> Case:
    """Read, override (`KEY=VALUE` strings) and validate a case."""
    path = find(name_or_path)
    text = read_text(path)
    raw = parse_toml(text, path)
    for item in overrides:
        apply_override(raw, item, path)
    data = validate(raw, str(path))
    digest = hashlib.sha256((text + "\n".join(overrides)).encode()).hexdigest()[:16]
    return Case(name=path.stem, path=path, data=data, sha256=digest, overrides=tuple(overrides))


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
    return data


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
    if isinstance(kind, dict):
        return check_table(v, kind, where, key + ".")
    if isinstance(kind, tuple):
        if v not in kind:
            _fail(where, key, f"expected one of {', '.join(kind)}, got {v!r}{hint(str(v), kind)}")
        return v
    if kind == "body":
        return _check_body(v, where, key)
    if kind in ("float", "float+", "float0+"):
        x = _number(v, where, key)
        if kind == "float+" and x <= 0:
            _fail(where, key, f"must be positive, got {v!r}")
        if kind == "float0+" and x < 0:
            _fail(where, key, f"must not be negative, got {v!r}")
        return x
    if kind == "poisson":
        x = _number(v, where, key)
        if not -1.0 < x < 0.5:
            _fail(where, key, f"Poisson's ratio must lie in (-1, 0.5), got {v!r}")
        return x
    if kind in ("int+", "int0+"):
        if isinstance(v, bool) or not isinstance(v, int):
            _fail(where, key, f"expected a whole number, got {v!r}")
        if abs(v) > LARGEST:
            _fail(where, key, f"expected a whole number of magnitude at most {LARGEST:g}, got {v!r}")
        if v < (1 if kind == "int+" else 0):
            _fail(where, key, f"must be {'positive' if kind == 'int+' else 'non-negative'}, got {v}")
        return v
    if kind in ("str", "line"):
        if not isinstance(v, str):
            _fail(where, key, f"expected a string, got {v!r}")
        if kind == "line" and (not v.strip() or not v.isprintable()):
            _fail(where, key, f"expected one non-empty line of text, got {v!r}")
        return v
    if kind == "bool":
        if not isinstance(v, bool):
            _fail(where, key, f"expected true or false, got {v!r}")
        return v
    if kind in ("vec3", "vec", "floats", "inertia"):
        items = [v] if kind == "floats" and not isinstance(v, list) else v
        if not isinstance(items, list):
            _fail(where, key, f"expected a list of numbers, got {v!r}")
        xs = [_number(x, where, key) for x in items]
        want = {"vec3": 3, "inertia": 6}.get(kind)
        if want and len(xs) != want:
            _fail(where, key, f"expected {want} numbers, got {len(xs)}")
        if kind == "inertia" and min(xs[:3]) <= 0:
            _fail(where, key, "principal moments Ixx, Iyy, Izz must be positive")
        return xs
    if kind == "point":
        if isinstance(v, list):
            return _check_value(v, "vec3", where, key)
        return _check_value(v, "float0+", where, key)
    if kind == "solver":
        if not isinstance(v, str):
            _fail(where, key, f"expected a solver name, got {v!r}")
        return v
    if kind == "solvers":
        if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
            _fail(where, key, f"expected a list of solver names, got {v!r}")
        return list(v)
    if kind == "tolerances":
        if not isinstance(v, dict):
            _fail(where, key, "expected a table channel = relative tolerance")
        return {ch: _check_value(t, "float+", where, f"{key}.{ch}") for ch, t in v.items()}
    if kind == "solver_settings":
        if not isinstance(v, dict):
            _fail(where, key, "expected a table of solver names")
        for name, settings in v.items():
            if not isinstance(settings, dict):
                _fail(where, f"{key}.{name}", "expected a table of settings")
        return copy.deepcopy(v)
    raise AssertionError(f"schema kind {kind!r}")


def _check_body(v, where, key):
    if not isinstance(v, dict):
        _fail(where, key, "expected a table")
    kind = v.get("type")
    schema = {"beam": BEAM, "rigid": RIGID}.get(kind) if isinstance(kind, str) else None
    if schema is None:
        _fail(where, key + ".type", f"expected beam or rigid, got {kind!r}{hint(str(kind), ['beam', 'rigid'])}")
    return check_table(v, schema, where, key + ".")


# ---------------------------------------------------------------------------------------------
# cross-references


def _check_references(d: dict, where: str) -> None:
    bodies, joints = d["bodies"], d["joints"]
    for key in ("bodies", "channels"):
        if not d[key]:
            _fail(where, key, f"expected at least one entry, the table is empty")
    _check_integrator(d, where)
    for name, b in bodies.items():
        k = f"bodies.{name}"
        if name == "ground":
            _fail(where, k, "'ground' is reserved for the inertial frame")
        if b["type"] == "beam":
            _check_beam(b, d, where, k)
        else:
            _check_rigid(b, where, k)

    # every body has exactly one joint to its parent, and the joints form a tree rooted at ground
    children = {}
    for name, j in joints.items():
        k = f"joints.{name}"
        for side in ("parent", "child"):
            ref = j[side]
            if ref != "ground" and ref not in bodies:
                _fail(where, f"{k}.{side}", f"no body {ref!r}{hint(ref, list(bodies) + ['ground'])}")
        if j["child"] == "ground":
            _fail(where, f"{k}.child", "ground cannot be a child")
        if j["child"] in children:
            _fail(where, f"{k}.child", f"body {j['child']!r} already has joint {children[j['child']]!r}")
        children[j["child"]] = name
        _check_attachment(j, bodies, where, k)
        _check_joint_values(j, where, k)
    for name in bodies:
        if name not in children:
            _fail(where, f"bodies.{name}", "no joint connects this body (add a joint with child = it)")
    _check_tree(joints, where)

    for name, ld in d["loads"].items():
        k = f"loads.{name}"
        if ld["body"] not in bodies:
            _fail(where, f"{k}.body", f"no body {ld['body']!r}{hint(ld['body'], bodies)}")
        _check_point(ld["at"], bodies[ld["body"]], where, f"{k}.at")
        p = ld["profile"]
        if p["type"] == "ramp" and (p["t1"] is None or p["t1"] <= p["t0"]):
            _fail(where, f"{k}.profile.t1", "a ramp needs t1 > t0")
        if p["type"] == "harmonic" and p["frequency"] is None:
            _fail(where, f"{k}.profile.frequency", "a harmonic load needs a frequency (Hz)")

    for name, c in d["channels"].items():
        _check_channel(name, c, bodies, joints, where)
    for ch in d["report"]["tolerances"]:
        if ch not in d["channels"]:
            _fail(where, f"report.tolerances.{ch}", f"no channel {ch!r}{hint(ch, d['channels'])}")
    rep = d["report"]
    if rep["solvers"] and rep["reference"] is not None and rep["reference"] not in rep["solvers"]:
        _fail(where, "report.reference", f"{rep['reference']!r} is not among report.solvers {rep['solvers']}")
    _check_snapshots(d, where)


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
        sec = flexbody.beam_section(b)
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


def _check_point(at, body, where, key):
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
    else:
        _check_point(j["at"], bodies[parent], where, f"{k}.at")
    if j["type"] in ("revolute", "prismatic") and math.hypot(*j["axis"]) < 1e-12:
        _fail(where, f"{k}.axis", "the joint axis must not be zero")


JOINT_COORDS = {"fixed": (0, 0), "revolute": (1, 1), "prismatic": (1, 1), "spherical": (4, 3), "free": (7, 6)}
JOINT_DOFS = {k: nv for k, (_, nv) in JOINT_COORDS.items()}


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


# the keys without default that each kind of channel reads (the others must be left out)
CHANNEL_KEYS = {"deflection": ("body", "at"), "stress_vm": ("body", "at", "fibre"), "joint_angle": ("joint",),
                "reaction_force": ("joint",), "reaction_moment": ("joint",), "energy": ()}


def _check_channel(name, c, bodies, joints, where):
    k = f"channels.{name}"
    if name == "t":
        _fail(where, k, "'t' is the time column of a result; expected another channel name")
    for key in ("body", "joint", "at", "fibre"):
        if c[key] is not None and key not in CHANNEL_KEYS[c["kind"]]:
            _fail(where, f"{k}.{key}", f"not used by a {c['kind']} channel")
    if c["kind"] in ("deflection", "stress_vm"):
        b = c["body"]
        if b is None:
            _fail(where, f"{k}.body", f"a {c['kind']} channel needs a body")
        if b not in bodies:
            _fail(where, f"{k}.body", f"no body {b!r}{hint(b, bodies)}")
        if bodies[b]["type"] != "beam":
            _fail(where, f"{k}.body", f"{c['kind']} needs a beam, {b!r} is rigid")
        if c["at"] is None:
            _fail(where, f"{k}.at", "needs a position along the beam (m)")
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
        if c["kind"] == "joint_angle" and joints[j]["type"] != "revolute":
            _fail(where, f"{k}.joint", f"joint_angle needs a revolute joint, {j!r} is {joints[j]['type']}")


# ---------------------------------------------------------------------------------------------
# the resolved case


def tree_order(data: dict) -> list:
    """Body names so that every parent comes before its children (file order kept otherwise)."""
    parent_of = {j["child"]: j["parent"] for j in data["joints"].values()}
    order, placed = [], {"ground"}
    while len(order) < len(parent_of):
        for name in data["bodies"]:
            if name not in placed and parent_of[name] in placed:
                order.append(name)
                placed.add(name)
    return order


def beam_point(data: dict, body: str, x: float) -> Point:
    b = data["bodies"][body]
    return Point(body=body, x=x, node=flexbody.node_index(b["length"], b["elements"], x),
                 x_node=flexbody.snapped(b["length"], b["elements"], x))


def resolve(data: dict) -> Resolved:
    """The resolved case of validated case data."""
    order = tree_order(data)
    index = {"ground": 0, **{name: k + 1 for k, name in enumerate(order)}}
    joint_of = {j["child"]: name for name, j in data["joints"].items()}
    bodies, joints, nq, nv = [], {}, 0, 0
    for name in order:
        b, jn = data["bodies"][name], joint_of[name]
        j = data["joints"][jn]
        kind = "rigid" if b["type"] == "rigid" else "rigid beam" if b["rigid"] else "beam"
        modes = b["modes"]["count"] if kind == "beam" else 0
        bodies.append(Body(name=name, index=index[name], kind=kind, parent=index[j["parent"]], joint=jn,
                           nodes=b["elements"] + 1 if kind != "rigid" else 0, modes=modes))
        on_beam = j["parent"] != "ground" and data["bodies"][j["parent"]]["type"] == "beam"
        p = beam_point(data, j["parent"], j["at"]) if on_beam else None
        jq, jv = JOINT_COORDS[j["type"]]
        axis = [a / math.hypot(*j["axis"]) for a in j["axis"]] if math.hypot(*j["axis"]) > 0 else [0.0, 0.0, 0.0]
        joints[jn] = Joint(name=jn, type=j["type"], parent=index[j["parent"]], child=index[name], nq=jq, nv=jv,
                           node=p.node if p else -1, x=p.x_node if p else None,
                           triad=tuple(tuple(float(x) for x in row) for row in rotation_rpy(j["rpy"])),
                           axis=tuple(float(a) for a in axis))
        nq, nv = nq + jq + modes, nv + jv + modes
    points = {n: beam_point(data, c["body"], c["at"]) for n, c in data["channels"].items() if c["kind"] == "deflection"}
    stress = {n: (beam_point(data, c["body"], c["at"]), None if c["fibre"] is None else tuple(c["fibre"]))
              for n, c in data["channels"].items() if c["kind"] == "stress_vm"}
    segments = {name: tuple(segment_name(name, k) for k in range(n)) for name, n in split(data).items()}
    return Resolved(bodies=tuple(bodies), joints=MappingProxyType(joints), points=MappingProxyType(points),
                    stress=MappingProxyType(stress), nq=nq, nv=nv, _data=data, segments=MappingProxyType(segments))


# ---------------------------------------------------------------------------------------------
# segments: a beam split into flexible beams joined rigidly (docs/formulation.md §9)


def split(data: dict) -> dict:
    """{beam: N} of the flexible beams with `segments` = N > 1 (a beam declared rigid or without
    modes is not split)."""
    return {name: b["segments"] for name, b in data["bodies"].items()
            if b["type"] == "beam" and not b["rigid"] and b["modes"]["count"] > 0 and b["segments"] > 1}


def modeless(data: dict) -> list:
    """Beams not declared rigid that retain no modes (`modes.count = 0`): the modal solvers model
    their rigid limit, as if declared rigid (`split_segments`)."""
    return [name for name, b in data["bodies"].items()
            if b["type"] == "beam" and not b["rigid"] and b["modes"]["count"] == 0]


def segment_name(beam: str, k: int) -> str:
    """Body name of segment k (0-based) of a split beam: 'beam:1' is its root segment."""
    return f"{beam}:{k + 1}"


def segment_of(length: float, n: int, x: float) -> tuple[int, float]:
    """(k, x - k length / n): the segment (0-based) of a beam split in n that holds position x (m),
    and x along that segment. A point on a boundary belongs to the segment that starts there
    (within round-off), the beam's end to the last segment."""
    s = x * n / length
    k = min(round(s) if abs(s - round(s)) < 1e-9 else int(s), n - 1)
    return k, max(x - k * length / n, 0.0)


def place(data: dict, body: str, x):
    """(body, x) in the segmented tree of position x along `body` (a point [x, y, z] on a body
    that is not split is returned as it is)."""
    n = split(data).get(body)
    if n is None:
        return body, x
    k, local = segment_of(data["bodies"][body]["length"], n, x)
    return segment_name(body, k), local


def split_segments(data: dict) -> dict:
    """The case data of the tree the modal solvers model: every flexible beam with `segments` = N
    > 1 replaced by N beams `beam:1` .. `beam:N` of length L / N and elements / N elements, each
    with the beam's `modes` table, joined by fixed joints `beam:k-k+1` at the end node of segment
    k. Segment 1 takes the beam's joint (same name, same parent); joints on the beam, loads and
    channels at position x go to the segment that holds x (`segment_of`). A beam without modes
    becomes a beam declared rigid, the modal model's limit (`modeless`). `data` itself when no
    beam is split or without modes."""
    parts, still = split(data), modeless(data)
    if not parts and not still:
        return data
    bodies, joints = {}, {}
    for jn, j in data["joints"].items():
        j = copy.deepcopy(j)
        if j["child"] in parts:
            j["child"] = segment_name(j["child"], 0)
        j["parent"], j["at"] = place(data, j["parent"], j["at"])
        joints[jn] = j
    for name, b in data["bodies"].items():
        n = parts.get(name)
        if n is None:
            bodies[name] = {**copy.deepcopy(b), "rigid": True} if name in still else copy.deepcopy(b)
            continue
        seg = {**copy.deepcopy(b), "length": b["length"] / n, "elements": b["elements"] // n, "segments": 1}
        for k in range(n):
            bodies[segment_name(name, k)] = copy.deepcopy(seg)
        for k in range(1, n):
            j = check_table({"type": "fixed", "parent": segment_name(name, k - 1), "child": segment_name(name, k),
                             "at": seg["length"]}, JOINT, "segments", "")
            _check_joint_values(j, "segments", "")
            joints[f"{name}:{k}-{k + 1}"] = j
    loads = copy.deepcopy(data["loads"])
    for ld in loads.values():
        ld["body"], ld["at"] = place(data, ld["body"], ld["at"])
    chans = copy.deepcopy(data["channels"])
    for c in chans.values():
        if c["kind"] in ("deflection", "stress_vm"):
            c["body"], c["at"] = place(data, c["body"], c["at"])
    return {**copy.deepcopy(data), "bodies": bodies, "joints": joints, "loads": loads, "channels": chans}


# ---------------------------------------------------------------------------------------------
# derived facts used by several solvers


def is_fixed_base(case: Case) -> bool:
    """True when every joint is fixed: the structure cannot move as a whole."""
    return all(j["type"] == "fixed" for j in case["joints"].values())
